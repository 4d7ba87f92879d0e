"""A rig of cameras rendered as one film: their images side by side, left to right.

Tomography renders every view of a set at every evaluation; as separate renders each view
costs a kernel trace and launch of its own, which on a GPU (where a 128² view marches in well
under a millisecond) is most of the time. A :class:`Rig` of V cameras on a film V·w pixels wide
marches all their rays in one launch: columns v·w … (v + 1)·w − 1 are camera v's w × h image,
its rays (``generate_rays``) exactly those camera v generates alone at w × h, so the ray index
of a pixel is its index in camera v's image plus v·w·h·s² (column-major film order).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.camera.camera import Camera


@dataclass(frozen=True)
class Rig:
    """Cameras (at least one, all of one projection) whose w × h images tile a film V·w wide."""

    cameras: tuple[Camera, ...]

    def __post_init__(self) -> None:
        cameras = tuple(self.cameras)
        if not cameras or not all(isinstance(c, Camera) for c in cameras):
            raise ValueError(f"a camera rig needs one or more Cameras; got {self.cameras!r:.80}")
        kinds = {c.projection for c in cameras}
        if len(kinds) > 1:
            raise ValueError(f"a camera rig's cameras must share one projection; got {kinds}")
        object.__setattr__(self, "cameras", cameras)

    @property
    def projection(self) -> str:
        return self.cameras[0].projection

    def view_width(self, width: int) -> int:
        """Each camera's image width, px, on a film ``width`` px wide (a multiple of V)."""
        count = len(self.cameras)
        if width % count:
            raise ValueError(f"a rig of {count} cameras needs a film width that is a multiple of "
                             f"{count}; got {width} px")  # fmt: skip
        return width // count

    def generate_rays(
        self, width: int, height: int, supersample: int = 1
    ) -> tuple[NDArray, NDArray]:
        """Every camera's rays at ``view_width(width)`` × ``height``, in film order."""
        w = self.view_width(width)
        parts = [c.generate_rays(w, height, supersample) for c in self.cameras]
        return np.concatenate([o for o, _ in parts]), np.concatenate([d for _, d in parts])

    def split(self, image: NDArray) -> list[NDArray]:
        """A film-shaped (H, V·w, …) array cut into the cameras' (H, w, …) images."""
        return np.split(np.asarray(image), len(self.cameras), axis=1)
