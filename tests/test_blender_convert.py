"""The add-on's Blender → incandescent camera conversion (integrations/blender/…/convert.py), in
plain Python: the sensor fits, orthographic scale and what our camera cannot be. Its agreement
with Blender's own projection is tests/blender/test_blender_addon.py's."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from incandescent.camera import Camera

PATH = Path(__file__).resolve().parents[1] / "integrations/blender/incandescent_blender/convert.py"
spec = importlib.util.spec_from_file_location("blender_convert", PATH)
assert spec is not None and spec.loader is not None
convert = importlib.util.module_from_spec(spec)
spec.loader.exec_module(convert)

IDENTITY = convert.translation((0.0, 0.0, 0.0))
DATA = {"lens": 50.0, "sensor_width": 36.0, "sensor_height": 24.0, "sensor_fit": "AUTO",
        "type": "PERSP", "ortho_scale": 6.0, "shift_x": 0.0, "shift_y": 0.0}  # fmt: skip


@pytest.mark.parametrize(
    ("fit", "width", "height", "half_height"),
    [
        ("AUTO", 200, 100, 18 / 50 * 100 / 200),  # wide: the sensor width spans the width
        ("AUTO", 100, 200, 18 / 50),  # tall: the sensor width spans the height
        ("HORIZONTAL", 100, 200, 18 / 50 * 2),
        ("VERTICAL", 200, 100, 12 / 50),
    ],
)
def test_field_of_view_follows_the_sensor_fit(fit, width, height, half_height):
    fov = convert.fitted_fov_deg(50.0, 36.0, 24.0, fit, width, height)
    assert math.tan(math.radians(fov) / 2) == pytest.approx(half_height, rel=1e-12)


def _args(camera_matrix, frame=IDENTITY, **data):
    args = convert.camera_arguments(camera_matrix, frame, DATA | data, 200, 100)
    return {args[i]: args[i + 1] for i in range(0, len(args), 2)}


def _vector(text):
    return np.array([float(v) for v in text.split(",")])


def test_a_camera_looking_down_blenders_y_looks_down_our_z():
    """A camera at Blender (0, −5, 1) rotated 90° about x looks along +y (Blender), up +z:
    ours at (0, 1, 5), looking along −z, up +y."""
    c, s = 0.0, 1.0  # cos, sin of 90°
    matrix = [[1, 0, 0, 0], [0, c, -s, -5], [0, s, c, 1], [0, 0, 0, 1]]
    args = _args(matrix)
    np.testing.assert_allclose(_vector(args["--eye"]), (0, 1, 5), atol=1e-12)
    direction = _vector(args["--target"]) - _vector(args["--eye"])
    np.testing.assert_allclose(direction, (0, 0, -1), atol=1e-12)
    np.testing.assert_allclose(_vector(args["--up"]), (0, 1, 0), atol=1e-12)
    Camera(eye=_vector(args["--eye"]), target=_vector(args["--target"]), up=_vector(args["--up"]))


def test_the_frame_of_the_file_is_taken_out():
    """A volume object moved by (1, 2, 3): the camera moves by −(1, 2, 3) in the file's frame."""
    matrix = [[1, 0, 0, 0], [0, 0, -1, -5], [0, 1, 0, 1], [0, 0, 0, 1]]
    moved = _args(matrix, convert.translation((1.0, 2.0, 3.0)))
    np.testing.assert_allclose(_vector(moved["--eye"]), (-1, -2, 7), atol=1e-12)


def test_orthographic_scale_spans_the_fitted_side():
    matrix = [[1, 0, 0, 0], [0, 0, -1, -5], [0, 1, 0, 1], [0, 0, 0, 1]]
    args = _args(matrix, type="ORTHO")
    assert args["--projection"] == "orthographic"
    assert float(args["--ortho-height"]) == pytest.approx(6.0 * 100 / 200)


def test_what_our_camera_cannot_be_is_refused_with_the_reason():
    matrix = [[1, 0, 0, 0], [0, 0, -1, -5], [0, 1, 0, 1], [0, 0, 0, 1]]
    with pytest.raises(ValueError, match="lens shift"):
        _args(matrix, shift_x=0.1)
    with pytest.raises(ValueError, match="PANO"):
        _args(matrix, type="PANO")
    scaled = [[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]]
    with pytest.raises(ValueError, match="apply its scale"):
        _args(matrix, scaled)
