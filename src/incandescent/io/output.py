"""Saving an HDRImage: EXR (linear, unclipped, metadata, alpha) or PNG (display pipeline)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from incandescent.imaging import DisplaySettings
from incandescent.imaging.pipeline import display_pixels
from incandescent.io.atomic import check_output
from incandescent.io.formats import IMAGE_SUFFIXES as _IMAGE_SUFFIXES
from incandescent.io.images import atomic_write, write_exr, write_png
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
        return write_exr(path, image.rgb(), meta, overwrite=overwrite, extra_channels=extra)
    if suffix == ".png":
        return write_png(
            path, display_pixels(image, display), overwrite=overwrite, metadata=_metadata(image)
        )
    raise ValueError(f"{path}: unsupported image format {path.suffix!r}; expected .exr or .png")


def write_json(path: str | Path, data: dict, overwrite: bool = False) -> Path:
    """Write ``data`` as JSON atomically."""
    text = json.dumps(data, indent=2, sort_keys=True, default=_jsonable)
    return write_text(path, text + "\n", overwrite=overwrite)


def write_text(path: str | Path, text: str, overwrite: bool = False) -> Path:
    """Write UTF-8 ``text`` atomically (temp file + rename), "\\n" line ends."""

    def write(tmp: Path) -> None:
        with open(tmp, "x", encoding="utf-8", newline="\n") as handle:
            handle.write(text)

    return atomic_write(Path(path), write, overwrite=overwrite)


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


#: Suffixes :func:`save_volume` writes.
VOLUME_OUTPUT_SUFFIXES = (".npz", ".vdb")


def volume_grids(volume) -> dict[str, np.ndarray]:
    """A Volume's grids by their file names (temperature in K, absorption in 1/m, …)."""
    grids = {"temperature": volume.temperature_K, "absorption": volume.absorption_per_m}
    if volume.emission_scale is not None:
        grids["emission_scale"] = volume.emission_scale
    if volume.sodium_fraction is not None:
        grids["sodium_fraction"] = volume.sodium_fraction
    grids.update(volume.species)
    if volume.velocity_m_s is not None:
        grids["velocity"] = volume.velocity_m_s
    return grids


_UNITS = {"temperature": "kelvin", "absorption": "1/m", "velocity": "m/s"}


def _check_vdb(tmp: Path, grids: dict[str, np.ndarray]) -> None:
    """OpenVDB reads ``tmp`` back with every grid written and each grid's active voxel count
    (OpenVDB does not report a write cut short by a full disk: the file must prove itself before
    it replaces anything)."""
    from incandescent.io import openvdb

    try:
        described = openvdb.describe(tmp, ranges=False, max_bytes=_read_back_bytes(grids))
        found = {g["name"]: g.get("active_voxels") for g in described}
    except ValueError as error:
        raise ValueError(str(error).removeprefix(f"{tmp}: ")) from None
    if set(found) != set(grids):
        raise ValueError(f"it holds grids {sorted(found)}, not the {sorted(grids)} written")
    for name, values in grids.items():
        if found[name] != _active_voxels(values):
            raise ValueError(
                f"grid {name!r} holds {found[name]} active voxels, not the "
                f"{_active_voxels(values)} written"
            )


def _read_back_bytes(grids: dict[str, np.ndarray]) -> int:
    """What reading back a file of ``grids`` may allocate: twice their float32 size and 64 MiB
    (a truncated file can make OpenVDB allocate without bound: it then fails fast instead)."""
    return 2 * sum(np.asarray(g).size * 4 for g in grids.values()) + 64 * 2**20


def _active_voxels(values: np.ndarray) -> int:
    """Voxels the OpenVDB writer makes active: those that differ from the background 0 (a vector
    grid's: any component)."""
    different = np.asarray(values, dtype=np.float32) != 0
    return int(np.count_nonzero(different.any(axis=-1) if different.ndim == 4 else different))


def save_volume(volume, path: str | Path, overwrite: bool = False) -> Path:
    """Write ``volume`` to ``.npz`` (dense, with ``voxel_size_m`` and ``origin_m``) or ``.vdb``
    (sparse: zeros inactive, pruned, written by OpenVDB so Blender and Houdini load it; a
    ``unit`` in each grid's metadata). Atomic; refuses to overwrite unless asked. Axes are the
    renderer's: x, y, z with +y up."""
    path = check_output(path, overwrite, VOLUME_OUTPUT_SUFFIXES, "volume")
    grids = volume_grids(volume)
    if path.suffix.lower() == ".vdb":
        from incandescent.io import openvdb

        meta = {
            name: {"unit": _UNITS.get(name, "fraction"), "written_by": "incandescent", "up": "y"}
            for name in grids
        }

        problem = openvdb.problem()
        if problem is not None:
            raise ValueError(f"cannot write {path}: {problem}")

        def write_vdb(tmp: Path) -> None:
            openvdb.write(tmp, grids, volume.voxel_size_m, volume.origin_m, meta)

        def read_back(tmp: Path) -> None:
            _check_vdb(tmp, grids)

        return atomic_write(path, write_vdb, overwrite=overwrite, verify=read_back)

    def write_npz(tmp: Path) -> None:
        with open(tmp, "xb") as handle:
            placement = {
                "voxel_size_m": np.float64(volume.voxel_size_m),
                "origin_m": np.asarray(volume.origin_m, dtype=np.float64),
            }
            np.savez_compressed(handle, **placement, **grids)  # type: ignore[arg-type]

    return atomic_write(path, write_npz, overwrite=overwrite)
