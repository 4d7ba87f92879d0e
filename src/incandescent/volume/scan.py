"""Fast scans of big grids: the smallest and largest positive values of κ in one cache-friendly
pass over float32 bits (what tells a two-valued κ from a graded one, ``Volume``)."""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

#: Values per chunk of the κ scan (1 MB, in cache; smaller chunks made the slab threads contend
#: for the GIL).
SCAN_CHUNK = 1 << 18


def positive_range(values: NDArray, graded: threading.Event | None = None) -> tuple[float, float]:
    """(smallest, largest) of the values > 0 (≥ 0 elsewhere, as validated); (inf, 0) if there are
    none. One pass in cache-sized chunks; for float32 over the bits, which order as the values do:
    bits − 1 wraps 0 (and −0) above every finite value, so its minimum + 1 is the smallest positive
    value's bits (1.5× faster than a masked ``min(where=values > 0)``).

    With ``graded``, stops at the first chunk after two different positive values were seen here
    (then sets it) or it was set elsewhere: a graded κ is known as such after one chunk.
    """
    flat = np.ascontiguousarray(values).reshape(-1)
    low, peak = np.inf, 0.0
    scratch = np.empty(min(flat.size, SCAN_CHUNK), np.uint32)
    for start in range(0, flat.size, SCAN_CHUNK):
        chunk = flat[start : start + SCAN_CHUNK]
        peak = max(peak, float(chunk.max()))
        if peak > 0:
            low = min(low, smallest_positive(chunk, scratch))
        if graded is not None and (graded.is_set() or low < peak):
            graded.set()
            break
    return low, peak


def smallest_positive(chunk: NDArray, scratch: NDArray[np.uint32]) -> float:
    """The smallest value > 0 of a chunk of values ≥ 0; inf if none (see ``positive_range``)."""
    if chunk.dtype != np.float32:
        return float(chunk.min(where=chunk > 0, initial=np.inf))
    below = np.subtract(chunk.view(np.uint32), np.uint32(1), out=scratch[: chunk.size])
    bits = int(below.min()) + 1
    return float(np.uint32(bits).view(np.float32)) if 0 < bits <= 0x7F800000 else np.inf
