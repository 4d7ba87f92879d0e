"""Macrocell grid for empty-space skipping (majorant grid, cf. pbrt-v4 ``DDAMajorantIterator``).

Cell c covers voxel coordinates [c·S, (c+1)·S] on each axis. A trilinear sample anywhere in that
range reads voxels c·S−1 … (c+1)·S (DESIGN.md §4), so each cell stores the maximum κ over its voxels
*plus a one-voxel border*. A cell whose maximum is 0 therefore guarantees κ = 0 at every sample in
it, so skipping it leaves the image exactly unchanged.

Each cell also stores its *empty radius* r: the Chebyshev distance, in cells, to the nearest cell
that is not empty (0 for such a cell). Every cell within r − 1 cells of an empty cell is empty too,
so a ray in it may jump to the exit of that (2r − 1)³ block of cells in one step (a distance field
over macrocells, the "proximity clouds" of Cohen & Sheffer 1994) instead of one cell at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent._parallel import map_slabs


@dataclass(frozen=True)
class MacrocellGrid:
    """Per-cell maximum absorption (1/m) including a one-voxel border; ``cell_voxels`` = S;
    ``empty_radius``: Chebyshev distance in cells to the nearest non-empty cell (float32)."""

    max_absorption: NDArray[np.float32]
    cell_voxels: int
    empty_radius: NDArray[np.float32]

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(n) for n in self.max_absorption.shape)  # type: ignore[return-value]

    @property
    def empty_fraction(self) -> float:
        return float(np.mean(self.max_absorption == 0))


def _extended_block_max(grid: NDArray, axis: int, s: int) -> NDArray:
    """Along ``axis``, cell c gets the maximum over voxels c·s − 1 … (c+1)·s (clamped to the grid).

    Applied to each axis in turn this is the maximum over each cell's box plus a one-voxel border,
    because a maximum over a box is separable. Elementwise maxima of every s-th layer (s strided
    views, one pass each), not a reduction over a reshaped axis: NumPy reduces a short contiguous
    axis (z) one cell at a time, ~10× slower on the (cx, cy, nz) pass.
    """
    g = np.moveaxis(grid, axis, 0)
    n = g.shape[0]
    cells, whole = -(-n // s), n // s
    out = np.empty((cells,) + g.shape[1:], dtype=np.float32)
    if whole:
        body = out[:whole]
        np.maximum(g[0 : whole * s : s], g[min(1, s - 1) : whole * s : s], out=body)
        for j in range(2, s):
            np.maximum(body, g[j : whole * s : s], out=body)
    if whole < cells:  # a last, partial cell (no copy of the grid to pad it)
        np.max(g[whole * s :], axis=0, out=out[whole])
    end = (cells - 1) * s
    np.maximum(out[:-1], g[s : end + 1 : s], out=out[:-1])  # first voxel of the next cell
    np.maximum(out[1:], g[s - 1 : end : s], out=out[1:])  # last voxel of the previous cell
    return np.moveaxis(out, 0, axis)


def _slab_maxima(grid: NDArray, s: int, lo: int, hi: int) -> NDArray:
    """The extended block maxima of the cells whose voxels along x are lo..hi − 1 (lo a multiple
    of s): along x first (the big pass), with the voxels just outside the slab, then y and z."""
    n = grid.shape[0]
    cells = _extended_block_max(grid[lo:hi], 0, s)
    if lo > 0:  # the last voxel of the previous slab
        cells[0] = np.maximum(cells[0], grid[lo - 1])
    if hi < n:  # the first voxel of the next slab
        cells[-1] = np.maximum(cells[-1], grid[hi])
    for axis in (1, 2):
        cells = _extended_block_max(cells, axis, s)
    return cells


def build_macrocells(absorption_per_m: NDArray, cell_voxels: int = 8) -> MacrocellGrid:
    """Per-cell maxima of κ over cells of ``cell_voxels``³ voxels plus a one-voxel border (slabs
    of cells along x on every core, ``slabs``)."""
    if not isinstance(cell_voxels, (int, np.integer)) or not 1 <= cell_voxels <= 64:
        raise ValueError(f"macrocell size must be an integer in 1..64 voxels; got {cell_voxels!r}")
    grid, s = np.asarray(absorption_per_m), int(cell_voxels)
    parts = map_slabs(lambda lo, hi: _slab_maxima(grid, s, lo, hi), grid.shape[0], grid.size, s)
    out = np.ascontiguousarray(np.concatenate(parts, axis=0))
    return MacrocellGrid(out, s, empty_radius(out > 0))


def _along(axis: int, part: slice) -> tuple[slice, ...]:
    """The index selecting ``part`` of ``axis`` in a 3-D array."""
    return tuple(part if a == axis else slice(None) for a in range(3))


def dilate_cells(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """``mask`` grown by one cell in every direction, diagonals included (Chebyshev radius 1):
    grown by one along each axis in turn (a cube is separable)."""
    out = mask
    for axis in range(3):
        grown = out.copy()
        head, tail = _along(axis, slice(1, None)), _along(axis, slice(None, -1))
        grown[head] |= out[tail]
        grown[tail] |= out[head]
        out = grown
    return out


def empty_radius(occupied: NDArray[np.bool_]) -> NDArray[np.float32]:
    """Chebyshev distance (in cells) from each cell to the nearest occupied cell; 0 on occupied
    cells; the largest side of the grid where no cell is occupied. Grown one ring at a time: a
    cell's distance is the number of rings that have not reached it yet."""
    limit = max(occupied.shape)
    if not occupied.any():
        return np.full(occupied.shape, float(limit), dtype=np.float32)
    radius = np.zeros(occupied.shape, dtype=np.float32)
    reached = occupied
    for _ in range(limit):
        if reached.all():
            break
        radius += ~reached
        reached = dilate_cells(reached)
    return radius


def dilated(cells: MacrocellGrid, rings: int) -> MacrocellGrid:
    """``cells`` with every non-empty cell grown by ``rings`` cells (Chebyshev): under motion
    blur a sample reads the medium up to ``rings`` cells from its own, so a cell is empty only if
    every cell that near is (the maxima are not kept: the kernel reads only the radius)."""
    if rings <= 0:
        return cells
    occupied = cells.max_absorption > 0
    for _ in range(min(rings, max(occupied.shape))):
        occupied = dilate_cells(occupied)
    marked = occupied.astype(np.float32)
    return MacrocellGrid(marked, cells.cell_voxels, empty_radius(occupied))
