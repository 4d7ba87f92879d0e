"""Synthetic scenes for demos, tests and benchmarks (NumPy, deterministic)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.volume import Volume

AMBIENT_K = 300.0


def _coords(shape: tuple[int, int, int]) -> tuple[NDArray, NDArray, NDArray]:
    """Voxel-centre coordinates scaled to [-1, 1] along x and z and [0, 1] along y (up)."""
    nx, ny, nz = shape
    x = (np.arange(nx) + 0.5) / nx * 2.0 - 1.0
    y = (np.arange(ny) + 0.5) / ny
    z = (np.arange(nz) + 0.5) / nz * 2.0 - 1.0
    return np.meshgrid(x, y, z, indexing="ij", sparse=True)


def plume_temperature(n: int = 128, peak_K: float = 2000.0, seed: int = 1) -> NDArray[np.float32]:
    """A rising turbulent plume: hot narrow base widening and cooling with height, with swirls.

    An n³ grid in kelvin (ambient 300 K); cheap to generate (no simulation).
    """
    x, y, z = _coords((n, n, n))
    rng = np.random.default_rng(seed)
    wobble = np.zeros_like(y)
    for _ in range(4):
        freq, phase, amp = rng.uniform(3, 9), rng.uniform(0, 2 * np.pi), rng.uniform(0.03, 0.08)
        wobble = wobble + amp * y * np.sin(freq * y * np.pi + phase)
    radius = 0.12 + 0.45 * y
    r2 = (x - wobble) ** 2 + (z - 0.7 * wobble) ** 2
    swirl = 1.0 + 0.25 * np.sin(10 * x + 7 * y) * np.sin(9 * z - 5 * y)
    core = np.exp(-r2 / (2 * radius**2)) * swirl
    height = np.exp(-((y - 0.25) ** 2) / 0.12) * np.clip(y * 12, 0, 1)
    temperature = AMBIENT_K + (peak_K - AMBIENT_K) * np.clip(core * height, 0, 1.2)
    return temperature.astype(np.float32)


def plume(n: int = 128, peak_K: float = 2000.0) -> Volume:
    """The plume on a 1 m grid with the default absorption (κ where T ≥ 500 K)."""
    return Volume.from_arrays(plume_temperature(n, peak_K), source=f"plume({n})")


def sparse_flame(n: int = 256, flame_fraction: float = 0.12, peak_K: float = 1900.0) -> Volume:
    """A small plume filling ``flame_fraction`` of the side of an otherwise empty n³ box."""
    m = max(4, int(round(n * flame_fraction)))
    temperature = np.full((n, n, n), AMBIENT_K, dtype=np.float32)
    lo = (n - m) // 2
    temperature[lo : lo + m, n // 8 : n // 8 + m, lo : lo + m] = plume_temperature(m, peak_K)
    return Volume.from_arrays(temperature, source=f"sparse_flame({n})")


def soot_sphere(n: int = 64, temperature_K: float = 3000.0, absorption_per_m: float = 0.5) -> Volume:
    """The paper's first scene: a roughly spherical cloud of transparent soot at ~3000 K."""
    x, y, z = _coords((n, n, n))
    r = np.sqrt(x**2 + ((y - 0.5) * 2) ** 2 + z**2)
    shell = np.clip((1.0 - r) / 0.15, 0.0, 1.0)
    temperature = AMBIENT_K + (temperature_K - AMBIENT_K) * shell
    kappa = np.where(r < 1.0, absorption_per_m, 0.0) * np.ones_like(temperature)
    return Volume.from_arrays(temperature, absorption=kappa, source=f"soot_sphere({n})")
