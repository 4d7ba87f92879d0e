"""Von Kries-type chromatic adaptation (Bradford and von Kries cone spaces) and white points.

A chromatic adaptation transform maps XYZ seen under a source white to corresponding colours
under a target white: convert to a cone-like space with ``M_A``, scale each channel by the ratio
of the target to the source white's response, and convert back:
``M = M_A⁻¹ · diag(ρ_t/ρ_s, γ_t/γ_s, β_t/β_s) · M_A``.

References
----------
Lam, K. M. (1985). *Metamerism and colour constancy*. PhD thesis, University of Bradford
(Bradford matrix, used here in its linearised form as in ICC.1:2010 Annex E).
Hunt, R. W. G., Pointer, M. R. (1985) and Estévez, O. (1979): the Hunt–Pointer–Estévez cone
fundamentals used for the von Kries transform, as tabulated in Fairchild, M. D. (2013),
*Color Appearance Models*, 3rd ed., Wiley, §9.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.colorimetry.xyz import D65_XY, as_components, xy_to_xyz

#: Bradford cone response matrix (Lam 1985; ICC.1:2010 Annex E, linearised).
CAT_BRADFORD = np.array(
    [
        [0.8951, 0.2664, -0.1614],
        [-0.7502, 1.7135, 0.0367],
        [0.0389, -0.0685, 1.0296],
    ]
)

#: Hunt–Pointer–Estévez cone fundamentals (Fairchild 2013, Eq. 9.2), for von Kries adaptation.
CAT_VON_KRIES = np.array(
    [
        [0.40024, 0.70760, -0.08081],
        [-0.22630, 1.16532, 0.04570],
        [0.00000, 0.00000, 0.91822],
    ]
)

CAT_METHODS: dict[str, NDArray[np.float64]] = {"bradford": CAT_BRADFORD, "von_kries": CAT_VON_KRIES}

#: CIE 1931 2° chromaticities of named whites (CIE 015:2018 Table 11.3; E is equal energy).
NAMED_WHITES_XY: dict[str, tuple[float, float]] = {
    "D65": D65_XY,
    "D50": (0.3457, 0.3585),
    "E": (1.0 / 3.0, 1.0 / 3.0),
}

White = str | None


def _white_xyz_array(xyz: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = _validate.finite(as_components(xyz, name), name)
    if arr.shape != (3,) or arr[1] <= 0:
        raise ValueError(f"{name} must be one XYZ triple with Y > 0; got {arr.tolist()}")
    return arr


def chromatic_adaptation_matrix(
    source_white_xyz: ArrayLike, target_white_xyz: ArrayLike, method: str = "bradford"
) -> NDArray[np.float64]:
    """3×3 matrix adapting XYZ under ``source_white_xyz`` to XYZ under ``target_white_xyz``.

    Parameters
    ----------
    source_white_xyz, target_white_xyz:
        White points as XYZ triples, shape (3,) with Y > 0 (any common scale; only ratios matter
        per white, and both are normalised to Y = 1 so luminance is preserved).
    method:
        ``"bradford"`` (default) or ``"von_kries"``.

    Returns
    -------
    Matrix ``M`` with ``XYZ_target = M @ XYZ_source``; ``M @ source_white`` = target white.
    """
    _validate.choice(method, "chromatic adaptation method", tuple(CAT_METHODS))
    cone = CAT_METHODS[method]
    src = _white_xyz_array(source_white_xyz, "source_white_xyz")
    dst = _white_xyz_array(target_white_xyz, "target_white_xyz")
    gain = (cone @ (dst / dst[1])) / (cone @ (src / src[1]))
    return np.linalg.inv(cone) @ (gain[:, None] * cone)


def white_point_xyz(white: White | ArrayLike) -> NDArray[np.float64] | None:
    """XYZ (normalised to Y = 1) of a white given by name or XYZ.

    Parameters
    ----------
    white:
        ``"D65"``, ``"D50"`` or ``"E"`` (case-insensitive); an XYZ triple (a blackbody's white is
        :func:`incandescent.spectra.planckian_white`); or ``None``, meaning "no white", i.e. no
        adaptation.

    Returns
    -------
    Array of shape (3,) with Y = 1, or ``None`` when ``white`` is ``None``.
    """
    if white is None:
        return None
    if isinstance(white, str):
        key = white.upper()
        _validate.choice(key, "white point", tuple(NAMED_WHITES_XY))
        return xy_to_xyz(NAMED_WHITES_XY[key])
    if isinstance(white, (bool, int, float, np.integer, np.floating)):
        raise ValueError(
            f"white {white!r} is a number, not a white point: give a name or an XYZ triple "
            "(a blackbody at T kelvin: incandescent.spectra.planckian_white(T))"
        )
    xyz = _white_xyz_array(white, "white")
    return xyz / xyz[1]


def adapt(
    xyz: ArrayLike,
    source_white: White | ArrayLike,
    target_white: White | ArrayLike,
    method: str = "bradford",
) -> NDArray[np.float64]:
    """Chromatically adapt XYZ ``[..., 3]`` from ``source_white`` to ``target_white``.

    Whites are anything :func:`white_point_xyz` accepts. When either is ``None`` the input is
    returned unchanged (as a float64 array): no adaptation was asked for.

    Examples
    --------
    >>> np.round(adapt(xy_to_xyz(D65_XY), "D65", "D50"), 4).tolist()
    [0.9643, 1.0, 0.8251]
    """
    arr = as_components(xyz, "xyz")
    src, dst = white_point_xyz(source_white), white_point_xyz(target_white)
    if src is None or dst is None:
        return arr
    return arr @ chromatic_adaptation_matrix(src, dst, method).T
