"""Colorimetry: chromaticities, RGB space matrices and chromatic adaptation vs colour-science."""

from __future__ import annotations

import numpy as np
import pytest
from _colour import import_colour
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from incandescent.colorimetry import (
    CAT_METHODS,
    D65_XY,
    RGB_SPACES,
    RGBSpace,
    adapt,
    chromatic_adaptation_matrix,
    rgb_space,
    rgb_to_xyz,
    white_point_xyz,
    xy_to_xyz,
    xyz_to_rgb,
    xyz_to_uv_prime,
    xyz_to_xy,
)
from incandescent.spectra import planckian_white

colour = import_colour()

COLOUR_NAMES = {
    "srgb": "sRGB",
    "rec2020": "ITU-R BT.2020",
    "display_p3": "Display P3",
    "acescg": "ACEScg",
}

finite_xyz = arrays(
    np.float64,
    st.tuples(st.integers(1, 4), st.just(3)),
    elements=st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False),
)


# --- chromaticity --------------------------------------------------------------------------


def test_xyz_to_xy_matches_colour_science():
    xyz = np.array([[0.2, 0.3, 0.4], [95.0, 100.0, 108.0], [1e5, 4e5, 2e3]])
    np.testing.assert_allclose(xyz_to_xy(xyz), colour.XYZ_to_xy(xyz), rtol=1e-12)


def test_black_has_d65_chromaticity_not_nan():
    black = np.zeros((2, 2, 3))
    np.testing.assert_array_equal(xyz_to_xy(black), np.broadcast_to(D65_XY, (2, 2, 2)))
    uv = xyz_to_uv_prime(black)
    assert np.isfinite(uv).all()
    np.testing.assert_allclose(uv[0, 0], xyz_to_uv_prime(xy_to_xyz(D65_XY)), rtol=1e-12)


def test_uv_prime_matches_colour_science():
    xyz = np.array([[0.2, 0.3, 0.4], [95.0, 100.0, 108.0]])
    np.testing.assert_allclose(
        xyz_to_uv_prime(xyz), colour.models.xy_to_Luv_uv(colour.XYZ_to_xy(xyz)), rtol=1e-12
    )


def test_xy_to_xyz_round_trip_and_zero_y():
    xyz = np.array([0.3, 0.5, 0.2]) * 7.0
    np.testing.assert_allclose(xy_to_xyz(xyz_to_xy(xyz), Y=xyz[1]), xyz, rtol=1e-12)
    assert np.isfinite(xy_to_xyz([0.3, 0.0])).all()


def test_components_shape_error_names_shape():
    with pytest.raises(ValueError, match=r"xyz must have shape \[\.\.\., 3\]; got shape \(4,\)"):
        xyz_to_xy(np.ones(4))
    with pytest.raises(TypeError, match="real number"):
        xyz_to_xy(np.array(["a", "b", "c"]))


# --- RGB spaces ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(RGB_SPACES))
def test_definition_matches_colour_science(name):
    ref = colour.RGB_COLOURSPACES[COLOUR_NAMES[name]]
    np.testing.assert_allclose(RGB_SPACES[name].primaries_xy, ref.primaries, atol=1e-12)
    np.testing.assert_allclose(RGB_SPACES[name].white_xy, ref.whitepoint, atol=1e-12)


@pytest.mark.parametrize("name", sorted(RGB_SPACES))
def test_matrices_match_colour_normalised_primary_matrix(name):
    ref = colour.RGB_COLOURSPACES[COLOUR_NAMES[name]]
    npm = colour.normalised_primary_matrix(ref.primaries, ref.whitepoint)
    np.testing.assert_allclose(RGB_SPACES[name].rgb_to_xyz_matrix, npm, atol=1e-6)
    np.testing.assert_allclose(RGB_SPACES[name].xyz_to_rgb_matrix, np.linalg.inv(npm), atol=1e-6)


def test_srgb_matrix_close_to_iec_rounded_matrix():
    # colour-science stores the 4-decimal IEC 61966-2-1 matrix for sRGB; ours is computed.
    ref = colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ
    np.testing.assert_allclose(RGB_SPACES["srgb"].rgb_to_xyz_matrix, ref, atol=1e-4)


@pytest.mark.parametrize("name", sorted(RGB_SPACES))
def test_white_maps_to_rgb_one(name):
    space = RGB_SPACES[name]
    white = xy_to_xyz(space.white_xy, Y=3.5)
    np.testing.assert_allclose(xyz_to_rgb(white, space), [3.5, 3.5, 3.5], rtol=1e-12)
    np.testing.assert_allclose(space.luminance_weights.sum(), 1.0, rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(xyz=finite_xyz, name=st.sampled_from(sorted(RGB_SPACES)))
def test_xyz_rgb_round_trip(xyz, name):
    back = rgb_to_xyz(xyz_to_rgb(xyz, name), name)
    np.testing.assert_allclose(back, xyz, rtol=1e-9, atol=1e-9)


def test_out_of_gamut_is_negative_not_clipped():
    spectral_green = xy_to_xyz([0.1, 0.8])  # outside sRGB
    assert xyz_to_rgb(spectral_green).min() < 0


def test_rgb_space_lookup_and_errors():
    assert rgb_space("sRGB") is RGB_SPACES["srgb"]
    assert rgb_space(RGB_SPACES["acescg"]) is RGB_SPACES["acescg"]
    with pytest.raises(ValueError, match="unknown RGB space 'adobe'.*srgb, rec2020"):
        rgb_space("adobe")
    with pytest.raises(TypeError, match="space must be a name or an RGBSpace"):
        rgb_space(3)


@pytest.mark.parametrize(
    ("primaries", "white", "match"),
    [
        (((0.6, 0.3), (0.3, 0.6)), D65_XY, r"shape \(3, 2\)"),
        (((0.6, 0.3), (0.3, 0.6), (0.15, 0.06)), (0.3,), r"shape \(2,\)"),
        (((0.6, 0.0), (0.3, 0.6), (0.15, 0.06)), D65_XY, "y must be > 0"),
        (((0.1, 0.1), (0.2, 0.2), (0.3, 0.3)), D65_XY, "collinear"),
    ],
)
def test_rgb_space_validation(primaries, white, match):
    with pytest.raises(ValueError, match=match):
        RGBSpace("bad", primaries, white)


# --- chromatic adaptation -----------------------------------------------------------------


WARM = tuple(planckian_white(3000.0))  # a blackbody's white, as an XYZ triple
WHITES = ["D65", "D50", WARM, "E"]


@pytest.mark.parametrize("method", sorted(CAT_METHODS))
@pytest.mark.parametrize(
    ("source", "target"), [("D65", "D50"), ("D50", "D65"), ("D65", WARM), (WARM, "D65")]
)
def test_adaptation_maps_source_white_to_target_white(method, source, target):
    src, dst = white_point_xyz(source), white_point_xyz(target)
    np.testing.assert_allclose(adapt(src * 2.0, source, target, method), dst * 2.0, rtol=1e-12)
    matrix = chromatic_adaptation_matrix(src, dst, method)
    np.testing.assert_allclose(matrix @ src, dst, rtol=1e-12)


@pytest.mark.parametrize(
    ("method", "transform"), [("bradford", "Bradford"), ("von_kries", "Von Kries")]
)
def test_matrix_matches_colour_science(method, transform):
    d65, d50 = white_point_xyz("D65"), white_point_xyz("D50")
    ref = colour.adaptation.matrix_chromatic_adaptation_VonKries(d65, d50, transform=transform)
    np.testing.assert_allclose(chromatic_adaptation_matrix(d65, d50, method), ref, atol=1e-9)


def test_bradford_d65_to_d50_published_matrix():
    # Lindbloom's Bradford D65 -> D50 matrix (http://www.brucelindbloom.com, Chromatic Adaptation).
    ref = [
        [1.0478112, 0.0228866, -0.0501270],
        [0.0295424, 0.9904844, -0.0170491],
        [-0.0092345, 0.0150436, 0.7521316],
    ]
    got = chromatic_adaptation_matrix(xy_to_xyz((0.31271, 0.32902)), xy_to_xyz((0.34567, 0.35850)))
    np.testing.assert_allclose(got, ref, atol=2e-4)


@pytest.mark.parametrize("white", [None, "D65"])
def test_adapt_with_none_is_identity(white):
    xyz = np.random.default_rng(1).random((3, 4, 3))
    np.testing.assert_array_equal(adapt(xyz, white, None), xyz)
    np.testing.assert_array_equal(adapt(xyz, None, white), xyz)


@pytest.mark.parametrize("white", WHITES)
def test_white_point_is_normalised(white):
    xyz = white_point_xyz(white)
    assert xyz.shape == (3,)
    assert xyz[1] == pytest.approx(1.0)


def test_blackbody_white_is_warm():
    x, y = xyz_to_xy(white_point_xyz(planckian_white(3000.0)))
    assert (x, y) == pytest.approx((0.4369, 0.4041), abs=1e-3)  # CIE 015 Planckian locus


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: white_point_xyz("D55"), ValueError, "unknown white point 'D55'.*D65"),
        (lambda: white_point_xyz(3000.0), ValueError, "a number, not a white point.*planckian"),
        (lambda: planckian_white(-5.0), ValueError, "white temperature_K must be"),
        (lambda: white_point_xyz([1.0, 0.0, 1.0]), ValueError, "Y > 0"),
        (
            lambda: chromatic_adaptation_matrix([1, 1, 1], [1, 1, 1], "cat02"),
            ValueError,
            "unknown chromatic adaptation method 'cat02'; expected one of: bradford, von_kries",
        ),
    ],
)
def test_adaptation_errors(call, error, match):
    with pytest.raises(error, match=match):
        call()


@pytest.mark.parametrize("shape", [(3,), (4, 3), (7, 5, 3), (2, 3, 4, 3)])
def test_rgb_conversions_are_the_matrix_product_for_any_leading_shape(shape):
    """Images are converted as one (N, 3) product: the values of ``x @ M.T`` to the bit."""
    x = np.random.default_rng(len(shape)).random(shape) * 500.0
    for space in ("srgb", "rec2020", "acescg"):
        matrices = rgb_space(space)
        np.testing.assert_array_equal(xyz_to_rgb(x, space), x @ matrices.xyz_to_rgb_matrix.T)
        np.testing.assert_array_equal(rgb_to_xyz(x, space), x @ matrices.rgb_to_xyz_matrix.T)
