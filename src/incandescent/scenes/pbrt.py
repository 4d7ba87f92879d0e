"""The two pbrt-v4 volpath reference scenes (``tests/data/pbrt_d1``, ``pbrt_d2``; made from
``shared/reference/pbrt-scatter``) in our axes, for the tests, the benchmark against pbrt and
the scattering page: pbrt's arrays P[z][y][x] with +z up and the camera on −y become ours by
``P.transpose(2, 0, 1)[:, :, ::-1]`` with +y up and the camera on +z."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from incandescent.camera import Camera
from incandescent.volume import Volume

#: Both scenes' camera: 30° field of view, 2.6 m from the box's centre.
CAMERA = Camera(eye=(0.0, 0.0, 2.6), target=(0.0, 0.0, 0.0), fov_deg=30.0)
#: pbrt's film Y for D2 → cd/m²: 683 lm/W × B_peak(2000 K) = 131.0615 W sr⁻¹ m⁻² nm⁻¹.
D2_CD_M2 = 89_515.0
#: pbrt's linear sRGB → Y.
PBRT_Y = np.array([0.2126735, 0.7151516, 0.0721749])


def _ours(a: np.ndarray) -> np.ndarray:
    return a.transpose(2, 0, 1)[:, :, ::-1]


def sunlit_sphere(folder: Path) -> Volume:
    """D1: a cold smooth-edged sphere, σ_a = 0.5·d, σ_s = 9.5·d per m, g = 0."""
    d = _ours(np.load(Path(folder) / "density.npy"))
    cold = Volume.from_arrays(np.zeros(d.shape), absorption=0.5 * d, voxel_size_m=1 / 64,
                              origin_m=(-0.5,) * 3)  # fmt: skip
    return cold.with_scattering(9.5 * d, phase_g=0.0)


def glowing_core(folder: Path) -> Volume:
    """D2: a lumpy cloud, σ_a = 4·d, σ_s = 6·d per m, g = 0.5, around a core of up to 1900 K."""
    d = _ours(np.load(Path(folder) / "density.npy"))
    temp = _ours(np.load(Path(folder) / "temperature_K.npy"))
    gas = Volume.from_arrays(temp, absorption=4.0 * d, voxel_size_m=1 / 64, origin_m=(-0.5,) * 3)
    return gas.with_scattering(6.0 * d, phase_g=0.5)
