"""Imaging: exposure, tone curves, gamut mapping, sRGB encoding and the display pipeline."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from _colour import import_colour
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from incandescent.colorimetry import RGB_SPACES, white_point_xyz, xyz_to_rgb
from incandescent.imaging import (
    TONEMAPS,
    DisplaySettings,
    auto_exposure_scale,
    camera_exposure_scale,
    ev_scale,
    gamut_map,
    quantize,
    saturation_luminance,
    srgb_oetf,
    to_display,
    tonemap,
)
from incandescent.spectra import blackbody_xyz

colour = import_colour()

rgb_arrays = arrays(
    np.float64,
    st.tuples(st.integers(1, 6), st.just(3)),
    elements=st.floats(-5.0, 50.0, allow_nan=False, allow_infinity=False),
)


# --- exposure ------------------------------------------------------------------------------


def test_ev_scale():
    assert ev_scale(0) == 1.0
    assert ev_scale(1.0) == 2.0
    assert ev_scale(-2) == 0.25
    with pytest.raises(ValueError, match="exposure_ev must be finite"):
        ev_scale(float("nan"))


def test_camera_saturation_luminance_iso_12232():
    # L_sat = 78 N^2 / (S t q): ISO 100, 1/100 s, f/8 -> 78 * 64 / (100 * 0.01 * 0.65) = 7680.
    assert saturation_luminance(100, 0.01, 8.0) == pytest.approx(7680.0)
    assert camera_exposure_scale(100, 0.01, 8.0) == pytest.approx(1.0 / 7680.0)
    # Frostbite (Lagarde & de Rousiers 2014, Eq. 9): L_max = 1.2 * 2**EV100, EV100 = log2(N^2/t).
    ev100 = np.log2(5.6**2 / (1 / 250))
    assert saturation_luminance(100, 1 / 250, 5.6) == pytest.approx(1.2 * 2**ev100)
    assert saturation_luminance(200, 0.01, 8.0) == pytest.approx(3840.0)  # twice as sensitive


@pytest.mark.parametrize("bad", [0.0, -1.0, float("inf")])
def test_camera_rejects_non_positive(bad):
    with pytest.raises(ValueError, match="shutter_s must be a finite number > 0"):
        camera_exposure_scale(100, bad, 8.0)


def test_auto_exposure_maps_percentile_to_target():
    lum = np.concatenate([np.zeros(1000), np.linspace(1.0, 100.0, 100)])
    scale = auto_exposure_scale(lum, percentile=50.0, target=0.5)
    assert scale * np.percentile(np.linspace(1.0, 100.0, 100), 50.0) == pytest.approx(0.5)


@pytest.mark.parametrize("image", [np.zeros((4, 4)), -np.ones(3), np.zeros(0)])
def test_auto_exposure_of_black_is_one(image):
    scale = auto_exposure_scale(image)
    assert np.isfinite(scale)
    assert scale == 1.0


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"luminance": [1.0, np.nan]}, ValueError, "luminance must be finite"),
        ({"luminance": [1.0], "percentile": 0.0}, ValueError, r"percentile must be in \(0, 100\]"),
        ({"luminance": [1.0], "percentile": 101}, ValueError, r"percentile must be in \(0, 100\]"),
        ({"luminance": [1.0], "target": 0.0}, ValueError, "target must be a finite number > 0"),
    ],
)
def test_auto_exposure_errors(kwargs, error, match):
    with pytest.raises(error, match=match):
        auto_exposure_scale(**kwargs)


# --- tone mapping --------------------------------------------------------------------------


@pytest.mark.parametrize("method", sorted(TONEMAPS))
def test_tonemap_monotonic_and_in_unit_interval(method):
    x = np.concatenate([[0.0], np.logspace(-6, 12, 2000)])
    y = tonemap(x, method)
    assert (np.diff(y) >= 0).all()
    assert y.min() == 0.0
    assert y.max() <= 1.0


@settings(max_examples=40, deadline=None)
@given(rgb=rgb_arrays, method=st.sampled_from(sorted(TONEMAPS)))
def test_tonemap_properties(rgb, method):
    y = tonemap(rgb, method)
    assert np.isfinite(y).all()
    assert (np.abs(y) <= 1.0).all()
    np.testing.assert_array_equal(tonemap(-rgb, method), -y)  # negatives mirrored, not lost
    assert (y[rgb >= 0] >= 0).all()
    assert (y[rgb < 0] <= 0).all()


def test_tonemap_reference_values():
    assert tonemap(1.0, "reinhard") == pytest.approx(0.5)
    assert tonemap(np.inf, "reinhard") == 1.0
    assert tonemap(1.0, "filmic") == pytest.approx(2.54 / 3.16)  # Narkowicz fit at x = 1
    assert tonemap(1e300, "filmic") == 1.0
    assert tonemap(1.7, "clip") == 1.0


def test_tonemap_unknown_method():
    with pytest.raises(ValueError, match="unknown tone map method 'aces'; expected one of: clip"):
        tonemap([1.0], "aces")


# --- gamut mapping and encoding -----------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(rgb=rgb_arrays, method=st.sampled_from(["clip", "desaturate"]))
def test_gamut_map_removes_negatives(rgb, method):
    out = gamut_map(rgb, method)
    assert (out >= 0).all()
    inside = (rgb >= 0).all(axis=-1)
    np.testing.assert_array_equal(out[inside], rgb[inside])


def test_desaturate_keeps_luminance_and_touches_zero():
    rgb = np.array([[1.2, -0.3, 0.1], [-0.05, 0.8, 0.2]])
    out = gamut_map(rgb, "desaturate")
    weights = RGB_SPACES["srgb"].luminance_weights
    np.testing.assert_allclose(out @ weights, rgb @ weights, rtol=1e-12)
    np.testing.assert_allclose(out.min(axis=-1), 0.0, atol=1e-15)


def test_desaturate_of_negative_luminance_is_black():
    np.testing.assert_array_equal(gamut_map([[-1.0, -1.0, -1.0], [-2.0, 0.1, 0.0]]), 0.0)


def test_gamut_map_unknown_method():
    with pytest.raises(ValueError, match="unknown gamut mapping method 'compress'"):
        gamut_map([[0.1, 0.2, 0.3]], "compress")


def test_srgb_oetf_matches_colour_science():
    x = np.concatenate([np.linspace(0.0, 1.0, 1001), [0.0031308, 1e-5]])
    np.testing.assert_allclose(srgb_oetf(x), colour.cctf_encoding(x, function="sRGB"), atol=1e-12)


def test_quantize():
    assert quantize([0.0, 0.5, 1.0, 2.0, -1.0]).tolist() == [0, 128, 255, 255, 0]
    q16 = quantize([[0.5 / 65535, 1.0]], bits=16)
    assert q16.dtype == np.uint16
    assert q16.tolist() == [[0, 65535]]
    with pytest.raises(ValueError, match="bits must be 8 or 16; got 12"):
        quantize([0.5], bits=12)
    with pytest.raises(ValueError, match="1 NaN value"):
        quantize([np.nan, 0.5])


# --- pipeline ------------------------------------------------------------------------------


def _flame(shape=(6, 8)):
    temps = np.linspace(900.0, 2400.0, shape[0] * shape[1]).reshape(shape)
    return blackbody_xyz(temps), temps


def test_to_display_default_shape_dtype():
    xyz, _ = _flame()
    img = to_display(xyz)
    assert img.shape == (6, 8, 3)
    assert img.dtype == np.uint8
    assert img.max() > 200  # auto exposure lights the flame
    assert (img[..., 0] >= img[..., 2]).all()  # a blackbody below 2400 K is reddish


@pytest.mark.parametrize("space", sorted(RGB_SPACES))
@pytest.mark.parametrize("tone", sorted(TONEMAPS))
def test_to_display_16_bit_every_option(space, tone):
    xyz, temps = _flame((3, 4))
    options = DisplaySettings(space=space, tonemap=tone, bits=16, white_balance="hottest")
    img = to_display(xyz, options, hottest_K=float(temps.max()))
    assert img.dtype == np.uint16
    assert img.shape == (3, 4, 3)


def test_hottest_white_balance_makes_hottest_pixel_neutral():
    xyz, temps = _flame()
    img = to_display(xyz, DisplaySettings(white_balance="hottest"), hottest_K=2400.0)
    hottest = img[-1, -1].astype(int)
    assert hottest.max() - hottest.min() <= 1


def test_d65_grey_stays_neutral():
    grey = np.broadcast_to(white_point_xyz("D65") * 300.0, (2, 2, 3))
    img = to_display(grey, DisplaySettings(white_balance="D65"))
    assert (img == img[..., :1]).all()


def test_black_image_is_black():
    img = to_display(np.zeros((4, 4, 3)))
    assert (img == 0).all()


def test_physical_camera_and_ev():
    xyz = np.broadcast_to(white_point_xyz("D65") * 7680.0 * 0.25, (1, 1, 3))
    cam = {"iso": 100, "shutter_s": 0.01, "f_number": 8.0, "tonemap": "clip", "gamut": "clip"}
    base = to_display(xyz, DisplaySettings(**cam))  # 0.25 of saturation
    assert base[0, 0, 1] == round(255 * float(srgb_oetf(0.25)))
    brighter = to_display(xyz, DisplaySettings(exposure_ev=2.0, **cam))  # EV on top: 1.0
    assert (brighter == 255).all()


def test_ev_only_without_auto_exposure():
    xyz = np.broadcast_to(white_point_xyz("D65") * 0.125, (1, 1, 3))
    img = to_display(xyz, DisplaySettings(auto_exposure=False, exposure_ev=3.0, tonemap="clip"))
    assert (img == 255).all()


def test_to_display_rejects_nan_with_count():
    xyz, _ = _flame((3, 3))
    xyz[0, 0, 1] = np.nan
    xyz[2, 1] = np.inf
    with pytest.raises(ValueError, match="2 of 9 pixel"):
        to_display(xyz)


def test_hottest_needs_temperature():
    xyz, _ = _flame((2, 2))
    with pytest.raises(ValueError, match="hottest_K"):
        to_display(xyz, DisplaySettings(white_balance="hottest"))


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"space": "adobe"}, ValueError, "unknown RGB space 'adobe'"),
        ({"white_balance": "D93"}, ValueError, "unknown white_balance 'D93'.*hottest"),
        ({"white_balance": -300.0}, ValueError, "white_balance temperature_K"),
        ({"white_balance": [1, 2]}, TypeError, "white_balance must be None"),
        ({"exposure_ev": np.inf}, ValueError, "exposure_ev must be finite"),
        ({"auto_exposure": "yes"}, TypeError, "auto_exposure must be True or False"),
        ({"auto_percentile": 0}, ValueError, "auto_percentile"),
        ({"iso": 100, "f_number": 8}, ValueError, "got iso, f_number but not shutter_s"),
        ({"iso": 100, "f_number": 8, "shutter_s": 0}, ValueError, "shutter_s must be"),
        ({"tonemap": "aces"}, ValueError, "unknown tonemap 'aces'"),
        ({"gamut": "compress"}, ValueError, "unknown gamut 'compress'"),
        ({"bits": 10}, ValueError, "bits must be 8 or 16; got 10"),
    ],
)
def test_display_settings_validation(kwargs, error, match):
    with pytest.raises(error, match=match):
        DisplaySettings(**kwargs)


def test_display_settings_frozen_and_replaceable():
    base = DisplaySettings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        base.bits = 16
    assert dataclasses.replace(base, bits=16).bits == 16
    with pytest.raises(ValueError, match="bits"):
        dataclasses.replace(base, bits=9)


def test_xyz_to_rgb_used_for_space():
    # The pipeline must use the chosen space: a Rec.2020-green XYZ is out of sRGB gamut.
    green = np.array([0.170, 0.797, 0.033]) / 0.797
    assert xyz_to_rgb(green, "srgb").min() < 0
    assert xyz_to_rgb(green, "rec2020").min() > -1e-12
