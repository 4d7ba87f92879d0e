"""The ``.vdb`` file header, checked before any library trusts its counts.

tinyvdb 0.9 allocates for the grid count before reading any grid (three flipped bytes in the
count made it commit 3.6 GB and spend 6 s); OpenVDB spends minutes on a file cut short inside a
grid. So both readers see a file only after its magic number, format version, metadata and
grid counts, and every grid's byte span, are checked here.
"""

from __future__ import annotations

import struct
from pathlib import Path

from incandescent.io.vdb.checks import library_error

_VDB_HEADER = struct.Struct("<QIIIB36s")  # magic, version, library major, minor, offsets, uuid
#: Fewest bytes a grid can take in a file (name, type and parent strings, three offsets).
_VDB_MIN_GRID_BYTES = 40


def check_vdb_file(path: Path) -> None:
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
        raise library_error(path, "cannot read the file", error) from None


def vdb_bytes(path: Path) -> bytes:
    """The file's bytes, with its magic number and header counts checked (before any library
    trusts them)."""
    try:
        data = path.read_bytes()
    except OSError as error:
        raise library_error(path, "cannot read the file", error) from None
    _check_vdb_magic(path, data)
    _check_vdb_header(path, data)
    return data


def _check_vdb_magic(path: Path, data) -> None:
    if len(data) < 8 or data[:4] != b"\x20\x42\x44\x56":  # OpenVDB magic 0x56444220 little-endian
        raise ValueError(f"{path}: not an OpenVDB file (no OpenVDB magic number at its start)")


def _check_vdb_header(path: Path, data) -> None:
    """Check the counts and grid offsets in the file header before a library trusts them.

    Header layout (file versions 220–225): magic, version, library version, has-grid-offsets
    flag, UUID, file metadata (count; name, type name and value, each length-prefixed), grid
    count, then per grid its name, type and parent (length-prefixed) and — with offsets — the
    int64 positions of its header, data blocks and end, where the next grid's descriptor starts.
    """
    try:
        _magic, version, _major, _minor, offsets, _uuid = _VDB_HEADER.unpack_from(data, 0)
        if not 220 <= version <= 225:
            raise ValueError(f"OpenVDB file format version {version}; tinyvdb reads 220–225")
        offset = _skip_file_metadata(data, _VDB_HEADER.size)
        (grids,) = struct.unpack_from("<i", data, offset)
        if not 0 <= grids <= (len(data) - offset) // _VDB_MIN_GRID_BYTES:
            raise ValueError(f"a grid count of {grids} in {len(data)} bytes")
        if offsets:
            _check_grid_offsets(data, offset + 4, grids)
    except (struct.error, ValueError) as error:
        raise library_error(path, "not a readable OpenVDB file, corrupt header", error) from None


def _skip_file_metadata(data, offset: int) -> int:
    """The byte offset just past the file metadata that starts at ``offset``."""
    (entries,) = struct.unpack_from("<i", data, offset)
    offset += 4
    if not 0 <= entries <= (len(data) - offset) // 12:
        raise ValueError(f"{entries} file metadata entries")
    for _ in range(3 * entries):  # name, type name, value: each a uint32 length + bytes
        (size,) = struct.unpack_from("<I", data, offset)
        offset += 4 + size
    return offset


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
