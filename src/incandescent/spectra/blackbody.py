"""Absolute CIE XYZ of blackbody radiation.

    X = K_m ∫ B_λ(T) x̄(λ) dλ,  Y = K_m ∫ B_λ(T) ȳ(λ) dλ,  Z = K_m ∫ B_λ(T) z̄(λ) dλ

with K_m = 683 lm/W (CIE 015:2018 eq. 7.1), integrated 360–830 nm at 1 nm by the rectangle rule
(the CIE's own convention for 1 nm tables). Y is luminance in cd/m².
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.constants import K_M, PlanckConstants, planck_constants
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.planck import NM_TO_M, _planck_m

_CHUNK = 4096


def blackbody_xyz(
    temperature_K: ArrayLike,
    observer: str = "cie1931_2",
    constants: str | PlanckConstants = "codata2018",
) -> NDArray[np.float64]:
    """Absolute XYZ of a blackbody at ``temperature_K``; Y is luminance in cd/m².

    Parameters
    ----------
    temperature_K:
        Array of temperatures in K (> 0, finite), any shape.
    observer:
        ``"cie1931_2"`` (default) or ``"cie1964_10"``.
    constants:
        Planck constant set, see :func:`incandescent.constants.planck_constants`.

    Returns
    -------
    Array of shape ``temperature_K.shape + (3,)``.

    Examples
    --------
    >>> xyz = blackbody_xyz(2000.0)
    >>> f"{xyz[1]:.3e}"
    '4.638e+05'
    """
    temp = _validate.positive_temperature(temperature_K)
    flat = temp.reshape(-1)
    out = np.empty((flat.size, 3))
    for start in range(0, flat.size, _CHUNK):
        out[start : start + _CHUNK] = _xyz_flat(flat[start : start + _CHUNK], observer, constants)
    return out.reshape(temp.shape + (3,))


def _xyz_flat(temp_K: NDArray, observer: str, constants: str | PlanckConstants) -> NDArray:
    cmf = cmfs(observer)
    c = planck_constants(constants)
    lam_m = cmf.wavelength_nm * NM_TO_M
    radiance_nm = _planck_m(lam_m[None, :], temp_K[:, None], c) * NM_TO_M
    return K_M * cmf.step_nm * (radiance_nm @ cmf.xyz_bar)


def planckian_white(temperature_K: float) -> NDArray[np.float64]:
    """XYZ (normalised to Y = 1) of a blackbody at ``temperature_K``: a white point on the
    Planckian locus, for :func:`incandescent.colorimetry.adapt`."""
    temp = _validate.positive_scalar(temperature_K, "white temperature_K")
    xyz = blackbody_xyz(temp)
    if not xyz[1] > 0:
        raise ValueError(f"white temperature_K {temp!r} K has zero luminance; use >= ~400 K")
    return xyz / xyz[1]
