"""Absolute Planck spectral radiance.

Planck's law for spectral radiance per unit wavelength (e.g. Planck 1901; CIE 015:2018 eq. 1.2):

    B_λ(T) = c1L / (λ⁵ · (exp(c2 / (λ T)) − 1)),   c1L = 2 h c²,   c2 = h c / k_B

returned in W·sr⁻¹·m⁻²·nm⁻¹ for λ given in nm. ``expm1`` keeps the long-wavelength (Rayleigh–Jeans)
end exact, and the exponent is clipped so that very small λT underflows cleanly to 0 instead of
overflowing to inf (exp(700) is near float64's limit; B is then < 1e-300 of its peak).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.constants import PlanckConstants, planck_constants

_MAX_EXPONENT = 700.0
NM_TO_M = 1e-9


def planck_radiance(
    wavelength_nm: ArrayLike,
    temperature_K: ArrayLike,
    constants: str | PlanckConstants = "codata2018",
) -> NDArray[np.float64]:
    """Spectral radiance B_λ(T) of a blackbody in W·sr⁻¹·m⁻²·nm⁻¹.

    Parameters
    ----------
    wavelength_nm:
        Wavelengths in nm (vacuum), > 0. Broadcast against ``temperature_K``.
    temperature_K:
        Temperatures in K, > 0.
    constants:
        ``"codata2018"`` (default), ``"cie"`` (c2 = 1.4388e-2 m·K) or ``"paper"``.

    Examples
    --------
    >>> round(float(planck_radiance(555.0, 2000.0)), 3)
    5.311
    """
    c = planck_constants(constants)
    lam_m = _positive_wavelength(wavelength_nm) * NM_TO_M
    temp = _validate.positive_temperature(temperature_K)
    return _planck_m(lam_m, temp, c) * NM_TO_M


def _positive_wavelength(value: ArrayLike) -> NDArray[np.float64]:
    """Validate wavelengths in nm: real, finite, > 0 (the error message says nm, not K)."""
    arr = _validate.finite(_validate.real_array(value, "wavelength_nm"), "wavelength_nm")
    bad = arr <= 0
    if bad.any():
        raise ValueError(f"wavelength_nm must be > 0 nm; got {_validate._first_bad(arr, bad)} nm")
    return arr


def _planck_m(lam_m: NDArray, temp_K: NDArray, c: PlanckConstants) -> NDArray[np.float64]:
    """B_λ in W·sr⁻¹·m⁻³ (per metre of wavelength), no validation; overflow-safe."""
    x = c.c2 / (lam_m * temp_K)
    overflow = x > _MAX_EXPONENT
    denom = np.expm1(np.minimum(x, _MAX_EXPONENT))
    radiance = c.c1L / (lam_m**5 * denom)
    return np.where(overflow, 0.0, radiance)
