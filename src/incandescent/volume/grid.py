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

#: Voxels at or above this temperature absorb under the default absorption, K.
DEFAULT_ABSORPTION_MIN_K = 500.0
#: Default optical depth across the largest side of the box.
DEFAULT_OPTICAL_DEPTH = 1.0
#: Hottest temperature a volume may hold, K: the top of the emission tables
#: (``incandescent.spectra.lut.T_MAX_K``), so a table never grows with the input. Gas this hot is
#: a plasma far outside the blackbody-gas model; hotter voxels are nearly always a wrong remap.
T_CEILING_K = 100_000.0


@dataclass(frozen=True)
class Remap:
    """Map a raw field to kelvin: ``T = (raw − offset)·scale``; T < ``cutoff_K`` is vacuum."""

    offset: float = 0.0
    scale: float = 1.0
    cutoff_K: float = 0.0

    def __post_init__(self) -> None:
        for name in ("offset", "scale", "cutoff_K"):
            value = float(getattr(self, name))
            if not np.isfinite(value):
                raise ValueError(f"remap {name} must be finite; got {value!r}")
        if self.scale <= 0:
            raise ValueError(f"remap scale must be > 0; got {self.scale!r}")
        if self.cutoff_K < 0:
            raise ValueError(f"remap cutoff_K must be >= 0 K; got {self.cutoff_K!r}")

    def apply(self, raw: NDArray) -> NDArray[np.float64]:
        return (raw - self.offset) * self.scale

    @classmethod
    def from_range(cls, low_K: float, high_K: float, cutoff_K: float = 0.0) -> Remap:
        """Map a normalised field linearly: raw 0 → ``low_K``, raw 1 → ``high_K``."""
        low, high = float(low_K), float(high_K)
        if not (np.isfinite(low) and np.isfinite(high)) or not 0 <= low < high:
            raise ValueError(
                f"temperature range must be LOW:HIGH in K, 0 <= LOW < HIGH; got {low_K}:{high_K}"
            )
        return cls(offset=-low / (high - low), scale=high - low, cutoff_K=cutoff_K)


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


#: Values per chunk of the κ scan (1 MB, in cache; smaller chunks made the slab threads contend
#: for the GIL).
_SCAN_CHUNK = 1 << 18


def _positive_range(values: NDArray, graded: threading.Event | None = None) -> tuple[float, float]:
    """(smallest, largest) of the values > 0 (≥ 0 elsewhere, as validated); (inf, 0) if there are
    none. One pass in cache-sized chunks; for float32 over the bits, which order as the values do:
    bits − 1 wraps 0 (and −0) above every finite value, so its minimum + 1 is the smallest positive
    value's bits (1.5× faster than a masked ``min(where=values > 0)``).

    With ``graded``, stops at the first chunk after two different positive values were seen here
    (then sets it) or it was set elsewhere: a graded κ is known as such after one chunk.
    """
    flat = np.ascontiguousarray(values).reshape(-1)
    low, peak = np.inf, 0.0
    scratch = np.empty(min(flat.size, _SCAN_CHUNK), np.uint32)
    for start in range(0, flat.size, _SCAN_CHUNK):
        chunk = flat[start : start + _SCAN_CHUNK]
        peak = max(peak, float(chunk.max()))
        if peak > 0:
            low = min(low, _smallest_positive(chunk, scratch))
        if graded is not None and (graded.is_set() or low < peak):
            graded.set()
            break
    return low, peak


def _smallest_positive(chunk: NDArray, scratch: NDArray[np.uint32]) -> float:
    """The smallest value > 0 of a chunk of values ≥ 0; inf if none (see ``_positive_range``)."""
    if chunk.dtype != np.float32:
        return float(chunk.min(where=chunk > 0, initial=np.inf))
    below = np.subtract(chunk.view(np.uint32), np.uint32(1), out=scratch[: chunk.size])
    bits = int(below.min()) + 1
    return float(np.uint32(bits).view(np.float32)) if 0 < bits <= 0x7F800000 else np.inf


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
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "soot_alpha", check_soot_alpha(self.soot_alpha))

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
        if "two_valued_kappa" not in self._cache:
            kappa, graded = self.absorption_per_m, threading.Event()
            ranges = map_slabs(
                lambda lo, hi: _positive_range(kappa[lo:hi], graded), kappa.shape[0], kappa.size
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
        return self._cache.get("absorbing_from_K")

    def replace(self, **changes) -> Volume:
        """A copy with ``changes`` applied (e.g. placement)."""
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
        volume = cls(
            temp, _f32(kappa), scale, origin, voxel, how, fractions, rule, velocity, soot_alpha
        )
        if kappa0 is not None:  # κ ∈ {0, κ₀} by construction: no scan for other values needed
            min_K = max(remap.cutoff_K, DEFAULT_ABSORPTION_MIN_K if absorption is None else 0.0)
            volume._cache["two_valued_kappa"] = _made_peak(volume, kappa0, peak_K, min_K)
            volume._cache["absorbing_from_K"] = _made_threshold_K(absorption, remap)
        if peak_K is not None:  # the validation's maximum: no second pass for the hottest voxel
            volume._cache["max_temperature_K"] = peak_K if peak_K >= remap.cutoff_K else 0.0
        return volume


def _temperature(
    value: ArrayLike, remap: Remap, source: str, adopt: bool = False
) -> tuple[NDArray, float | None]:
    """(kelvin per voxel, hottest voxel K or None), validated: finite, ≥ 0 unless a cutoff removes
    it, below T_CEILING_K. The array is new and writable, or with ``adopt`` the input itself when
    it can be handed over (see :func:`_handed_over`). float32 input without offset or scale stays
    float32 — (raw − 0)·1 in float64, rounded back, is raw exactly — and is checked in one
    chunked pass (its min and max); anything else is remapped in float64."""
    arr = np.asarray(value)
    if arr.dtype != np.float32 or remap.offset != 0 or remap.scale != 1:
        temp = _remapped_temperature(_grid(value, source)[0], remap, source)
        _check_ceiling(temp, remap, source)
        return temp, None
    _check_shape(arr, source)
    low, high = _finite_range(arr, source)
    if low < 0:
        _remapped_temperature(arr, remap, source, copy=False)  # names the voxel unless a cutoff
    if high > T_CEILING_K:
        _check_ceiling(arr, remap, source)  # raises, naming the voxel
    return (arr if adopt and _handed_over(arr) else arr.copy()), high


def _check_shape(arr: NDArray, name: str) -> None:
    if arr.ndim != 3:
        raise ValueError(f"{name} must be a 3-D grid (nx, ny, nz); got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty: shape {arr.shape}")


def _handed_over(arr: NDArray) -> bool:
    """Can ``arr`` become a Volume's grid as it is? float32, C-ordered, writable, and owning its
    memory or the whole-array reshape of an array that does (what ``np.load`` returns) — not a
    view into something else (a file mapping, a library's buffer, a larger array)."""
    flags, base = arr.flags, arr.base
    whole = base is None or (
        isinstance(base, np.ndarray) and base.base is None and base.nbytes == arr.nbytes
    )
    return arr.dtype == np.float32 and flags.c_contiguous and flags.writeable and whole


def _value_range(values: NDArray) -> tuple[float, float]:
    """(min, max) of a 3-D grid, NaN if it holds a NaN: one pass over cache-sized runs of x-layers
    on every core, without the grid-sized boolean temporaries of ``isfinite``/``< 0`` masks (each
    a fresh allocation: the page faults cost more than the comparisons)."""
    layers = max(1, _SCAN_CHUNK // max(1, values[0].size))

    def slab(lo: int, hi: int) -> tuple[float, float]:
        low, high = np.inf, -np.inf
        for a in range(lo, hi, layers):
            chunk = values[a : min(a + layers, hi)]
            c_low, c_high = float(chunk.min()), float(chunk.max())
            if np.isnan(c_low) or np.isnan(c_high):
                return np.nan, np.nan
            low, high = min(low, c_low), max(high, c_high)
        return low, high

    ranges = map_slabs(slab, values.shape[0], values.size)
    if any(np.isnan(r[0]) for r in ranges):
        return np.nan, np.nan
    return min(r[0] for r in ranges), max(r[1] for r in ranges)


def _finite_range(arr: NDArray, name: str) -> tuple[float, float]:
    """(min, max) of a grid that must be finite; NaN or ±inf raises, naming the first."""
    low, high = _value_range(arr)
    if not (np.isfinite(low) and np.isfinite(high)):
        _validate.finite(arr, name)  # raises with the offending value and its index
    return low, high


def _grid(
    value: ArrayLike, name: str, like: tuple[int, ...] | None = None
) -> tuple[NDArray, float]:
    """A finite 3-D grid (``_validate.real_grid``: float32 as it is) of shape ``like`` when
    given, and its minimum."""
    arr = _validate.real_grid(value, name)
    _check_shape(arr, name)
    if like is not None and arr.shape != like:
        raise ValueError(f"{name} grid has shape {arr.shape}; expected the temperature's {like}")
    low, _ = _finite_range(arr, name)
    return arr, low


def _remapped_temperature(
    raw: NDArray, remap: Remap, source: str, copy: bool = True
) -> NDArray[np.float64]:
    temp = np.array(remap.apply(raw), dtype=np.float64) if copy else raw
    negative = temp < 0
    if remap.cutoff_K <= 0 and negative.any():
        index = tuple(int(i) for i in np.argwhere(negative)[0])
        raise ValueError(
            f"{source}: temperature {temp[index]:g} K at voxel {index} is negative after remap "
            f"(offset={remap.offset:g}, scale={remap.scale:g}); kelvin must be >= 0 — "
            "fix the remap or set a cutoff"
        )
    return temp


def _check_ceiling(temp: NDArray, remap: Remap, source: str) -> None:
    """Refuse voxels hotter than T_CEILING_K, naming the first and the remap that made it."""
    hot = temp > T_CEILING_K
    if hot.any():
        index = tuple(int(i) for i in np.argwhere(hot)[0])
        raise ValueError(
            f"{source}: temperature {temp[index]:.4g} K at voxel {index} is above the "
            f"{T_CEILING_K:g} K ceiling of the emission tables (remap offset={remap.offset:g}, "
            f"scale={remap.scale:g}); if the field is not in kelvin, map it with --scale, "
            "--temperature-range or a --preset"
        )


#: Voxel sides a Volume accepts, m: a nanometre to a thousand kilometres.
VOXEL_SIZE_RANGE_M = (1e-9, 1e6)


def _voxel_size(voxel_size_m: float | None, shape: tuple[int, ...]) -> float:
    if voxel_size_m is None:
        return 1.0 / max(shape)
    size = _validate.positive_scalar(voxel_size_m, "voxel_size_m")
    low, high = VOXEL_SIZE_RANGE_M
    if not low <= size <= high:
        raise ValueError(f"voxel_size_m must be in [{low:g}, {high:g}] m; got {voxel_size_m!r}")
    return size


def _origin(origin_m: ArrayLike | None, shape: tuple[int, ...], voxel: float) -> tuple:
    if origin_m is None:
        return tuple(-0.5 * n * voxel for n in shape)
    origin = _validate.finite(_validate.real_array(origin_m, "origin_m"), "origin_m")
    if origin.shape != (3,):
        raise ValueError(f"origin_m must be 3 numbers (x, y, z) in m; got shape {origin.shape}")
    return tuple(float(v) for v in origin)


def _absorption(
    value, temp: NDArray, side_m: float, source: str, adopt: bool = False
) -> tuple[NDArray, str, float | None]:
    """(κ per voxel in 1/m, how it was given, κ₀ when it was made as κ₀ or 0 per voxel). κ is a
    new writable float32 array (values rounded once from float64), or with ``adopt`` the given
    grid itself when it can be handed over; the default is scaled to the box's largest side
    ``side_m``."""
    if value is None:
        kappa = np.float32(DEFAULT_OPTICAL_DEPTH / side_m)
        grid = np.where(temp >= DEFAULT_ABSORPTION_MIN_K, kappa, np.float32(0.0))
        how = f"default: {kappa:g} 1/m where T >= {DEFAULT_ABSORPTION_MIN_K:g} K"
        return grid, how, float(kappa)
    if np.ndim(value) == 0:
        kappa = np.float32(_nonnegative_scalar(value, "absorption (1/m)"))
        return np.full(temp.shape, kappa), f"constant {kappa:g} 1/m", float(kappa)
    return _checked_grid(value, temp.shape, "absorption", source, adopt), "grid", None


def _made_peak(volume: Volume, kappa0: float, peak_K: float | None, min_K: float) -> float | None:
    """The two-valued κ₀ of a κ made as κ₀ where T ≥ ``min_K`` K (0 elsewhere), None if no voxel
    got it: from the hottest voxel when validation found it (no pass over κ), else κ's maximum."""
    if peak_K is None:
        peak = float(volume.absorption_per_m.max())
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


def _optional_grid(value, shape, name: str, source: str) -> NDArray[np.float32] | None:
    if value is None:
        return None
    if np.ndim(value) == 0:
        return _f32(np.full(shape, _nonnegative_scalar(value, name)))
    return _f32(_checked_grid(value, shape, name, source))


def _checked_grid(value, shape, name: str, source: str, adopt: bool = False) -> NDArray[np.float32]:
    """A non-negative finite grid of ``shape`` as a new writable float32 array (or with ``adopt``
    the input itself, see :func:`_handed_over`)."""
    arr, low = _grid(value, f"{source}: {name}", shape)
    if low < 0:
        index = tuple(int(i) for i in np.argwhere(arr < 0)[0])
        raise ValueError(f"{source}: {name} must be >= 0; got {arr[index]:g} at voxel {index}")
    if adopt and _handed_over(arr):
        return arr
    return np.array(arr, dtype=np.float32)


def _velocity(value, shape, source: str) -> NDArray[np.float32] | None:
    """A finite (nx, ny, nz, 3) velocity grid in m/s as float32, or None."""
    if value is None:
        return None
    arr = _validate.real_grid(value, f"{source}: velocity")
    if arr.shape != tuple(shape) + (3,):
        raise ValueError(
            f"{source}: velocity grid has shape {arr.shape}; expected {tuple(shape) + (3,)} "
            "(a 3-vector in m/s per voxel)"
        )
    return _f32(np.array(_validate.finite(arr, f"{source}: velocity (m/s)"), dtype=np.float32))


#: The species whose fraction a ``sodium_fraction`` grid gives (the 2011 paper's sodium term).
SODIUM = "Na"


def check_soot_alpha(alpha) -> float:
    """The soot exponent α of κ_λ = κ·(550 nm/λ)^α, a number in [0, 4]."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.number)):
        raise ValueError(f"soot_alpha must be a number in [0, 4]; got {alpha!r}")
    if not np.isfinite(float(alpha)) or not 0 <= alpha <= 4:
        raise ValueError(f"soot_alpha must be in [0, 4]; got {alpha!r}")
    return float(alpha)


def _with_sodium(species, sodium_fraction, source: str) -> dict:
    """The species fractions with ``sodium_fraction`` (if given) as species ``Na``."""
    out = dict(species or {})
    if sodium_fraction is None:
        return out
    if SODIUM in out:
        raise ValueError(
            f"{source}: sodium_fraction is the fraction of species {SODIUM!r}, also given; "
            "give one of them"
        )
    out[SODIUM] = sodium_fraction
    return out


def _fraction_grid(value, shape, name: str, source: str):
    """A fraction grid in [0, 1] (constant or grid), or None."""
    grid = _optional_grid(value, shape, name, source)
    if grid is not None and grid.max() > 1.0:
        index = tuple(int(i) for i in np.argwhere(grid > 1.0)[0])
        got = f"{grid[index]:g} at voxel {index}"
        raise ValueError(f"{source}: {name} must be in [0, 1]; got {got}")
    return grid


def _nonnegative_scalar(value, name: str) -> float:
    if value == 0:
        return 0.0
    return _validate.positive_scalar(value, name)


def _f32(arr: NDArray) -> NDArray[np.float32]:
    out = np.ascontiguousarray(arr, dtype=np.float32)
    out.setflags(write=False)
    return out
