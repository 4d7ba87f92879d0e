"""Colorimetry: XYZ chromaticities, linear RGB spaces and chromatic adaptation."""

from incandescent.colorimetry.adaptation import (
    CAT_METHODS,
    NAMED_WHITES_XY,
    adapt,
    chromatic_adaptation_matrix,
    white_point_xyz,
)
from incandescent.colorimetry.rgb_spaces import (
    RGB_SPACES,
    RGBSpace,
    rgb_space,
    rgb_to_xyz,
    xyz_to_rgb,
)
from incandescent.colorimetry.xyz import D65_XY, xy_to_xyz, xyz_to_uv_prime, xyz_to_xy

__all__ = [
    "CAT_METHODS",
    "D65_XY",
    "NAMED_WHITES_XY",
    "RGBSpace",
    "RGB_SPACES",
    "adapt",
    "chromatic_adaptation_matrix",
    "rgb_space",
    "rgb_to_xyz",
    "white_point_xyz",
    "xy_to_xyz",
    "xyz_to_rgb",
    "xyz_to_uv_prime",
    "xyz_to_xy",
]
