"""The scenes of the 2011 paper (§6) as deterministic NumPy generators.

* :func:`paper_sphere` — Fig. 2: "a roughly spherical volume of a transparent blackbody material
  (such as soot particles in air) heated to around 3000K".
* :class:`PlateScene` — Figs. 3–4: "a 250-frame video sequence depicting an extremely hot planar
  object (around 10,000 K) moving at high speed through an air-filled volume. Gas touching the
  object becomes heated, and gradually cools off as the heat is removed." The paper gives no
  equations ("the simulation was simply a means of producing data to render"); the model below is
  ours, chosen to be simple, documented, exactly mirror-symmetric and fast.

Both are pure NumPy: no randomness, the same numbers on every run and platform with IEEE floats.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.volume import Volume

#: Room-temperature air, K.
AMBIENT_K = 300.0
#: Largest explicit diffusion number D·Δt/Δx² per sub-step; the 3-D 7-point scheme is stable
#: for values ≤ 1/6 (von Neumann analysis), we keep a 10 % margin.
MAX_DIFFUSION_NUMBER = 0.9 / 6.0


def paper_sphere(
    n: int = 64, temperature_K: float = 3000.0, absorption_per_m: float = 0.5
) -> Volume:
    """The paper's Fig. 2 scene: a roughly spherical cloud of transparent soot at ~3000 K.

    An n³ grid (1 m box, centred on the origin) at ``temperature_K`` inside a sphere of radius
    0.5 m, falling linearly to ambient (300 K) over the outer 15 % of the radius; the soot absorbs
    (and so emits) with constant ``absorption_per_m`` (1/m) inside the sphere and the air outside
    is vacuum. Optical depth along a diameter = ``absorption_per_m`` × 1 m (0.5: "transparent").

    Examples
    --------
    >>> vol = paper_sphere(16)
    >>> vol.shape, round(vol.max_temperature_K)
    ((16, 16, 16), 3000)
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 4:
        raise ValueError(f"paper_sphere n must be an integer >= 4; got {n!r}")
    _validate.positive_scalar(temperature_K, "temperature_K")
    centres = (np.arange(n) + 0.5) / n * 2.0 - 1.0  # voxel centres in units of the radius
    x, y, z = np.meshgrid(centres, centres, centres, indexing="ij", sparse=True)
    r = np.sqrt(x**2 + y**2 + z**2)
    shell = np.clip((1.0 - r) / 0.15, 0.0, 1.0)
    temperature = AMBIENT_K + (temperature_K - AMBIENT_K) * shell
    kappa = np.where(r < 1.0, float(absorption_per_m), 0.0)
    return Volume.from_arrays(temperature, absorption=kappa, source=f"paper_sphere({n})")


def _overlap(lo: NDArray, hi: NDArray, a: float, b: float) -> NDArray[np.float64]:
    """Length of [lo, hi] ∩ [a, b] for each voxel interval (voxel units), ≥ 0."""
    return np.clip(np.minimum(hi, b) - np.maximum(lo, a), 0.0, None)


def _centred_coverage(n: int, size: float) -> NDArray[np.float64]:
    """Fraction of each of n voxels covered by a segment of ``size`` voxels centred on the grid.

    Symmetrised so that ``coverage[k] == coverage[n − 1 − k]`` exactly (round-off included).
    """
    edges = np.arange(n, dtype=np.float64)
    cover = _overlap(edges, edges + 1.0, 0.5 * (n - size), 0.5 * (n + size))
    return 0.5 * (cover + cover[::-1])


@dataclass(frozen=True)
class PlateScene:
    """The paper's 250-frame plate video: a ~10 000 K plate flying through air, heating it.

    Parameters
    ----------
    shape:
        Grid (nx, ny, nz) in voxels; the plate flies along +x.
    plate_temperature_K:
        T_p, temperature of the plate (the paper: "around 10,000 K").
    plate_size_voxels:
        (height along y, width along z) of the plate, voxels; centred in y and z.
    plate_thickness_voxels:
        w, thickness of the plate along x, voxels ("thin planar object").
    start_x_voxels:
        x of the plate's leading face at frame 0, voxels (0: it enters at the x = 0 face).
    speed_voxels_per_frame:
        v, plate speed along +x, voxels per frame.
    ambient_K:
        T_a, temperature of the air initially and beyond the grid, K.
    heating_rate_per_frame:
        h, heat-transfer rate from plate to air during full contact, per frame.
    diffusivity_voxels2_per_frame:
        D, thermal diffusivity of the gas, voxel²/frame.
    cooling_rate_per_frame:
        c, Newton cooling rate toward ambient, per frame (e-folding time 1/c frames).
    n_frames:
        Number of frames (the paper's video: 250).
    voxel_size_m:
        Side of a voxel, m (placement only: the simulation works in voxel units).
    absorption_per_m:
        κ_p, absorption coefficient of gas at the plate temperature, 1/m (see :meth:`volume`).

    Notes
    -----
    State: the gas temperature T[i, j, k] (K) on voxel centres. Frame n (n = 0, 1, …) is the state
    after these three steps, applied to frame n − 1 (frame −1 is air at T_a everywhere):

    1. **Plate contact.** The plate occupies x ∈ [x_n − w, x_n], x_n = x_0 + v·n, and during the
       frame sweeps S_n = [x_n − w, x_n + v]. Each air voxel it touches relaxes toward the
       plate temperature::

           T ← T + (1 − exp(−h · o_i · a_j · b_k)) · (T_p − T)

       with o_i = |[i, i+1] ∩ S_n| the swept fraction of voxel column i and a_j, b_k the fractions
       of voxel j (k) inside the plate's y (z) extent, all in [0, 1]. The plate is not rendered
       as a solid: what glows is the gas layer it heats.
    2. **Diffusion.** ∂T/∂t = D ∇²T, explicit Euler with the 7-point Laplacian
       ∇²T ≈ Σ_neighbours T − 6T, split into m = ⌈D / (0.9/6)⌉ equal sub-steps so each has
       D/m ≤ 0.9/6 < 1/6 (stable, monotone). Outside the grid is open air at T_a (Dirichlet
       ghost voxels), so gas at the faces loses heat fastest.
    3. **Newton cooling** toward ambient, integrated exactly over the frame::

           T ← T_a + (T − T_a) · exp(−c)

    Finally T ← ½(T + T[:, :, ::-1]): the model is mirror-symmetric in z, and this makes every
    frame *exactly* symmetric despite round-off (a no-op up to the last bit).

    The excess heat E_n = Σ (T − T_a) grows while the plate is in the grid (contact adds heat,
    cooling removes c·E per frame) and decays strictly once it has left. The x = 0 layer, heated
    first, cools below any threshold at some frame; the paper's triangular artifact appeared
    when "the leftmost column of voxels has cooled to below some threshold" (frame 105). With the
    defaults the hottest voxel of that layer falls below 1000 K first at frame 105 (we chose the
    cooling rate to land on the paper's frame; ``tests/scenes/test_paper_scenes.py`` checks it);
    the plate leaves the grid during frame 120 and the x = nx − 1 layer falls below 1000 K at
    frame 216. "High speed": the plate outruns diffusion by far (Péclet number v·nx/D ≈ 770).

    The state is float32 with one ghost layer and is updated in place: the default 250 frames of
    96×64×64 voxels take under a second.

    Examples
    --------
    >>> scene = PlateScene(shape=(24, 16, 16), n_frames=10)
    >>> t = scene.frame(9)
    >>> t.shape, t.dtype, bool((t == t[:, :, ::-1]).all())
    ((24, 16, 16), dtype('float32'), True)
    """

    shape: tuple[int, int, int] = (96, 64, 64)
    plate_temperature_K: float = 10_000.0
    plate_size_voxels: tuple[float, float] = (48.0, 48.0)
    plate_thickness_voxels: float = 1.0
    start_x_voxels: float = 0.0
    speed_voxels_per_frame: float = 0.8
    ambient_K: float = AMBIENT_K
    heating_rate_per_frame: float = 2.0
    diffusivity_voxels2_per_frame: float = 0.1
    cooling_rate_per_frame: float = 0.0087
    n_frames: int = 250
    voxel_size_m: float = 0.01
    absorption_per_m: float = 2.0

    def __post_init__(self) -> None:
        shape = tuple(self.shape)
        if len(shape) != 3 or any(
            isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2 for n in shape
        ):
            raise ValueError(f"shape must be 3 integers >= 2 (nx, ny, nz); got {self.shape!r}")
        object.__setattr__(self, "shape", tuple(int(n) for n in shape))
        if isinstance(self.n_frames, bool) or not isinstance(self.n_frames, (int, np.integer)):
            raise TypeError(f"n_frames must be an integer; got {self.n_frames!r}")
        if self.n_frames < 1:
            raise ValueError(f"n_frames must be >= 1; got {self.n_frames!r}")
        for name in ("plate_temperature_K", "ambient_K", "speed_voxels_per_frame"):
            _validate.positive_scalar(getattr(self, name), name)
        for name in ("plate_thickness_voxels", "voxel_size_m"):
            _validate.positive_scalar(getattr(self, name), name)
        for name in (
            "heating_rate_per_frame",
            "diffusivity_voxels2_per_frame",
            "cooling_rate_per_frame",
            "absorption_per_m",
        ):
            _validate.nonnegative_scalar(getattr(self, name), name)
        if not math.isfinite(self.start_x_voxels):
            raise ValueError(f"start_x_voxels must be finite; got {self.start_x_voxels!r}")
        if self.plate_temperature_K <= self.ambient_K:
            raise ValueError(
                f"plate_temperature_K ({self.plate_temperature_K:g} K) must exceed ambient_K "
                f"({self.ambient_K:g} K)"
            )
        if len(self.plate_size_voxels) != 2:
            raise ValueError(
                f"plate_size_voxels must be (y, z) sizes; got {self.plate_size_voxels}"
            )
        for size in self.plate_size_voxels:
            _validate.positive_scalar(size, "plate_size_voxels")

    def replace(self, **changes) -> PlateScene:
        """A copy with ``changes`` applied."""
        return replace(self, **changes)

    # --- the simulation ------------------------------------------------------------------------
    def plate_x_voxels(self, frame: int) -> float:
        """x of the plate's leading face at ``frame``, voxels (may lie beyond the grid)."""
        return self.start_x_voxels + self.speed_voxels_per_frame * frame

    def frames(self) -> Iterator[NDArray[np.float32]]:
        """Temperature grids (nx, ny, nz), float32 K, of frames 0 … n_frames − 1 (new arrays)."""
        state = self._initial_state()
        for n in range(self.n_frames):
            self._step(state, n)
            yield _interior(state).copy()

    def frame(self, index: int) -> NDArray[np.float32]:
        """Frame ``index`` (a new array), simulated from frame 0: the scene is a value and keeps
        no state between calls (iterate :meth:`frames` for a whole sequence)."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise TypeError(f"frame index must be an integer; got {index!r}")
        if not 0 <= index < self.n_frames:
            raise IndexError(f"frame {index} out of range: the scene has {self.n_frames} frames")
        state = self._initial_state()
        for n in range(index + 1):
            self._step(state, n)
        return _interior(state).copy()

    def excess_heat(self, temperature: ArrayLike) -> float:
        """E = Σ (T − T_a) over the grid, K·voxel (proportional to the gas's excess heat)."""
        return float(np.sum(np.asarray(temperature, dtype=np.float64) - self.ambient_K))

    def _initial_state(self) -> NDArray[np.float32]:
        """Air at T_a, with one layer of ghost voxels (open air at T_a) around the grid."""
        return np.full(tuple(n + 2 for n in self.shape), self.ambient_K, dtype=np.float32)

    def _step(self, state: NDArray[np.float32], n: int) -> None:
        """Advance the padded ``state`` from frame n − 1 to frame n, in place."""
        inner = _interior(state)
        self._heat(inner, n)
        self._diffuse(state)
        inner -= self.ambient_K
        inner *= np.float32(math.exp(-self.cooling_rate_per_frame))
        inner += self.ambient_K
        inner += inner[:, :, ::-1].copy()  # exact mirror symmetry: fl(a + b) == fl(b + a)
        inner *= np.float32(0.5)

    def _heat(self, inner: NDArray[np.float32], n: int) -> None:
        """Relax the voxels the plate sweeps during frame n toward T_p (step 1), in place."""
        ny, nz = self.shape[1:]
        a = _centred_coverage(ny, self.plate_size_voxels[0])
        b = _centred_coverage(nz, self.plate_size_voxels[1])
        yz = self.heating_rate_per_frame * a[:, None] * b[None, :]
        x = self.plate_x_voxels(n)
        edges = np.arange(self.shape[0], dtype=np.float64)
        sweep = (x - self.plate_thickness_voxels, x + self.speed_voxels_per_frame)
        swept = _overlap(edges, edges + 1.0, *sweep)
        for i in np.flatnonzero(swept):
            weight = (-np.expm1(-swept[i] * yz)).astype(np.float32)
            inner[i] += weight * (np.float32(self.plate_temperature_K) - inner[i])

    def _diffuse(self, state: NDArray[np.float32]) -> None:
        """D ∇²T by explicit Euler sub-steps on the padded ``state`` (step 2), in place."""
        d = self.diffusivity_voxels2_per_frame
        if d == 0:
            return
        substeps = max(1, math.ceil(d / MAX_DIFFUSION_NUMBER))
        r = np.float32(d / substeps)
        inner = _interior(state)
        lap = np.empty_like(inner)
        for _ in range(substeps):
            np.add(state[:-2, 1:-1, 1:-1], state[2:, 1:-1, 1:-1], out=lap)
            lap += state[1:-1, :-2, 1:-1]
            lap += state[1:-1, 2:, 1:-1]
            lap += state[1:-1, 1:-1, :-2] + state[1:-1, 1:-1, 2:]  # z pair first: symmetric
            lap -= np.float32(6.0) * inner
            lap *= r
            inner += lap

    # --- rendering ------------------------------------------------------------------------------
    def volume(self, temperature: ArrayLike) -> Volume:
        """A frame as a :class:`~incandescent.volume.Volume` of ``voxel_size_m`` voxels, centred on
        the world origin (so the z-mirror plane is z = 0).

        Absorption rises linearly with the excess temperature, saturating at the plate's::

            κ(T) = κ_p · clip((T − T_a) / (T_p − T_a), 0, 1)

        so ambient air is vacuum, hot gas absorbs and emits, and κ is continuous and
        non-decreasing in T (no threshold where gas pops in or out of view as it cools).
        """
        temp = _validate.finite(_validate.real_array(temperature, "temperature"), "temperature")
        if temp.shape != self.shape:
            raise ValueError(f"temperature has shape {temp.shape}; the scene's is {self.shape}")
        excess = (temp - self.ambient_K) / (self.plate_temperature_K - self.ambient_K)
        kappa = self.absorption_per_m * np.clip(excess, 0.0, 1.0)
        return Volume.from_arrays(
            temp, absorption=kappa, voxel_size_m=self.voxel_size_m, source="PlateScene frame"
        )


def _interior(state: NDArray[np.float32]) -> NDArray[np.float32]:
    """The grid inside the ghost layer (a view)."""
    return state[1:-1, 1:-1, 1:-1]
