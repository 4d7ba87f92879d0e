"""Exposure: scale factors from scene luminance (cd/m²) to display-referred linear values.

Every function returns a scalar multiplier for linear RGB/XYZ whose Y is in cd/m², chosen so
that the reference luminance maps to a display value (1.0 = display white before tone mapping).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from incandescent import _validate

#: Lens/vignetting transmission factor ``q`` of ISO 12232:2019 (§B; 0.65 for a typical lens).
ISO_12232_Q = 0.65
#: Saturation-based speed constant of ISO 12232 (S_sat = 78 / H_sat, H in lx·s).
ISO_12232_SATURATION_CONSTANT = 78.0


#: Largest exposure compensation in stops either way: 2^±100 spans any luminance float32 holds.
MAX_EV = 100.0


def ev_scale(ev: float) -> float:
    """Exposure compensation multiplier ``2**ev`` (``ev`` in stops, |ev| ≤ MAX_EV; +1 doubles
    brightness)."""
    stops = _validate.finite_scalar(ev, "exposure_ev")
    if abs(stops) > MAX_EV:
        raise ValueError(f"exposure_ev must be within ±{MAX_EV:g} stops; got {ev!r}")
    return float(2.0**stops)


def saturation_luminance(iso: float, shutter_s: float, f_number: float) -> float:
    """Scene luminance (cd/m²) that just saturates a camera, per ISO 12232 saturation speed.

    ``L_sat = 78 · N² / (S · t · q)`` with ``q = 0.65``: the focal-plane exposure
    ``H = q · L · t / N²`` (lx·s) reaches the saturation exposure ``H_sat = 78 / S``.

    Parameters
    ----------
    iso:
        Arithmetic ISO speed ``S`` (e.g. 100).
    shutter_s:
        Exposure time ``t`` in s.
    f_number:
        Relative aperture ``N`` (e.g. 8 for f/8).

    References
    ----------
    ISO 12232:2019, *Photography — Digital still cameras — Determination of exposure index,
    ISO speed ratings, standard output sensitivity, and recommended exposure index*, §6.2 and
    Annex B (saturation-based speed); see also the "Film speed" and "Exposure value" entries
    derived from it.
    """
    s = _validate.positive_scalar(iso, "iso")
    t = _validate.positive_scalar(shutter_s, "shutter_s")
    n = _validate.positive_scalar(f_number, "f_number")
    return ISO_12232_SATURATION_CONSTANT * n * n / (s * t * ISO_12232_Q)


def camera_exposure_scale(iso: float, shutter_s: float, f_number: float) -> float:
    """Multiplier ``1 / L_sat`` so that the saturating luminance maps to 1.0.

    See :func:`saturation_luminance` for ``L_sat`` (cd/m²). Example: ISO 100, 1/100 s, f/8
    saturates at ≈ 7.7e3 cd/m², so a 2000 K blackbody surface (≈ 4.6e5 cd/m²) is ~60× over.
    """
    return 1.0 / saturation_luminance(iso, shutter_s, f_number)


def auto_exposure_scale(
    luminance: ArrayLike, percentile: float = 99.0, target: float = 0.8
) -> float:
    """Multiplier mapping the ``percentile``-th percentile of the non-zero luminance to ``target``.

    Parameters
    ----------
    luminance:
        Luminance image (cd/m², any shape, finite). Pixels ≤ 0 (empty background) are ignored so
        that a small flame in a black frame is still exposed for the flame.
    percentile:
        In (0, 100]; 99 keeps the brightest 1 % of lit pixels for highlight compression.
    target:
        Display value (> 0) that percentile should reach before tone mapping.

    Returns
    -------
    A finite positive float; 1.0 when no pixel is > 0 (all-black image).
    """
    lum = _validate.finite(_validate.real_array(luminance, "luminance"), "luminance")
    pct = _validate.finite_scalar(percentile, "percentile")
    if not 0.0 < pct <= 100.0:
        raise ValueError(f"percentile must be in (0, 100]; got {percentile!r}")
    goal = _validate.positive_scalar(target, "target")
    reference = lit_percentile(lum, pct)
    return goal / reference if reference > 0 else 1.0


def lit_percentile(luminance: ArrayLike, percentile: float = 99.0) -> float:
    """The ``percentile``-th percentile of the pixels with luminance > 0 (what auto exposure
    maps to its target); 0.0 when no pixel is lit."""
    lum = np.asarray(luminance)
    lit = lum[lum > 0]
    return float(np.percentile(lit, percentile)) if lit.size else 0.0
