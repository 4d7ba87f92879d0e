"""NanoVDB ``.nvdb`` through tinyvdb. tinyvdb's NanoVDBFile sees the first grid of a file only,
so each file segment (16-byte header, per-grid metadata + name, grid data) is found here and
handed to it as a file of its own. Its voxel access can crash the process on corrupt files, so
reads run in a worker process (:func:`run_isolated`)."""

from __future__ import annotations

import importlib
import os
import struct
import tempfile
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from incandescent.io.vdb.checks import LIBRARY_ERRORS, check_values, library_error, pick
from incandescent.io.vdb.results import DenseGrid, GridInfo, floats, ints, matrix
from incandescent.io.vdb.tinyvdb import library
from incandescent.io.vdb.transform import Box, common_transform, placement, union_box

_NANO_MAGICS = (0x304244566F6E614E, 0x314244566F6E614E)  # "NanoVDB0", "NanoVDB1"
_NANO_HEADER = struct.Struct("<QIHH")  # magic, version, grid count, codec
_NANO_META = struct.Struct("<QQQQII")  # grid size, file size, name key, voxel count, type, class
_NANO_META_SIZE = 176
_NANO_NAME_SIZE_AT = 136

T = TypeVar("T")


@dataclass(frozen=True)
class _NanoSegment:
    """Bytes [start, end) of the file: one grid, named ``name``."""

    start: int
    end: int
    name: str


def list_grids(path: Path) -> list[GridInfo]:
    """Every grid of the file (no value ranges: tinyvdb gives none for NanoVDB)."""
    return [_info(path, segment) for segment in _segments(path)]


def read_grids(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    """:func:`_read` in a separate process. tinyvdb 0.9's NanoVDB voxel access can crash the
    process (segmentation fault) on corrupt files — fuzzing found it — so the read runs where a
    crash becomes a clear ValueError instead of killing the caller. The worker is reused; a crash
    discards it and the next read starts a new one."""
    return run_isolated(path, _read, path, names, max_voxels)


#: One worker process for NanoVDB reads, started on first use and reused (see above).
_NANO_WORKER: ProcessPoolExecutor | None = None


def run_isolated(path: Path, function: Callable[..., T], *args: Any) -> T:
    """``function(*args)`` in the reusable worker process; a crash there is a ValueError."""
    global _NANO_WORKER
    if _NANO_WORKER is None:
        _NANO_WORKER = ProcessPoolExecutor(max_workers=1, mp_context=get_context("spawn"))
    try:
        return _NANO_WORKER.submit(function, *args).result()
    except BrokenProcessPool:
        _NANO_WORKER = None
        raise ValueError(
            f"{path}: the NanoVDB reader (tinyvdb) crashed on this file: it is corrupt or uses a "
            "layout tinyvdb cannot read"
        ) from None


def _segments(path: Path) -> list[_NanoSegment]:
    try:
        data = path.read_bytes()
    except OSError as error:
        raise library_error(path, "cannot read the file", error) from None
    segments, offset = [], 0
    while offset < len(data):
        segments.append(_segment(path, data, offset))
        offset = segments[-1].end
    if not segments:
        raise ValueError(f"{path}: empty file; not a NanoVDB file")
    return segments


def _segment(path: Path, data: bytes, start: int) -> _NanoSegment:
    """The segment that starts at byte ``start``, its header checked."""
    try:
        magic, _version, count, _codec = _NANO_HEADER.unpack_from(data, start)
        if magic not in _NANO_MAGICS:
            raise ValueError("no NanoVDB magic number")
        if count != 1:
            raise ValueError(f"a segment with {count} grids (tinyvdb reads one grid per segment)")
        meta = start + _NANO_HEADER.size
        file_size = _NANO_META.unpack_from(data, meta)[1]
        (name_size,) = struct.unpack_from("<I", data, meta + _NANO_NAME_SIZE_AT)
        name_at = meta + _NANO_META_SIZE
        name = data[name_at : name_at + name_size].split(b"\0", 1)[0].decode("utf-8")
        end = name_at + name_size + file_size
        if name_size == 0 or end > len(data):
            raise ValueError("truncated")
    except (struct.error, ValueError, UnicodeDecodeError) as error:
        raise library_error(path, f"not a readable NanoVDB file at byte {start}", error) from None
    return _NanoSegment(start, end, name)


@contextmanager
def _open(path: Path, segment: _NanoSegment) -> Iterator[Any]:
    """tinyvdb's NanoVDBFile on the segment alone, written to a temporary file."""
    library()
    nanovdb = importlib.import_module("tinyvdb._tinyvdb_nanovdb")  # not re-exported by tinyvdb

    data = path.read_bytes()[segment.start : segment.end]
    handle, name = None, None
    try:
        with tempfile.NamedTemporaryFile(suffix=".nvdb", delete=False) as temporary:
            temporary.write(data)
            name = temporary.name
        handle = nanovdb.NanoVDBFile(name)
        yield handle
    except LIBRARY_ERRORS as error:
        raise library_error(path, f"cannot read NanoVDB grid {segment.name!r}", error) from None
    finally:
        if handle is not None:
            handle.close()
        if name is not None:
            os.unlink(name)


def _info(path: Path, segment: _NanoSegment) -> GridInfo:
    """The segment's grid as tinyvdb describes it (placed by voxel size and world box)."""
    with _open(path, segment) as handle:
        type_name = str(handle.grid_type(0))
        voxel = floats(handle.voxel_size(0, axis) for axis in range(3))
        lo, hi = (ints(corner) for corner in handle.bbox(0))
        world = np.asarray(handle.world_bbox(0), dtype=np.float64)
        count = int(handle.active_voxel_count(0))
        grid_class = str(handle.grid_class(0))
    offset = world[0] - np.asarray(lo) * np.asarray(voxel)
    array = np.eye(4)
    array[:3, :3] = np.diag(voxel)
    array[:3, 3] = offset
    problem = _problem(type_name, count, lo, hi, voxel, world)
    return GridInfo.of(
        segment.name,
        type_name,
        (None if problem else matrix(array), voxel, floats(offset)),
        value_type="float" if type_name == "Float" else type_name,
        grid_class=grid_class,
        active_voxels=count,
        box=(None, None) if count == 0 else (lo, hi),
        unreadable=problem,
    )


def _problem(
    type_name: str, count: int, lo: tuple, hi: tuple, voxel: tuple, world: NDArray
) -> str | None:
    """Why tinyvdb cannot read this NanoVDB grid correctly, or None.

    tinyvdb exposes no map matrix for NanoVDB; a rotated map shows as a world box that is not the
    index box times the voxel size.
    """
    if type_name != "Float":
        return (
            f"holds {type_name} values; only NanoVDB Float grids can be read (tinyvdb 0.9 "
            "reads quantised Fp4/Fp8/Fp16/FpN grids as zeros)"
        )
    extent = (np.asarray(hi) - np.asarray(lo) + 1) * np.asarray(voxel)
    if count and not np.allclose(world[1] - world[0], extent, rtol=1e-5, atol=0.0):
        return (
            f"has a rotated or sheared index→world map (world box {world.tolist()} is not its "
            f"index box times voxel size {voxel}); the renderer needs axis-aligned cubic voxels"
        )
    return None


def _read(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    """Grids ``names`` densified onto the union of their active boxes (run in the worker)."""
    segments = {segment.name: segment for segment in _segments(path)}
    chosen = {name: pick(path, segments, name) for name in names}
    infos = {name: _info(path, segment) for name, segment in chosen.items()}
    for info in infos.values():
        if info.unreadable:
            raise ValueError(f"{path}: NanoVDB grid {info.name!r} {info.unreadable}")
    box = union_box(path, infos, max_voxels)
    voxel, offset = common_transform(path, infos)
    return {name: _densify(path, chosen[name], infos[name], box, voxel, offset) for name in names}


def _densify(
    path: Path, segment: _NanoSegment, info: GridInfo, box: Box, voxel: float, offset: NDArray
) -> DenseGrid:
    """The segment's grid on the inclusive ``box``, voxel by voxel (about 0.25 µs each)."""
    lo, hi = box
    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    values = np.empty(shape, dtype=np.float32)
    with _open(path, segment) as handle:
        get = handle.get
        for a, i in enumerate(range(int(lo[0]), int(hi[0]) + 1)):
            for b, j in enumerate(range(int(lo[1]), int(hi[1]) + 1)):
                values[a, b, :] = [get(0, i, j, k) for k in range(int(lo[2]), int(hi[2]) + 1)]
        background = float(get(0, *(int(v) - 1_000_000 for v in lo)))  # far outside any data
    check_values(path, info.name, values)
    index_min, origin, source = placement(path, info, box, voxel, offset)
    return DenseGrid(info.name, values, origin, voxel, background, index_min, source)
