"""``.vdb`` through the ``tinyvdb`` library, where OpenVDB itself is not installed: the file's
header checked first (:mod:`.header`), grids described from their leaf voxels, float grids
densified onto one box. Active tiles (constant regions above the leaf level) are not read by
tinyvdb 0.9, so a grid whose recorded voxel count disagrees with its leaves is refused."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.io import openvdb
from incandescent.io.vdb.checks import (
    LIBRARY_ERRORS,
    check_values,
    library_error,
    pick,
    value_range,
)
from incandescent.io.vdb.header import vdb_bytes
from incandescent.io.vdb.results import DenseGrid, GridInfo, Transform, floats, ints, matrix
from incandescent.io.vdb.transform import (
    Box,
    common_transform,
    placement,
    transform_problem,
    union_box,
)

_SCALE_MAPS = (
    "uniform_scale",
    "uniform_scale_translate",
    "scale",
    "scale_translate",
    "translation",
)


def library() -> Any:
    """The ``tinyvdb`` module (an ImportError saying how to install it where it is missing)."""
    try:
        import tinyvdb
    except ImportError as error:  # pragma: no cover - tinyvdb is a dependency
        raise ImportError(
            "reading .vdb/.nvdb needs the 'tinyvdb' package: pip install tinyvdb"
        ) from error
    return tinyvdb


def list_grids(path: Path) -> list[GridInfo]:
    """Every grid of the file, value ranges included (from its leaf voxels)."""
    with _open(path) as handle:
        return [_info(path, grid) for grid in _grids(path, handle)]


def read_grids(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    """Float grids ``names`` densified onto the union of their active boxes (at most
    ``max_voxels`` voxels), each filled with its background outside its leaves."""
    with _open(path) as handle:
        grids = {g.name: g for g in _grids(path, handle)}
        chosen = {name: pick(path, grids, name) for name in names}
        infos = {name: _info(path, grid, need_float=True) for name, grid in chosen.items()}
        box = union_box(path, infos, max_voxels)
        voxel, translation = common_transform(path, infos)
        return {
            name: _densify(path, chosen[name], infos[name], box, voxel, translation)
            for name in names
        }


@contextmanager
def _open(path: Path) -> Iterator[Any]:
    """tinyvdb's handle on the file (header checked first), its grids read."""
    tinyvdb = library()
    data = vdb_bytes(path)
    try:
        handle = tinyvdb.from_bytes(data)
        handle.read_grids()
    except LIBRARY_ERRORS as error:
        raise library_error(
            path, "not a readable OpenVDB file, truncated or corrupt", error
        ) from None
    try:
        yield handle
    finally:
        handle.close()


def _grids(path: Path, handle: Any) -> list[Any]:
    try:
        grids = [handle.grid(i) for i in range(int(handle.grid_count))]
        names = [str(grid.name) for grid in grids]
    except LIBRARY_ERRORS as error:
        raise library_error(path, "cannot read the grid list", error) from None
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: grid names repeat ({names}); cannot tell the grids apart")
    return grids


def _value_type(type_name: str) -> str:
    """``Tree_float_5_4_3`` → ``float``; anything unrecognised is returned whole."""
    parts = type_name.split("_")
    if len(parts) >= 2 and parts[0] == "Tree":
        return "_".join(p for p in parts[1:] if not p.isdigit())
    return type_name


def _transform(transform: dict) -> Transform:
    """(index→world matrix or None, voxel size m, translation m) of tinyvdb's map record."""
    kind = str(transform.get("type", ""))
    if kind in _SCALE_MAPS:
        scale = np.asarray(transform.get("scale", (1.0, 1.0, 1.0)), dtype=np.float64)
        if kind == "translation":
            scale = np.ones(3)
        offset = np.asarray(transform.get("translation", (0.0, 0.0, 0.0)), dtype=np.float64)
        array = np.eye(4)
        array[:3, :3] = np.diag(scale)
        array[:3, 3] = offset
    elif kind == "affine":
        array = np.asarray(transform["matrix"], dtype=np.float64).T  # OpenVDB: row vectors
        scale = np.linalg.norm(array[:3, :3], axis=0)
        offset = array[:3, 3]
    else:  # unitary, frustum and unknown maps: not linear scale/affine as far as we can read
        scale = np.asarray(transform.get("voxel_size", (0.0, 0.0, 0.0)), dtype=np.float64)
        return None, floats(scale), (0.0, 0.0, 0.0)
    return matrix(array), floats(scale), floats(offset)


#: What a grid's header says: (name, type name, metadata, transform).
_Header = tuple[str, str, dict, Transform]


def _header(path: Path, grid: Any) -> _Header:
    """(name, type name, metadata, transform) of a grid."""
    try:
        name, type_name = str(grid.name), str(grid.type_name)
        metadata = dict(grid.metadata)
        transform = _transform(dict(grid.transform))
    except (*LIBRARY_ERRORS, KeyError) as error:
        raise library_error(path, "cannot read a grid's header", error) from None
    return name, type_name, metadata, transform


def _info(path: Path, grid: Any, need_float: bool = False) -> GridInfo:
    """Describe a grid; with ``need_float`` raise when it cannot be densified."""
    header = _header(path, grid)
    name, type_name, metadata, transform = header
    value_type = _value_type(type_name)
    if value_type != "float":
        problem = f"holds {value_type} values; only float grids can be read"
        info = GridInfo.unread(problem, name, type_name, transform, metadata, value_type)
    else:
        info = _float_info(path, grid, header)
    if need_float and info.unreadable:
        raise ValueError(f"{path}: grid {name!r} {info.unreadable}")
    return info


def _float_info(path: Path, grid: Any, header: _Header) -> GridInfo:
    """A float grid described from its leaf voxels."""
    name, type_name, metadata, transform = header
    coords, values, background = _sparse(path, grid, name)
    tiles = _tile_problem(metadata, len(values))
    if tiles:
        return GridInfo.unread(tiles, name, type_name, transform, metadata, "float")
    box = (ints(coords.min(axis=0)), ints(coords.max(axis=0))) if len(coords) else (None, None)
    return GridInfo.of(
        name,
        type_name,
        transform,
        value_type="float",
        metadata=metadata,
        active_voxels=len(values),
        box=box,
        value_range=value_range(values),
        background=background,
        unreadable=transform_problem(transform[0], transform[1]),
    )


def _sparse(path: Path, grid: Any, name: str) -> tuple[NDArray, NDArray, float]:
    """(leaf voxel indices (n, 3), their values (n,), background) of a float grid."""
    try:
        sparse = grid.to_sparse()
        coords = np.frombuffer(sparse["coords"], dtype=np.int32).reshape(-1, 3)
        values = np.frombuffer(sparse["values"], dtype=np.float32)
        background = float(grid.float_background())
    except (*LIBRARY_ERRORS, KeyError) as error:
        raise library_error(path, f"cannot read the voxels of grid {name!r}", error) from None
    if len(coords) != len(values):
        raise ValueError(
            f"{path}: grid {name!r}: {len(coords)} coordinates for {len(values)} values"
        )
    return coords, values, background


def _tile_problem(metadata: dict, seen: int) -> str | None:
    """Why a grid whose recorded voxel count is not the ``seen`` leaf voxels cannot be read."""
    recorded = metadata.get("file_voxel_count")
    if isinstance(recorded, int) and not isinstance(recorded, bool) and recorded != seen:
        return (
            f"has {recorded} active voxels but only {seen} are stored in leaf nodes; the rest "
            "are active tiles, which tinyvdb 0.9 (used because OpenVDB is not installed) reads "
            f"as background; {openvdb.INSTALL_HINT}"
        )
    return None


def _densify(
    path: Path, grid: Any, info: GridInfo, box: Box, voxel: float, offset: NDArray
) -> DenseGrid:
    """Grid ``info.name`` on the inclusive ``box``; ``voxel`` (m) and ``offset`` (the
    translation, m) place it."""
    lo, hi = box
    background = float(info.background or 0.0)
    try:
        dense = grid.materialize_dense(
            tuple(int(v) for v in lo), tuple(int(v) + 1 for v in hi), background
        )
        shape = tuple(int(n) for n in dense.shape)
        flat = np.frombuffer(dense, dtype=np.float32)
    except LIBRARY_ERRORS as error:
        raise library_error(path, f"cannot densify grid {info.name!r}", error) from None
    expected = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    if shape != expected or flat.size != int(np.prod(expected)):
        raise ValueError(f"{path}: grid {info.name!r} densified to {shape}; expected {expected}")
    values = flat.reshape(expected, order="F").copy()  # tinyvdb stores x fastest
    check_values(path, info.name, values)
    index_min, origin, source = placement(path, info, box, voxel, offset)
    return DenseGrid(info.name, values, origin, voxel, background, index_min, source)
