"""Render settings: a frozen, validated value (change with :meth:`RenderSettings.replace`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from incandescent import _validate

BRIGHTNESS_LAWS = ("physical",)


def _positive_int(value: int, name: str, maximum: int = 1 << 15) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= maximum:
        raise ValueError(f"{name} must be an integer in 1..{maximum}; got {value!r}")


@dataclass(frozen=True)
class RenderSettings:
    """How to render.

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
    space: RGB space of the output image (see incandescent.colorimetry).
    observer: CIE observer, "cie1931_2" or "cie1964_10".
    constants: Planck constant set ("codata2018", "cie", "paper").
    brightness: brightness law; "physical" is absolute Planck radiance.
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
    observer: str = "cie1931_2"
    constants: str = "codata2018"
    brightness: str = "physical"

    def __post_init__(self) -> None:
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
        _validate.choice(self.brightness, "brightness law", BRIGHTNESS_LAWS)

    def replace(self, **changes) -> RenderSettings:
        return replace(self, **changes)
