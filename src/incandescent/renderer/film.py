"""HDRImage: the renderer's output — scene-referred absolute XYZ (or, for a display model such
as the 2011 paper's, display-referred RGB) plus metadata, no file I/O."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, eq=False)
class HDRImage:
    """A rendered image.

    Attributes
    ----------
    xyz: (H, W, 3) float32 absolute CIE XYZ; Y is luminance in cd/m². None for a
        display-referred image.
    transmittance: (H, W) float32 transmittance along each pixel's rays (1 = nothing in front).
    space: name of the RGB space :meth:`rgb` converts to by default.
    metadata: what made the image (backend, device, settings, samples, seconds, versions...).
    depth_m: (H, W) distance in m from the camera to the first emitting sample, the nearest over
        a pixel's sub-samples; inf where nothing emits.
    display_rgb: (H, W, 3) float32 display-referred sRGB values of a *display* emission model
        (the 2011 paper's sums, capped at 255: 8-bit code values, not radiometric), else None.
    layers: name → (H, W, 3) float32 XYZ of a part of the image (``renderer.layers``: emission,
        scatter.direct, scatter.indirect, light.N), written as EXR layers; empty by default.
    """

    xyz: NDArray[np.float32] | None
    transmittance: NDArray[np.float32]
    space: str = "srgb"
    metadata: dict = field(default_factory=dict)
    depth_m: NDArray[np.float32] | None = None
    display_rgb: NDArray[np.float32] | None = None
    layers: dict[str, NDArray[np.float32]] = field(default_factory=dict)

    @property
    def height(self) -> int:
        return int(self.transmittance.shape[0])

    @property
    def width(self) -> int:
        return int(self.transmittance.shape[1])

    @property
    def scene_xyz(self) -> NDArray[np.float32]:
        """``xyz``, or a clear error for a display-referred image (which has none)."""
        if self.xyz is None:
            raise ValueError(
                "this image is display-referred RGB (image.display_rgb: the 2011 paper's capped "
                "sums), not absolute XYZ; it has no luminance or scene-linear RGB"
            )
        return self.xyz

    @property
    def luminance(self) -> NDArray[np.float32]:
        """Y in cd/m², (H, W)."""
        return self.scene_xyz[..., 1]

    @property
    def alpha(self) -> NDArray[np.float32]:
        """Coverage 1 − transmittance, (H, W)."""
        return 1.0 - self.transmittance

    def rgb(self, space: str | None = None) -> NDArray[np.float32]:
        """Linear RGB (H, W, 3) in ``space`` (default: the image's), unclipped."""
        from incandescent.colorimetry import xyz_to_rgb

        return xyz_to_rgb(self.scene_xyz, space or self.space).astype(np.float32)

    def layer_rgb(self, name: str, space: str | None = None) -> NDArray[np.float32]:
        """Layer ``name``'s linear RGB (H, W, 3), as :meth:`rgb`."""
        from incandescent.colorimetry import xyz_to_rgb

        return xyz_to_rgb(self.layers[name], space or self.space).astype(np.float32)


def resolve_pixels(
    values: NDArray, width: int, height: int, supersample: int, reduce=np.mean
) -> NDArray:
    """Reduce (default: average) the s² sub-pixel values of column-major ray data (n, ...) into an
    (H, W, ...) image."""
    s2 = supersample * supersample
    tail = values.shape[1:]
    per_pixel = values.reshape((width, height, s2) + tail)
    per_pixel = per_pixel[:, :, 0] if s2 == 1 else reduce(per_pixel, axis=2)
    return np.ascontiguousarray(np.swapaxes(per_pixel, 0, 1))
