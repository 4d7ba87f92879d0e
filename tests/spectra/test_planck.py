"""Planck's law: reference values, Stefan–Boltzmann, Wien peak, overflow safety, input errors.

The reference values are computed here independently of ``incandescent.constants``, in 50-digit
:mod:`decimal` arithmetic, from the exact SI 2019 defining constants (h, c, k_B) and the CIE
ITS-90 c2 = 1.4388e-2 m·K.
"""

from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from incandescent.constants import PLANCK_CONSTANT_SETS, SIGMA_SB, WIEN_B, planck_constants
from incandescent.spectra import planck_radiance

# --- independent reference in decimal arithmetic -------------------------------------------

_PI = Decimal("3.14159265358979323846264338327950288419716939937510")
_H = Decimal("6.62607015e-34")  # J·s, exact
_C = Decimal("299792458")  # m/s, exact
_K = Decimal("1.380649e-23")  # J/K, exact
_C1_CODATA = 2 * _PI * _H * _C**2  # 2πhc², W·m²
_C2_CODATA = _H * _C / _K  # hc/k, m·K

#: (c1 = 2πhc² in W·m², c2 in m·K) per constant set, written out independently.
REFERENCE_CONSTANTS = {
    "codata2018": (_C1_CODATA, _C2_CODATA),
    "cie": (_C1_CODATA, Decimal("1.4388e-2")),
    "paper": (Decimal("3.74183e-16"), Decimal("1.4388e-2")),
}


def reference_planck(wavelength_nm: float, temperature_K: float, constants: str) -> float:
    """B_λ(T) in W·sr⁻¹·m⁻²·nm⁻¹ with 50 significant digits, rounded to float."""
    c1, c2 = REFERENCE_CONSTANTS[constants]
    with localcontext() as ctx:
        ctx.prec = 50
        lam_m = Decimal(float(wavelength_nm)) * Decimal("1e-9")
        x = c2 / (lam_m * Decimal(float(temperature_K)))
        radiance_per_m = (c1 / _PI) / (lam_m**5 * (x.exp() - 1))
        return float(radiance_per_m * Decimal("1e-9"))


WAVELENGTHS_NM = (100.0, 360.0, 455.5, 555.0, 700.0, 830.0, 2_500.0, 10_000.0, 100_000.0)
TEMPERATURES_K = (300.0, 800.0, 1_500.0, 2_000.0, 5_778.0, 6_500.0, 12_000.0, 40_000.0)


def _sigma_of(constants: str) -> float:
    """Stefan–Boltzmann constant implied by a set's c1, c2: σ = c1 π⁴ / (15 c2⁴)."""
    c = planck_constants(constants)
    return c.c1 * math.pi**4 / (15.0 * c.c2**4)


def _wien_peak_nm(temperature_K: float) -> float:
    """λ of maximum B_λ(T) by golden-section search on log λ (no derivative used)."""
    lo, hi = (
        math.log(0.5 * WIEN_B / temperature_K * 1e9),
        math.log(2 * WIEN_B / temperature_K * 1e9),
    )
    inv_phi = (math.sqrt(5.0) - 1.0) / 2.0

    def f(log_nm: float) -> float:
        return float(planck_radiance(math.exp(log_nm), temperature_K))

    a, b = hi - inv_phi * (hi - lo), lo + inv_phi * (hi - lo)
    fa, fb = f(a), f(b)
    for _ in range(80):
        if fa > fb:
            hi, b, fb = b, a, fa
            a = hi - inv_phi * (hi - lo)
            fa = f(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + inv_phi * (hi - lo)
            fb = f(b)
    return math.exp(0.5 * (lo + hi))


# --- reference values ----------------------------------------------------------------------


@pytest.mark.parametrize("constants", sorted(PLANCK_CONSTANT_SETS))
def test_planck_matches_independent_decimal_evaluation(constants):
    lam, temp = np.meshgrid(WAVELENGTHS_NM, TEMPERATURES_K, indexing="ij")
    got = planck_radiance(lam, temp, constants=constants)
    expected = np.vectorize(reference_planck)(lam, temp, constants)
    assert got.dtype == np.float64
    assert got.shape == lam.shape
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=0)


def test_planck_accepts_constants_object_and_docstring_value():
    obj = planck_constants("cie")
    assert planck_radiance(555.0, 2000.0, constants=obj) == planck_radiance(555.0, 2000.0, "cie")
    assert float(planck_radiance(555.0, 2000.0)) == pytest.approx(5.31078, rel=1e-5)


def test_planck_constant_sets_differ_as_documented():
    codata = planck_radiance(555.0, 2000.0, "codata2018")
    cie = planck_radiance(555.0, 2000.0, "cie")
    # c2 differs by 1.6e-5 relative; at x = c2/(λT) ≈ 13 that is x·1.6e-5 ≈ 2.1e-4 in B.
    c2_codata, c2_cie = planck_constants("codata2018").c2, planck_constants("cie").c2
    assert (c2_cie - c2_codata) / c2_codata == pytest.approx(1.607e-5, rel=1e-3)
    assert (codata - cie) / codata == pytest.approx(2.08e-4, rel=1e-2)


def test_planck_broadcasts_wavelength_against_temperature():
    lam = np.linspace(400.0, 700.0, 4)[:, None]
    temp = np.array([[1000.0, 3000.0, 6500.0]])
    out = planck_radiance(lam, temp)
    assert out.shape == (4, 3)
    assert out[2, 1] == planck_radiance(lam[2, 0], temp[0, 1])


# --- physical laws -------------------------------------------------------------------------


@pytest.mark.parametrize("constants", sorted(PLANCK_CONSTANT_SETS))
@pytest.mark.parametrize("temperature_K", [300.0, 1_000.0, 2_000.0, 5_778.0, 12_000.0, 40_000.0])
def test_stefan_boltzmann(temperature_K, constants):
    """π ∫ B_λ dλ over 10 nm–1 mm equals σT⁴ within 0.1 %."""
    wavelength_nm = np.geomspace(10.0, 1e6, 20_001)
    radiance = planck_radiance(wavelength_nm, temperature_K, constants)
    exitance = math.pi * np.trapezoid(radiance, wavelength_nm)  # W/m²
    sigma = SIGMA_SB if constants == "codata2018" else _sigma_of(constants)
    assert exitance == pytest.approx(sigma * temperature_K**4, rel=1e-3)


def test_sigma_of_codata_constants_is_codata_sigma():
    assert _sigma_of("codata2018") == pytest.approx(SIGMA_SB, rel=1e-9)


def test_wien_constant_of_codata_constants():
    """b = c2 / x_w where x_w = 5 + W(−5 e⁻⁵) = 4.965114231744276…"""
    assert planck_constants("codata2018").c2 / 4.965114231744276 == pytest.approx(WIEN_B, rel=1e-9)


@settings(max_examples=25, deadline=None)
@given(temperature_K=st.floats(300.0, 40_000.0))
def test_wien_peak(temperature_K):
    peak_nm = _wien_peak_nm(temperature_K)
    assert peak_nm * 1e-9 * temperature_K == pytest.approx(WIEN_B, rel=1e-6)


@settings(max_examples=200, deadline=None)
@given(
    wavelength_nm=st.floats(10.0, 1e6),
    t1=st.floats(1.0, 1e6),
    ratio=st.floats(1.0, 100.0),
    constants=st.sampled_from(sorted(PLANCK_CONSTANT_SETS)),
)
def test_planck_monotonic_in_temperature(wavelength_nm, t1, ratio, constants):
    t2 = t1 * ratio
    b1, b2 = planck_radiance(wavelength_nm, [t1, t2], constants)
    assert np.isfinite(b1) and np.isfinite(b2)
    assert 0.0 <= b1 <= b2
    if b1 > 0 and ratio > 1.000001:
        assert b2 > b1


# --- numerical safety ----------------------------------------------------------------------


def test_tiny_lambda_t_underflows_to_zero_without_warnings():
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        assert planck_radiance(1.0, 300.0) == 0.0  # c2/(λT) ≈ 4.8e4
        out = planck_radiance(np.geomspace(1e-3, 1e3, 61), np.array([[1.0], [300.0], [1e4]]))
    assert np.isfinite(out).all()
    assert (out >= 0).all()


def test_large_lambda_t_is_rayleigh_jeans_without_warnings():
    wavelength_nm, temperature_K = 1e7, 1e6  # 1 cm at 1e6 K: c2/(λT) ≈ 1.4e-6
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        got = float(planck_radiance(wavelength_nm, temperature_K))
    lam_m = wavelength_nm * 1e-9
    rayleigh_jeans = 2.0 * 299_792_458.0 * 1.380649e-23 * temperature_K / lam_m**4 * 1e-9
    assert math.isfinite(got)
    assert got == pytest.approx(rayleigh_jeans, rel=1e-5)
    assert got == pytest.approx(reference_planck(wavelength_nm, temperature_K, "codata2018"))


# --- input errors --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (float("nan"), r"must be finite; got .*nan"),
        (float("inf"), r"must be finite; got .*inf"),
        (-float("inf"), r"must be finite; got .*-inf"),
        (0.0, r"must be > 0 .*got .*0\."),
        (-5.0, r"must be > 0 .*got .*-5\."),
        ([500.0, -1.5, 600.0], r"must be > 0 .*-1\.5.* at index \(1,\)"),
    ],
)
@pytest.mark.parametrize("argument", ["wavelength_nm", "temperature_K"])
def test_bad_values_raise_value_error_naming_value(argument, value, match):
    kwargs = {"wavelength_nm": 555.0, "temperature_K": 2000.0, argument: value}
    with pytest.raises(ValueError, match=f"{argument} {match}"):
        planck_radiance(**kwargs)


def test_wavelength_error_states_nm_not_kelvin():
    with pytest.raises(ValueError, match=r"wavelength_nm must be > 0 nm; got .*-3\.0?.* nm$"):
        planck_radiance(-3.0, 2000.0)
    with pytest.raises(ValueError, match=r"temperature_K must be > 0 K; got .*-3\.0?.* K$"):
        planck_radiance(555.0, -3.0)


@pytest.mark.parametrize(
    ("value", "dtype"),
    [("555", "<U3"), (np.array([1.0, "x"], dtype=object), "object"), (True, "bool")],
)
@pytest.mark.parametrize("argument", ["wavelength_nm", "temperature_K"])
def test_bad_dtypes_raise_type_error_naming_dtype(argument, value, dtype):
    kwargs = {"wavelength_nm": 555.0, "temperature_K": 2000.0, argument: value}
    with pytest.raises(
        TypeError, match=f"{argument} must be a real number array; got dtype {dtype}"
    ):
        planck_radiance(**kwargs)


def test_unknown_constant_set_lists_choices():
    with pytest.raises(ValueError, match="unknown Planck constant set 'si'; expected one of: "):
        planck_radiance(555.0, 2000.0, constants="si")
