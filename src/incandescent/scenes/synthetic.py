"""Synthetic scenes for demos, tests and benchmarks (NumPy, deterministic)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.volume import Volume
from incandescent.volume.sparse import LEAF, SparseVolume

AMBIENT_K = 300.0


def _coords(shape: tuple[int, int, int]) -> tuple[NDArray, NDArray, NDArray]:
    """Voxel-centre coordinates scaled to [-1, 1] along x and z and [0, 1] along y (up)."""
    nx, ny, nz = shape
    x = (np.arange(nx) + 0.5) / nx * 2.0 - 1.0
    y = (np.arange(ny) + 0.5) / ny
    z = (np.arange(nz) + 0.5) / nz * 2.0 - 1.0
    return np.meshgrid(x, y, z, indexing="ij", sparse=True)


def plume_temperature(n: int = 128, peak_K: float = 2000.0, seed: int = 1) -> NDArray[np.float32]:
    """A rising turbulent plume: a hot narrow base widening and cooling with height, with swirls.

    An n³ grid in kelvin (ambient 300 K), x and z across, y up; cheap to generate (no simulation).
    """
    x, y, z = _coords((n, n, n))
    rng = np.random.default_rng(seed)
    wobble_x, wobble_z = np.zeros_like(y), np.zeros_like(y)
    for _ in range(3):
        freq, phase, amp = rng.uniform(2, 6), rng.uniform(0, 2 * np.pi), rng.uniform(0.05, 0.1)
        wobble_x = wobble_x + amp * y * np.sin(freq * np.pi * y + phase)
        wobble_z = wobble_z + amp * y * np.cos(freq * np.pi * y + 2 * phase)
    radius = 0.12 + 0.38 * y
    r2 = (x - wobble_x) ** 2 + (z - wobble_z) ** 2
    swirl = 1.0 + 0.18 * np.sin(11 * x + 9 * y) * np.sin(8 * z - 13 * y) * np.sin(17 * y)
    axis_K = peak_K * (1.0 - 0.5 * y) * np.clip(y * 10.0, 0.0, 1.0) * np.clip((1 - y) * 6, 0, 1)
    heat = np.clip(np.exp(-r2 / (2 * radius**2)) * swirl, 0.0, 1.05)
    return (AMBIENT_K + np.maximum(axis_K - AMBIENT_K, 0.0) * heat).astype(np.float32)


def plume(n: int = 128, peak_K: float = 2000.0) -> Volume:
    """The plume on a 1 m grid with the default absorption (κ where T ≥ 500 K)."""
    return Volume.from_arrays(plume_temperature(n, peak_K), source=f"plume({n})")


def soot_plume(n: int = 128, peak_K: float = 2000.0, kappa_per_m: float = 2.0) -> Volume:
    """The plume with a graded absorption grid: κ rises linearly from 0 at 500 K to
    ``kappa_per_m`` at the peak (so the kernel reads a general (κ, T) grid, not a two-valued κ)."""
    temperature = plume_temperature(n, peak_K)
    soot = np.clip((temperature - 500.0) / (peak_K - 500.0), 0.0, 1.0)
    return Volume.from_arrays(temperature, absorption=soot * kappa_per_m, source=f"soot_plume({n})")


def sparse_flame(n: int = 256, flame_fraction: float = 0.12, peak_K: float = 1900.0) -> Volume:
    """A small plume filling ``flame_fraction`` of the side of an otherwise empty n³ box."""
    m = max(4, int(round(n * flame_fraction)))
    temperature = np.full((n, n, n), AMBIENT_K, dtype=np.float32)
    lo = (n - m) // 2
    temperature[lo : lo + m, n // 8 : n // 8 + m, lo : lo + m] = plume_temperature(m, peak_K)
    return Volume.from_arrays(temperature, source=f"sparse_flame({n})")


def explosion_shell(
    n: int = 1024, occupancy: float = 0.03, peak_K: float = 2100.0, kappa_per_m: float = 4.0
) -> SparseVolume:
    """A turbulent spherical fireball shell in an empty n³ box, built leaf by leaf (never dense).

    The shell (radius 0.35·n, thickness chosen so that ``occupancy`` of the box's voxels lie in
    it) is hottest mid-shell with a smooth ±25 % ripple; κ rises with T as in
    :func:`soot_plume`. At n = 1024 that is ~32 M hot voxels in a box whose dense (κ, T) grid
    would be 8 GiB."""
    centre, radius = n / 2.0, 0.35 * n
    half = occupancy * n**3 / (4.0 * np.pi * radius**2) / 2.0  # half thickness, voxels
    leaves = np.indices((-(-n // LEAF),) * 3).reshape(3, -1).T
    middle = np.linalg.norm(leaves * LEAF + LEAF / 2.0 - centre, axis=1)
    reach = half * 1.3 + LEAF * np.sqrt(3) / 2.0  # the ripple widens the shell by 30 %
    leaves = leaves[np.abs(middle - radius) < reach].astype(np.int32)
    temp = np.empty((len(leaves), LEAF, LEAF, LEAF), dtype=np.float32)
    offsets = np.indices((LEAF,) * 3, dtype=np.float32) + 0.5
    for start in range(0, len(leaves), 4096):  # ~8 MB of voxels at a time
        part = leaves[start : start + 4096, :, None, None, None] * LEAF
        x, y, z = (part[:, a] + offsets[a] for a in range(3))
        temp[start : start + 4096] = _shell_temperature(x, y, z, centre, radius, half, peak_K, n)
    kappa = np.clip((temp - 500.0) / (peak_K - 500.0), 0.0, 1.0) * np.float32(kappa_per_m)
    keep = temp.reshape(len(temp), -1).max(axis=1) > 0
    return SparseVolume.from_leaves(
        (n, n, n), leaves[keep], temp[keep], kappa[keep], source=f"explosion_shell({n})"
    )


def _shell_temperature(x, y, z, centre, radius, half, peak_K, n) -> NDArray[np.float32]:
    """T (K) of the shell at voxel centres (x, y, z): a smooth bump across the shell, rippled."""
    k = 2.0 * np.pi * 5.0 / n
    ripple = 1.0 + 0.3 * np.sin(k * x) * np.sin(1.3 * k * y + 0.7) * np.sin(0.9 * k * z + 1.9)
    d = np.sqrt((x - centre) ** 2 + (y - centre) ** 2 + (z - centre) ** 2) - radius
    bump = np.clip(1.0 - (d / (half * ripple)) ** 2, 0.0, None)
    temp = peak_K * bump * (0.75 + 0.25 * ripple)
    return np.where(temp > 400.0, temp, 0.0).astype(np.float32)  # below 400 K: vacuum


def simulated_campfire(n: int = 48) -> Volume:
    """Frame 30 (1.25 s) of the ``campfire`` preset simulated at 48 cells
    (``scripts/make_demo_fire.py``), shipped with the package: temperature, soot κ and the blue
    core's CH and C₂ fractions. ``n`` is ignored (the frame has its own grid)."""
    return _shipped_frame("campfire")


def simulated_explosion(n: int = 48) -> Volume:
    """Frame 24 (1 s) of the ``explosion`` preset simulated at 48 cells
    (``scripts/make_demo_fire.py --preset explosion --frames 24``), shipped with the package.
    ``n`` is ignored."""
    return _shipped_frame("explosion")


def _shipped_frame(name: str) -> Volume:
    """The simulated frame ``scenes/data/NAME.npz``: T, soot κ, CH and C₂ fractions."""
    from importlib.resources import files

    with files("incandescent.scenes").joinpath(f"data/{name}.npz").open("rb") as handle:
        with np.load(handle) as data:
            return Volume.from_arrays(
                data["temperature"],
                absorption=data["absorption"],
                voxel_size_m=float(data["voxel_size_m"]),
                origin_m=data["origin_m"],
                species={"CH": data["CH"], "C2": data["C2"]},
                source=f"simulated {name}",
                absorption_source="soot",
                temperature_source="simulated (K)",
            )
