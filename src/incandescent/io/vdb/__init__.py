"""Reading OpenVDB ``.vdb`` and NanoVDB ``.nvdb`` grids into dense arrays (or OpenVDB leaves).

``.vdb`` is read with OpenVDB itself where it is installed (:mod:`.via_openvdb`, through the
worker of :mod:`incandescent.io.openvdb`), else with tinyvdb (:mod:`.tinyvdb`, leaf voxels
only); ``.nvdb`` with tinyvdb in a worker process (:mod:`.nanovdb`). Both ``.vdb`` readers see a
file only after its header is checked (:mod:`.header`); grids read together share one box and
transform (:mod:`.transform`). Why tinyvdb, what it cannot do (each an error here, never a
silent wrong answer) and the axis conventions: ``docs/design/vdb-readers.md``.

Conventions, in short: ``values[a, b, c]`` is the VDB voxel ``index_min + (a, b, c)`` (x, y, z as
in the renderer, no axis swapped); voxel centres sit at integer index coordinates, so the world
corner of the box is ``translation + (index_min − 0.5) · voxel_size`` (m).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from incandescent.io import openvdb
from incandescent.io.vdb import nanovdb, tinyvdb, via_openvdb
from incandescent.io.vdb.checks import MAX_DENSE_VOXELS, SUFFIXES, checked_path, unique_names
from incandescent.io.vdb.results import DenseGrid, GridInfo, LeafGrids
from incandescent.io.vdb.transform import TRANSFORM_RTOL

__all__ = [
    "MAX_DENSE_VOXELS",
    "SUFFIXES",
    "TRANSFORM_RTOL",
    "DenseGrid",
    "GridInfo",
    "LeafGrids",
    "box_and_active_voxels",
    "grid_sums",
    "grids_with_sums",
    "list_grids",
    "read_grid",
    "read_grids",
    "read_leaves",
]


def list_grids(path: str | Path, ranges: bool = True) -> list[GridInfo]:
    """Describe every grid in a ``.vdb`` or ``.nvdb`` file (errors name the file and problem).

    ``.vdb`` files are read with OpenVDB itself where it is installed (:mod:`.via_openvdb`), else
    with tinyvdb. Without ``ranges`` OpenVDB leaves out the value ranges (a vector grid's range
    visits every value in Python): what a read needs."""
    path = checked_path(path)
    if path.suffix.lower() == ".nvdb":
        return nanovdb.list_grids(path)
    if openvdb.interpreter():
        return via_openvdb.list_grids(path, ranges)
    return tinyvdb.list_grids(path)


def grid_sums(path: str | Path) -> dict[str, float]:
    """Sum of the active values (active tiles included, once per voxel they cover) of each float
    grid that can be read; OpenVDB computes it where installed, else tinyvdb's leaf voxels."""
    return grids_with_sums(path)[1]


def grids_with_sums(path: str | Path) -> tuple[list[GridInfo], dict[str, float]]:
    """:func:`list_grids` (with ranges) and :func:`grid_sums` of the file from one listing."""
    path = checked_path(path)
    if via_openvdb.reads(path):
        return via_openvdb.grids_with_sums(path)
    infos = list_grids(path)
    return infos, _summed(path, infos)


def _summed(path: Path, infos: list[GridInfo]) -> dict[str, float]:
    """Each readable float grid's sum of active values, from its dense box less the box voxels
    its background fills."""
    out = {}
    for info in infos:
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
    path = checked_path(path)
    names = unique_names(path, names)
    if path.suffix.lower() == ".nvdb":
        return nanovdb.read_grids(path, names, max_voxels)
    if openvdb.interpreter():
        return via_openvdb.read_grids(path, names, max_voxels)
    return tinyvdb.read_grids(path, names, max_voxels)


def read_leaves(
    path: str | Path, names: Sequence[str], z_up: bool = False, rings: int = 0
) -> LeafGrids:
    """Read grids as the occupied 8³ leaves of the union of their active boxes, and the leaves
    around them (``rings`` more rings for motion blur), with OpenVDB — never densifying the box
    (a big sparse cache stays sparse)."""
    path = checked_path(path)
    return via_openvdb.read_leaves(path, unique_names(path, names), z_up, rings)


def box_and_active_voxels(path: str | Path, names: Sequence[str]) -> tuple[int, int]:
    """(voxels of the union of the grids' active boxes, their most active voxels) from the
    file's description alone."""
    path = checked_path(path)
    return via_openvdb.extent(path, unique_names(path, names))
