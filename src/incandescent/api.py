"""The public API in one place: what the CLI, scripts and notebooks call."""

from __future__ import annotations

from pathlib import Path

from incandescent.camera import Camera, default_camera
from incandescent.imaging import DisplaySettings, to_display
from incandescent.io.output import save_image, write_json
from incandescent.io.volumes import load_grids
from incandescent.render import HDRImage, RenderSettings, render
from incandescent.volume import Remap, Volume

__all__ = [
    "Camera",
    "DisplaySettings",
    "HDRImage",
    "Remap",
    "RenderSettings",
    "Volume",
    "camera_from",
    "load_volume",
    "render",
    "save_image",
    "to_display",
    "write_json",
]


def load_volume(
    path: str | Path,
    temperature_grid: str = "temperature",
    absorption: float | None = None,
    voxel_size_m: float | None = None,
    remap: Remap | None = None,
) -> Volume:
    """Read a ``.npy``/``.npz`` file into a validated Volume; a constant ``absorption`` overrides
    the file's absorption grid."""
    grids = load_grids(path, temperature_grid)
    kappa = absorption if absorption is not None else grids.absorption
    return Volume.from_arrays(
        grids.temperature,
        kappa,
        grids.emission_scale,
        voxel_size_m,
        remap=remap,
        source=str(grids.path),
        sodium_fraction=grids.sodium_fraction,
    )


def camera_from(
    volume: Volume, eye=None, target=None, fov_deg: float = 40.0, frame_content: bool = True
) -> Camera:
    """The default three-quarter camera — framing the gas, or the whole box when
    ``frame_content`` is false (animations) — with any of eye/target/fov overridden."""
    bounds = volume.content_bounds_m if frame_content else volume.bounds_m
    camera = default_camera(bounds, fov_deg=fov_deg)
    changes = {k: v for k, v in (("eye", eye), ("target", target)) if v is not None}
    return camera.replace(**changes) if changes else camera
