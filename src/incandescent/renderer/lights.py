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
#: The sun's mean angular diameter seen from the Earth, degrees (0.5332°: 2 × 959.63″, IAU).
SUN_DIAMETER_DEG = 0.5332
#: Most directions a disk light is integrated over.
MAX_DISK = 256
#: π(3 − √5): the golden angle, radians (Vogel 1979's spiral).
GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


@dataclass(frozen=True)
class DirectionalLight:
    """Light from a distant source in ``direction`` (toward the light, world axes; normalised),
    ``illuminance_lux`` on a plane facing it, with a blackbody spectrum at ``temperature_K`` (None:
    flat, equal-energy white).

    ``angular_diameter_deg`` 0 is a delta light (sharp shadows); above 0 the source is a disk of
    uniform radiance that wide (the sun: 0.53°), integrated over ``disk_samples`` directions of
    equal solid angle (:meth:`disk`), so shadows have penumbrae. :meth:`from_radiance` gives
    such a disk by its luminance instead of its illuminance."""

    direction: tuple[float, float, float]
    illuminance_lux: float = 1.0
    temperature_K: float | None = SUN_K
    angular_diameter_deg: float = 0.0
    disk_samples: int = 16

    def __post_init__(self) -> None:
        d = np.asarray(self.direction, dtype=np.float64)
        if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) == 0:
            raise ValueError(
                "a directional light needs a direction X,Y,Z toward the light (not all 0); got "
                f"{self.direction!r}"
            )
        object.__setattr__(self, "direction", tuple(float(v) for v in d / np.linalg.norm(d)))
        _check_amount(self, "illuminance_lux")
        diameter = _validate.finite_scalar(self.angular_diameter_deg, "angular_diameter_deg")
        if not 0 <= diameter < 180:
            raise ValueError(
                f"a directional light's angular_diameter_deg must be in [0, 180); got "
                f"{self.angular_diameter_deg!r}"
            )
        object.__setattr__(self, "angular_diameter_deg", float(diameter))
        n = self.disk_samples
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_DISK:
            raise ValueError(f"disk_samples must be an integer in 1..{MAX_DISK}; got {n!r}")
        object.__setattr__(self, "disk_samples", int(n))

    @classmethod
    def from_radiance(
        cls,
        direction,
        radiance_cd_m2: float,
        angular_diameter_deg: float,
        temperature_K: float | None = SUN_K,
        disk_samples: int = 16,
    ) -> DirectionalLight:
        """A disk of uniform luminance ``radiance_cd_m2`` (cd/m²) and ``angular_diameter_deg``:
        its illuminance on a plane facing it is E = L·π·sin²δ, δ the angular radius (a uniform
        disk's cosine-weighted solid angle). The sun's 1.6e9 cd/m² at 0.53° is ≈ 1.1e5 lux."""
        radiance = _validate.finite_scalar(radiance_cd_m2, "radiance_cd_m2")
        diameter = _validate.finite_scalar(angular_diameter_deg, "angular_diameter_deg")
        if radiance < 0 or not 0 < diameter < 180:
            raise ValueError(
                "a sun given by its radiance needs radiance_cd_m2 >= 0 and 0 < "
                f"angular_diameter_deg < 180; got {radiance_cd_m2!r} and {angular_diameter_deg!r}"
            )
        lux = radiance * np.pi * np.sin(np.radians(diameter / 2)) ** 2
        return cls(direction, float(lux), temperature_K, float(diameter), disk_samples)

    def disk(self) -> tuple[DirectionalLight, ...]:
        """The light as delta lights: itself if it is one, else ``disk_samples`` directions of
        equal solid angle Ω/N over the disk of angular radius δ (rings uniform in cos θ, turned
        by the golden angle: a Vogel spiral on the cap), each giving L·Ω/N = E·2/(N(1 + cos δ))
        — so Σ E_i cos θ_i = E, the illuminance on the plane facing the centre."""
        if self.angular_diameter_deg == 0.0:
            return (self,)
        n, cos_delta = self.disk_samples, np.cos(np.radians(self.angular_diameter_deg / 2))
        i = np.arange(n) + 0.5
        cos_t = 1.0 - (1.0 - cos_delta) * i / n
        sin_t, phi = np.sqrt(1.0 - cos_t**2), i * GOLDEN_ANGLE
        d = np.asarray(self.direction)
        u, v = _frame(d)
        around = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
        dirs = cos_t[:, None] * d + sin_t[:, None] * around
        each = self.illuminance_lux * 2.0 / (n * (1.0 + cos_delta))
        return tuple(DirectionalLight(tuple(x), each, self.temperature_K) for x in dirs)

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
class SpotLight(PointLight):
    """A point light at ``position_m`` shining along ``direction`` (world axes, normalised):
    ``intensity_cd`` on its axis, falling smoothly to 0 between ``cone_deg`` − ``falloff_deg``
    and ``cone_deg`` off the axis — pbrt-v4's ``spot`` (coneangle, conedelta): I·smoothstep
    (cos θ_cone, cos(θ_cone − Δ), cos θ)."""

    direction: tuple[float, float, float] = (0.0, -1.0, 0.0)
    cone_deg: float = 30.0
    falloff_deg: float = 5.0

    def __post_init__(self) -> None:
        super().__post_init__()
        d = np.asarray(self.direction, dtype=np.float64)
        if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) == 0:
            raise ValueError(
                f"a spot light needs a direction X,Y,Z it shines along (not all 0); got "
                f"{self.direction!r}"
            )
        object.__setattr__(self, "direction", tuple(float(v) for v in d / np.linalg.norm(d)))
        cone = _validate.finite_scalar(self.cone_deg, "cone_deg")
        falloff = _validate.finite_scalar(self.falloff_deg, "falloff_deg")
        if not 0 < cone <= 180 or not 0 <= falloff <= cone:
            raise ValueError(
                f"a spot light needs 0 < cone_deg <= 180 and 0 <= falloff_deg <= cone_deg; got "
                f"cone_deg {self.cone_deg!r}, falloff_deg {self.falloff_deg!r}"
            )
        object.__setattr__(self, "cone_deg", float(cone))
        object.__setattr__(self, "falloff_deg", float(falloff))

    def factor(self, cos_theta, clip):
        """The intensity's fraction at cos θ off the axis (``clip``: np.clip or dr.clip)."""
        end = float(np.cos(np.radians(self.cone_deg)))
        start = float(np.cos(np.radians(self.cone_deg - self.falloff_deg)))
        if start - end < 1e-12:  # no falloff: a hard edge
            return clip((cos_theta - end) * 1e30, 0.0, 1.0)
        t = clip((cos_theta - end) * (1.0 / (start - end)), 0.0, 1.0)
        return t * t * (3.0 - 2.0 * t)


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


@dataclass(frozen=True, eq=False, repr=False)
class EnvironmentMap:
    """A sky from an HDR lat-long (equirectangular) image: ``radiance_rgb`` (H, W, 3) linear
    Rec.709/sRGB-primaries values, W = 2H, × ``scale`` = radiance with Y in cd/m². Row 0 is the
    zenith (+y), the last row the nadir; column u ∈ [0, 1) is the azimuth φ = 2π(u − ½), the
    image's centre looking toward −z and u = ¾ toward +x: ω = (sin θ sin φ, cos θ, −sin θ cos φ)
    with θ = π·v. Sampled by its pixels' power (``integrators.environment_map``); like the
    uniform sky it lights the gas and is not the image's background."""

    radiance_rgb: NDArray
    scale: float = 1.0
    source: str = "an array"

    def __post_init__(self) -> None:
        rgb = np.asarray(self.radiance_rgb)
        where = f"environment map {self.source}"
        if rgb.ndim != 3 or rgb.shape[2] not in (3, 4) or rgb.shape[0] < 2:
            raise ValueError(f"{where}: expected a lat-long RGB image (H, W, 3); got {rgb.shape}")
        if rgb.shape[1] != 2 * rgb.shape[0]:
            raise ValueError(
                f"{where}: a lat-long map is twice as wide as high; got {rgb.shape[1]}×"
                f"{rgb.shape[0]} pixels"
            )
        if not np.issubdtype(rgb.dtype, np.floating):
            raise ValueError(f"{where}: expected a float (HDR) image; got {rgb.dtype}")
        rgb = rgb[..., :3].astype(np.float64)
        if not np.isfinite(rgb).all() or (rgb < 0).any():
            raise ValueError(f"{where}: its values must be finite and >= 0")
        object.__setattr__(self, "radiance_rgb", rgb)
        scale = _validate.finite_scalar(self.scale, "scale")
        if scale < 0:
            raise ValueError(f"scale must be >= 0; got {self.scale!r}")
        object.__setattr__(self, "scale", float(scale))

    @classmethod
    def from_file(cls, path, scale: float = 1.0) -> EnvironmentMap:
        """The map in the EXR file ``path`` (its R, G, B channels)."""
        from incandescent.io.images import read_exr

        if not str(path).lower().endswith(".exr"):
            raise ValueError(f"environment map {path}: expected an OpenEXR (.exr) lat-long image")
        return cls(read_exr(path)[0], scale, str(path))

    def xyz(self) -> NDArray[np.float64]:
        """The XYZ radiance per pixel (H, W, 3), Y in cd/m²."""
        from incandescent.colorimetry import rgb_to_xyz

        return rgb_to_xyz(self.radiance_rgb, "srgb") * self.scale

    def __repr__(self) -> str:
        h, w, _ = self.radiance_rgb.shape
        return f"EnvironmentMap({self.source}, {w}×{h}, scale={self.scale:g})"


#: A light with a direction or a position.
FixedLight = DirectionalLight | PointLight
#: A light the scattering integrators take.
Light = DirectionalLight | PointLight | EmissionLight | EnvironmentLight | EnvironmentMap


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


def _frame(d: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit vectors completing the unit ``d`` to a right-handed orthonormal frame."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(d, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(d, u)


def henyey_greenstein(cos_theta, g):
    """The Henyey–Greenstein phase function (1/sr) at the scattering angle's cosine
    (Henyey & Greenstein 1941, ApJ 93:70): p = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}),
    normalised over the sphere; g > 0 scatters forward (a number, or one per sample)."""
    denom = 1.0 + g * g - 2.0 * g * cos_theta
    return (1.0 - g * g) / (4.0 * np.pi * denom * denom**0.5)
