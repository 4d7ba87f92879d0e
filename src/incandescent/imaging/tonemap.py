"""Tone mapping: compress scene-linear values (after exposure) to display-linear values.

Every curve maps ``[0, ∞)`` monotonically into ``[0, 1]`` and is applied per RGB channel. The
display pipeline (:func:`incandescent.imaging.to_display`) gamut-maps the linear HDR values
*before* tone mapping (a per-channel curve on out-of-gamut colours can turn highlights black), so
input here is normally non-negative. Negative components, if given, are mirrored,
``f(−x) = −f(x)``, rather than clipped: outputs are in ``[−1, 1]``, and in ``[0, 1]`` for
non-negative input.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate

ToneCurve = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def clip_curve(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hard clip: ``min(x, 1)`` for ``x ≥ 0`` (no highlight compression)."""
    return np.minimum(x, 1.0)


def reinhard_curve(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Reinhard et al. (2002) global operator ``x / (1 + x)``, Eq. 3, applied per channel.

    Per channel (not on luminance) so that the output stays within [0, 1] per component; this
    desaturates very bright colours towards white, as film does.

    References
    ----------
    Reinhard, E., Stark, M., Shirley, P., Ferwerda, J. (2002). Photographic tone reproduction for
    digital images. *ACM Transactions on Graphics* 21(3), 267–276.
    """
    x = np.minimum(x, 1e300)  # x = inf gives 1, not inf / inf = NaN
    return x / (1.0 + x)


def filmic_curve(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """ACES-like filmic curve: Narkowicz's rational fit to the ACES RRT + ODT, clamped to 1.

    ``f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)``, monotonic for ``x ≥ 0`` and
    reaching 1 at ``x ≈ 7.24``. Used as published (without the optional 0.6 pre-scale).

    References
    ----------
    Narkowicz, K. (2016-01-06). *ACES Filmic Tone Mapping Curve*.
    https://knarkowicz.wordpress.com/2016/01/06/aces-filmic-tone-mapping-curve/
    """
    x = np.minimum(x, 100.0)  # saturated beyond ≈ 7.24; avoids inf / inf for huge x
    y = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)
    return np.minimum(y, 1.0)


TONEMAPS: dict[str, ToneCurve] = {
    "clip": clip_curve,
    "reinhard": reinhard_curve,
    "filmic": filmic_curve,
}


def tonemap(rgb: ArrayLike, method: str = "filmic") -> NDArray[np.float64]:
    """Apply the tone curve ``method`` (``"clip"``, ``"reinhard"``, ``"filmic"``) per channel.

    Parameters
    ----------
    rgb:
        Exposed scene-linear values, any shape (1.0 = display white).
    method:
        Name in :data:`TONEMAPS`.

    Returns
    -------
    Display-linear values of the same shape, in [0, 1] for non-negative input; negative input
    is mirrored (see module notes).

    Examples
    --------
    >>> tonemap([0.0, 1.0, 1e9], "reinhard").round(3).tolist()
    [0.0, 0.5, 1.0]
    """
    _validate.choice(method, "tone map method", tuple(TONEMAPS))
    arr = _validate.real_array(rgb, "rgb")
    return np.sign(arr) * TONEMAPS[method](np.abs(arr))
