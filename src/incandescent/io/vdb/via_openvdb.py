"""``.vdb`` through OpenVDB itself, where installed: the worker of :mod:`incandescent.io.openvdb`
describes, densifies (tiles expanded) and cuts grids into 8³ leaves; the file's header is
checked here first (:mod:`.header`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from incandescent.io import openvdb
from incandescent.io.vdb.checks import check_values, pick
from incandescent.io.vdb.header import check_vdb_file
from incandescent.io.vdb.results import DenseGrid, GridInfo, LeafGrids, floats, ints, matrix
from incandescent.io.vdb.transform import common_transform, placement, transform_problem, union_box


def reads(path: Path) -> bool:
    """Whether OpenVDB itself reads ``path``: a ``.vdb`` where OpenVDB is installed."""
    return path.suffix.lower() == ".vdb" and openvdb.interpreter() is not None


def list_grids(path: Path, ranges: bool) -> list[GridInfo]:
    """Every grid of the file; without ``ranges`` no value ranges (what a read needs)."""
    check_vdb_file(path)
    return [_info(grid) for grid in openvdb.describe(path, ranges=ranges)]


def grids_with_sums(path: Path) -> tuple[list[GridInfo], dict[str, float]]:
    """Every grid of the file, and the sum of each readable float grid's active values (tiles
    once per voxel they cover), from ONE description by the worker."""
    check_vdb_file(path)
    described = openvdb.describe(path, sums=True)
    sums = {g["name"]: g["sum"] for g in described if "sum" in g}
    return [_info(grid) for grid in described], sums


def readable(path: Path, names: list[str]) -> dict[str, GridInfo]:
    """The grids ``names`` of a ``.vdb`` OpenVDB can read, or an error naming the first not."""
    if not reads(path):
        raise ValueError(f"{path}: reading leaves needs a .vdb file and OpenVDB (python3-openvdb)")
    infos = {info.name: info for info in list_grids(path, ranges=False)}
    chosen = {name: pick(path, infos, name) for name in names}
    for name, info in chosen.items():
        if info.unreadable:
            raise ValueError(f"{path}: grid {name!r} {info.unreadable}")
    return chosen


def read_grids(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    """Grids densified onto the union of their active boxes by OpenVDB (tiles expanded)."""
    chosen = readable(path, names)
    box = union_box(path, chosen, max_voxels)
    voxel, translation = common_transform(path, chosen)
    arrays = openvdb.dense(path, names, *box)
    out = {}
    for name, info in chosen.items():
        check_values(path, name, arrays[name])
        index_min, origin, source = placement(path, info, box, voxel, translation)
        background = float(info.background or 0.0)
        out[name] = DenseGrid(name, arrays[name], origin, voxel, background, index_min, source)
    return out


def read_leaves(path: Path, names: list[str], z_up: bool, rings: int) -> LeafGrids:
    """Grids as the occupied 8³ leaves of the union of their active boxes and ``rings`` more
    rings of leaves around them, never densified."""
    chosen = readable(path, names)
    box = union_box(path, chosen, max_voxels=np.iinfo(np.int64).max)
    voxel, translation = common_transform(path, chosen)
    coords, arrays, shape = openvdb.leaves(path, names, *box, z_up, rings)
    for name, values in arrays.items():
        check_values(path, name, values)
    _, origin, _ = placement(path, chosen[names[0]], box, voxel, translation)
    backgrounds = {name: float(info.background or 0.0) for name, info in chosen.items()}
    return LeafGrids(coords, arrays, shape, origin, voxel, backgrounds)  # type: ignore[arg-type]


def extent(path: Path, names: list[str]) -> tuple[int, int]:
    """(voxels of the union of the grids' active boxes, their most active voxels)."""
    chosen = readable(path, names)
    lo, hi = union_box(path, chosen, max_voxels=np.iinfo(np.int64).max)
    box = int(np.prod(hi - lo + 1))
    return box, max(int(info.active_voxels or 0) for info in chosen.values())


def _info(grid: dict) -> GridInfo:
    """A :class:`GridInfo` from the worker's description of one grid."""
    meta = {k: tuple(v) if isinstance(v, list) else v for k, v in grid["metadata"].items()}
    index_to_world = matrix(np.asarray(grid["matrix"])) if "matrix" in grid else None
    voxel = floats(grid.get("voxel_size", (0.0, 0.0, 0.0)))
    translation = (
        floats(row[3] for row in index_to_world[:3]) if index_to_world else (0.0, 0.0, 0.0)
    )
    transform = (index_to_world, voxel, translation)
    name, type_name = str(grid["name"]), str(grid["type"])
    problem = grid.get("unreadable")
    if problem is None and grid["type"] == "bool":
        problem = "holds bool values (a mask), not a field the renderer reads"
    if problem is not None:
        return GridInfo.unread(problem, name, type_name, transform, meta)
    background = grid.get("background")
    return GridInfo.of(
        name,
        type_name,
        transform,
        metadata=meta,
        active_voxels=int(grid["active_voxels"]),
        box=(_index(grid, "index_min"), _index(grid, "index_max")),
        value_range=(grid.get("min"), grid.get("max")),
        background=background if isinstance(background, float) else None,
        unreadable=transform_problem(index_to_world, voxel),
    )


def _index(grid: dict, key: str) -> tuple[int, int, int] | None:
    return ints(grid[key]) if key in grid else None
