"""Lights: a directional light (the sun), a point light and a uniform sky
(:class:`EnvironmentLight`), in photometric units, and the volume's own emission
(:class:`EmissionLight`).

A :class:`DirectionalLight` gives an illuminance E_v (lux) on a plane facing it, with the
spectrum of a blackbody at ``temperature_K`` (5778 K: the sun's effective temperature) or a flat
(equal-energy) one. In XYZ its irradiance is E_v·(x/y, 1, z/y) of that spectrum's chromaticity,
so the light scattered once by σ_s with phase p (1/sr) is radiance in cd/m² (= lux/sr). This is
pbrt-v4's `distant` light with its `scale` normalised to film-Y irradiance (pbrt divides by
∫ȳL), so E_v = 1 lux renders pbrt's film Y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent import _validate
from incandescent.spectra import blackbody_xyz

#: The sun's effective temperature, K (IAU 2015 nominal: 5772 K; 5778 K the common value).
SUN_K = 5778.0
#: A point light's default: CIE illuminant A, a tungsten-filament lamp, K.
POINT_K = 2856.0


@dataclass(frozen=True)
class DirectionalLight:
    """Light from a distant source in ``direction`` (toward the light, world axes; normalised),
    ``illuminance_lux`` on a plane facing it, with a blackbody spectrum at ``temperature_K`` (None:
    flat, equal-energy white)."""

    direction: tuple[float, float, float]
    illuminance_lux: float = 1.0
    temperature_K: float | None = SUN_K

    def __post_init__(self) -> None:
        d = np.asarray(self.direction, dtype=np.float64)
        if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) == 0:
            raise ValueError(
                "a directional light needs a direction X,Y,Z toward the light (not all 0); got "
                f"{self.direction!r}"
            )
        object.__setattr__(self, "direction", tuple(float(v) for v in d / np.linalg.norm(d)))
        _check_amount(self, "illuminance_lux")

    def irradiance_xyz(self) -> NDArray[np.float64]:
        """XYZ irradiance on a plane facing the light, Y = ``illuminance_lux``."""
        return _chroma(self.temperature_K) * self.illuminance_lux

    def xyz(self) -> NDArray[np.float64]:
        """What the light gives a sample before its transmittance: the XYZ irradiance (lux)."""
        return self.irradiance_xyz()


@dataclass(frozen=True)
class PointLight:
    """An isotropic point light at ``position_m`` (world, m) of ``intensity_cd`` candela, with a
    blackbody spectrum at ``temperature_K`` (None: flat): irradiance I/r² lux at r metres."""

    position_m: tuple[float, float, float]
    intensity_cd: float = 1.0
    temperature_K: float | None = POINT_K

    def __post_init__(self) -> None:
        p = np.asarray(self.position_m, dtype=np.float64)
        if p.shape != (3,) or not np.isfinite(p).all():
            raise ValueError(f"a point light needs a position X,Y,Z in m; got {self.position_m!r}")
        object.__setattr__(self, "position_m", tuple(float(v) for v in p))
        _check_amount(self, "intensity_cd")

    def xyz(self) -> NDArray[np.float64]:
        """The XYZ intensity (Y in cd); a sample at r m receives it / r²."""
        return _chroma(self.temperature_K) * self.intensity_cd


@dataclass(frozen=True)
class EmissionLight:
    """The volume's own emission as a light: the fire lighting its smoke (and itself). Sampled
    by its power over cells of the grid and by the phase function, combined by multiple
    importance sampling (``renderer.integrators.emission_light``); ``SingleScattering.spp`` sets
    the number of sample pairs."""


@dataclass(frozen=True)
class EnvironmentLight:
    """A uniform sky: radiance of ``luminance_cd_m2`` from every direction outside the box, with
    a blackbody spectrum at ``temperature_K`` (None: flat, equal-energy white). It lights the gas
    (sampled by the phase function, its transmittance marched to the box); the image's
    background stays the gas's own (transparent where nothing is), for compositing over a
    plate."""

    luminance_cd_m2: float = 1.0
    temperature_K: float | None = None

    def __post_init__(self) -> None:
        _check_amount(self, "luminance_cd_m2")

    def xyz(self) -> NDArray[np.float64]:
        """The XYZ radiance (Y in cd/m²)."""
        return _chroma(self.temperature_K) * self.luminance_cd_m2


#: A light with a direction or a position.
FixedLight = DirectionalLight | PointLight
#: A light the scattering integrators take.
Light = DirectionalLight | PointLight | EmissionLight | EnvironmentLight
#: The lights a scattering integrator samples by Monte Carlo.
SampledLight = EmissionLight | EnvironmentLight


def _check_amount(light, name: str) -> None:
    """A light's ``name`` (its illuminance or intensity) a finite number >= 0, stored as a float;
    its ``temperature_K`` None or > 0."""
    value = _validate.finite_scalar(getattr(light, name), name)
    if value < 0:
        raise ValueError(f"{name} must be >= 0; got {getattr(light, name)!r}")
    object.__setattr__(light, name, float(value))
    if light.temperature_K is not None:
        _validate.positive_scalar(light.temperature_K, "light temperature_K")


def _chroma(temperature_K: float | None) -> NDArray[np.float64]:
    """XYZ / Y of a blackbody at ``temperature_K``, or of the equal-energy white (None)."""
    if temperature_K is None:
        return np.ones(3)  # equal-energy white: x = y = z = 1/3
    xyz = blackbody_xyz(float(temperature_K))
    return xyz / xyz[1]


def henyey_greenstein(cos_theta, g: float):
    """The Henyey–Greenstein phase function (1/sr) at the scattering angle's cosine
    (Henyey & Greenstein 1941, ApJ 93:70): p = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}),
    normalised over the sphere; g > 0 scatters forward."""
    denom = 1.0 + g * g - 2.0 * g * cos_theta
    return (1.0 - g * g) / (4.0 * np.pi * denom * denom**0.5)
