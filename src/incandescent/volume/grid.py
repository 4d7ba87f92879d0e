"""The Volume: temperature (K), absorption (1/m) and emission-scale grids placed in the world.

Conventions (DESIGN.md §4): ``a[i, j, k]`` is the voxel at x=i, y=j, z=k; ``origin_m`` is the world
position of the corner of voxel (0, 0, 0); voxels are cubes of side ``voxel_size_m``. By default the
grid is centred at the world origin with its largest side 1 m long.

Absorption. When no absorption is given, the *default absorption* applies: κ = 1/L (optical depth 1
across the box's largest side L) in voxels at or above 500 K and 0 in colder voxels, so the glowing
gas absorbs and the cold surroundings are vacuum. Temperature remapping (for fields that are not in
kelvin) is ``T = (raw − offset) · scale``; voxels with T below ``cutoff_K`` are vacuum: they neither
emit nor absorb. Negative kelvin after remapping is an error unless a cutoff (> 0) removes it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent._parallel import map_slabs
from incandescent.volume.macrocells import MacrocellGrid, build_macrocells
from incandescent.volume.remap import Remap
from incandescent.volume.scan import positive_range
from incandescent.volume.validate import (
    DEFAULT_ABSORPTION_MIN_K,
    DEFAULT_OPTICAL_DEPTH,
    SODIUM,
    T_CEILING_K,
    _absorption,
    _f32,
    _fraction_grid,
    _optional_grid,
    _origin,
    _temperature,
    _velocity,
    _voxel_size,
    _with_sodium,
    check_phase_g,
    check_soot_alpha,
    scattering_grid,
)

__all__ = [
    "DEFAULT_ABSORPTION_MIN_K",
    "DEFAULT_OPTICAL_DEPTH",
    "SODIUM",
    "T_CEILING_K",
    "MediumSummary",
    "Placed",
    "Remap",
    "Volume",
    "check_soot_alpha",
]


class Placed:
    """The box of a grid of ``shape`` voxels of side ``voxel_size_m`` with its corner at
    ``origin_m`` (dense :class:`Volume` and sparse volumes alike)."""

    origin_m: tuple[float, float, float]
    voxel_size_m: float

    @property
    def size_m(self) -> NDArray[np.float64]:
        """Extent of the box along x, y, z in m."""
        shape = self.shape  # type: ignore[attr-defined]  # a field or a property of the subclass
        return np.asarray(shape, dtype=np.float64) * self.voxel_size_m

    @property
    def bounds_m(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        lo = np.asarray(self.origin_m, dtype=np.float64)
        return lo, lo + self.size_m


@dataclass(frozen=True)
class MediumSummary:
    """What :meth:`Volume.from_arrays` knows of the medium by construction, so that the kernel's
    layout (``renderer.backends.medium``) needs no scan of κ.

    kappa_known: κ was made from T (the default absorption, or a constant), so the next two are
        known; False: κ was given as a grid and is scanned when asked.
    two_valued_absorption_per_m: κ₀ when every voxel's κ is 0 or κ₀ (None: κ is graded, or 0).
    absorbing_from_K: the float32 T (K) from which a voxel absorbs — κ > 0 exactly where T ≥ it —
        when κ was made from T (the default absorption, or a constant); None when not known.
    max_temperature_K: the hottest voxel, K, as validation found it (None: not known).
    """

    kappa_known: bool = False
    two_valued_absorption_per_m: float | None = None
    absorbing_from_K: float | None = None
    max_temperature_K: float | None = None


#: Grids whose change makes a volume's :class:`MediumSummary` stale.
MEDIUM_GRIDS = ("temperature_K", "absorption_per_m")


@dataclass(frozen=True, eq=False)
class Volume(Placed):
    """Validated, placed grids ready to render. Build with :meth:`Volume.from_arrays`.

    Attributes
    ----------
    temperature_K: (nx, ny, nz) float32, kelvin; 0 in vacuum voxels.
    absorption_per_m: (nx, ny, nz) float32 κ in 1/m (already 0 where T < cutoff).
    emission_scale: (nx, ny, nz) float32 or None — a non-physical multiplier of emission only.
    velocity_m_s: (nx, ny, nz, 3) float32 gas velocity in m/s (x, y, z) or None — what motion
        blur advects κ and T along (``RenderSettings.shutter``).
    species: name → (nx, ny, nz) float32 fraction in [0, 1] of an emitting species (Na, Li, …)
        whose lines (``incandescent.spectra.lines``) add to the emission; ``Na`` is also the
        2011 paper's sodium term (grid name ``sodium_fraction`` in files).
    soot_alpha: the spectral law of the absorption, κ_λ = κ·(550 nm/λ)^α (1: the Rayleigh
        limit; 1.39: Hottel & Broughton 1932), used where transport runs in spectral bins; κ is
        the absorption at 550 nm.
    scattering_per_m: (nx, ny, nz) float32 σ_s in 1/m, or None (the gas does not scatter): what
        a scattering integrator (``renderer.integrators.single_scattering``) scatters; the
        extinction is then κ + σ_s.
    phase_g: the Henyey–Greenstein asymmetry g of the scattering, −1 < g < 1 (> 0 forward): a
        number, or an (nx, ny, nz) float32 grid of g per voxel (interpolated like σ_s).
    scattering_alpha: the spectral law of the scattering, σ_s,λ = σ_s·(550 nm/λ)^β (0: grey,
        the default; 4: Rayleigh's small particles), used where transport runs in spectral
        bins; σ_s is the scattering at 550 nm.
    medium: what construction already knows of κ and T (:class:`MediumSummary`), or None.
    origin_m: world position of the corner of voxel (0, 0, 0), m.
    voxel_size_m: side of a voxel, m.
    absorption_source: how κ was given ("grid", "constant 2.0 1/m", or the default's description).
    """

    temperature_K: NDArray[np.float32]
    absorption_per_m: NDArray[np.float32]
    emission_scale: NDArray[np.float32] | None
    origin_m: tuple[float, float, float]
    voxel_size_m: float
    absorption_source: str = field(default="grid")
    species: dict[str, NDArray[np.float32]] = field(default_factory=dict)
    temperature_source: str = "given in K"
    velocity_m_s: NDArray[np.float32] | None = None
    soot_alpha: float = 1.0
    medium: MediumSummary | None = field(default=None, repr=False)
    scattering_per_m: NDArray[np.float32] | None = None
    phase_g: float | NDArray[np.float32] = 0.0
    scattering_alpha: float = 0.0
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "soot_alpha", check_soot_alpha(self.soot_alpha))
        object.__setattr__(self, "phase_g", check_phase_g(self.phase_g, self.shape))
        beta = check_soot_alpha(self.scattering_alpha, "scattering_alpha")
        object.__setattr__(self, "scattering_alpha", beta)

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(n) for n in self.temperature_K.shape)  # type: ignore[return-value]

    @property
    def content_bounds_m(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World box around the voxels that absorb (and so may emit); the whole box if none do."""
        box = self._absorbing_box()
        if box is None:
            return self.bounds_m
        origin = np.asarray(self.origin_m)
        return origin + box[0] * self.voxel_size_m, origin + box[1] * self.voxel_size_m

    def _absorbing_box(self) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """(first, last + 1) voxel index per axis of the voxels with κ > 0, or None if there are
        none; computed once, from each x-layer's maximum and the maximum across the layers, slab
        by slab (κ ≥ 0, so a maximum > 0 is a voxel that absorbs): no grid-sized mask (192³:
        6–7 → 3–4 ms in a fresh process; 1 GB less at 1024³)."""
        if "absorbing_box" not in self._cache:
            kappa = self.absorption_per_m

            def maxima(lo: int, hi: int) -> tuple[NDArray, NDArray]:
                part = kappa[lo:hi]
                return part.reshape(hi - lo, -1).max(axis=1), part.max(axis=0)

            parts = map_slabs(maxima, kappa.shape[0], kappa.size)
            plane = np.maximum.reduce([p[1] for p in parts])
            layers = np.concatenate([p[0] for p in parts])
            projections = (layers, plane.max(axis=1), plane.max(axis=0))
            per_axis = [np.flatnonzero(m > 0) for m in projections]
            self._cache["absorbing_box"] = (
                None
                if per_axis[0].size == 0
                else (
                    np.array([float(i[0]) for i in per_axis]),
                    np.array([float(i[-1] + 1) for i in per_axis]),
                )
            )
        return self._cache["absorbing_box"]

    @property
    def max_temperature_K(self) -> float:
        """Hottest voxel, K (computed once: the grids are read-only)."""
        if self.medium is not None and self.medium.max_temperature_K is not None:
            return self.medium.max_temperature_K
        if "max_temperature_K" not in self._cache:
            t = self.temperature_K
            self._cache["max_temperature_K"] = float(
                max(map_slabs(lambda lo, hi: t[lo:hi].max(), t.shape[0], t.size))
            )
        return self._cache["max_temperature_K"]

    @property
    def two_valued_absorption_per_m(self) -> float | None:
        """κ₀ when every voxel's κ is 0 or one value κ₀ > 0 (the default absorption; a constant κ
        with a cutoff), else None. The kernel then stores only T, its sign bit marking κ = 0."""
        if self.medium is not None and self.medium.kappa_known:
            return self.medium.two_valued_absorption_per_m
        if "two_valued_kappa" not in self._cache:
            kappa, graded = self.absorption_per_m, threading.Event()
            ranges = map_slabs(
                lambda lo, hi: positive_range(kappa[lo:hi], graded), kappa.shape[0], kappa.size
            )
            low, peak = min(r[0] for r in ranges), max(r[1] for r in ranges)
            two_valued = 0 < low == peak and not graded.is_set()
            self._cache["two_valued_kappa"] = float(peak) if two_valued else None
        return self._cache["two_valued_kappa"]

    @property
    def absorbing_from_K(self) -> float | None:
        """T in K (a float32 value) from which a voxel absorbs — κ > 0 exactly where T ≥ it —
        when κ was made from T by :meth:`from_arrays` (the default absorption, or a constant);
        None when that is not known. The kernel then reads T alone."""
        return None if self.medium is None else self.medium.absorbing_from_K

    def replace(self, **changes) -> Volume:
        """A copy with ``changes`` applied (e.g. placement); new κ or T grids drop the medium
        summary (it described the old ones)."""
        if any(name in changes for name in MEDIUM_GRIDS):
            changes.setdefault("medium", None)
        return replace(self, _cache={}, **changes)

    @property
    def max_speed_m_s(self) -> float:
        """Largest |v| component of any voxel, m/s (0 without a velocity grid; computed once):
        what bounds a sample's displacement under motion blur along each axis."""
        if "max_speed" not in self._cache:
            v = self.velocity_m_s
            self._cache["max_speed"] = 0.0 if v is None else float(np.abs(v).max())
        return self._cache["max_speed"]

    def with_velocity(self, velocity_m_s: ArrayLike | None) -> Volume:
        """A copy with a velocity grid ((nx, ny, nz, 3) m/s, or None) for motion blur."""
        return self.replace(velocity_m_s=_velocity(velocity_m_s, self.shape, "volume"))

    def with_sodium(self, sodium_fraction: ArrayLike | float) -> Volume:
        """A copy with a sodium fraction (0..1, constant or grid): the species ``Na`` (its lines;
        the 2011 paper's sodium term)."""
        what = f"species {SODIUM!r} fraction"
        sodium = _fraction_grid(sodium_fraction, self.shape, what, "volume")
        return self.replace(species={**self.species, SODIUM: sodium})

    def with_soot_alpha(self, alpha: float) -> Volume:
        """A copy whose absorption follows κ_λ = κ·(550 nm/λ)^α (see ``soot_alpha``)."""
        return self.replace(soot_alpha=alpha)

    def with_scattering(
        self,
        scattering_per_m: ArrayLike | float | None = None,
        albedo: float | None = None,
        phase_g: ArrayLike | float = 0.0,
        scattering_alpha: float = 0.0,
    ) -> Volume:
        """A copy that scatters: σ_s in 1/m (a constant or a grid), or from the single-scattering
        albedo α = σ_s/(σ_s + κ) as σ_s = α/(1 − α)·κ; Henyey–Greenstein asymmetry ``phase_g``
        (a constant or a grid); spectral law ``scattering_alpha`` (β of σ_s,λ ∝ λ^−β)."""
        sigma = scattering_grid(
            scattering_per_m, albedo, self.absorption_per_m, self.shape, "volume"
        )
        return self.replace(
            scattering_per_m=sigma, phase_g=phase_g, scattering_alpha=scattering_alpha
        )

    def with_extinction_split(self, albedo: float, phase_g: ArrayLike | float = 0.0) -> Volume:
        """A copy whose κ is read as the extinction σ_t and split into scattering σ_s = α·σ_t
        and absorption (1 − α)·σ_t (how a DCC's smoke density becomes both: Cycles' Principled
        Volume, ``volume.presets``); Henyey–Greenstein asymmetry ``phase_g``."""
        alpha = _validate.finite_scalar(albedo, "smoke albedo")
        if not 0.0 <= alpha < 1.0:
            raise ValueError(f"smoke albedo must be in [0, 1); got {albedo!r}")
        extinction = self.absorption_per_m
        split = self.replace(absorption_per_m=(extinction * (1.0 - alpha)).astype(np.float32))
        return split.with_scattering(extinction * alpha, phase_g=phase_g)

    def macrocells(
        self,
        cell_voxels: int = 8,
        rule: str = "absorption",
        occupancy: Callable[[Volume], NDArray] | None = None,
    ) -> MacrocellGrid:
        """Macrocells for empty-space skipping, computed once per cell size and ``rule``.

        A cell is empty where its ``occupancy(volume)`` grid (default: κ; an emission model's
        rule otherwise, ``incandescent.emission``) is 0 in every voxel, border included.
        """
        key = ("macrocells", cell_voxels, rule)
        if key not in self._cache:
            grid = self.absorption_per_m if occupancy is None else occupancy(self)
            self._cache[key] = build_macrocells(grid, cell_voxels)
        return self._cache[key]

    @classmethod
    def from_arrays(
        cls,
        temperature: ArrayLike,
        absorption: ArrayLike | float | None = None,
        emission_scale: ArrayLike | float | None = None,
        voxel_size_m: float | None = None,
        origin_m: ArrayLike | None = None,
        remap: Remap | None = None,
        source: str = "temperature",
        sodium_fraction: ArrayLike | float | None = None,
        species: Mapping[str, ArrayLike | float] | None = None,
        absorption_source: str | None = None,
        temperature_source: str | None = None,
        box_side_m: float | None = None,
        velocity_m_s: ArrayLike | None = None,
        copy: bool = True,
        soot_alpha: float = 1.0,
    ) -> Volume:
        """Validate and place grids; ``source`` names the data's origin in error messages;
        ``absorption_source`` says where an absorption grid came from (metadata, ``--stats``);
        ``box_side_m``: the largest side of the box the default absorption is scaled to (default:
        these grids'; leaves of a sparse volume pass their whole box's). ``copy=False`` hands the
        grids over: a float32, C-ordered temperature or absorption array that owns its data is
        kept as it is and made read-only instead of copied (a file reader's fresh arrays) when
        nothing in it has to change (no cutoff)."""
        remap = remap or Remap()
        adopt = not copy and remap.cutoff_K <= 0
        temp, peak_K = _temperature(temperature, remap, source, adopt)
        vacuum = temp < np.float64(remap.cutoff_K) if remap.cutoff_K > 0 else None  # in float64
        if vacuum is not None:
            temp[vacuum] = 0.0
        temp = _f32(temp)  # κ made from T reads the T stored (``absorbing_from_K``)
        voxel = _voxel_size(voxel_size_m, temp.shape)
        side = voxel * max(temp.shape) if box_side_m is None else float(box_side_m)
        kappa, how, kappa0 = _absorption(absorption, temp, side, source, adopt)
        if absorption_source and how == "grid":
            how = f"grid ({absorption_source})"
        if vacuum is not None:
            kappa[vacuum] = 0.0
        scale = _optional_grid(emission_scale, temp.shape, "emission_scale", source)
        origin = _origin(origin_m, temp.shape, voxel)
        fractions = {
            str(name): _f32(grid if vacuum is None else np.where(vacuum, 0.0, grid))  # vacuum
            for name, value in _with_sodium(species, sodium_fraction, source).items()
            if (grid := _fraction_grid(value, temp.shape, f"species {name!r} fraction", source))
            is not None
        }
        rule = temperature_source or "given"
        if remap != Remap():
            rule += f"; T = (raw − {remap.offset:g})·{remap.scale:g} K"
            rule += f", vacuum below {remap.cutoff_K:g} K" if remap.cutoff_K else ""
        velocity = _velocity(velocity_m_s, temp.shape, source)
        kappa = _f32(kappa)
        medium = _summary(kappa, kappa0, peak_K, absorption, remap)
        return cls(
            temp, kappa, scale, origin, voxel, how, fractions, rule, velocity, soot_alpha, medium
        )


def _summary(kappa, kappa0, peak_K, absorption, remap: Remap) -> MediumSummary | None:
    """What construction knows: κ ∈ {0, κ₀} when κ was made from T (no scan needed for other
    values), and the validation's hottest voxel (no second pass); None when it knows neither."""
    if kappa0 is None and peak_K is None:
        return None
    hottest = None if peak_K is None else (peak_K if peak_K >= remap.cutoff_K else 0.0)
    if kappa0 is None:
        return MediumSummary(max_temperature_K=hottest)
    min_K = max(remap.cutoff_K, DEFAULT_ABSORPTION_MIN_K if absorption is None else 0.0)
    two_valued = _made_peak(kappa, kappa0, peak_K, min_K)
    return MediumSummary(True, two_valued, _made_threshold_K(absorption, remap), hottest)


def _made_peak(kappa, kappa0: float, peak_K: float | None, min_K: float) -> float | None:
    """The two-valued κ₀ of a κ made as κ₀ where T ≥ ``min_K`` K (0 elsewhere), None if no voxel
    got it: from the hottest voxel when validation found it (no pass over κ), else κ's maximum."""
    if peak_K is None:
        peak = float(kappa.max())
    else:
        peak = kappa0 if peak_K >= min_K else 0.0
    return peak if peak > 0 else None


def _made_threshold_K(absorption, remap: Remap) -> float | None:
    """For κ made from T: the float32 t with κ > 0 exactly where the stored T ≥ t. The default
    κ is κ₀ where that T ≥ DEFAULT_ABSORPTION_MIN_K (vacuum voxels hold T = 0); a constant κ₀ is
    everywhere (t = 0) or, with a cutoff c, where T ≥ c before rounding, i.e. where the stored T
    ≥ c rounded to float32 (rounding is monotone; vacuum 0 stays below it). None if that is 0."""
    if absorption is None:
        return DEFAULT_ABSORPTION_MIN_K
    if remap.cutoff_K <= 0:
        return 0.0
    threshold = float(np.float32(remap.cutoff_K))
    return threshold if threshold > 0 else None
