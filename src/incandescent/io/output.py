"""Saving an HDRImage: EXR (linear, unclipped, metadata, alpha) or PNG (display pipeline)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from incandescent.imaging import DisplaySettings, to_display
from incandescent.io.images import atomic_write, write_exr, write_png
from incandescent.render.film import HDRImage

IMAGE_SUFFIXES = (".exr", ".png")


def _metadata(image: HDRImage, extra: dict | None = None) -> dict[str, str]:
    meta = {k: str(v) for k, v in image.metadata.items()}
    meta.update({"units": "XYZ Y in cd/m^2; RGB linear, absolute", "colour_space": image.space})
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
    if suffix == ".exr":
        meta = _metadata(image, {"exposure": "none (scene-referred)"})
        return write_exr(
            path, image.rgb(), meta, overwrite=overwrite, extra_channels={"A": image.alpha}
        )
    if suffix == ".png":
        display = display or DisplaySettings(space=image.space)
        pixels = to_display(image.xyz, display, hottest_K=image.metadata.get("max_temperature_K"))
        return write_png(path, pixels, overwrite=overwrite, metadata=_metadata(image))
    raise ValueError(f"{path}: unsupported image format {path.suffix!r}; expected .exr or .png")


def write_json(path: str | Path, data: dict, overwrite: bool = False) -> Path:
    """Write ``data`` as JSON atomically."""
    text = json.dumps(data, indent=2, sort_keys=True, default=_jsonable)

    def write(tmp: Path) -> None:
        tmp.write_text(text + "\n")

    return atomic_write(Path(path), write, overwrite=overwrite)


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    return str(value)
