"""Macrocell grid for empty-space skipping (majorant grid, cf. pbrt-v4 ``DDAMajorantIterator``).

Cell c covers voxel coordinates [c·S, (c+1)·S] on each axis. A trilinear sample anywhere in that
range reads voxels c·S−1 … (c+1)·S (DESIGN.md §4), so each cell stores the maximum κ over its voxels
*plus a one-voxel border*. A cell whose maximum is 0 therefore guarantees κ = 0 at every sample in
it, so skipping it leaves the image exactly unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class MacrocellGrid:
    """Per-cell maximum absorption (1/m) including a one-voxel border; ``cell_voxels`` = S."""

    max_absorption: NDArray[np.float32]
    cell_voxels: int

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(int(n) for n in self.max_absorption.shape)  # type: ignore[return-value]

    @property
    def empty_fraction(self) -> float:
        return float(np.mean(self.max_absorption == 0))


def _dilate_max(grid: NDArray) -> NDArray:
    """Maximum over each voxel's 3×3×3 neighbourhood (edges clamped)."""
    out = grid
    for axis in range(3):
        padded = np.concatenate([np.take(out, [0], axis), out, np.take(out, [-1], axis)], axis=axis)
        n = out.shape[axis]
        lo, mid, hi = (np.take(padded, range(s, s + n), axis) for s in (0, 1, 2))
        out = np.maximum(np.maximum(lo, mid), hi)
    return out


def build_macrocells(absorption_per_m: NDArray, cell_voxels: int = 8) -> MacrocellGrid:
    """Block maxima of the border-dilated absorption grid, cells of ``cell_voxels``³ voxels."""
    if not isinstance(cell_voxels, (int, np.integer)) or not 1 <= cell_voxels <= 64:
        raise ValueError(f"macrocell size must be an integer in 1..64 voxels; got {cell_voxels!r}")
    dilated = _dilate_max(np.asarray(absorption_per_m, dtype=np.float32))
    cells = [-(-n // cell_voxels) for n in dilated.shape]
    padded = np.zeros([c * cell_voxels for c in cells], dtype=np.float32)
    padded[tuple(slice(0, n) for n in dilated.shape)] = dilated
    blocks = padded.reshape(cells[0], cell_voxels, cells[1], cell_voxels, cells[2], cell_voxels)
    return MacrocellGrid(np.ascontiguousarray(blocks.max(axis=(1, 3, 5))), int(cell_voxels))
