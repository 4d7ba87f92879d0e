"""Blackbody XYZ: CMF integrals, chromaticity vs colour-science, luminance, shapes, errors."""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
import pytest
from _colour import import_colour
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import array_shapes, arrays

from incandescent.colorimetry import xyz_to_xy
from incandescent.spectra import blackbody_xyz, cmfs
from incandescent.spectra.cmf import OBSERVERS

colour = import_colour()

TEMPERATURES_K = np.array(
    [1000.0, 1500.0, 2000.0, 2500.0, 3000.0, 4000.0, 5000.0, 6500.0, 8000.0, 10_000.0, 15_000.0]
    + [20_000.0]
)
SHAPE = colour.SpectralShape(360, 830, 1)


def colour_blackbody_xy(temperature_K: float, observer: str) -> np.ndarray:
    """colour-science's own blackbody chromaticity (its c2 = 1.4388e-2 m·K), emissive: the
    illuminant is equal energy so ``sd_to_XYZ`` integrates the spectrum itself."""
    cmf = colour.MSDS_CMFS[OBSERVERS[observer]].copy().align(SHAPE)
    sd = colour.sd_blackbody(temperature_K, SHAPE)
    xyz = colour.sd_to_XYZ(sd, cmf, illuminant=colour.sd_ones(SHAPE), method="Integration")
    return colour.XYZ_to_xy(xyz)


# --- colour matching functions -------------------------------------------------------------


def test_cie1931_cmf_integrals():
    cmf = cmfs("cie1931_2")
    assert cmf.wavelength_nm[0] == 360.0
    assert cmf.wavelength_nm[-1] == 830.0
    assert cmf.step_nm == 1.0
    assert cmf.xyz_bar.shape == (471, 3)
    integrals = cmf.xyz_bar.sum(axis=0) * cmf.step_nm
    assert integrals[1] == pytest.approx(106.857, abs=5e-3)
    # Equal-energy white E is (1/3, 1/3): the three integrals agree to 0.04 %.
    np.testing.assert_allclose(integrals, integrals[1], rtol=4e-4)


def test_cie1964_cmf_integrals():
    integrals = cmfs("cie1964_10").xyz_bar.sum(axis=0)
    np.testing.assert_allclose(integrals, 116.66, rtol=2e-4)


def test_cmfs_are_cached_and_read_only():
    assert cmfs("cie1931_2") is cmfs("cie1931_2")
    with pytest.raises(ValueError, match="read-only"):
        cmfs().wavelength_nm[0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        cmfs().xyz_bar[0, 0] = 1.0


# --- chromaticity vs colour-science -----------------------------------------------------------


@pytest.mark.parametrize("observer", sorted(OBSERVERS))
def test_chromaticity_matches_colour_science(observer):
    got = xyz_to_xy(blackbody_xyz(TEMPERATURES_K, observer, constants="cie"))
    expected = np.array([colour_blackbody_xy(t, observer) for t in TEMPERATURES_K])
    assert np.abs(got - expected).max() < 2e-4


def test_codata_constants_shift_chromaticity_only_slightly():
    codata = xyz_to_xy(blackbody_xyz(TEMPERATURES_K))
    cie = xyz_to_xy(blackbody_xyz(TEMPERATURES_K, constants="cie"))
    assert 0 < np.abs(codata - cie).max() < 1e-5


def test_known_chromaticities():
    xy = xyz_to_xy(blackbody_xyz([2856.0, 6500.0], constants="cie"))
    # Illuminant A is a 2856 K blackbody (CIE 015:2018 Table 9.1: 0.44757, 0.40745).
    np.testing.assert_allclose(xy[0], [0.44757, 0.40745], atol=5e-5)
    np.testing.assert_allclose(xy[1], [0.3135, 0.3236], atol=1e-4)


def test_cie1964_observer_works_and_differs():
    xy2 = xyz_to_xy(blackbody_xyz(TEMPERATURES_K, "cie1931_2"))
    xy10 = xyz_to_xy(blackbody_xyz(TEMPERATURES_K, "cie1964_10"))
    assert np.isfinite(xy10).all()
    assert (np.abs(xy10 - xy2).max(axis=-1) > 5e-4).all()
    # The 10° observer's ȳ integrates to ~116.7 instead of ~106.9, so Y is higher.
    assert (
        blackbody_xyz(TEMPERATURES_K, "cie1964_10")[:, 1] > blackbody_xyz(TEMPERATURES_K)[:, 1]
    ).all()


# --- absolute luminance --------------------------------------------------------------------


def _reference_luminance(temperature_K: float) -> float:
    """Y = 683 Σ B_λ ȳ Δλ with B_λ from the exact SI constants in 40-digit decimal arithmetic."""
    h, c, k = Decimal("6.62607015e-34"), Decimal("299792458"), Decimal("1.380649e-23")
    cmf = cmfs("cie1931_2")
    total = Decimal(0)
    with localcontext() as ctx:
        ctx.prec = 40
        for lam_nm, ybar in zip(cmf.wavelength_nm, cmf.xyz_bar[:, 1], strict=True):
            lam_m = Decimal(float(lam_nm)) * Decimal("1e-9")
            x = h * c / (k * lam_m * Decimal(temperature_K))
            total += 2 * h * c**2 / (lam_m**5 * (x.exp() - 1)) * Decimal(float(ybar))
        return float(683 * total * Decimal("1e-9"))


def test_luminance_at_2000K():
    y = blackbody_xyz(2000.0)[1]
    assert y == pytest.approx(4.60e5, rel=1e-2)  # DESIGN.md §3: "Y ≈ 4.6e5"
    assert y == pytest.approx(4.6376e5, rel=1e-4)
    assert y == pytest.approx(_reference_luminance(2000.0), rel=1e-9)


def test_luminance_grows_monotonically():
    y = blackbody_xyz(np.geomspace(300.0, 1e5, 400))[:, 1]
    assert (np.diff(y) > 0).all()


# --- shapes --------------------------------------------------------------------------------


def test_scalar_gives_three_components():
    assert blackbody_xyz(2000.0).shape == (3,)
    assert blackbody_xyz(2000).shape == (3,)


@settings(max_examples=20, deadline=None)
@given(
    arrays(
        np.float64,
        array_shapes(min_dims=1, max_dims=3, max_side=4),
        elements=st.floats(300.0, 40_000.0),
    )
)
def test_n_dimensional_input(temperature_K):
    out = blackbody_xyz(temperature_K)
    assert out.shape == temperature_K.shape + (3,)
    flat = blackbody_xyz(temperature_K.reshape(-1))
    np.testing.assert_array_equal(out.reshape(-1, 3), flat)


def test_large_input_is_chunked_consistently():
    temps = np.linspace(500.0, 30_000.0, 9000)  # more than one 4096-row chunk
    out = blackbody_xyz(temps)
    np.testing.assert_allclose(
        out[[0, 5000, 8999]], blackbody_xyz(temps[[0, 5000, 8999]]), rtol=1e-12
    )


def test_empty_input():
    assert blackbody_xyz(np.empty((0, 2))).shape == (0, 2, 3)


def test_cold_blackbody_is_zero_not_nan():
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        xyz = blackbody_xyz([1.0, 10.0, 50.0])
    assert np.isfinite(xyz).all()
    assert (xyz >= 0).all()


# --- errors --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (float("nan"), ValueError, r"temperature_K must be finite; got .*nan"),
        (
            [1000.0, float("inf")],
            ValueError,
            r"temperature_K must be finite; got .*inf.* index \(1,\)",
        ),
        (0.0, ValueError, r"temperature_K must be > 0 K; got .*0\..* K"),
        ([[1000.0, -20.0]], ValueError, r"> 0 K; got .*-20\..* at index \(0, 1\) K"),
        ("2000", TypeError, r"temperature_K must be a real number array; got dtype <U4"),
        ([True, False], TypeError, r"temperature_K must be a real number array; got dtype bool"),
        (None, TypeError, r"temperature_K must be a real number array; got dtype object"),
    ],
)
def test_bad_temperatures_raise(value, error, match):
    with pytest.raises(error, match=match):
        blackbody_xyz(value)


def test_unknown_observer_lists_choices():
    with pytest.raises(ValueError, match="unknown observer 'cie2015'; expected one of: cie1931_2"):
        blackbody_xyz(2000.0, observer="cie2015")


def test_unknown_constants_list_choices():
    with pytest.raises(ValueError, match="unknown Planck constant set 'nist'; expected one of"):
        blackbody_xyz(2000.0, constants="nist")
