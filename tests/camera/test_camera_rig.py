"""A rig of cameras rendered as one film is exactly its cameras rendered one by one."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

import incandescent as inc
from incandescent.camera import Rig


def _flame(n: int = 12) -> inc.Volume:
    x = (np.indices((n, n, n)).transpose(1, 2, 3, 0) + 0.5) / n - 0.5
    r = np.linalg.norm(x - [0.08, -0.05, 0.0], axis=-1)
    temp = 300 + 1600 * np.exp(-((r / 0.3) ** 2))
    kappa = 6.0 * np.exp(-((np.linalg.norm(x, axis=-1) / 0.4) ** 2))
    return inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.1 / n)


def _ring(count: int, **extra) -> tuple[inc.Camera, ...]:
    angles = 2 * np.pi * np.arange(count) / count
    return tuple(inc.Camera(eye=(0.25 * np.sin(a), 0.05, 0.25 * np.cos(a)), fov_deg=30.0,
                            **extra) for a in angles)  # fmt: skip


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_a_rig_renders_each_camera_bit_for_bit(backend, projection):
    """Three views of 16×10 on one 48×10 film: each camera's columns equal its own render
    exactly (the same rays, the same kernel arithmetic), transmittance too."""
    extra = {"projection": projection, "ortho_height_m": 0.12}
    cameras, volume = _ring(3, **extra), _flame()
    settings = inc.RenderSettings(width=16, height=10, jitter=False)
    rig = Rig(cameras)
    film = inc.render(volume, rig, settings.replace(width=48), backend)
    for camera, xyz, tr in zip(cameras, rig.split(film.xyz), rig.split(film.transmittance),
                               strict=True):  # fmt: skip
        alone = inc.render(volume, camera, settings, backend)
        assert np.asarray(alone.xyz).max() > 0
        np.testing.assert_array_equal(xyz, alone.xyz)
        np.testing.assert_array_equal(tr, alone.transmittance)


def test_a_rig_refuses_what_it_cannot_tile():
    """No cameras, mixed projections and a film width that is not a multiple of the cameras:
    one line each."""
    with pytest.raises(ValueError, match="needs one or more Cameras"):
        Rig(())
    mixed = (_ring(1)[0], _ring(1, projection="orthographic")[0])
    with pytest.raises(ValueError, match="share one projection"):
        Rig(mixed)
    rig = Rig(_ring(3))
    with pytest.raises(ValueError, match="multiple of 3; got 40 px"):
        inc.render(_flame(), rig, inc.RenderSettings(width=40, height=10), "cpu")
