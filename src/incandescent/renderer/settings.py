"""Render settings: the film and the sampling, a frozen, validated value (change with
:meth:`RenderSettings.replace`). How light is transported is the integrator's
(``renderer.integrators``), how the gas emits the emission models' (``incandescent.emission``)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from incandescent import _validate

#: Device layouts of the grids: "dense" padded grids, "sparse" 8³ bricks of the occupied leaves
#: (``renderer.backends.layout``), "auto" chooses by occupancy and memory.
LAYOUTS = ("auto", "dense", "sparse")


def _positive_int(value: int, name: str, maximum: int = 1 << 15) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer in 1..{maximum}; got {value!r}")
    if not 1 <= value <= maximum:
        raise ValueError(f"{name} must be an integer in 1..{maximum}; got {int(value)}")


@dataclass(frozen=True)
class RenderSettings:
    """How to render: the image, the step lattice and the sampling.

    Attributes
    ----------
    width, height: image size in pixels.
    step_voxels: ray-march step in voxels (0.25–0.5 typical; any > 0 is exact for uniform media).
    supersample: N for N×N rays per pixel.
    jitter: per-pixel seeded random offset of the step lattice (removes banding, reproducible).
    seed: jitter seed.
    min_transmittance: early termination once the transmittance falls below this.
    skip_empty: empty-space skipping with a macrocell grid (does not change the image).
    macrocell_voxels: macrocell side in voxels.
    space: RGB space of the image's linear RGB (see incandescent.colorimetry).
    layout: "auto", "dense" or "sparse": how the grids are laid out for the march (images are
        equal; sparse keeps only occupied 8³ bricks, see ``renderer.layout``).
    shutter: (open, close) in frames relative to the frame's instant (e.g. (-0.25, 0.25): a
        180° shutter centred on it), or None: no motion blur. Each ray gets a time in it
        (stratified over the N×N rays of a pixel) and κ, T are sampled at x − v(x)·t from the
        volume's velocity grid (first-order backward advection, as Cycles and Arnold do).
    fps: frames per second: a frame lasts 1/fps s (converts the shutter to seconds).
    """

    width: int = 512
    height: int = 512
    step_voxels: float = 0.5
    supersample: int = 1
    jitter: bool = True
    seed: int = 0
    min_transmittance: float = 1e-4
    skip_empty: bool = True
    macrocell_voxels: int = 8
    space: str = "srgb"
    layout: str = "auto"
    shutter: tuple[float, float] | None = None
    fps: float = 24.0

    def __post_init__(self) -> None:
        for name in ("width", "height", "supersample", "macrocell_voxels", "seed"):
            value = getattr(self, name)
            if isinstance(value, np.integer):  # NumPy integers are integers: store plain ints
                object.__setattr__(self, name, int(value))
        _positive_int(self.width, "width")
        _positive_int(self.height, "height")
        _positive_int(self.supersample, "supersample", 16)
        _positive_int(self.macrocell_voxels, "macrocell_voxels", 64)
        step = _validate.positive_scalar(self.step_voxels, "step_voxels")
        if step > 64:
            raise ValueError(f"step_voxels must be <= 64 voxels; got {step!r}")
        if not 0 <= float(self.min_transmittance) < 1:
            raise ValueError(f"min_transmittance must be in [0, 1); got {self.min_transmittance!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer; got {self.seed!r}")
        _validate.choice(self.layout, "layout", LAYOUTS)
        _check_shutter(self.shutter)
        if self.shutter is not None:  # a list from a scene file: store a tuple of floats
            object.__setattr__(self, "shutter", tuple(float(v) for v in self.shutter))
        fps = _validate.positive_scalar(self.fps, "fps")
        if fps > 10_000:
            raise ValueError(f"fps must be <= 10000 frames per second; got {self.fps!r}")

    def replace(self, **changes) -> RenderSettings:
        return replace(self, **changes)

    @property
    def shutter_s(self) -> tuple[float, float] | None:
        """The shutter interval in seconds from the frame's instant, or None (no blur)."""
        if self.shutter is None:
            return None
        return (self.shutter[0] / self.fps, self.shutter[1] / self.fps)


def _check_shutter(shutter) -> None:
    """None, or (open, close) in frames with −1 ≤ open ≤ close ≤ 1."""
    if shutter is None:
        return
    try:
        low, high = (float(v) for v in shutter)
    except (TypeError, ValueError):
        raise ValueError(f"shutter must be (open, close) in frames; got {shutter!r}") from None
    if not (np.isfinite(low) and np.isfinite(high) and -1.0 <= low <= high <= 1.0):
        raise ValueError(
            "shutter must be (open, close) in frames with -1 <= open <= close <= 1; "
            f"got {shutter!r}"
        )
