"""CIE XYZ ↔ chromaticity conversions (CIE 1931 xy and CIE 1976 u′v′).

Arrays are ``[..., 3]`` (XYZ) or ``[..., 2]`` (chromaticity). Black (X + Y + Z = 0) has no
chromaticity; it is given the D65 white point's chromaticity so that downstream code never sees
NaN (the same convention as colour-science's ``XYZ_to_xy``, which returns the illuminant there).

References
----------
CIE 015:2018, *Colorimetry*, 4th ed., §7.3 (x, y) and §8.1 (u′, v′).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate

#: CIE 1931 2° chromaticity of illuminant D65 (CIE 015:2018, Table 11.3).
D65_XY: tuple[float, float] = (0.3127, 0.3290)


def as_components(value: ArrayLike, name: str, n: int = 3) -> NDArray[np.float64]:
    """Validate a real array whose last axis has ``n`` components (``[..., n]``)."""
    arr = _validate.real_array(value, name)
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise ValueError(f"{name} must have shape [..., {n}]; got shape {arr.shape}")
    return arr


def _safe_ratio(num: NDArray, den: NDArray, fallback: float) -> NDArray:
    """``num / den`` with ``fallback`` wherever ``den == 0`` (no warnings, no NaN)."""
    zero = den == 0
    return np.where(zero, fallback, num / np.where(zero, 1.0, den))


def xyz_to_xy(xyz: ArrayLike) -> NDArray[np.float64]:
    """CIE 1931 chromaticity ``x = X/(X+Y+Z)``, ``y = Y/(X+Y+Z)``.

    Parameters
    ----------
    xyz:
        Tristimulus values, shape ``[..., 3]`` (any consistent unit, e.g. cd/m²).

    Returns
    -------
    Chromaticity, shape ``[..., 2]`` (dimensionless). Where ``X + Y + Z = 0`` the D65
    chromaticity ``(0.3127, 0.3290)`` is returned instead of NaN.

    Examples
    --------
    >>> xyz_to_xy([0.0, 0.0, 0.0]).tolist()
    [0.3127, 0.329]
    """
    arr = as_components(xyz, "xyz")
    total = arr.sum(axis=-1)
    x = _safe_ratio(arr[..., 0], total, D65_XY[0])
    y = _safe_ratio(arr[..., 1], total, D65_XY[1])
    return np.stack([x, y], axis=-1)


def xy_to_xyz(xy: ArrayLike, Y: ArrayLike = 1.0) -> NDArray[np.float64]:
    """Tristimulus values from chromaticity and luminance: ``X = xY/y``, ``Z = (1−x−y)Y/y``.

    Parameters
    ----------
    xy:
        Chromaticity, shape ``[..., 2]``.
    Y:
        Luminance (any unit, e.g. cd/m², or 1 for a relative white), broadcast
        against ``xy[..., 0]``.

    Returns
    -------
    XYZ, shape ``[..., 3]``, in the unit of ``Y``. Where ``y = 0`` (not a real colour)
    ``X = Z = 0`` is returned instead of infinity.

    Examples
    --------
    >>> np.round(xy_to_xyz([0.3127, 0.3290]), 5).tolist()
    [0.95046, 1.0, 1.08906]
    """
    c = as_components(xy, "xy", n=2)
    lum = _validate.real_array(Y, "Y")
    x, y = c[..., 0], c[..., 1]
    lum, x, y = np.broadcast_arrays(lum, x, y)
    scale = _safe_ratio(lum, y, 0.0)
    return np.stack([x * scale, lum, (1.0 - x - y) * scale], axis=-1)


def xyz_to_uv_prime(xyz: ArrayLike) -> NDArray[np.float64]:
    """CIE 1976 UCS chromaticity ``u′ = 4X/(X+15Y+3Z)``, ``v′ = 9Y/(X+15Y+3Z)``.

    Parameters
    ----------
    xyz:
        Tristimulus values, shape ``[..., 3]``.

    Returns
    -------
    ``(u′, v′)``, shape ``[..., 2]``. Where the denominator is 0 (black) the D65 ``u′v′``
    (≈ ``(0.19783, 0.46832)``) is returned instead of NaN.
    """
    arr = as_components(xyz, "xyz")
    den = arr[..., 0] + 15.0 * arr[..., 1] + 3.0 * arr[..., 2]
    white = xy_to_xyz(D65_XY)
    w_den = white[0] + 15.0 * white[1] + 3.0 * white[2]
    u = _safe_ratio(4.0 * arr[..., 0], den, 4.0 * white[0] / w_den)
    v = _safe_ratio(9.0 * arr[..., 1], den, 9.0 * white[1] / w_den)
    return np.stack([u, v], axis=-1)
