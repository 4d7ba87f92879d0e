"""Camera paths: orbit and keyframes."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.camera import Camera
from incandescent.camera.paths import keyframes, orbit


def test_orbit_keeps_distance_and_height_and_turns_fully():
    cam = Camera(eye=(1.0, 0.5, 2.0), target=(0.1, 0.0, -0.2))
    path = orbit(cam, 8, 360.0)
    assert path(0) == cam
    target = np.asarray(cam.target)
    radius = np.linalg.norm(np.subtract(cam.eye, target)[[0, 2]])
    for frame in range(8):
        eye = np.asarray(path(frame).eye)
        assert eye[1] == pytest.approx(cam.eye[1])
        assert np.linalg.norm((eye - target)[[0, 2]]) == pytest.approx(radius)
    np.testing.assert_allclose(orbit(cam, 8, 360.0)(8).eye, cam.eye, atol=1e-12)  # a full turn
    half = orbit(cam, 3, 180.0)(2).eye  # the last frame of a partial orbit reaches the angle
    np.testing.assert_allclose(
        np.subtract(half, target)[[0, 2]], -np.subtract(cam.eye, target)[[0, 2]], atol=1e-12
    )


def test_keyframes_interpolate_linearly_and_hold_at_the_ends():
    a = Camera(eye=(0.0, 0.0, 2.0), fov_deg=30.0)
    b = Camera(eye=(2.0, 0.0, 2.0), fov_deg=50.0)
    path = keyframes([(10, b), (0, a)])
    mid = path(5)
    np.testing.assert_allclose(mid.eye, (1.0, 0.0, 2.0))
    assert mid.fov_deg == pytest.approx(40.0)
    assert path(-3) == a and path(99) == b
    with pytest.raises(ValueError, match="at least one"):
        keyframes([])
