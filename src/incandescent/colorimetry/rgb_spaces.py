"""Linear RGB colour spaces defined by primaries and white point, with computed matrices.

The RGB → XYZ matrix is the *normalised primary matrix* of SMPTE RP 177-1993 §3.3: with the
primaries' XYZ (at Y = 1) as the columns of ``P`` and the white ``W`` at Y = 1,
``S = P⁻¹ W`` and ``M = P · diag(S)``, so that RGB ``(1, 1, 1)`` maps to the white and the
middle row of ``M`` gives each primary's luminance weight. Nothing is clipped: negative
components mean "outside the gamut of the space".

References
----------
SMPTE RP 177-1993, *Derivation of Basic Television Color Equations*.
ITU-R BT.709-6 (sRGB/Rec.709 primaries), IEC 61966-2-1:1999 (sRGB), ITU-R BT.2020-2,
SMPTE EG 432-1:2010 (Display P3: DCI-P3 primaries, D65 white), Academy S-2014-004 (ACEScg, AP1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.colorimetry.xyz import D65_XY, as_components, xy_to_xyz


@dataclass(frozen=True)
class RGBSpace:
    """A linear RGB space: three primaries and a white point, as CIE 1931 xy chromaticities.

    Parameters
    ----------
    name:
        Human-readable identifier.
    primaries_xy:
        ``((x_R, y_R), (x_G, y_G), (x_B, y_B))``, shape (3, 2).
    white_xy:
        ``(x_W, y_W)``, shape (2,).
    """

    name: str
    primaries_xy: tuple[tuple[float, float], ...]
    white_xy: tuple[float, float]

    def __post_init__(self) -> None:
        prim = _validate.finite(
            _validate.real_array(self.primaries_xy, "primaries_xy"), "primaries_xy"
        )
        white = _validate.finite(_validate.real_array(self.white_xy, "white_xy"), "white_xy")
        if prim.shape != (3, 2):
            raise ValueError(f"primaries_xy must have shape (3, 2); got {prim.shape}")
        if white.shape != (2,):
            raise ValueError(f"white_xy must have shape (2,); got {white.shape}")
        if (prim[:, 1] <= 0).any() or white[1] <= 0:
            raise ValueError(
                f"chromaticity y must be > 0; got primaries {prim.tolist()}, white {white.tolist()}"
            )
        if abs(np.linalg.det(xy_to_xyz(prim))) < 1e-9:
            raise ValueError(f"primaries_xy {prim.tolist()} are collinear; they span no gamut")
        object.__setattr__(self, "primaries_xy", tuple(tuple(map(float, p)) for p in prim))
        object.__setattr__(self, "white_xy", tuple(map(float, white)))

    @property
    def rgb_to_xyz_matrix(self) -> NDArray[np.float64]:
        """Normalised primary matrix (SMPTE RP 177): ``XYZ = M @ RGB``, white ↦ Y = 1."""
        primaries = xy_to_xyz(np.asarray(self.primaries_xy)).T  # columns = primaries
        white = xy_to_xyz(np.asarray(self.white_xy))
        return np.asarray(primaries * np.linalg.solve(primaries, white), dtype=np.float64)

    @property
    def xyz_to_rgb_matrix(self) -> NDArray[np.float64]:
        """Inverse of :attr:`rgb_to_xyz_matrix`: ``RGB = M⁻¹ @ XYZ``."""
        return np.asarray(np.linalg.inv(self.rgb_to_xyz_matrix), dtype=np.float64)

    @property
    def luminance_weights(self) -> NDArray[np.float64]:
        """Relative luminance of each primary (the Y row of the RGB → XYZ matrix), summing to 1."""
        return self.rgb_to_xyz_matrix[1]


#: White point of the ACES colour spaces (Academy TB-2014-004), close to but not D60.
ACES_WHITE_XY: tuple[float, float] = (0.32168, 0.33767)

RGB_SPACES: dict[str, RGBSpace] = {
    "srgb": RGBSpace("srgb", ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06)), D65_XY),
    "rec2020": RGBSpace("rec2020", ((0.708, 0.292), (0.170, 0.797), (0.131, 0.046)), D65_XY),
    "display_p3": RGBSpace("display_p3", ((0.680, 0.320), (0.265, 0.690), (0.150, 0.060)), D65_XY),
    "acescg": RGBSpace("acescg", ((0.713, 0.293), (0.165, 0.830), (0.128, 0.044)), ACES_WHITE_XY),
}
"""Registry of built-in spaces; ``"srgb"`` (sRGB / Rec.709 primaries, D65) is the default."""

DEFAULT_SPACE = "srgb"


def rgb_space(space: str | RGBSpace) -> RGBSpace:
    """Resolve a registry name (case-insensitive) or pass an :class:`RGBSpace` through.

    Raises
    ------
    ValueError
        For an unknown name, listing the valid names.
    TypeError
        For anything that is neither a string nor an :class:`RGBSpace`.
    """
    if isinstance(space, RGBSpace):
        return space
    if not isinstance(space, str):
        raise TypeError(
            f"space must be a name or an RGBSpace; got {type(space).__name__} {space!r}"
        )
    key = space.lower()
    _validate.choice(key, "RGB space", tuple(RGB_SPACES))
    return RGB_SPACES[key]


def xyz_to_rgb(xyz: ArrayLike, space: str | RGBSpace = DEFAULT_SPACE) -> NDArray[np.float64]:
    """Linear RGB in ``space`` from XYZ, shape ``[..., 3]`` → ``[..., 3]``; unclipped.

    The RGB unit is the XYZ unit: with Y in cd/m², ``(1, 1, 1)`` is the white at 1 cd/m².

    Examples
    --------
    >>> np.round(xyz_to_rgb(xy_to_xyz(D65_XY)), 12).tolist()
    [1.0, 1.0, 1.0]
    """
    arr = as_components(xyz, "xyz")
    return _times_transposed(arr, rgb_space(space).xyz_to_rgb_matrix)


def rgb_to_xyz(rgb: ArrayLike, space: str | RGBSpace = DEFAULT_SPACE) -> NDArray[np.float64]:
    """XYZ from linear RGB in ``space``, shape ``[..., 3]`` → ``[..., 3]``."""
    arr = as_components(rgb, "rgb")
    return _times_transposed(arr, rgb_space(space).rgb_to_xyz_matrix)


def _times_transposed(arr: NDArray[np.float64], matrix: NDArray[np.float64]) -> NDArray[np.float64]:
    """``arr @ matrix.T`` for ``[..., 3]`` arrays as one (N, 3) product: the same values as
    NumPy's stacked product of an image's rows, in less time (a 512² image 2.4 → 1.1 ms)."""
    return (arr.reshape(-1, arr.shape[-1]) @ matrix.T).reshape(arr.shape)
