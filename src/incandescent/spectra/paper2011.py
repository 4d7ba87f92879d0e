"""The 2011 paper's per-voxel colour model, reproduced exactly (host-side NumPy, float64).

Zonenberg & Forrest (2011), §4 "Blackbody rendering", computes one RGB colour per voxel:

1. Planck's law with the paper's (and Walker's ``specrend.c``) constants, λ in metres::

       L_e(T, λ) = c1 λ⁻⁵ / (exp(c2 / (λ T)) − 1),   c1 = 3.74183e-16,  c2 = 1.4388e-2

   (c1 = 2πhc² is the constant for spectral *exitance*, W·m⁻²·m⁻¹; see
   :data:`incandescent.constants.PAPER_2011`), sampled at λ_i = 380, 395, …, 650 nm (15 nm steps,
   19 samples, :data:`PAPER_WAVELENGTHS_NM`).
2. Each sample times the CIE 1931 2° colour matching functions at λ_i, summed (plain sums: no
   Δλ = 15 nm factor, no K_m; the scale cancels in step 3)::

       X = Σ_i L_e(T, λ_i) x̄(λ_i),   Y = Σ_i L_e(T, λ_i) ȳ(λ_i),   Z = Σ_i L_e(T, λ_i) z̄(λ_i)

3. Optional sodium: "an extra call to the spectrum evaluator at 590 nm (the closest value in our
   lookup table to sodium's D-lines […]), and scaling that by a sodium percentage value". We read
   the percentage as a per-voxel *fraction* f ∈ [0, 1] and the scaled term as *added on top of*
   the blackbody sums (the blackbody part is not reduced by 1 − f)::

       (X, Y, Z) += f · L_e(T, 590 nm) · (x̄, ȳ, z̄)(590 nm)

   590 nm is itself one of the 19 samples, so f = 1 doubles that sample's weight.
4. Chromaticity ``x = X/(X+Y+Z)``, ``y = Y/(X+Y+Z)``, ``z = Z/(X+Y+Z)``.
5. ``(x, y, z)`` → linear RGB by a constant matrix, "a Von Kries transformation calibrated for the
   sRGB white point": Lindbloom's XYZ → sRGB (D65) matrix :data:`PAPER_XYZ_TO_RGB`, applied to
   the chromaticity vector (as Walker's ``xyz_to_rgb`` does). Because the matrix is linear and
   every later step is invariant to a positive scale, applying it to X, Y, Z gives the same
   result.
6. "make sure the values are non-negative": negatives are clamped to 0; "the magnitude is
   normalized": divided by the largest component, so that it is 1.
7. "scaled by the blackbody intensity": multiplied by T^1.5 (the paper's exponent, chosen for
   dynamic range instead of Stefan–Boltzmann's T⁴; :data:`PAPER_EXPONENT`, a parameter here).

The renderer then sums these values along the ray; that part lives in the kernels.

Numerics. :func:`paper_spectrum_xyz` and :func:`paper_sodium_xyz` evaluate the formula literally,
so they are exactly 0 where ``exp(c2/(λT))`` overflows float64 (c2/(λT) > 709.78 at 650 nm, i.e.
below about 31 K). :func:`paper_rgb` only needs the *ratios* of the samples, so it evaluates
``L_e(T, λ) · exp(c2 / (650 nm · T))`` instead (every factor ≤ 1 for λ ≤ 650 nm; the same value up
to rounding), which keeps the colour defined for every T > 0. A float32 re-implementation of the
literal formula loses every sample much earlier: exp overflows float32 for c2/(λT) > 88.7, i.e.
below about 250 K at 650 nm.

Readings of the paper's prose (its text gives no code):

- "non-negative" is taken as clamping at 0. Walker's ``constrain_rgb``, which the paper cites,
  instead *adds white* (−min(r, g, b) to every component), which keeps the hue but desaturates.
- "the magnitude is normalized" is taken as max(r, g, b) = 1 (Walker's ``norm_rgb``), not as unit
  vector length.
- The matrix is Lindbloom's plain XYZ → sRGB matrix: the sRGB white is D65 and no adaptation
  (no Bradford or von Kries step) is added, whatever "mimic a Von Kries transformation" meant.
- The brightness factor is T^exponent with no constant (the paper sums it along the ray and caps
  at 255, so its absolute unit is the renderer's choice).

References
----------
M. Zonenberg, E. Forrest, "A GPU Accelerated Volumetric Ray Tracer for Incandescent Gas", 2011,
§4 (``shared/reference/paper.md``).
J. Walker, "Colour Rendering of Spectra", 1996 (``specrend.c``: ``bb_spectrum``, ``xyz_to_rgb``,
``norm_rgb``), https://www.fourmilab.ch/documents/specrend/.
B. Lindbloom, "Useful Color Equations" and "RGB/XYZ Matrices" (sRGB, D65),
http://www.brucelindbloom.com/.
CIE 015:2018, *Colorimetry*, 4th ed. (CIE 1931 2° standard observer; u′v′ in §8.1).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.colorimetry.xyz import as_components, xyz_to_uv_prime
from incandescent.constants import PAPER_2011
from incandescent.spectra.blackbody import blackbody_xyz
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.planck import NM_TO_M

#: The paper's 19 wavelengths, 380 to 650 nm in 15 nm steps (§4), in nm.
PAPER_WAVELENGTHS_NM: NDArray[np.float64] = np.arange(380.0, 651.0, 15.0)
PAPER_WAVELENGTHS_NM.setflags(write=False)
#: The wavelength of the sodium term (the paper's table entry nearest the D lines, 589.0/589.6 nm).
PAPER_SODIUM_NM = 590.0
#: The index of :data:`PAPER_SODIUM_NM` in :data:`PAPER_WAVELENGTHS_NM` (14).
_SODIUM_INDEX = int(np.flatnonzero(PAPER_WAVELENGTHS_NM == PAPER_SODIUM_NM)[0])
#: Lindbloom's XYZ → linear sRGB matrix (sRGB primaries, D65 reference white, no adaptation).
PAPER_XYZ_TO_RGB: NDArray[np.float64] = np.array(
    [
        [3.2404542, -1.5371385, -0.4985314],
        [-0.9692660, 1.8760108, 0.0415560],
        [0.0556434, -0.2040259, 1.0572252],
    ]
)
PAPER_XYZ_TO_RGB.setflags(write=False)
#: The paper's brightness exponent: colour × T^1.5 ("believable values", §4).
PAPER_EXPONENT = 1.5
#: Longest paper wavelength in m; the reference of the overflow-free scaled spectrum.
_LAMBDA_REF_M = float(PAPER_WAVELENGTHS_NM[-1]) * NM_TO_M


@functools.cache
def paper_cmf() -> NDArray[np.float64]:
    """CIE 1931 2° x̄ȳz̄ at :data:`PAPER_WAVELENGTHS_NM`, shape (19, 3), read-only.

    Taken from :func:`incandescent.spectra.cmf.cmfs` (CIE 015:2018 1 nm table) at those exact
    integer wavelengths; row 14 is the 590 nm sodium entry.
    """
    table = cmfs("cie1931_2")
    index = np.searchsorted(table.wavelength_nm, PAPER_WAVELENGTHS_NM)
    if not np.array_equal(table.wavelength_nm[index], PAPER_WAVELENGTHS_NM):
        raise RuntimeError("the CMF table lacks one of the paper's wavelengths")
    values = table.xyz_bar[index].copy()
    values.setflags(write=False)
    return values


def _planck_literal(lam_m: NDArray | float, temp_K: NDArray) -> NDArray[np.float64]:
    """The paper's L_e(T, λ) = c1 λ⁻⁵ / (exp(c2/(λT)) − 1), λ in m; 0 where exp overflows."""
    with np.errstate(over="ignore"):
        return PAPER_2011.c1 * lam_m**-5 / np.expm1(PAPER_2011.c2 / (lam_m * temp_K))


def _planck_scaled(lam_m: NDArray, temp_K: NDArray) -> NDArray[np.float64]:
    """``L_e(T, λ) · exp(c2 / (650 nm · T))``: same ratios across λ ≤ 650 nm, never 0 or inf."""
    x = PAPER_2011.c2 / (lam_m * temp_K)
    x_ref = PAPER_2011.c2 / (_LAMBDA_REF_M * temp_K)
    return PAPER_2011.c1 * lam_m**-5 * np.exp(x_ref - x) / -np.expm1(-x)


def paper_spectrum_xyz(temperature_K: ArrayLike) -> NDArray[np.float64]:
    """The paper's blackbody sums ``(X, Y, Z) = Σ_i L_e(T, λ_i) x̄ȳz̄(λ_i)``, unnormalised.

    Parameters
    ----------
    temperature_K:
        Temperatures in K (finite, > 0), any shape S.

    Returns
    -------
    Shape S + (3,), in the paper's units of L_e (W·m⁻²·m⁻¹, summed over 19 samples). Exactly 0
    below about 31 K, where ``exp(c2/(λT))`` overflows float64 at every sample.

    Examples
    --------
    >>> xyz = paper_spectrum_xyz(3000.0)
    >>> [round(float(v / xyz.sum()), 4) for v in xyz]
    [0.4295, 0.4075, 0.163]
    """
    temp = _validate.positive_temperature(temperature_K)[..., None]
    return _planck_literal(PAPER_WAVELENGTHS_NM * NM_TO_M, temp) @ paper_cmf()


def paper_sodium_xyz(temperature_K: ArrayLike) -> NDArray[np.float64]:
    """The sodium term before the fraction: ``L_e(T, 590 nm) · x̄ȳz̄(590 nm)``, shape S + (3,)."""
    temp = _validate.positive_temperature(temperature_K)[..., None]
    return _planck_literal(PAPER_SODIUM_NM * NM_TO_M, temp) * paper_cmf()[_SODIUM_INDEX]


def paper_chromaticity_rgb(xyz: ArrayLike) -> NDArray[np.float64]:
    """Steps 4–6: chromaticity → :data:`PAPER_XYZ_TO_RGB` → clamp at 0 → largest component 1.

    Parameters
    ----------
    xyz:
        Tristimulus sums (X, Y, Z), shape ``[..., 3]``, finite and ≥ 0 (any common scale).

    Returns
    -------
    Linear sRGB, shape ``[..., 3]``, components in [0, 1] with the largest exactly 1. Black
    (X + Y + Z = 0, no chromaticity) gives (0, 0, 0).

    Examples
    --------
    >>> paper_chromaticity_rgb([0.95047, 1.0, 1.08883]).round(4).tolist()
    [1.0, 1.0, 1.0]
    """
    arr = _validate.finite(as_components(xyz, "xyz"), "xyz")
    negative = arr < 0
    if negative.any():
        raise ValueError(f"xyz must be >= 0; got {_validate._first_bad(arr, negative)}")
    total = arr.sum(axis=-1, keepdims=True)
    chroma = arr / np.where(total == 0, 1.0, total)  # (x, y, z); black stays (0, 0, 0)
    rgb = np.maximum(chroma @ PAPER_XYZ_TO_RGB.T, 0.0)
    peak = rgb.max(axis=-1, keepdims=True)
    return rgb / np.where(peak == 0, 1.0, peak)


def _sodium_fraction(value: ArrayLike) -> NDArray[np.float64]:
    """Validate per-voxel sodium fractions: real, finite, in [0, 1]."""
    arr = _validate.finite(_validate.real_array(value, "sodium_fraction"), "sodium_fraction")
    bad = (arr < 0) | (arr > 1)
    if bad.any():
        raise ValueError(
            f"sodium_fraction must be in [0, 1] (a fraction, not a percentage); "
            f"got {_validate._first_bad(arr, bad)}"
        )
    return arr


def paper_rgb(
    temperature_K: ArrayLike,
    sodium_fraction: ArrayLike = 0.0,
    exponent: float = PAPER_EXPONENT,
) -> NDArray[np.float64]:
    """The paper's full per-voxel colour: normalised linear sRGB × T^exponent.

    Parameters
    ----------
    temperature_K:
        Temperatures in K (finite, > 0).
    sodium_fraction:
        Sodium fraction f ∈ [0, 1] per voxel, broadcast against ``temperature_K``; adds
        ``f · L_e(T, 590 nm) · x̄ȳz̄(590 nm)`` to the blackbody sums.
    exponent:
        Brightness exponent (the paper's 1.5; 4 would be Stefan–Boltzmann).

    Returns
    -------
    Shape ``broadcast(temperature_K, sodium_fraction).shape + (3,)``; components ≥ 0, the largest
    exactly ``T**exponent`` (K^exponent, the paper's arbitrary brightness unit).

    Examples
    --------
    >>> bool(paper_rgb(1000.0).max() == 1000.0**1.5)
    True
    """
    temp = _validate.positive_temperature(temperature_K)
    frac = _sodium_fraction(sodium_fraction)
    power = _validate.finite_scalar(exponent, "exponent")
    temp, frac = np.broadcast_arrays(temp, frac)
    lam_m = PAPER_WAVELENGTHS_NM * NM_TO_M
    spectrum = _planck_scaled(lam_m, temp[..., None])  # S + (19,), common factor per T
    xyz = spectrum @ paper_cmf()
    xyz += (frac * spectrum[..., _SODIUM_INDEX])[..., None] * paper_cmf()[_SODIUM_INDEX]
    return paper_chromaticity_rgb(xyz) * (temp**power)[..., None]


def truncation_shift_uv(temperature_K: ArrayLike) -> NDArray[np.float64]:
    """Δu′v′ of the paper's 19-sample 380–650 nm sum against the full blackbody, per temperature.

    The reference is :func:`incandescent.blackbody_xyz` (360–830 nm at 1 nm, same constants);
    Δu′v′ is the Euclidean distance in the CIE 1976 UCS diagram.

    Parameters
    ----------
    temperature_K:
        Temperatures in K (finite, ≥ 25 K: below, the 360–830 nm reference underflows float64).

    Returns
    -------
    Δu′v′ (dimensionless), shape of ``temperature_K``. About 0.027 at 1000 K, 0.006 at 3000 K and
    0.003 at 6500 K; it falls with T above about 450 K but is not monotonic below (it peaks near
    0.050 around 450 K, where the cut at 650 nm drops most of the visible emission).

    Examples
    --------
    >>> round(float(truncation_shift_uv(3000.0)), 4)
    0.0063
    """
    temp = _validate.positive_temperature(temperature_K)
    reference = blackbody_xyz(temp, constants="paper")
    black = reference.sum(axis=-1) == 0
    if black.any():
        raise ValueError(
            "truncation_shift_uv needs temperature_K >= 25 K (the 360-830 nm reference "
            f"underflows below); got {_validate._first_bad(temp, black)} K"
        )
    paper = _planck_scaled(PAPER_WAVELENGTHS_NM * NM_TO_M, temp[..., None]) @ paper_cmf()
    delta = xyz_to_uv_prime(paper) - xyz_to_uv_prime(reference)
    return np.hypot(delta[..., 0], delta[..., 1])
