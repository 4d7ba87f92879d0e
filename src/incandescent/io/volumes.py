"""Reading volume files into named raw grids: ``.npy`` (one temperature grid), ``.npz`` (named
grids) and — through :mod:`incandescent.io.vdb` — OpenVDB ``.vdb`` / NanoVDB ``.nvdb``.

Standard ``.npz`` grid names: ``temperature``, ``absorption`` (1/m), ``emission_scale`` and
``sodium_fraction`` (0..1, paper mode); any other names can be chosen per role. Arrays are read
with ``allow_pickle=False``. Axis order is x, y, z (``a[i, j, k]`` is the voxel at x=i, y=j, z=k).
"""

from __future__ import annotations

import struct
import zipfile
import zlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

NUMPY_SUFFIXES = (".npy", ".npz")
VDB_SUFFIXES = (".vdb", ".nvdb")
SCIENCE_SUFFIXES = (".h5", ".hdf5", ".nc", ".nc4")  # incandescent.io.scientific (extra "science")
SUFFIXES = NUMPY_SUFFIXES + VDB_SUFFIXES + SCIENCE_SUFFIXES


@dataclass(frozen=True)
class Grids:
    """Grids read on one common box of voxels, and that box's placement where the file has one
    (VDB: world position of the corner of voxel (0, 0, 0) and voxel side, m), else None."""

    arrays: dict[str, NDArray]
    origin_m: tuple[float, float, float] | None = None
    voxel_size_m: float | None = None


@dataclass(frozen=True)
class GridSource:
    """A volume file's readable grids by name, and a reader for the ones a render needs."""

    path: Path
    names: tuple[str, ...]
    read: Callable[[Iterable[str]], Grids]
    #: per grid, what the reader did or found (axis order, unit conversion, placement, problems)
    notes: Mapping[str, str] = field(default_factory=dict)


#: What NumPy, zipfile and zlib raise on corrupt or truncated .npy/.npz files (found by fuzzing).
_CORRUPT = (
    ValueError,
    OSError,
    EOFError,
    zipfile.BadZipFile,
    zlib.error,
    struct.error,
    UnicodeDecodeError,
    SyntaxError,
    NotImplementedError,
    RuntimeError,  # zipfile: "File ... is encrypted, password required" (a flipped flag bit)
)


def _np_load(path: Path):
    try:
        return np.load(path, allow_pickle=False)
    except _CORRUPT as error:
        raise ValueError(f"{path}: not a readable {path.suffix} file ({error})") from None


def _npz_reader(path: Path, data) -> Callable[[Iterable[str]], Grids]:
    def read(names: Iterable[str]) -> Grids:
        out = {}
        for name in names:
            try:
                out[name] = np.asarray(data[name])
            except KeyError:
                raise ValueError(
                    f"{path}: no grid named {name!r}; the file has: {', '.join(data.files)}"
                ) from None
            except _CORRUPT as error:
                raise ValueError(f"{path}: grid {name!r} cannot be read ({error})") from None
        return Grids(out)

    return read


def open_grids(path: str | Path, axes: str | None = None) -> GridSource:
    """Open a volume file (errors name the file and the problem).

    ``axes``: the order of the stored array axes (e.g. "zyx") for files that do not say it
    (HDF5/NetCDF without axis metadata, .npy/.npz); arrays are returned in x, y, z order."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(
            f"{path}: unsupported volume format {path.suffix!r}; expected one of "
            f"{', '.join(SUFFIXES)} (or a .toml/.json scene file)"
        )
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such volume file")
    if suffix in VDB_SUFFIXES:
        return _vdb_source(path)
    if suffix in SCIENCE_SUFFIXES:
        from incandescent.io.scientific import open_scientific

        return open_scientific(path, axes)
    data = _np_load(path)
    if isinstance(data, np.ndarray):
        source = GridSource(path, ("temperature",), _npy_reader(path, data))
    else:
        source = GridSource(path, tuple(data.files), _npz_reader(path, data))
    return _with_axes(source, axes)


def _with_axes(source: GridSource, axes: str | None) -> GridSource:
    """A source whose arrays, stored in ``axes`` order, are returned in x, y, z order."""
    if axes is None or axes == "xyz":
        return source
    if sorted(axes) != ["x", "y", "z"]:
        raise ValueError(f"axes must be a permutation of xyz (e.g. zyx); got {axes!r}")
    order = [axes.index(c) for c in "xyz"]

    def read(names: Iterable[str]) -> Grids:
        grids = source.read(names)
        arrays = {n: np.ascontiguousarray(np.transpose(a, order)) for n, a in grids.arrays.items()}
        return Grids(arrays, grids.origin_m, grids.voxel_size_m)

    notes = {n: f"stored axes {axes}, transposed to xyz" for n in source.names}
    return GridSource(source.path, source.names, read, notes)


def _npy_reader(path: Path, data: NDArray) -> Callable[[Iterable[str]], Grids]:
    def read(names: Iterable[str]) -> Grids:
        names = list(names)
        other = [n for n in names if n != "temperature"]
        if other:
            raise ValueError(f"{path}: a .npy file holds one grid (temperature), not {other[0]!r}")
        return Grids({n: data for n in names})

    return read


def _vdb_source(path: Path) -> GridSource:
    """OpenVDB/NanoVDB through :mod:`incandescent.io.vdb`: the float grids it can read, densified
    onto the union of their active boxes, placed by the file's transform."""
    from incandescent.io import vdb

    readable = tuple(g.name for g in vdb.list_grids(path) if g.unreadable is None)

    def read(names: Iterable[str]) -> Grids:
        dense = vdb.read_grids(path, list(names))
        first = next(iter(dense.values()))
        arrays = {name: grid.values for name, grid in dense.items()}
        return Grids(arrays, first.origin_m, first.voxel_size_m)

    return GridSource(path, readable, read)


@dataclass(frozen=True)
class GridSummary:
    """What ``incandescent info`` shows about one grid."""

    name: str
    value_type: str
    shape: tuple[int, ...] | None
    value_min: float | None
    value_max: float | None
    placement: str
    note: str | None = None


def describe(path: str | Path, axes: str | None = None) -> list[GridSummary]:
    """A summary of every grid in a volume file: type, shape, value range, placement."""
    path = Path(path)
    if path.suffix.lower() in VDB_SUFFIXES and path.is_file():
        return _describe_vdb(path)
    source = open_grids(path, axes)
    return [_summary(source, name) for name in source.names]


def _summary(source: GridSource, name: str) -> GridSummary:
    note = source.notes.get(name)
    try:
        grids = source.read([name])
    except ValueError as error:  # one unreadable grid does not hide the others
        return GridSummary(name, "?", None, None, None, "—", str(error))
    values = grids.arrays[name]
    numeric = np.issubdtype(values.dtype, np.number) and values.size > 0
    low, high = (float(np.nanmin(values)), float(np.nanmax(values))) if numeric else (None, None)
    placement = "none stored (default: centred, largest side 1 m)"
    if grids.voxel_size_m is not None:
        placement = f"voxel {grids.voxel_size_m:g} m, corner {grids.origin_m} m"
    return GridSummary(name, str(values.dtype), values.shape, low, high, placement, note)


def _describe_vdb(path: Path) -> list[GridSummary]:
    from incandescent.io import vdb

    out = []
    for g in vdb.list_grids(path):
        shape = None
        if g.index_min is not None and g.index_max is not None:
            shape = tuple(hi - lo + 1 for lo, hi in zip(g.index_min, g.index_max, strict=True))
        placement = f"voxel {g.voxel_size_m} m, voxel (0,0,0) centre at {g.translation_m} m"
        out.append(
            GridSummary(
                g.name,
                g.value_type,
                shape,
                g.value_min,
                g.value_max,
                placement,
                g.unreadable and f"cannot be read: {g.unreadable}",
            )
        )
    return out
