"""Reading OpenVDB ``.vdb`` and NanoVDB ``.nvdb`` grids into dense arrays, through ``tinyvdb``.

Library choice
--------------
``tinyvdb`` (PyPI, Apache-2.0, https://github.com/syoyo/tinyvdb; 0.9.0 used here) is a C library
with a stable-ABI Python extension: one wheel per platform (Linux x86_64/aarch64, macOS, Windows)
for CPython ≥ 3.11, no system OpenVDB, Boost, TBB or Blosc (it bundles miniz, LZ4 and zstd). Its
README claims OpenVDB file versions 220–225 (OpenVDB 3.x to 10.x+) and NanoVDB. It is young and
has one maintainer (first PyPI release 2026-04-11, 0.9.0 on 2026-04-26), so pin ``tinyvdb ~= 0.9.0``
and keep the tests below as the contract; it is tested upstream against libopenvdb. Checked here
against libopenvdb 10.0 (Debian's ``python3-openvdb``): Blender 3.4 Mantaflow caches (BLOSC and
half float; also NONE and ZIP/32-bit bakes) and files written by OpenVDB's own writer read back
with the same grid names, transforms and active boxes and bit-identical dense values
(``tests/test_vdb.py``).
Alternatives looked at: OpenVDB's own Python binding has no maintained PyPI release (``pyopenvdb``
on PyPI is a third-party cp37-only build, versions 0.1.0–0.1.4, all uploaded in March 2020; there is
no ``openvdb`` package on PyPI) — it needs a source or distribution build of libopenvdb with Boost
and TBB (Debian's ``python3-openvdb`` serves the system Python only; used here only to make and
cross-check the reference test files). tinyvdb is the maintained, pip-installable reader that covers
what users bring (Blender, OpenVDB-written BLOSC/ZIP and half-float files).

What tinyvdb 0.9.0 does *not* do (each is an error here, never a silent wrong answer):

- **active tiles** (constant regions stored above the leaf level, common in pruned Houdini and
  EmberGen grids) read as background. Detected with the ``file_voxel_count`` metadata OpenVDB
  writes: a mismatch with the voxels tinyvdb sees raises ``ValueError``.
- non-``float`` OpenVDB grids (``double``, ``int``, ``bool``, ``vec3s`` …) cannot be densified.
- NanoVDB: only ``Float`` grids (quantised ``Fp4/Fp8/Fp16/FpN`` read as zeros), no BLOSC-coded
  ``.nvdb`` ("Failed to decompress grid data"), only the first grid of a file (the other grids of a
  multi-grid file are reached here by handing each file segment to tinyvdb on its own), per-voxel
  access only (about 0.25 µs per voxel), and no index→world map beyond voxel size and world box
  (a rotated map is detected from the box and rejected).
- corrupt counts: tinyvdb allocates for counts read from the file before checking them (a corrupt
  grid count made it commit 3.6 GB and take 6 s before failing). The file header's counts are
  checked here first; counts inside grids are left to tinyvdb (its allocation failures surface as
  ``ValueError``; 6000 fuzzed files raised nothing else).
- writing: tinyvdb 0.9 writes a grid only into a template file (``replace_grid_from_sparse``), not
  half float; the tests write through that path.

Conventions
-----------
The dense array's axes are VDB's index axes: ``values[a, b, c]`` is the VDB voxel
``(i, j, k) = index_min + (a, b, c)`` — i.e. ``a[i, j, k]`` is x=i, y=j, z=k as in the renderer
(DESIGN.md §4). No axis is swapped: VDB world space is whatever the exporting program used
(Blender caches are z-up, Houdini's y-up; for Blender point the camera's ``up`` at +z).
OpenVDB places voxel *centres* at integer index coordinates, so the world position of the corner of
the dense box is ``translation + (index_min − 0.5) · voxel_size``. The Blender 3.4 Mantaflow cache
tested stores voxel size only (no translation): the domain object's placement is not in the file.
"""

from __future__ import annotations

import importlib
import os
import struct
import tempfile
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.io import openvdb
from incandescent.io.formats import VDB_SUFFIXES

SUFFIXES = VDB_SUFFIXES
#: Default cap on the voxels of one dense box (512³ float32 = 512 MiB per grid).
MAX_DENSE_VOXELS = 512**3
#: Relative tolerance when comparing voxel sizes and translations.
TRANSFORM_RTOL = 1e-6
#: Exceptions the library raises on malformed input (VDBError is a RuntimeError).
_LIBRARY_ERRORS = (
    RuntimeError,
    OSError,
    ValueError,
    IndexError,
    TypeError,
    MemoryError,
    SystemError,
)
_SCALE_MAPS = (
    "uniform_scale",
    "uniform_scale_translate",
    "scale",
    "scale_translate",
    "translation",
)


@dataclass(frozen=True)
class GridInfo:
    """What a file says about one grid (no voxel data beyond value statistics).

    Attributes
    ----------
    name: grid name as stored.
    value_type: "float", "double", "int32", "bool", "vec3s", … (OpenVDB) or NanoVDB's type name.
    type_name: the library's raw type string (``Tree_float_5_4_3``, ``Float``).
    active_voxels: number of active voxels (None when the library cannot count them).
    index_min, index_max: inclusive index box of the active voxels (None when empty or unknown).
    index_to_world: 4×4 matrix, world = M @ (i, j, k, 1) (column vectors; None if not linear).
    voxel_size_m: voxel size along x, y, z (world units, taken as m).
    translation_m: world position of the centre of voxel (0, 0, 0).
    value_min, value_max: range of the active values (None for non-float grids).
    background: value outside the active voxels (None for non-float grids).
    half_float: stored as 16-bit floats (None when the file does not say).
    compression: the file's compression as recorded in the grid metadata (None when not recorded).
    grid_class: "fog volume", "level set", … (None when not recorded).
    unreadable: why :func:`read_grid` would refuse this grid (None when it can be read); counts
        and boxes then come from OpenVDB's ``file_*`` metadata where the file has it.
    """

    name: str
    value_type: str
    type_name: str
    active_voxels: int | None
    index_min: tuple[int, int, int] | None
    index_max: tuple[int, int, int] | None
    index_to_world: tuple[tuple[float, ...], ...] | None
    voxel_size_m: tuple[float, float, float]
    translation_m: tuple[float, float, float]
    value_min: float | None
    value_max: float | None
    background: float | None
    half_float: bool | None
    compression: str | None
    grid_class: str | None
    unreadable: str | None = None

    @property
    def is_float(self) -> bool:
        return self.value_type == "float"

    @property
    def shape(self) -> tuple[int, int, int] | None:
        """Dense shape of the active box (nx, ny, nz), or None when the grid is empty."""
        if self.index_min is None or self.index_max is None:
            return None
        return _ints(h - l + 1 for l, h in zip(self.index_min, self.index_max, strict=True))


@dataclass(frozen=True, eq=False)
class DenseGrid:
    """One grid densified over an index box.

    Attributes
    ----------
    name: grid name.
    values: (nx, ny, nz) float32; ``values[a, b, c]`` is VDB voxel ``index_min + (a, b, c)``.
    origin_m: world position of the corner of ``values[0, 0, 0]`` (its centre minus half a voxel).
    voxel_size_m: side of the (cubic) voxels.
    background: the grid's background value (filled in where the box has no stored voxel).
    index_min: VDB index of ``values[0, 0, 0]``.
    source: ``"path:name"`` for messages.
    """

    name: str
    values: NDArray[np.float32]
    origin_m: tuple[float, float, float]
    voxel_size_m: float
    background: float
    index_min: tuple[int, int, int]
    source: str


# --------------------------------------------------------------------------------------------
# public API


def list_grids(path: str | Path, ranges: bool = True) -> list[GridInfo]:
    """Describe every grid in a ``.vdb`` or ``.nvdb`` file (errors name the file and problem).

    ``.vdb`` files are read with OpenVDB itself where it is installed (:mod:`.openvdb`), else
    with tinyvdb. Without ``ranges`` OpenVDB leaves out the value ranges (a vector grid's range
    visits every value in Python): what a read needs."""
    path = _checked_path(path)
    if path.suffix.lower() == ".nvdb":
        return [_nano_info(path, segment) for segment in _nano_segments(path)]
    if openvdb.interpreter():
        _check_vdb_file(path)
        return [_openvdb_info(grid) for grid in openvdb.describe(path, ranges=ranges)]
    with _open_vdb(path) as handle:
        return [_vdb_info(path, grid) for grid in _vdb_grids(path, handle)]


def grid_sums(path: str | Path) -> dict[str, float]:
    """Sum of the active values (active tiles included, once per voxel they cover) of each float
    grid that can be read; OpenVDB computes it where installed, else tinyvdb's leaf voxels."""
    path = _checked_path(path)
    if path.suffix.lower() == ".vdb" and openvdb.interpreter():
        _check_vdb_file(path)
        return {g["name"]: g["sum"] for g in openvdb.describe(path, sums=True) if "sum" in g}
    out = {}
    for info in list_grids(path):
        if info.unreadable is None and info.is_float and info.active_voxels:
            grid = read_grid(path, info.name)
            inactive = grid.values.size - info.active_voxels  # box voxels filled by background
            box_sum = float(grid.values.sum(dtype=np.float64))
            out[info.name] = box_sum - inactive * grid.background
    return out


def read_grid(path: str | Path, name: str, max_voxels: int = MAX_DENSE_VOXELS) -> DenseGrid:
    """Read float grid ``name`` densified over its active box (see the module's conventions)."""
    return read_grids(path, [name], max_voxels)[name]


def read_grids(
    path: str | Path, names: Sequence[str], max_voxels: int = MAX_DENSE_VOXELS
) -> dict[str, DenseGrid]:
    """Read float grids densified onto ONE box, the union of their active boxes.

    All grids must share one uniform voxel size and translation, so the arrays line up voxel for
    voxel (same shape, same ``origin_m``). Each is filled with its own background outside its data.
    A box of more than ``max_voxels`` voxels is an error (a sparse grid spread over a huge box, or
    a corrupt file), not an attempt to allocate it.
    """
    path = _checked_path(path)
    names = _unique_names(path, names)
    if path.suffix.lower() == ".nvdb":
        return _nano_read_isolated(path, names, max_voxels)
    if openvdb.interpreter():
        return _openvdb_read(path, names, max_voxels)
    with _open_vdb(path) as handle:
        grids = {g.name: g for g in _vdb_grids(path, handle)}
        chosen = {name: _pick(path, grids, name) for name in names}
        infos = {name: _vdb_info(path, grid, need_float=True) for name, grid in chosen.items()}
        box = _union_box(path, infos, max_voxels)
        voxel, translation = _common_transform(path, infos)
        return {
            name: _densify_vdb(path, chosen[name], infos[name], box, voxel, translation)
            for name in names
        }


@dataclass(frozen=True)
class LeafGrids:
    """Grids read as the 8³ leaves of one box (``openvdb_worker.leaves``): ``coords`` (n, 3)
    leaf coordinates from the box's low corner, ``arrays`` name → (n, 8, 8, 8[, 3]) float32,
    ``shape`` of the box (turned y-up when read z-up), ``origin_m`` the corner of the box's
    voxel (0, 0, 0) in the file's axes, ``backgrounds`` each grid's background."""

    coords: NDArray[np.int32]
    arrays: dict[str, NDArray[np.float32]]
    shape: tuple[int, int, int]
    origin_m: tuple[float, float, float]
    voxel_size_m: float
    backgrounds: dict[str, float]


def read_leaves(
    path: str | Path, names: Sequence[str], z_up: bool = False, rings: int = 0
) -> LeafGrids:
    """Read grids as the occupied 8³ leaves of the union of their active boxes, and the leaves
    around them (``rings`` more rings for motion blur), with OpenVDB — never densifying the box
    (a big sparse cache stays sparse)."""
    path = _checked_path(path)
    names = _unique_names(path, names)
    chosen = _readable(path, names)
    box = _union_box(path, chosen, max_voxels=np.iinfo(np.int64).max)
    voxel, translation = _common_transform(path, chosen)
    coords, arrays, shape = openvdb.leaves(path, names, *box, z_up, rings)
    for name, values in arrays.items():
        _check_values(path, name, values)
    _, origin, _ = _dense_info(path, chosen[names[0]], box, voxel, translation)
    backgrounds = {name: float(info.background or 0.0) for name, info in chosen.items()}
    return LeafGrids(coords, arrays, shape, origin, voxel, backgrounds)  # type: ignore[arg-type]


def box_and_active_voxels(path: str | Path, names: Sequence[str]) -> tuple[int, int]:
    """(voxels of the union of the grids' active boxes, their most active voxels) from the
    file's description alone."""
    path = _checked_path(path)
    chosen = _readable(path, _unique_names(path, names))
    lo, hi = _union_box(path, chosen, max_voxels=np.iinfo(np.int64).max)
    box = int(np.prod(hi - lo + 1))
    return box, max(int(info.active_voxels or 0) for info in chosen.values())


def _readable(path: Path, names: list[str]) -> dict[str, GridInfo]:
    """The grids ``names`` of a ``.vdb`` OpenVDB can read, or an error naming the first not."""
    if path.suffix.lower() != ".vdb" or not openvdb.interpreter():
        raise ValueError(f"{path}: reading leaves needs a .vdb file and OpenVDB (python3-openvdb)")
    infos = {info.name: info for info in list_grids(path, ranges=False)}
    chosen = {name: _pick(path, infos, name) for name in names}
    for name, info in chosen.items():
        if info.unreadable:
            raise ValueError(f"{path}: grid {name!r} {info.unreadable}")
    return chosen


# --------------------------------------------------------------------------------------------
# OpenVDB itself (.vdb), through the worker of io/openvdb.py


def _openvdb_info(grid: dict) -> GridInfo:
    """A :class:`GridInfo` from the worker's description of one grid."""
    meta = {k: tuple(v) if isinstance(v, list) else v for k, v in grid["metadata"].items()}
    matrix = _matrix(np.asarray(grid["matrix"])) if "matrix" in grid else None
    voxel = _floats(grid.get("voxel_size", (0.0, 0.0, 0.0)))
    common = dict(
        name=str(grid["name"]),
        value_type=str(grid["type"]),
        type_name=str(grid["type"]),
        index_to_world=matrix,
        voxel_size_m=voxel,
        translation_m=_floats(row[3] for row in matrix[:3]) if matrix else (0.0, 0.0, 0.0),
        half_float=_optional_bool(meta.get("is_saved_as_half_float")),
        compression=_optional_str(meta.get("file_compression")),
        grid_class=_optional_str(meta.get("class")),
    )
    problem = grid.get("unreadable")
    if problem is None and grid["type"] == "bool":
        problem = "holds bool values (a mask), not a field the renderer reads"
    if problem is not None:
        return _info_from_metadata(meta, common, problem)
    background = grid.get("background")
    return GridInfo(
        active_voxels=int(grid["active_voxels"]),
        index_min=_ints(grid["index_min"]) if "index_min" in grid else None,
        index_max=_ints(grid["index_max"]) if "index_max" in grid else None,
        value_min=grid.get("min"),
        value_max=grid.get("max"),
        background=background if isinstance(background, float) else None,
        unreadable=_transform_problem(matrix, voxel),
        **common,  # type: ignore[arg-type]
    )


def _openvdb_read(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    """Grids densified onto the union of their active boxes by OpenVDB (tiles expanded)."""
    chosen = _readable(path, names)
    box = _union_box(path, chosen, max_voxels)
    voxel, translation = _common_transform(path, chosen)
    arrays = openvdb.dense(path, names, *box)
    out = {}
    for name, info in chosen.items():
        _check_values(path, name, arrays[name])
        index_min, origin, source = _dense_info(path, info, box, voxel, translation)
        background = float(info.background or 0.0)
        out[name] = DenseGrid(name, arrays[name], origin, voxel, background, index_min, source)
    return out


# --------------------------------------------------------------------------------------------
# checks shared by both formats
def _ints(values: Any) -> tuple[int, int, int]:
    a, b, c = (int(v) for v in values)
    return a, b, c


def _floats(values: Any) -> tuple[float, float, float]:
    a, b, c = (float(v) for v in values)
    return a, b, c


def _matrix(matrix: NDArray) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in matrix)


def _checked_path(path: str | Path) -> Path:
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(
            f"{path}: unsupported volume format {path.suffix!r}; expected .vdb or .nvdb"
        )
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such volume file")
    return path


def _unique_names(path: Path, names: Sequence[str]) -> list[str]:
    if isinstance(names, str):
        names = [names]
    names = list(names)
    if not names:
        raise ValueError(f"{path}: no grid names given")
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: grid names repeat: {names}")
    return names


def _pick(path: Path, grids: dict[str, Any], name: str) -> Any:
    if name not in grids:
        available = ", ".join(repr(n) for n in grids) or "none"
        raise ValueError(f"{path}: no grid named {name!r}; the file has: {available}")
    return grids[name]


def _union_box(path: Path, infos: dict[str, GridInfo], max_voxels: int) -> tuple[NDArray, NDArray]:
    boxes = [(i.index_min, i.index_max) for i in infos.values() if i.index_min and i.index_max]
    if not boxes:
        raise ValueError(f"{path}: grids {list(infos)} have no active voxels; nothing to read")
    lo = np.min([b[0] for b in boxes], axis=0).astype(np.int64)
    hi = np.max([b[1] for b in boxes], axis=0).astype(np.int64)
    shape = hi - lo + 1
    if int(np.prod(shape)) > max_voxels:
        raise ValueError(
            f"{path}: the active box of {list(infos)} spans {tuple(int(n) for n in shape)} = "
            f"{int(np.prod(shape))} voxels, more than max_voxels={max_voxels}; raise the limit "
            "if the memory is there (4 bytes per voxel per grid)"
        )
    return lo, hi


def _common_transform(path: Path, infos: dict[str, GridInfo]) -> tuple[float, NDArray]:
    voxel, translation = None, None
    for info in infos.values():
        size = _uniform_voxel_size(path, info)
        offset = np.asarray(info.translation_m, dtype=np.float64)
        if voxel is None or translation is None:
            voxel, translation = size, offset
            continue
        tolerance = TRANSFORM_RTOL * max(voxel, size)
        if abs(size - voxel) > tolerance or np.abs(offset - translation).max() > tolerance:
            described = {i.name: (i.voxel_size_m, i.translation_m) for i in infos.values()}
            raise ValueError(
                f"{path}: grids do not share one index→world transform, so they cannot be read "
                f"onto one box: (voxel size, translation) = {described}"
            )
    assert voxel is not None and translation is not None  # infos is never empty
    return voxel, translation


def _uniform_voxel_size(path: Path, info: GridInfo) -> float:
    problem = _transform_problem(info.index_to_world, info.voxel_size_m)
    if problem:
        raise ValueError(f"{path}: grid {info.name!r} {problem}")
    return float(info.voxel_size_m[0])


def _transform_problem(matrix: tuple | None, voxel_size_m: tuple) -> str | None:
    """Why an index→world map is not the uniform scale + translation the renderer needs."""
    size = np.asarray(voxel_size_m, dtype=np.float64)
    linear = None if matrix is None else np.asarray(matrix, dtype=np.float64)[:3, :3]
    shear = 0.0 if linear is None else float(np.abs(linear - np.diag(np.diag(linear))).max())
    if (
        linear is None
        or not np.all(np.isfinite(size))
        or size.min() <= 0
        or size.max() - size.min() > TRANSFORM_RTOL * size.max()
        or shear > TRANSFORM_RTOL * size.max()
    ):
        return (
            f"has an index→world transform that is not a uniform scale plus translation "
            f"(voxel size {voxel_size_m}, matrix {matrix}); the renderer needs cubic, "
            "axis-aligned voxels — resample the grid first"
        )
    return None


def _dense_info(
    path: Path, info: GridInfo, box: tuple[NDArray, NDArray], voxel: float, translation: NDArray
) -> tuple[tuple[int, int, int], tuple[float, float, float], str]:
    lo = _ints(box[0])
    origin = _floats(t + (i - 0.5) * voxel for t, i in zip(translation, lo, strict=True))
    return lo, origin, f"{path}:{info.name}"


def _value_range(values: NDArray) -> tuple[float | None, float | None]:
    if values.size == 0:
        return None, None
    return float(values.min()), float(values.max())


def _check_values(path: Path, name: str, values: NDArray) -> None:
    if not np.all(np.isfinite(values)):
        count = int(np.count_nonzero(~np.isfinite(values)))
        raise ValueError(f"{path}: grid {name!r} has {count} non-finite values (NaN or inf)")


# --------------------------------------------------------------------------------------------
# OpenVDB (.vdb)


def _library() -> Any:
    try:
        import tinyvdb
    except ImportError as error:  # pragma: no cover - tinyvdb is a dependency
        raise ImportError(
            "reading .vdb/.nvdb needs the 'tinyvdb' package: pip install tinyvdb"
        ) from error
    return tinyvdb


def _library_error(path: Path, what: str, error: BaseException) -> ValueError:
    detail = str(error) or type(error).__name__
    return ValueError(f"{path}: {what} ({detail})")


def _check_vdb_file(path: Path) -> None:
    """The magic number and header counts of a file that OpenVDB will read, checked through a
    memory map: only the header and grid descriptors are touched, not the voxel data."""
    import mmap

    try:
        with (
            open(path, "rb") as handle,
            mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as data,
        ):
            _check_vdb_magic(path, data)
            _check_vdb_header(path, data)
    except ValueError as error:
        if "cannot mmap an empty file" not in str(error):
            raise
        raise ValueError(f"{path}: not an OpenVDB file (it is empty)") from None
    except OSError as error:
        raise _library_error(path, "cannot read the file", error) from None


def _check_vdb_magic(path: Path, data) -> None:
    if len(data) < 8 or data[:4] != b"\x20\x42\x44\x56":  # OpenVDB magic 0x56444220 little-endian
        raise ValueError(f"{path}: not an OpenVDB file (no OpenVDB magic number at its start)")


def _vdb_bytes(path: Path) -> bytes:
    """The file's bytes, with its magic number and header counts checked (before any library
    trusts them)."""
    try:
        data = path.read_bytes()
    except OSError as error:
        raise _library_error(path, "cannot read the file", error) from None
    _check_vdb_magic(path, data)
    _check_vdb_header(path, data)
    return data


@contextmanager
def _open_vdb(path: Path) -> Iterator[Any]:
    tinyvdb = _library()
    data = _vdb_bytes(path)
    try:
        handle = tinyvdb.from_bytes(data)
        handle.read_grids()
    except _LIBRARY_ERRORS as error:
        raise _library_error(
            path, "not a readable OpenVDB file, truncated or corrupt", error
        ) from None
    try:
        yield handle
    finally:
        handle.close()


_VDB_HEADER = struct.Struct("<QIIIB36s")  # magic, version, library major, minor, offsets, uuid
#: Fewest bytes a grid can take in a file (name, type and parent strings, three offsets).
_VDB_MIN_GRID_BYTES = 40


def _check_vdb_header(path: Path, data) -> None:
    """Check the counts and grid offsets in the file header before a library trusts them.

    tinyvdb 0.9 allocates for the grid count before reading any grid: three flipped bytes in the
    count made it commit 3.6 GB and spend 6 s; OpenVDB spends minutes on a file cut short inside
    a grid. Header layout (file versions 220–225): magic, version, library version, has-grid-offsets
    flag, UUID, file metadata (count; name, type name and value, each length-prefixed), grid
    count, then per grid its name, type and parent (length-prefixed) and — with offsets — the
    int64 positions of its header, data blocks and end, where the next grid's descriptor starts.
    """
    try:
        _magic, version, _major, _minor, offsets, _uuid = _VDB_HEADER.unpack_from(data, 0)
        if not 220 <= version <= 225:
            raise ValueError(f"OpenVDB file format version {version}; tinyvdb reads 220–225")
        offset = _VDB_HEADER.size
        (entries,) = struct.unpack_from("<i", data, offset)
        offset += 4
        if not 0 <= entries <= (len(data) - offset) // 12:
            raise ValueError(f"{entries} file metadata entries")
        for _ in range(3 * entries):  # name, type name, value: each a uint32 length + bytes
            (size,) = struct.unpack_from("<I", data, offset)
            offset += 4 + size
        (grids,) = struct.unpack_from("<i", data, offset)
        if not 0 <= grids <= (len(data) - offset) // _VDB_MIN_GRID_BYTES:
            raise ValueError(f"a grid count of {grids} in {len(data)} bytes")
        if offsets:
            _check_grid_offsets(data, offset + 4, grids)
    except (struct.error, ValueError) as error:
        raise _library_error(path, "not a readable OpenVDB file, corrupt header", error) from None


def _check_grid_offsets(data, offset: int, grids: int) -> None:
    """Every grid's descriptor, and its end within the file (a cut file ends early)."""
    for index in range(grids):
        for _ in range(3):  # name, type, parent
            (size,) = struct.unpack_from("<I", data, offset)
            offset += 4 + size
        start, blocks, end = struct.unpack_from("<qqq", data, offset)
        if not offset < start <= blocks <= end <= len(data):
            raise ValueError(
                f"grid {index} spans bytes {start}–{end} of a {len(data)}-byte file: truncated "
                "or corrupt"
            )
        offset = end


def _vdb_grids(path: Path, handle: Any) -> list[Any]:
    try:
        grids = [handle.grid(i) for i in range(int(handle.grid_count))]
        names = [str(grid.name) for grid in grids]
    except _LIBRARY_ERRORS as error:
        raise _library_error(path, "cannot read the grid list", error) from None
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: grid names repeat ({names}); cannot tell the grids apart")
    return grids


def _value_type(type_name: str) -> str:
    """``Tree_float_5_4_3`` → ``float``; anything unrecognised is returned whole."""
    parts = type_name.split("_")
    if len(parts) >= 2 and parts[0] == "Tree":
        return "_".join(p for p in parts[1:] if not p.isdigit())
    return type_name


def _vdb_transform(transform: dict) -> tuple[tuple | None, tuple, tuple]:
    kind = str(transform.get("type", ""))
    if kind in _SCALE_MAPS:
        scale = np.asarray(transform.get("scale", (1.0, 1.0, 1.0)), dtype=np.float64)
        if kind == "translation":
            scale = np.ones(3)
        offset = np.asarray(transform.get("translation", (0.0, 0.0, 0.0)), dtype=np.float64)
        matrix = np.eye(4)
        matrix[:3, :3] = np.diag(scale)
        matrix[:3, 3] = offset
    elif kind == "affine":
        matrix = np.asarray(transform["matrix"], dtype=np.float64).T  # OpenVDB: row vectors
        scale = np.linalg.norm(matrix[:3, :3], axis=0)
        offset = matrix[:3, 3]
    else:  # unitary, frustum and unknown maps: not linear scale/affine as far as we can read
        scale = np.asarray(transform.get("voxel_size", (0.0, 0.0, 0.0)), dtype=np.float64)
        return None, _floats(scale), (0.0, 0.0, 0.0)
    return _matrix(matrix), _floats(scale), _floats(offset)


def _vdb_info(path: Path, grid: Any, need_float: bool = False) -> GridInfo:
    """Describe a grid; with ``need_float`` raise when it cannot be densified."""
    try:
        name, type_name = str(grid.name), str(grid.type_name)
        metadata = dict(grid.metadata)
        matrix, voxel, offset = _vdb_transform(dict(grid.transform))
    except (*_LIBRARY_ERRORS, KeyError) as error:
        raise _library_error(path, "cannot read a grid's header", error) from None
    value_type = _value_type(type_name)
    common = dict(
        name=name,
        value_type=value_type,
        type_name=type_name,
        index_to_world=matrix,
        voxel_size_m=voxel,
        translation_m=offset,
        half_float=_optional_bool(metadata.get("is_saved_as_half_float")),
        compression=_optional_str(metadata.get("file_compression")),
        grid_class=_optional_str(metadata.get("class")),
    )
    if value_type != "float":
        problem = f"holds {value_type} values; only float grids can be read"
        info = _info_from_metadata(metadata, common, problem)
    else:
        coords, values, background = _vdb_sparse(path, grid, name)
        tiles = _tile_problem(metadata, len(values))
        if tiles:
            info = _info_from_metadata(metadata, common, tiles)
        else:
            lo = _ints(coords.min(axis=0)) if len(coords) else None
            hi = _ints(coords.max(axis=0)) if len(coords) else None
            vmin, vmax = _value_range(values)
            info = GridInfo(
                active_voxels=len(values),
                index_min=lo,
                index_max=hi,
                value_min=vmin,
                value_max=vmax,
                background=background,
                unreadable=_transform_problem(matrix, voxel),
                **common,  # type: ignore[arg-type]
            )
    if need_float and info.unreadable:
        raise ValueError(f"{path}: grid {name!r} {info.unreadable}")
    return info


def _info_from_metadata(metadata: dict, common: dict, problem: str) -> GridInfo:
    """What OpenVDB's own ``file_*`` metadata says, for grids whose voxels cannot be read."""
    count = metadata.get("file_voxel_count")
    lo, hi = metadata.get("file_bbox_min"), metadata.get("file_bbox_max")
    box_ok = isinstance(lo, tuple) and isinstance(hi, tuple) and len(lo) == len(hi) == 3
    return GridInfo(
        active_voxels=count if isinstance(count, int) and not isinstance(count, bool) else None,
        index_min=_ints(lo) if box_ok else None,
        index_max=_ints(hi) if box_ok else None,
        value_min=None,
        value_max=None,
        background=None,
        unreadable=problem,
        **common,
    )


def _optional_bool(value: object) -> bool | None:
    return value if isinstance(value, bool) else None


def _optional_str(value: object) -> str | None:
    return value if isinstance(value, str) else None


def _vdb_sparse(path: Path, grid: Any, name: str) -> tuple[NDArray, NDArray, float]:
    try:
        sparse = grid.to_sparse()
        coords = np.frombuffer(sparse["coords"], dtype=np.int32).reshape(-1, 3)
        values = np.frombuffer(sparse["values"], dtype=np.float32)
        background = float(grid.float_background())
    except (*_LIBRARY_ERRORS, KeyError) as error:
        raise _library_error(path, f"cannot read the voxels of grid {name!r}", error) from None
    if len(coords) != len(values):
        raise ValueError(
            f"{path}: grid {name!r}: {len(coords)} coordinates for {len(values)} values"
        )
    return coords, values, background


def _tile_problem(metadata: dict, seen: int) -> str | None:
    recorded = metadata.get("file_voxel_count")
    if isinstance(recorded, int) and not isinstance(recorded, bool) and recorded != seen:
        return (
            f"has {recorded} active voxels but only {seen} are stored in leaf nodes; the rest "
            "are active tiles, which tinyvdb 0.9 (used because OpenVDB is not installed) reads "
            f"as background; {openvdb.INSTALL_HINT}"
        )
    return None


def _densify_vdb(
    path: Path,
    grid: Any,
    info: GridInfo,
    box: tuple[NDArray, NDArray],
    voxel: float,
    offset: NDArray,
) -> DenseGrid:
    lo, hi = box
    background = float(info.background or 0.0)
    try:
        dense = grid.materialize_dense(
            tuple(int(v) for v in lo), tuple(int(v) + 1 for v in hi), background
        )
        shape = tuple(int(n) for n in dense.shape)
        flat = np.frombuffer(dense, dtype=np.float32)
    except _LIBRARY_ERRORS as error:
        raise _library_error(path, f"cannot densify grid {info.name!r}", error) from None
    expected = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    if shape != expected or flat.size != int(np.prod(expected)):
        raise ValueError(f"{path}: grid {info.name!r} densified to {shape}; expected {expected}")
    values = flat.reshape(expected, order="F").copy()  # tinyvdb stores x fastest
    _check_values(path, info.name, values)
    index_min, origin, source = _dense_info(path, info, box, voxel, offset)
    return DenseGrid(info.name, values, origin, voxel, background, index_min, source)


# --------------------------------------------------------------------------------------------
# NanoVDB (.nvdb): tinyvdb's NanoVDBFile sees the first grid of a file only, so each file segment
# (16-byte header, per-grid metadata + name, grid data) is handed to it as a file of its own.

_NANO_MAGICS = (0x304244566F6E614E, 0x314244566F6E614E)  # "NanoVDB0", "NanoVDB1"
_NANO_HEADER = struct.Struct("<QIHH")  # magic, version, grid count, codec
_NANO_META = struct.Struct("<QQQQII")  # grid size, file size, name key, voxel count, type, class
_NANO_META_SIZE = 176
_NANO_NAME_SIZE_AT = 136


@dataclass(frozen=True)
class _NanoSegment:
    start: int
    end: int
    name: str


def _nano_segments(path: Path) -> list[_NanoSegment]:
    try:
        data = path.read_bytes()
    except OSError as error:
        raise _library_error(path, "cannot read the file", error) from None
    segments, offset = [], 0
    while offset < len(data):
        segments.append(_nano_segment(path, data, offset))
        offset = segments[-1].end
    if not segments:
        raise ValueError(f"{path}: empty file; not a NanoVDB file")
    return segments


def _nano_segment(path: Path, data: bytes, start: int) -> _NanoSegment:
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
        raise _library_error(path, f"not a readable NanoVDB file at byte {start}", error) from None
    return _NanoSegment(start, end, name)


@contextmanager
def _open_nano(path: Path, segment: _NanoSegment) -> Iterator[Any]:
    _library()
    nanovdb = importlib.import_module("tinyvdb._tinyvdb_nanovdb")  # not re-exported by tinyvdb

    data = path.read_bytes()[segment.start : segment.end]
    handle, name = None, None
    try:
        with tempfile.NamedTemporaryFile(suffix=".nvdb", delete=False) as temporary:
            temporary.write(data)
            name = temporary.name
        handle = nanovdb.NanoVDBFile(name)
        yield handle
    except _LIBRARY_ERRORS as error:
        raise _library_error(path, f"cannot read NanoVDB grid {segment.name!r}", error) from None
    finally:
        if handle is not None:
            handle.close()
        if name is not None:
            os.unlink(name)


def _nano_info(path: Path, segment: _NanoSegment) -> GridInfo:
    with _open_nano(path, segment) as handle:
        type_name = str(handle.grid_type(0))
        voxel = _floats(handle.voxel_size(0, axis) for axis in range(3))
        lo, hi = (_ints(corner) for corner in handle.bbox(0))
        world = np.asarray(handle.world_bbox(0), dtype=np.float64)
        count = int(handle.active_voxel_count(0))
        grid_class = str(handle.grid_class(0))
    offset = world[0] - np.asarray(lo) * np.asarray(voxel)
    matrix = np.eye(4)
    matrix[:3, :3] = np.diag(voxel)
    matrix[:3, 3] = offset
    problem = _nano_problem(type_name, count, lo, hi, voxel, world)
    empty = count == 0
    return GridInfo(
        name=segment.name,
        value_type="float" if type_name == "Float" else type_name,
        type_name=type_name,
        active_voxels=count,
        index_min=None if empty else lo,
        index_max=None if empty else hi,
        index_to_world=None if problem else _matrix(matrix),
        voxel_size_m=voxel,
        translation_m=_floats(offset),
        value_min=None,
        value_max=None,
        background=None,
        half_float=None,
        compression=None,
        grid_class=grid_class,
        unreadable=problem,
    )


def _nano_problem(
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


#: One worker process for NanoVDB reads, started on first use and reused (see below).
_NANO_WORKER: ProcessPoolExecutor | None = None


def _nano_read_isolated(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    """:func:`_nano_read` in a separate process. tinyvdb 0.9's NanoVDB voxel access can crash the
    process (segmentation fault) on corrupt files — fuzzing found it — so the read runs where a
    crash becomes a clear ValueError instead of killing the caller. The worker is reused; a crash
    discards it and the next read starts a new one."""
    return _run_isolated(path, _nano_read, path, names, max_voxels)


def _run_isolated(path: Path, function, *args):
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


def _nano_read(path: Path, names: list[str], max_voxels: int) -> dict[str, DenseGrid]:
    segments = {segment.name: segment for segment in _nano_segments(path)}
    chosen = {name: _pick(path, segments, name) for name in names}
    infos = {name: _nano_info(path, segment) for name, segment in chosen.items()}
    for info in infos.values():
        if info.unreadable:
            raise ValueError(f"{path}: NanoVDB grid {info.name!r} {info.unreadable}")
    box = _union_box(path, infos, max_voxels)
    voxel, offset = _common_transform(path, infos)
    return {
        name: _densify_nano(path, chosen[name], infos[name], box, voxel, offset) for name in names
    }


def _densify_nano(
    path: Path,
    segment: _NanoSegment,
    info: GridInfo,
    box: tuple[NDArray, NDArray],
    voxel: float,
    offset: NDArray,
) -> DenseGrid:
    lo, hi = box
    shape = tuple(int(h - l + 1) for l, h in zip(lo, hi, strict=True))
    values = np.empty(shape, dtype=np.float32)
    with _open_nano(path, segment) as handle:
        get = handle.get
        for a, i in enumerate(range(int(lo[0]), int(hi[0]) + 1)):
            for b, j in enumerate(range(int(lo[1]), int(hi[1]) + 1)):
                values[a, b, :] = [get(0, i, j, k) for k in range(int(lo[2]), int(hi[2]) + 1)]
        background = float(get(0, *(int(v) - 1_000_000 for v in lo)))  # far outside any data
    _check_values(path, info.name, values)
    index_min, origin, source = _dense_info(path, info, box, voxel, offset)
    return DenseGrid(info.name, values, origin, voxel, background, index_min, source)
