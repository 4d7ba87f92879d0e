"""A ``.vdb``/``.nvdb`` file as a :class:`~incandescent.io.grids.GridSource` (what
``io.volumes.open_grids`` returns): the file is listed once, and that listing serves the
source's names, its readability checks and its grids' largest values."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from incandescent.budget import Limits
from incandescent.io import vdb
from incandescent.io.grids import Grids, GridSource
from incandescent.io.vdb import via_openvdb
from incandescent.io.vdb.results import GridInfo

#: Host bytes per voxel per grid of a dense read: the float32 box, the float64 working copy of
#: validation and remapping, the Volume's float32 grid.
DENSE_READ_BYTES_PER_VOXEL = 4 + 8 + 4


def open_source(path: Path, limits: Limits) -> GridSource:
    """OpenVDB/NanoVDB through :mod:`incandescent.io.vdb`: the float grids it can read, densified
    onto the union of their active boxes (refused when the machine's memory cannot hold it),
    placed by the file's transform; where OpenVDB reads the file, also as sparse leaves."""
    listing = _Listing(path)
    infos = listing.plain  # names and readability are all a render needs

    def needed(names: Iterable[str]) -> list[str]:
        return _needed(path, infos, names)

    def read(names: Iterable[str]) -> Grids:
        return _read_dense(path, infos, needed(names), limits)

    def read_leaves(names: Iterable[str], z_up: bool, rings: int = 0):
        return vdb.read_leaves(path, needed(names), z_up, rings)

    def extent(names: Iterable[str]) -> tuple[int, int]:
        return vdb.box_and_active_voxels(path, needed(names))

    sparse = via_openvdb.reads(path)
    return GridSource(
        path,
        tuple(g.name for g in infos),
        read,
        read_leaves=read_leaves if sparse else None,
        extent=extent if sparse else None,
        value_max=lambda name: _largest(listing.ranged(), name),
    )


class _Listing:
    """One file's grids, listed once without value ranges (what a read needs); asked for the
    ranges, the same listing serves where it has them (tinyvdb, NanoVDB), else the file is
    listed once more with them (OpenVDB leaves them out unless asked) and that is kept."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.plain = vdb.list_grids(path, ranges=False)
        self._ranged = None if via_openvdb.reads(path) else self.plain

    def ranged(self) -> list[GridInfo]:
        """The grids with their value ranges."""
        if self._ranged is None:
            self._ranged = vdb.list_grids(self.path)
        return self._ranged


def _needed(path: Path, infos: list[GridInfo], names: Iterable[str]) -> list[str]:
    """The names a role needs; one that exists but cannot be read is an error saying why."""
    unreadable = {g.name: g.unreadable for g in infos if g.unreadable is not None}
    names = list(names)
    for name in names:
        if name in unreadable:
            raise ValueError(f"{path}: grid {name!r} is needed but {unreadable[name]}")
    return names


def _read_dense(path: Path, infos: list[GridInfo], names: list[str], limits: Limits) -> Grids:
    """Grids ``names`` densified onto one box, once ``limits`` say the memory is there."""
    box = _dense_box_voxels(infos, names)
    need = box * DENSE_READ_BYTES_PER_VOXEL * len(names)
    limits.check_memory(need, f"reading {', '.join(names)} of {path} densely ({box} voxels)")
    dense = vdb.read_grids(path, names, max_voxels=box)
    first = next(iter(dense.values()))
    arrays = {name: grid.values for name, grid in dense.items()}
    return Grids(arrays, first.origin_m, first.voxel_size_m)


def _largest(infos: list[GridInfo], name: str) -> tuple[float, float] | None:
    """(largest value — a vector grid's largest magnitude —, voxel side in m) of grid ``name``."""
    for info in infos:
        if info.name == name and info.value_max is not None:
            return float(info.value_max), float(info.voxel_size_m[0])
    return None


def _dense_box_voxels(infos: list[GridInfo], names: list[str]) -> int:
    """Voxels of the union of the named grids' active boxes (1 where none is known)."""
    known = [(i.index_min, i.index_max) for i in infos if i.name in names]
    boxes = [(lo, hi) for lo, hi in known if lo and hi]  # both or neither are known
    if not boxes:
        return 1
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    return int(np.prod(np.asarray(hi) - np.asarray(lo) + 1))
