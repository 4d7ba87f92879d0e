"""Writers that are formats only: a Volume as ``.npz`` or ``.vdb``, JSON and text, each atomic.

Saving a rendered image (a display pipeline, then a file) is :mod:`incandescent.output`'s."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from incandescent.io.atomic import check_output
from incandescent.io.images import atomic_write


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


def save_vdb_grids(
    grids: dict[str, np.ndarray],
    path: str | Path,
    voxel_size_m: float,
    origin_m,
    metadata: dict[str, dict[str, str]],
    overwrite: bool = False,
) -> Path:
    """Write ``grids`` (name → float32 (nx, ny, nz) or (nx, ny, nz, 3)) as a sparse ``.vdb``
    through OpenVDB: ``origin_m`` the corner of voxel (0, 0, 0), cubic voxels, ``metadata`` per
    grid. Atomic, read back by OpenVDB before it replaces anything; refuses to overwrite unless
    asked."""
    from incandescent.io import openvdb

    path = check_output(path, overwrite, (".vdb",), "volume")
    problem = openvdb.problem()
    if problem is not None:
        raise ValueError(f"cannot write {path}: {problem}")

    def write_vdb(tmp: Path) -> None:
        openvdb.write(tmp, grids, voxel_size_m, origin_m, metadata)

    def read_back(tmp: Path) -> None:
        _check_vdb(tmp, grids)

    return atomic_write(path, write_vdb, overwrite=overwrite, verify=read_back)


def save_volume(volume, path: str | Path, overwrite: bool = False) -> Path:
    """Write ``volume`` to ``.npz`` (dense, with ``voxel_size_m`` and ``origin_m``) or ``.vdb``
    (sparse: zeros inactive, pruned, written by OpenVDB so Blender and Houdini load it; a
    ``unit`` in each grid's metadata). Atomic; refuses to overwrite unless asked. Axes are the
    renderer's: x, y, z with +y up."""
    path = check_output(path, overwrite, VOLUME_OUTPUT_SUFFIXES, "volume")
    grids = volume_grids(volume)
    if path.suffix.lower() == ".vdb":
        meta = {
            name: {"unit": _UNITS.get(name, "fraction"), "written_by": "incandescent", "up": "y"}
            for name in grids
        }
        return save_vdb_grids(grids, path, volume.voxel_size_m, volume.origin_m, meta, overwrite)

    def write_npz(tmp: Path) -> None:
        with open(tmp, "xb") as handle:
            placement = {
                "voxel_size_m": np.float64(volume.voxel_size_m),
                "origin_m": np.asarray(volume.origin_m, dtype=np.float64),
            }
            np.savez_compressed(handle, **placement, **grids)  # type: ignore[arg-type]

    return atomic_write(path, write_npz, overwrite=overwrite)
