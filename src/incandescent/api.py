"""The public API in one place: what the CLI, scripts and notebooks call."""

from __future__ import annotations

from incandescent.budget import Limits
from incandescent.camera import Camera, default_camera
from incandescent.config.assemble import load_volume, volume_from_section
from incandescent.imaging import DisplaySettings, to_display
from incandescent.io.output import save_volume, write_json
from incandescent.output import save_image
from incandescent.renderer import HDRImage, RenderSettings, render
from incandescent.volume import Remap, Volume
from incandescent.volume.sparse import SparseVolume

__all__ = [
    "Camera",
    "DisplaySettings",
    "HDRImage",
    "Limits",
    "Remap",
    "RenderSettings",
    "Volume",
    "camera_from",
    "load_volume",
    "volume_from_section",
    "render",
    "save_image",
    "save_volume",
    "to_display",
    "write_json",
]


def camera_from(
    volume: Volume | SparseVolume,
    eye=None,
    target=None,
    fov_deg: float = 40.0,
    frame_content: bool = True,
) -> Camera:
    """The default three-quarter camera — framing the gas, or the whole box when
    ``frame_content`` is false (animations) — with any of eye/target/fov overridden."""
    bounds = volume.content_bounds_m if frame_content else volume.bounds_m
    camera = default_camera(bounds, fov_deg=fov_deg)
    changes = {k: v for k, v in (("eye", eye), ("target", target)) if v is not None}
    return camera.replace(**changes) if changes else camera
