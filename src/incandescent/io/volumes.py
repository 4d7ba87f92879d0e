"""Reading volume files into named raw grids: ``.npy`` (one temperature grid), ``.npz`` (named
grids) and — through :mod:`incandescent.io.vdb` — OpenVDB ``.vdb`` / NanoVDB ``.nvdb``.

Standard ``.npz`` grid names: ``temperature``, ``absorption`` (1/m), ``emission_scale`` and
``sodium_fraction`` (0..1, paper mode); any other names can be chosen per role. Arrays are read
with ``allow_pickle=False``. Axis order is x, y, z (``a[i, j, k]`` is the voxel at x=i, y=j, z=k).
"""

from __future__ import annotations

import os
import struct
import tokenize
import zipfile
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent.budget import Limits
from incandescent.io import vdb
from incandescent.io.formats import (
    SCIENCE_SUFFIXES,
    VDB_SUFFIXES,
    VOLUME_SUFFIXES,
    VTK_INPUT_SUFFIXES,
)
from incandescent.io.grids import Grids, GridSource
from incandescent.io.vdb.source import (  # imported from here (config.assemble)
    DENSE_READ_BYTES_PER_VOXEL as DENSE_READ_BYTES_PER_VOXEL,
)
from incandescent.io.vdb.source import open_source
from incandescent.io.vtk import is_openfoam, open_vtk

SUFFIXES = VOLUME_SUFFIXES


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
    tokenize.TokenError,  # a .npy header dict literal cut short (found by fuzzing)
)


_CORRUPT_BESIDES_VALUE = tuple(error for error in _CORRUPT if error is not ValueError)
#: Peak host bytes per voxel of building a Volume from a temperature grid (float64 validation,
#: remap and κ, float32 results), beyond the array as stored; measured ~37 on a 256³ plume.
BYTES_PER_VOXEL = 40


@dataclass(frozen=True)
class ArrayHeader:
    """What a ``.npy`` header (or a ``.npz`` member's) says, read without reading the data."""

    shape: tuple[int, ...]
    dtype: np.dtype
    data_bytes: int  # bytes the array's data take as stored


def _npy_header(handle, where: str) -> ArrayHeader:
    """Parse the header at the start of ``handle`` (NEP 1: magic, version, dict literal)."""
    from numpy.lib import format as npy

    if handle.read(6) != npy.MAGIC_PREFIX:
        raise ValueError(f"{where}: not a NumPy .npy array (no \\x93NUMPY signature)")
    version = tuple(handle.read(2))
    if version not in ((1, 0), (2, 0), (3, 0)):
        raise ValueError(f"{where}: unsupported .npy format version {version}")
    read_header = npy.read_array_header_1_0 if version == (1, 0) else npy.read_array_header_2_0
    try:
        shape, _, dtype = read_header(handle)
    except (*_CORRUPT, TypeError) as error:  # TypeError: a bytes key, b'...' (found by fuzzing)
        raise ValueError(f"{where}: corrupt .npy header ({error})") from None
    if dtype.hasobject or not (dtype.kind in "biuf" and dtype.fields is None):
        raise ValueError(
            f"{where}: holds dtype {dtype}, not numbers; only numeric grids are read (Python "
            "objects are never unpickled)"
        )
    return ArrayHeader(tuple(shape), dtype, int(np.prod(shape, dtype=object)) * dtype.itemsize)


def _check_stored(header: ArrayHeader, stored_bytes: int, where: str) -> None:
    """The data must be there: a header may claim any shape."""
    if stored_bytes < header.data_bytes:
        raise ValueError(
            f"{where}: header claims shape {header.shape} {header.dtype} "
            f"({header.data_bytes:.3g} bytes) but the file holds {stored_bytes:.3g} bytes of "
            "data; the file is truncated or corrupt"
        )


def _input_bytes(header: ArrayHeader) -> float:
    """The stored array plus the working set of building a Volume from it."""
    return header.data_bytes + float(np.prod(header.shape, dtype=object)) * BYTES_PER_VOXEL


def _check_npy(path: Path, limits: Limits) -> None:
    """Header, stored size and memory budget of a ``.npy`` file, before reading its data."""
    with open(path, "rb") as handle:
        header = _npy_header(handle, str(path))
        offset = handle.tell()
    _check_stored(header, path.stat().st_size - offset, str(path))
    limits.check_memory(_input_bytes(header), f"reading {path} ({header.shape} {header.dtype})")


def _npz_header(archive: zipfile.ZipFile, name: str, where: str) -> ArrayHeader:
    """A member's header (inflating only its first bytes) checked against its stored size."""
    names = archive.namelist()
    if f"{name}.npy" not in names and name not in names:
        raise ValueError(f"{where}: no such member in the archive")
    member = archive.getinfo(f"{name}.npy" if f"{name}.npy" in names else name)
    with archive.open(member) as handle:
        header = _npy_header(handle, where)
        offset = handle.tell()
    _check_stored(header, member.file_size - offset, where)
    return header


#: The first bytes of a zip archive (a local file header, or the end record of an empty one).
ZIP_SIGNATURES = (b"PK\x03\x04", b"PK\x05\x06")


def check_npz_signature(path: Path, what: str = "volume file") -> None:
    """Refuse an ``.npz`` that is neither a zip archive nor a ``.npy`` array by its first bytes
    (NumPy would try to unpickle it and say "pickled data"), naming the file and ``what``."""
    from numpy.lib import format as npy

    with open(path, "rb") as handle:
        head = handle.read(len(npy.MAGIC_PREFIX))
    if not (head.startswith(ZIP_SIGNATURES) or head == npy.MAGIC_PREFIX):
        raise ValueError(
            f"{path}: not an .npz archive (its first bytes are no zip signature); expected a "
            f"{what} written by numpy.savez"
        )


def _np_load(path: Path, limits: Limits):
    if path.suffix.lower() == ".npy":
        _check_npy(path, limits)
    elif path.suffix.lower() == ".npz":
        check_npz_signature(path)
    try:
        return np.load(path, allow_pickle=False)
    except _CORRUPT as error:
        raise ValueError(f"{path}: not a readable {path.suffix} file ({error})") from None


def _npz_budget(path: Path, data, names: list[str], limits: Limits) -> None:
    """Check the headers and memory of the grids to read, before inflating any of them: each
    grid as stored plus its float32 copy, and the float64 working set of building the Volume
    once, for the largest grid (whichever role it has)."""
    headers = []
    for name in names:
        if name not in data.files:
            continue  # reported by the reader with the grids the file has
        where = f"{path}: grid {name!r}"
        try:
            headers.append(_npz_header(data.zip, name, where))
        except _CORRUPT_BESIDES_VALUE as error:  # ValueErrors already name the grid
            raise ValueError(f"{where} cannot be read ({error})") from None
    voxels = [float(np.prod(h.shape, dtype=object)) for h in headers]
    total = sum(h.data_bytes + 4 * n for h, n in zip(headers, voxels, strict=True))
    total += (BYTES_PER_VOXEL - 4) * max(voxels, default=0.0)
    limits.check_memory(total, f"reading {', '.join(names)} from {path}")


#: ``.npz`` entries that place the grids (written by ``save_volume``), not grids themselves.
PLACEMENT_KEYS = ("voxel_size_m", "origin_m")


def _npz_placement(path: Path, data) -> tuple[tuple[float, float, float] | None, float | None]:
    """(origin_m, voxel_size_m) stored in the file, or None each."""
    if not set(PLACEMENT_KEYS) <= set(data.files):
        return None, None
    try:
        voxel = float(np.asarray(data["voxel_size_m"]).reshape(()))
        origin = np.asarray(data["origin_m"], dtype=np.float64).reshape(3)
    except (*_CORRUPT, TypeError) as error:
        raise ValueError(f"{path}: voxel_size_m/origin_m cannot be read ({error})") from None
    return (float(origin[0]), float(origin[1]), float(origin[2])), voxel


def _npz_reader(path: Path, data, limits: Limits) -> Callable[[Iterable[str]], Grids]:
    def read(names: Iterable[str]) -> Grids:
        names = list(names)
        _npz_budget(path, data, names, limits)
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
        return Grids(out, *_npz_placement(path, data))

    return read


def check_input_file(path: Path, what: str = "volume file") -> Path:
    """A path that names a regular file, or an error saying what it names instead."""
    import stat

    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such {what}") from None
    except OSError as error:
        raise ValueError(f"{path}: cannot read it ({error.strerror})") from None
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(f"{path}: is a folder, not a {what}")
    if not stat.S_ISREG(mode):
        kind = "FIFO (named pipe)" if stat.S_ISFIFO(mode) else "device or socket"
        raise ValueError(f"{path}: is a {kind}, not a regular file; expected a {what}")
    return path


def open_grids(
    path: str | Path,
    axes: str | None = None,
    limits: Limits | None = None,
    resolution: int | None = None,
) -> GridSource:
    """Open a volume file (errors name the file and the problem).

    ``axes``: the order of the stored array axes (e.g. "zyx") for files that do not say it
    (HDF5/NetCDF without axis metadata, .npy/.npz); arrays are returned in x, y, z order.
    ``limits``: NumPy grids are checked against them from their headers before their data are
    read (default: the memory available now). ``resolution``: voxels along the longest side of
    a VTK/OpenFOAM dataset resampled onto voxels (``io.vtk``; default chosen from its cells)."""
    path = Path(path)
    limits = limits or Limits()
    suffix = path.suffix.lower()
    if suffix in VTK_INPUT_SUFFIXES or (path.is_dir() and is_openfoam(path)):
        return open_vtk(path, resolution, limits)
    if os.path.lexists(path):
        check_input_file(path)
    if suffix not in SUFFIXES:
        got = repr(path.suffix) if path.suffix else "no suffix"
        raise ValueError(
            f"{path}: unsupported volume format ({got}); expected one of "
            f"{', '.join(SUFFIXES)} (or a .toml/.json scene file)"
        )
    check_input_file(path)
    if suffix in VDB_SUFFIXES:
        return open_source(path, limits)
    if suffix in SCIENCE_SUFFIXES:
        from incandescent.io.scientific import open_scientific

        return open_scientific(path, axes)
    data = _np_load(path, limits)
    if isinstance(data, np.ndarray):
        source = GridSource(path, ("temperature",), _npy_reader(path, data))
    else:
        names = tuple(n for n in data.files if n not in PLACEMENT_KEYS)
        source = GridSource(path, names, _npz_reader(path, data, limits))
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
    #: active voxels (tiles included), their inclusive index box, and the sum of their values
    #: (None where unknown: vectors, unreadable grids); dense files: every voxel is active
    active_voxels: int | None = None
    index_min: tuple[int, ...] | None = None
    index_max: tuple[int, ...] | None = None
    value_sum: float | None = None

    @property
    def readable(self) -> bool:
        return self.value_type != "?" and not (self.note or "").startswith("cannot be read")

    def as_json(self) -> dict:
        """The ``info --json`` record of this grid."""
        return {
            "name": self.name,
            "type": self.value_type,
            "active_voxels": self.active_voxels,
            "bbox_min": None if self.index_min is None else list(self.index_min),
            "bbox_max": None if self.index_max is None else list(self.index_max),
            "min": self.value_min,
            "max": self.value_max,
            "sum": self.value_sum,
            "readable": self.readable,
            "notes": self.note,
        }


def describe(
    path: str | Path, axes: str | None = None, resolution: int | None = None
) -> list[GridSummary]:
    """A summary of every grid in a volume file: type, shape, value range and sum, active
    voxels and their box, placement."""
    path = Path(path)
    if path.suffix.lower() in VDB_SUFFIXES and path.is_file():
        return _describe_vdb(path)
    source = open_grids(path, axes, resolution=resolution)
    return [_summary(source, name) for name in source.names]


#: Grids of a Blender Mantaflow (fire/smoke) cache; a file with these is one.
MANTAFLOW_GRIDS = frozenset({"density", "flame", "velocity"})


def file_warnings(path: str | Path, grids: list[GridSummary]) -> list[str]:
    """What ``info`` should say about the file as a whole (e.g. which preset fits it)."""
    names = {g.name for g in grids}
    if {"color", "density", "temperature"} <= names and "flame" in names:  # convert --for blender
        return [
            f"{Path(path).name} looks like a VDB written for Blender (convert --for blender: "
            "temperature in K, density = κ in 1/m, z up): render it with --up-axis z "
            "--absorption-grid density"
        ]
    if MANTAFLOW_GRIDS <= names and names & {"heat", "temperature"}:
        return [
            f"{Path(path).name} looks like a Blender Mantaflow cache (density, flame, heat or "
            "temperature, velocity): render it with --preset blender"
        ]
    return []


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
    total = float(np.nansum(values, dtype=np.float64)) if numeric else None
    box = (0, 0, 0), tuple(n - 1 for n in values.shape[:3])
    return GridSummary(
        name, str(values.dtype), values.shape, low, high, placement, note,
        int(values.size), *box, total,
    )  # fmt: skip


def _describe_vdb(path: Path) -> list[GridSummary]:
    out = []
    infos, sums = vdb.grids_with_sums(path)  # one listing of the file for both
    for g in infos:
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
                g.active_voxels,
                g.index_min,
                g.index_max,
                sums.get(g.name),
            )
        )
    return out
