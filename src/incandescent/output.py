"""Saving an HDRImage: EXR (linear, unclipped, metadata, alpha) or PNG (display pipeline).

A product step above the renderer and the display pipeline (``imaging``); the file formats
themselves are in ``io.images``.
"""

from __future__ import annotations

from pathlib import Path

from incandescent.imaging import DisplaySettings
from incandescent.imaging.pipeline import display_pixels
from incandescent.io.formats import IMAGE_SUFFIXES as _IMAGE_SUFFIXES
from incandescent.io.images import write_exr, write_png
from incandescent.renderer.film import HDRImage

IMAGE_SUFFIXES = _IMAGE_SUFFIXES
#: What the RGB of a display-referred image (the 2011 paper's) is.
DISPLAY_UNITS = "display-referred sRGB code values 0..255 (the 2011 paper's sums), not radiometric"


def _metadata(image: HDRImage, extra: dict | None = None) -> dict[str, str]:
    meta = {k: str(v) for k, v in image.metadata.items()}
    meta.update({"units": "XYZ Y in cd/m^2; RGB linear, absolute", "colour_space": image.space})
    if image.display_rgb is not None:
        meta.update({"units": DISPLAY_UNITS, "colour_space": "srgb (display-encoded)"})
    meta.update({k: str(v) for k, v in (extra or {}).items()})
    return meta


def save_image(
    image: HDRImage,
    path: str | Path,
    display: DisplaySettings | None = None,
    overwrite: bool = False,
) -> Path:
    """Write ``image`` to ``path`` by suffix; never renders again; atomic; refuses to overwrite."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".exr" and image.display_rgb is not None:
        meta = _metadata(image, {"units": DISPLAY_UNITS, "exposure": "none (display-referred)"})
        return write_exr(path, image.display_rgb, meta, overwrite, {"A": image.alpha})
    if suffix == ".exr":
        meta = _metadata(image, {"exposure": "none (scene-referred)"})
        extra = {"A": image.alpha}
        if image.depth_m is not None:
            extra["Z"] = image.depth_m
            meta["Z"] = "distance in m from the camera to the first emitting sample (inf: none)"
        for name in image.layers:  # EXR layers "emission.R" … (renderer.layers)
            rgb = image.layer_rgb(name)
            extra.update({f"{name}.{c}": rgb[..., i] for i, c in enumerate("RGB")})
        if image.layers:  # for compositing: what shows through the gas (A = 1 − it)
            extra["transmittance.Y"] = image.transmittance
            meta["transmittance"] = "transmittance.Y: e^(-optical depth) along each pixel's rays"
        return write_exr(path, image.rgb(), meta, overwrite=overwrite, extra_channels=extra)
    if suffix == ".png":
        return write_png(
            path, display_pixels(image, display), overwrite=overwrite, metadata=_metadata(image)
        )
    raise ValueError(f"{path}: unsupported image format {path.suffix!r}; expected .exr or .png")
