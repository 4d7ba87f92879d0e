"""What a camera records of a volume: the renderer's radiance through a sensor's channels,
exposed into electrons and read out as a raw Bayer mosaic (``sensor``).

The render integrates the scene's spectral radiance against the sensor's k_c(λ) (its
observer): emission–absorption in spectral bins, so soot's κ_λ = κ·(550 nm/λ)^α shapes what
each channel sees; the float64 reference backend integrates every nanometre.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.camera import Camera
from incandescent.emission import Emission
from incandescent.io.raw import RawImage
from incandescent.renderer import RenderSettings, render
from incandescent.renderer.integrators import EmissionAbsorption
from incandescent.sensor import Sensor

#: Spectral bins of a camera render by default (soot's λ-dependence across each channel).
DEFAULT_BINS = 32


@dataclass(frozen=True, eq=False)
class Photograph:
    """A raw exposure: ``mosaic`` (H, W) uint16 DN, the mean ``electrons`` (H, W, 3) each
    channel would hold at every pixel, the ``sensor``, and whether noise was drawn."""

    mosaic: NDArray[np.uint16]
    electrons: NDArray[np.float64]
    sensor: Sensor
    noise: bool
    seed: int | None

    def raw(self) -> RawImage:
        """The mosaic as a raw file's image, every sensor parameter in its metadata."""
        sensor = self.sensor
        meta: dict[str, str | float | int] = {
            k: (
                v if isinstance(v, (int, float, str)) and not isinstance(v, bool) else json.dumps(v)
            )
            for k, v in sensor.parameters().items()
        }
        meta |= {"noise": str(self.noise), "seed": str(self.seed), "name": f"incandescent "
                 f"{sensor.sensitivity}"}  # fmt: skip
        return RawImage(self.mosaic, sensor.pattern, sensor.black_level_dn,
                        sensor.white_level_dn, sensor.bits, meta)  # fmt: skip


def electron_rates(
    volume,
    camera: Camera | None,
    settings: RenderSettings,
    sensor: Sensor,
    backend: str = "auto",
    spectral_bins: int = DEFAULT_BINS,
) -> NDArray:
    """ė_c per pixel (H, W, 3), e⁻/s on the axis: the render with the sensor's observer."""
    emission = Emission(observer=sensor.observer())
    integrator = EmissionAbsorption(spectral_bins=spectral_bins, emission=emission)
    image = render(volume, camera, settings, backend, integrator=integrator)
    assert image.xyz is not None, "emission–absorption renders radiance"
    return np.asarray(image.xyz, dtype=np.float64)


def cos4_map(camera: Camera | None, width: int, height: int) -> NDArray[np.float64]:
    """cos⁴θ of each pixel's ray off the optical axis (a pinhole of vertical ``fov_deg``; 1 for
    an orthographic camera or the default one)."""
    if camera is None or camera.projection != "perspective":
        return np.ones((height, width))
    half = np.tan(np.radians(camera.fov_deg) / 2)
    v = (1 - 2 * (np.arange(height) + 0.5) / height) * half
    u = (2 * (np.arange(width) + 0.5) / width - 1) * half * width / height
    tan2 = u[None, :] ** 2 + v[:, None] ** 2
    return 1.0 / (1.0 + tan2) ** 2


def photograph(
    volume,
    camera: Camera | None,
    settings: RenderSettings,
    sensor: Sensor,
    backend: str = "auto",
    seed: int | None = 0,
    noise: bool = True,
    spectral_bins: int = DEFAULT_BINS,
) -> Photograph:
    """The raw exposure of ``volume`` seen by ``camera`` through ``sensor`` (``settings``: the
    film, one pixel per photosite); refused in one line when it saturates every pixel."""
    rates = electron_rates(volume, camera, settings, sensor, backend, spectral_bins)
    cos4 = cos4_map(camera, settings.width, settings.height)
    electrons = sensor.mean_electrons(rates, cos4)
    sensor.check_exposure(electrons)
    return Photograph(sensor.mosaic(electrons, seed, noise), electrons, sensor, noise, seed)


def demosaic(raw: RawImage, method: str = "Menon2007") -> NDArray[np.float64]:
    """The raw image as linear camera RGB at every pixel, DN above black (H, W, 3): for viewing
    or for tools that want an RGB image. colour-demosaicing's ``Menon2007`` (Menon, Andriani &
    Calvagno 2007, IEEE TIP 16:132; directional, edge-aware) or ``bilinear`` (the ``camera``
    extra). Pyrometry does not use it: it estimates each channel at cell centres with exact
    variances (``pyrometry.superpixels``)."""
    import colour_demosaicing as cd

    methods = {"Menon2007": cd.demosaicing_CFA_Bayer_Menon2007,
               "bilinear": cd.demosaicing_CFA_Bayer_bilinear}  # fmt: skip
    if method not in methods:
        raise ValueError(f"unknown demosaicing {method!r}; expected one of: {', '.join(methods)}")
    signal = raw.mosaic.astype(np.float64) - raw.black_level_dn
    return np.asarray(methods[method](signal, raw.pattern), dtype=np.float64)
