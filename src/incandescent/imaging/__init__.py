"""Imaging: exposure, tone mapping, gamut mapping and display encoding of scene XYZ."""

from incandescent.imaging.encode import gamut_map, quantize, srgb_oetf
from incandescent.imaging.exposure import (
    auto_exposure_scale,
    camera_exposure_scale,
    ev_scale,
    lit_percentile,
    saturation_luminance,
)
from incandescent.imaging.pipeline import DisplaySettings, display_pixels, to_display
from incandescent.imaging.tonemap import TONEMAPS, tonemap

__all__ = [
    "TONEMAPS",
    "DisplaySettings",
    "auto_exposure_scale",
    "camera_exposure_scale",
    "display_pixels",
    "ev_scale",
    "gamut_map",
    "lit_percentile",
    "quantize",
    "saturation_luminance",
    "srgb_oetf",
    "to_display",
    "tonemap",
]
