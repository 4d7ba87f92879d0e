"""Host-side passes over big grids on every core, slab by slab along x.

A new volume costs passes over its grids before the first ray (macrocells, the κ and T scans,
the box around the absorbing voxels; the device layout is a Dr.Jit pass, ``backends.medium``).
NumPy releases the GIL inside its loops, so threads that each take one slab of x run those passes
in parallel; the results are the serial ones exactly (each pass is a max or a min, order-free).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")

#: Below this many voxels a pass runs on the calling thread: waking threads costs more.
MIN_PARALLEL_VOXELS = 1 << 20

_POOL: list[ThreadPoolExecutor] = []


def workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def bounds(n: int, parts: int, align: int = 1) -> list[tuple[int, int]]:
    """[lo, hi) ranges covering 0..n in ``parts`` slabs (fewer if n is small), each starting on a
    multiple of ``align`` (so a slab of macrocells holds whole cells)."""
    blocks = -(-n // align)
    parts = max(1, min(parts, blocks))
    edges = [min(n, (blocks * p // parts) * align) for p in range(parts + 1)]
    return [(lo, hi) for lo, hi in zip(edges, edges[1:], strict=False) if hi > lo]


def map_slabs(fn: Callable[[int, int], T], n: int, voxels: int, align: int = 1) -> list[T]:
    """``fn(lo, hi)`` for slabs of 0..n, in order; on the worker threads when the grid has
    ``voxels`` ≥ MIN_PARALLEL_VOXELS and this process has more than one core."""
    count = workers() if voxels >= MIN_PARALLEL_VOXELS else 1
    slabs = bounds(n, count, align)
    if len(slabs) == 1:
        return [fn(*slabs[0])]
    if not _POOL:
        _POOL.append(ThreadPoolExecutor(workers(), thread_name_prefix="incandescent-slab"))
    return list(_POOL[0].map(lambda b: fn(*b), slabs))
