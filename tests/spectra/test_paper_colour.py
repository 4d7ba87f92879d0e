"""The 2011 paper's colour model against an independent evaluation written out here.

The reference below uses only :mod:`math`, the paper's constants, a CMF table typed in from the CIE
table and Lindbloom's matrix typed in, so it shares no code or data with
:mod:`incandescent.spectra.paper2011`.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from incandescent.spectra.paper2011 import (
    PAPER_EXPONENT,
    PAPER_SODIUM_NM,
    PAPER_WAVELENGTHS_NM,
    PAPER_XYZ_TO_RGB,
    paper_chromaticity_rgb,
    paper_cmf,
    paper_rgb,
    paper_sodium_xyz,
    paper_spectrum_xyz,
    truncation_shift_uv,
)

# --- independent reference ------------------------------------------------------------------

C1 = 3.74183e-16  # the paper's c1, W·m²
C2 = 1.4388e-2  # the paper's c2, m·K

#: CIE 1931 2° standard observer x̄, ȳ, z̄ at 380, 395, …, 650 nm, typed in from the CIE 1 nm table
#: (CIE 015:2018 / CIE S 014-1, as distributed by CVRL, ``ciexyz31_1.csv``). That table carries
#: its own rounding artefacts at 380 (z̄ 0.006450001), 425 (z̄ 1.0390501), 485 (x̄ 0.05795001) and
#: 620 nm (x̄ 0.8544499), kept here as published.
CIE1931_2DEG = {
    380: (0.001368, 0.000039, 0.006450001),
    395: (0.00765, 0.000217, 0.03621),
    410: (0.04351, 0.00121, 0.2074),
    425: (0.21477, 0.0073, 1.0390501),
    440: (0.34828, 0.023, 1.74706),
    455: (0.3187, 0.048, 1.7441),
    470: (0.19536, 0.09098, 1.28764),
    485: (0.05795001, 0.1693, 0.6162),
    500: (0.0049, 0.323, 0.272),
    515: (0.0291, 0.6082, 0.1117),
    530: (0.1655, 0.862, 0.04216),
    545: (0.3597, 0.9803, 0.0134),
    560: (0.5945, 0.995, 0.0039),
    575: (0.8425, 0.9154, 0.0018),
    590: (1.0263, 0.757, 0.0011),
    605: (1.0456, 0.5668, 0.0006),
    620: (0.8544499, 0.381, 0.00019),
    635: (0.5419, 0.217, 0.00003),
    650: (0.2835, 0.107, 0.0),
}

#: B. Lindbloom, "RGB/XYZ Matrices", sRGB (D65): XYZ → linear RGB.
LINDBLOOM_XYZ_TO_SRGB = (
    (3.2404542, -1.5371385, -0.4985314),
    (-0.9692660, 1.8760108, 0.0415560),
    (0.0556434, -0.2040259, 1.0572252),
)


def reference_le(temperature_K: float, wavelength_nm: float) -> float:
    lam = wavelength_nm * 1e-9
    return C1 * lam**-5 / (math.exp(C2 / (lam * temperature_K)) - 1.0)


def reference_xyz(temperature_K: float, sodium: float) -> list[float]:
    sums = [0.0, 0.0, 0.0]
    for wavelength, bar in CIE1931_2DEG.items():
        le = reference_le(temperature_K, wavelength)
        for k in range(3):
            sums[k] += le * bar[k]
    le_na = reference_le(temperature_K, 590)
    return [sums[k] + sodium * le_na * CIE1931_2DEG[590][k] for k in range(3)]


def reference_rgb(temperature_K: float, sodium: float = 0.0, exponent: float = 1.5) -> list[float]:
    xyz = reference_xyz(temperature_K, sodium)
    chroma = [v / sum(xyz) for v in xyz]
    rgb = [
        max(0.0, sum(m * c for m, c in zip(row, chroma, strict=True)))
        for row in LINDBLOOM_XYZ_TO_SRGB
    ]
    return [v / max(rgb) * temperature_K**exponent for v in rgb]


def xy(xyz) -> np.ndarray:
    xyz = np.asarray(xyz)
    return xyz[..., :2] / xyz.sum(axis=-1, keepdims=True)


# --- tests ----------------------------------------------------------------------------------


def test_constants():
    assert PAPER_WAVELENGTHS_NM.shape == (19,)
    assert PAPER_WAVELENGTHS_NM.tolist() == list(map(float, CIE1931_2DEG))
    assert PAPER_SODIUM_NM == 590.0
    assert PAPER_EXPONENT == 1.5
    np.testing.assert_array_equal(PAPER_XYZ_TO_RGB, LINDBLOOM_XYZ_TO_SRGB)
    np.testing.assert_array_equal(paper_cmf(), list(CIE1931_2DEG.values()))


@pytest.mark.parametrize("temperature_K", [1000.0, 3000.0, 6500.0, 10_000.0])
@pytest.mark.parametrize("sodium", [0.0, 0.3, 1.0])
def test_paper_rgb_matches_independent_evaluation(temperature_K, sodium):
    np.testing.assert_allclose(
        paper_rgb(temperature_K, sodium), reference_rgb(temperature_K, sodium), rtol=1e-9, atol=0
    )


@pytest.mark.parametrize("temperature_K", [300.0, 1000.0, 3000.0, 10_000.0])
def test_unnormalised_sums_match_independent_evaluation(temperature_K):
    blackbody = reference_xyz(temperature_K, 0.0)
    sodium = [reference_le(temperature_K, 590) * v for v in CIE1931_2DEG[590]]
    np.testing.assert_allclose(paper_spectrum_xyz(temperature_K), blackbody, rtol=1e-12)
    np.testing.assert_allclose(paper_sodium_xyz(temperature_K), sodium, rtol=1e-12)


def test_largest_component_is_t_to_the_exponent():
    temperature_K = np.array([5.0, 40.0, 300.0, 800.0, 1000.0, 3000.0, 6500.0, 1e4, 1e5])
    rgb = paper_rgb(temperature_K, sodium_fraction=[[0.0], [0.5]])
    assert rgb.shape == (2, temperature_K.size, 3)
    assert np.all(rgb >= 0)
    np.testing.assert_array_equal(rgb.max(axis=-1), np.broadcast_to(temperature_K**1.5, (2, 9)))


def test_broadcasting_matches_scalar_calls():
    temperature_K, sodium = np.array([[900.0], [2500.0]]), np.array([0.0, 0.25, 1.0])
    rgb = paper_rgb(temperature_K, sodium)
    assert rgb.shape == (2, 3, 3)
    for i, t in enumerate(temperature_K[:, 0]):
        for j, f in enumerate(sodium):
            np.testing.assert_allclose(rgb[i, j], paper_rgb(t, f), rtol=1e-13)
    assert paper_spectrum_xyz(temperature_K).shape == (2, 1, 3)
    assert paper_sodium_xyz(temperature_K).shape == (2, 1, 3)


@pytest.mark.parametrize("temperature_K", [1000.0, 2000.0, 6500.0])
def test_sodium_moves_chromaticity_toward_590_nm(temperature_K):
    fractions = np.linspace(0.0, 1.0, 11)
    xyz = paper_spectrum_xyz(temperature_K) + fractions[:, None] * paper_sodium_xyz(temperature_K)
    distance = np.linalg.norm(xy(xyz) - xy(CIE1931_2DEG[590]), axis=-1)
    assert np.all(np.diff(distance) < 0)
    rgb = paper_rgb(temperature_K, fractions)
    np.testing.assert_array_equal(rgb.max(axis=-1), temperature_K**1.5)
    assert np.all(np.diff(rgb[:, 2]) <= 0)  # 590 nm has no blue: sodium never adds any


def test_exponent_parameter():
    temperature_K = np.array([800.0, 3000.0])
    chroma = paper_chromaticity_rgb(paper_spectrum_xyz(temperature_K))
    for exponent in (0.0, 1.5, 4.0, -1.0):
        rgb = paper_rgb(temperature_K, exponent=exponent)
        np.testing.assert_allclose(rgb, chroma * (temperature_K**exponent)[:, None], rtol=1e-12)
    np.testing.assert_allclose(paper_rgb(3000.0, exponent=4.0), reference_rgb(3000.0, 0.0, 4.0))


def test_chromaticity_rgb_scale_invariant_and_black():
    xyz = paper_spectrum_xyz(2000.0)
    np.testing.assert_allclose(paper_chromaticity_rgb(1e-30 * xyz), paper_chromaticity_rgb(xyz))
    np.testing.assert_array_equal(paper_chromaticity_rgb(np.zeros((2, 3))), np.zeros((2, 3)))


def test_very_cold_voxels_stay_defined():
    # The literal sums overflow to 0 below ~31 K; the colour is still the red end of the range.
    assert np.all(paper_spectrum_xyz(20.0) == 0)
    rgb = paper_rgb(20.0)
    np.testing.assert_array_equal(rgb, [20.0**1.5, 0.0, 0.0])


def test_truncation_shift():
    temperature_K = np.array([800.0, 1000.0, 2000.0, 3000.0, 6500.0])
    shift = truncation_shift_uv(temperature_K)
    assert 0.02 < shift[1] < 0.035
    assert 0.003 < shift[3] < 0.01
    assert np.all(shift > 0)
    assert np.all(np.diff(shift) < 0)


@pytest.mark.parametrize(
    ("temperature_K", "match"),
    [(float("nan"), "nan"), (float("inf"), "inf"), (0.0, "0.0"), ([1000.0, -5.0], "-5.0")],
)
def test_bad_temperatures_raise(temperature_K, match):
    for function in (paper_rgb, paper_spectrum_xyz, paper_sodium_xyz, truncation_shift_uv):
        with pytest.raises(ValueError, match=f"temperature_K.*{match}"):
            function(temperature_K)
    with pytest.raises(TypeError, match="temperature_K"):
        paper_rgb("hot")


@pytest.mark.parametrize("sodium", [-0.1, 1.5, 50.0, float("nan")])
def test_bad_sodium_fraction_raises(sodium):
    with pytest.raises(ValueError, match=f"sodium_fraction.*{sodium}"):
        paper_rgb(1000.0, sodium)


def test_bad_exponent_and_xyz_raise():
    with pytest.raises(ValueError, match="exponent.*nan"):
        paper_rgb(1000.0, exponent=float("nan"))
    with pytest.raises(TypeError, match="exponent.*'1.5'"):
        paper_rgb(1000.0, exponent="1.5")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"xyz must be >= 0; got -1.0"):
        paper_chromaticity_rgb([1.0, -1.0, 0.5])
    with pytest.raises(ValueError, match=r"shape \[\.\.\., 3\]"):
        paper_chromaticity_rgb([1.0, 1.0])
    with pytest.raises(ValueError, match="25 K.*10.0"):
        truncation_shift_uv(10.0)
