"""What every volume reader returns: named raw grids on one box of voxels, and a lazy source of
them (``io.volumes``, ``io.vdb``, ``io.scientific``)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from numpy.typing import NDArray


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
    #: (names, z_up) → ``io.vdb.LeafGrids``: the grids as occupied 8³ leaves, never densified
    #: (OpenVDB files where OpenVDB is installed); None where the format has no leaves
    read_leaves: Callable[[Iterable[str], bool], Any] | None = None
    #: names → (voxels of their box, most active voxels of one grid), from metadata alone
    extent: Callable[[Iterable[str]], tuple[int, int]] | None = None
    #: name → (the grid's largest value — a vector grid's largest magnitude —, its voxel side
    #: in m), or None where unknown
    value_max: Callable[[str], tuple[float, float] | None] | None = None
