"""Display encoding: gamut mapping, the sRGB transfer function and integer quantisation."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.colorimetry.rgb_spaces import DEFAULT_SPACE, RGBSpace, rgb_space
from incandescent.colorimetry.xyz import as_components

GAMUT_METHODS: tuple[str, ...] = ("clip", "desaturate")
BIT_DEPTHS: tuple[int, ...] = (8, 16)


def _desaturate(rgb: NDArray[np.float64], weights: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mix each pixel towards its luminance ``L`` just enough that its minimum component is 0.

    ``c' = L + s (c − L)`` with ``s = L / (L − min c)`` when ``min c < 0``; luminance and hue
    angle are preserved. Pixels with ``L ≤ 0`` (no displayable colour) become black. Only the
    pixels with a negative component are mixed (a fifth of a typical flame image; the minimum
    of three components from two ``minimum`` passes, not a reduction over an axis of 3).
    """
    out = np.array(rgb, dtype=np.float64)
    if out.ndim == 1:
        return _desaturate(out[None], weights)[0]
    low = np.minimum(np.minimum(out[..., 0], out[..., 1]), out[..., 2])
    needs = low < 0
    if not needs.any():
        return out
    colour = out[needs]
    lum = (colour @ weights)[:, None]
    spread = lum - low[needs][:, None]  # >= 0: a weighted mean is never below the minimum
    s = np.clip(lum / np.where(spread > 0, spread, 1.0), 0.0, 1.0)
    out[needs] = np.maximum(lum + s * (colour - lum), 0.0)  # max() only removes round-off
    return out


def gamut_map(
    rgb: ArrayLike, method: str = "desaturate", space: str | RGBSpace = DEFAULT_SPACE
) -> NDArray[np.float64]:
    """Remove negative (out-of-gamut) components from linear RGB ``[..., 3]``.

    Parameters
    ----------
    rgb:
        Linear RGB in ``space``.
    method:
        ``"clip"``: set negative components to 0 (shifts hue and luminance);
        ``"desaturate"``: mix towards the pixel's luminance (Y row of the space's RGB → XYZ
        matrix) just enough that the minimum component is 0, keeping luminance.
    space:
        RGB space whose luminance weights ``"desaturate"`` uses.

    Returns
    -------
    Array of the same shape with no negative components; pixels with no negative component
    are returned unchanged. Values above 1 are left for the encoder to clip.
    """
    _validate.choice(method, "gamut mapping method", GAMUT_METHODS)
    arr = as_components(rgb, "rgb")
    if method == "clip":
        return np.maximum(arr, 0.0)
    return _desaturate(arr, rgb_space(space).luminance_weights)


def srgb_oetf(linear: ArrayLike) -> NDArray[np.float64]:
    """sRGB encoding (inverse EOTF) of IEC 61966-2-1:1999, §5.2, Eq. 5.

    ``V = 12.92 L`` for ``L ≤ 0.0031308``, else ``V = 1.055 L^(1/2.4) − 0.055``. Defined on
    [0, 1]; values outside are extended (linear segment below 0, power law above 1) as in
    colour-science's ``eotf_inverse_sRGB``, and clipped later by :func:`quantize`.
    """
    arr = _validate.real_array(linear, "linear")
    out = np.array(12.92 * arr, dtype=np.float64)
    bright = arr > 0.0031308  # the power law only where it applies (dark pixels are common)
    out[bright] = 1.055 * np.power(arr[bright], 1.0 / 2.4) - 0.055
    return out


def quantize(encoded: ArrayLike, bits: int = 8) -> NDArray[np.uint8] | NDArray[np.uint16]:
    """Quantise encoded values in [0, 1] to ``uint8`` (``bits=8``) or ``uint16`` (``bits=16``).

    Values are clipped to [0, 1], scaled by ``2**bits − 1`` and rounded to nearest (ties to
    even). NaN raises ``ValueError`` naming the count.
    """
    if isinstance(bits, bool) or bits not in BIT_DEPTHS:
        raise ValueError(f"bits must be 8 or 16; got {bits!r}")
    arr = _validate.real_array(encoded, "encoded")
    bad = int(np.isnan(arr).sum())
    if bad:
        raise ValueError(f"encoded contains {bad} NaN value(s); cannot quantise")
    top = (1 << bits) - 1
    dtype = np.uint8 if bits == 8 else np.uint16
    return np.round(np.clip(arr, 0.0, 1.0) * top).astype(dtype)  # type: ignore[return-value]
