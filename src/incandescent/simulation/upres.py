"""Detail for rendering: a simulated frame up-resolved 2–4× with procedural turbulence below the
simulation's grid, after Kim, Thürey, James & Gross 2008 ("Wavelet Turbulence for Fluid
Simulation", ACM TOG 27(3):50) — what Mantaflow's "noise" does.

A frame's cell fields (temperature, soot κ, species fractions) are interpolated trilinearly onto a
grid ``factor`` times finer, then carried for one frame's time Δt by the turbulence the coarse
grid cannot hold: ``u_t(x) = Σ_i 2^(−5/6·(i+1)) · √(2 e_t(x)) · ∇ × w_i(x)``, one octave i per
doubling (each octave's displacement at most its eddies' radius 1/k_i: ``displacement_cells``),
where

- e_t is the kinetic energy of the coarse velocity's finest resolved band, ½|u − G₁ * u|²
  (u minus its Gaussian blur of one coarse cell), per unit mass: the energy at the grid's
  cut-off that Kim et al. extrapolate (their eq. 7) into the unresolved octaves by Kolmogorov's
  E(k) ∝ k^(−5/3), whose amplitude falls by 2^(−5/6) per octave;
- w_i is band-limited noise of the octave's wavelengths (Gaussian white noise band-passed by FFT
  to wavenumbers 2^i..2^(i+1) times the coarse grid's Nyquist, seeded), its curl scaled to
  unit RMS: divergence-free, so the detail moves gas without compressing it (Kim et al. use
  Cook & DeRose 2005's wavelet noise for the same band-limited, tileable field).

Each fine sample takes the value upstream, ``q(x − Δt·u_t(x))`` (semi-Lagrangian, trilinear).
Where the coarse flow is smooth (e_t = 0) the result is exactly the trilinear up-sampling.

So that the detail travels with the gas from frame to frame, the noise is looked up at texture
coordinates advected by the coarse velocity (Kim et al. §5), regenerated as Neyret 2003
("Advected textures", SCA) does: two phases, each reset to the identity (with new noise) every
``PERIOD_FRAMES`` frames, half a period apart, each advected from its last reset through the
frames since (``advected``), blended with triangle weights that vanish at a phase's reset and
normalised by √(w₀² + w₁²) (the two noises are independent: the blend keeps unit RMS). A
frame's coordinates so depend only on the frames since the older reset — at most a period of
them, read again for each frame: frames render in any order, in parallel, or one alone. A frame
without its predecessors (``history`` None) gets fixed noise, one seed for every frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy import ndimage

#: The up-resolution factors offered: 2× (one octave of detail), 3×, 4× (two octaves).
FACTORS = (2, 3, 4)
#: Frames between a texture phase's resets (0.5 s at 24 fps): Neyret's regeneration period, a
#: free (artistic) choice — long enough that the detail is seen to travel, short enough that the
#: shearing flow does not stretch the advected noise into streaks (a parcel at 1 m/s crosses
#: ~15 cells of the 48-cell campfire in that time).
PERIOD_FRAMES = 12


def check_factor(factor: object, where: str = "upres") -> int:
    """``factor`` as an int in ``FACTORS``; else a one-line ValueError naming ``where``."""
    if (
        isinstance(factor, bool)
        or not isinstance(factor, int | np.integer)
        or factor not in FACTORS
    ):
        raise ValueError(f"{where} must be one of {', '.join(map(str, FACTORS))}; got {factor!r}")
    return int(factor)


def upsample(field: np.ndarray, factor: int) -> np.ndarray:
    """Trilinear interpolation of a cell-centred (nx, ny, nz) field onto the cell centres of a
    grid ``factor`` times finer (edge values extended), float32."""
    axes = [(np.arange(n * factor) + 0.5) / factor - 0.5 for n in field.shape]
    points = np.meshgrid(*axes, indexing="ij")
    return ndimage.map_coordinates(field, points, order=1, mode="nearest").astype(np.float32)


def unresolved_energy(velocity_m_s: np.ndarray) -> np.ndarray:
    """e_t (m²/s²) per coarse cell: ½|u − G₁ * u|², the energy of the velocity's finest band
    (``velocity_m_s`` of shape (nx, ny, nz, 3), cell-centred)."""
    smooth = np.stack(
        [ndimage.gaussian_filter(velocity_m_s[..., a], 1.0, mode="nearest") for a in range(3)],
        axis=-1,
    )
    return 0.5 * np.sum((velocity_m_s - smooth) ** 2, axis=-1)


def curl_noise(
    shape: tuple[int, ...], octave: int, factor: int, seed: int | Sequence[int]
) -> np.ndarray:
    """A divergence-free field of unit RMS (shape + (3,), per fine cell) whose wavelengths are
    those of octave ``octave`` below a coarse grid ``factor`` times coarser: the curl of a
    vector potential of white noise band-passed to |k| in [2^octave, 2^(octave+1)] × k_c,
    k_c = π/factor radians per fine cell (the coarse grid's Nyquist: the first unresolved
    wavenumber)."""
    rng = np.random.default_rng([*np.atleast_1d(seed).tolist(), octave])
    k = np.meshgrid(*[np.fft.fftfreq(n) * 2 * math.pi for n in shape], indexing="ij")
    magnitude = np.sqrt(k[0] ** 2 + k[1] ** 2 + k[2] ** 2)
    low = math.pi / factor * 2**octave
    band = (magnitude >= low) & (magnitude < 2 * low)
    potential = [np.fft.fftn(rng.standard_normal(shape)) * band for _ in range(3)]
    # ∇ × A in Fourier space: i k × Â
    curl = [
        k[1] * potential[2] - k[2] * potential[1],
        k[2] * potential[0] - k[0] * potential[2],
        k[0] * potential[1] - k[1] * potential[0],
    ]
    field = np.stack([np.real(np.fft.ifftn(1j * c)) for c in curl], axis=-1)
    rms = math.sqrt(float(np.mean(np.sum(field**2, axis=-1)))) or 1.0
    return field / rms


def octaves(factor: int) -> int:
    """Octaves of detail between the coarse grid and one ``factor`` times finer: ⌈log₂ factor⌉."""
    return max(1, math.ceil(math.log2(factor)))


def band_wavenumber(octave: int, factor: int) -> float:
    """The middle of octave ``octave``'s band, radians per fine cell (``curl_noise``'s band)."""
    return 1.5 * math.pi / factor * 2**octave


def displacement_cells(velocity_m_s: np.ndarray, factor: int, dt_s: float, fine_m: float,
                       seed: int, noise: list[np.ndarray] | None = None) -> np.ndarray:  # fmt: skip
    """How far (fine cells; (fx, fy, fz, 3)) the unresolved turbulence carries gas in ``dt_s``:
    per octave, Δt·2^(−5/6·(i+1))·√(2 e_t) along its unit curl noise, but at most 1/k_i — an
    eddy of wavenumber k_i turns over before it carries gas further than its own radius, and a
    larger single displacement would fold the field into speckle."""
    energy = upsample(unresolved_energy(velocity_m_s), factor)
    speed_m_s = np.sqrt(2.0 * np.maximum(energy, 0.0))[..., None]
    total = np.zeros(energy.shape + (3,), dtype=np.float32)
    for i in range(octaves(factor)):
        reach = dt_s * 2.0 ** (-5.0 / 6.0 * (i + 1)) * speed_m_s / fine_m
        reach = np.minimum(reach, 1.0 / band_wavenumber(i, factor))
        unit = curl_noise(energy.shape, i, factor, seed) if noise is None else noise[i]
        total += (reach * unit).astype(np.float32)
    return total


def phases(frame: int, period: int = PERIOD_FRAMES) -> list[tuple[int, float]]:
    """The two texture phases at ``frame``: (the frame of its last reset, its blend weight).
    Phase k resets at the frames ≡ k·period/2 (mod period), and its weight is a triangle over
    its life: 0 at a reset, 1 half a period after."""
    out = []
    for k in range(2):
        offset = k * period // 2
        age = (frame - offset) % period
        weight = 1.0 - abs(2.0 * age / period - 1.0)
        out.append((frame - age, weight))
    return out


def advected(velocities_m_s: Sequence[np.ndarray], voxel_size_m: float, dt_s: float) -> np.ndarray:
    """Texture coordinates (coarse cells; (nx, ny, nz, 3)) carried from the identity through
    each of ``velocities_m_s`` (the coarse cell velocities, m/s, of the frames since the reset,
    oldest first) for ``dt_s`` each: X ← X(x − Δt·u(x)/h) (semi-Lagrangian, trilinear, edge
    values extended)."""
    shape = np.shape(velocities_m_s[0])[:3] if velocities_m_s else None
    if shape is None:
        raise ValueError("advected needs at least one velocity grid")
    grid = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij"))
    coords = np.moveaxis(grid, 0, -1).copy()
    for velocity in velocities_m_s:
        back = grid - np.moveaxis(np.asarray(velocity, np.float64), -1, 0) * (dt_s / voxel_size_m)
        coords = np.stack([ndimage.map_coordinates(coords[..., a], back, order=1, mode="nearest")
                           for a in range(3)], axis=-1)  # fmt: skip
    return coords


def _noise_at(coords: np.ndarray, factor: int, seed: Sequence[int]) -> list[np.ndarray]:
    """Each octave's unit curl noise (``curl_noise``, periodic) looked up trilinearly at the fine
    cells whose texture coordinates are ``coords`` (coarse cells, up-sampled)."""
    fine = np.stack([upsample(coords[..., a], factor) for a in range(3)])
    fine = (fine + 0.5) * factor - 0.5  # coarse cell → fine cell coordinates
    out = []
    for i in range(octaves(factor)):
        noise = curl_noise(fine.shape[1:], i, factor, seed)
        out.append(np.stack([ndimage.map_coordinates(noise[..., a], fine, order=1,
                                                     mode="grid-wrap")
                             for a in range(3)], axis=-1))  # fmt: skip
    return out


def advected_noise(frame: int, shape: tuple[int, ...], history: Callable[[int], np.ndarray | None],
                   voxel_size_m: float, factor: int, dt_s: float,
                   seed: int = 0) -> list[np.ndarray]:  # fmt: skip
    """Each octave's noise at ``frame`` (coarse grid ``shape``) advected with the gas: the two
    phases (``phases``) at
    their coordinates advected from their resets through the frames' velocities
    (``history(f)``: frame f's coarse cell velocity in m/s, or None where it is not there, which
    stops that phase's advection at the frames after it), blended by √-normalised weights. Each
    reset draws new noise: seed (``seed``, phase, reset frame)."""
    blended: list[np.ndarray] | None = None
    parts = phases(frame)
    norm = math.sqrt(sum(w * w for _, w in parts))
    for k, (reset, weight) in enumerate(parts):
        if weight == 0.0:
            continue
        steps: list[np.ndarray] = []
        for f in range(reset, frame):
            velocity = history(f)
            steps = [] if velocity is None else steps + [velocity]
        coords = advected(steps, voxel_size_m, dt_s) if steps else _identity(shape)
        noise = _noise_at(coords, factor, (seed, k, reset % 2**31))
        scaled = [n * (weight / norm) for n in noise]
        if blended is not None:
            scaled = [a + b for a, b in zip(blended, scaled, strict=True)]
        blended = scaled
    assert blended is not None, "one phase always has weight"
    return blended


def _identity(shape: tuple[int, ...]) -> np.ndarray:
    grid = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")
    return np.stack(grid, axis=-1)


def upres_fields(
    fields: Mapping[str, np.ndarray],
    velocity_m_s: np.ndarray,
    voxel_size_m: float,
    factor: int,
    dt_s: float,
    seed: int = 0,
    noise: list[np.ndarray] | None = None,
) -> dict[str, np.ndarray]:
    """Each (nx, ny, nz) field of ``fields`` on the grid ``factor`` times finer, carried for
    ``dt_s`` (s) by the unresolved turbulence of ``velocity_m_s`` (the coarse (nx, ny, nz, 3)
    cell velocity, m/s) — see the module docstring; ``noise``: each octave's unit curl noise
    per fine cell (``advected_noise``), else fixed noise of ``seed``. Returns float32 grids of
    the fine shape."""
    factor = check_factor(factor)
    shift = displacement_cells(velocity_m_s, factor, dt_s, voxel_size_m / factor, seed, noise)
    grid = np.meshgrid(*[np.arange(n) for n in shift.shape[:3]], indexing="ij")
    upstream = [grid[a] - shift[..., a] for a in range(3)]
    out = {}
    for name, field in fields.items():
        fine = upsample(np.asarray(field, dtype=np.float32), factor)
        out[name] = ndimage.map_coordinates(fine, upstream, order=1, mode="nearest").astype(
            np.float32
        )
    return out
