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
Where the coarse flow is smooth (e_t = 0) the result is exactly the trilinear up-sampling. The
noise is fixed in space (one seed for every frame); Kim et al. advect its texture coordinates
with the flow, which this per-frame version does not: the detail does not travel with the gas
between frames.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from scipy import ndimage

#: The up-resolution factors offered: 2× (one octave of detail), 3×, 4× (two octaves).
FACTORS = (2, 3, 4)


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


def curl_noise(shape: tuple[int, ...], octave: int, factor: int, seed: int) -> np.ndarray:
    """A divergence-free field of unit RMS (shape + (3,), per fine cell) whose wavelengths are
    those of octave ``octave`` below a coarse grid ``factor`` times coarser: the curl of a
    vector potential of white noise band-passed to |k| in [2^octave, 2^(octave+1)] × k_c,
    k_c = π/factor radians per fine cell (the coarse grid's Nyquist: the first unresolved
    wavenumber)."""
    rng = np.random.default_rng([seed, octave])
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
                       seed: int) -> np.ndarray:  # fmt: skip
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
        total += (reach * curl_noise(energy.shape, i, factor, seed)).astype(np.float32)
    return total


def upres_fields(
    fields: Mapping[str, np.ndarray],
    velocity_m_s: np.ndarray,
    voxel_size_m: float,
    factor: int,
    dt_s: float,
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """Each (nx, ny, nz) field of ``fields`` on the grid ``factor`` times finer, carried for
    ``dt_s`` (s) by the unresolved turbulence of ``velocity_m_s`` (the coarse (nx, ny, nz, 3)
    cell velocity, m/s) — see the module docstring. Returns float32 grids of the fine shape."""
    factor = check_factor(factor)
    shift = displacement_cells(velocity_m_s, factor, dt_s, voxel_size_m / factor, seed)
    grid = np.meshgrid(*[np.arange(n) for n in shift.shape[:3]], indexing="ij")
    upstream = [grid[a] - shift[..., a] for a in range(3)]
    out = {}
    for name, field in fields.items():
        fine = upsample(np.asarray(field, dtype=np.float32), factor)
        out[name] = ndimage.map_coordinates(fine, upstream, order=1, mode="nearest").astype(
            np.float32
        )
    return out
