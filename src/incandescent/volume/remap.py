"""Temperature remapping: a raw field → kelvin, ``T = (raw − offset)·scale``, voxels below
``cutoff_K`` vacuum (``docs/scene-files.md``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Remap:
    """Map a raw field to kelvin: ``T = (raw − offset)·scale``; T < ``cutoff_K`` is vacuum."""

    offset: float = 0.0
    scale: float = 1.0
    cutoff_K: float = 0.0

    def __post_init__(self) -> None:
        for name in ("offset", "scale", "cutoff_K"):
            value = float(getattr(self, name))
            if not np.isfinite(value):
                raise ValueError(f"remap {name} must be finite; got {value!r}")
        if self.scale <= 0:
            raise ValueError(f"remap scale must be > 0; got {self.scale!r}")
        if self.cutoff_K < 0:
            raise ValueError(f"remap cutoff_K must be >= 0 K; got {self.cutoff_K!r}")

    def apply(self, raw: NDArray) -> NDArray[np.float64]:
        return (raw - self.offset) * self.scale

    @classmethod
    def from_range(cls, low_K: float, high_K: float, cutoff_K: float = 0.0) -> Remap:
        """Map a normalised field linearly: raw 0 → ``low_K``, raw 1 → ``high_K``."""
        low, high = float(low_K), float(high_K)
        if not (np.isfinite(low) and np.isfinite(high)) or not 0 <= low < high:
            raise ValueError(
                f"temperature range must be LOW:HIGH in K, 0 <= LOW < HIGH; got {low_K}:{high_K}"
            )
        return cls(offset=-low / (high - low), scale=high - low, cutoff_K=cutoff_K)
