"""The scene schema: one pydantic model shared by scene files, the Python API and CLI flags.

Every section forbids unknown keys and is frozen. Values are checked by the objects they build —
:class:`~incandescent.renderer.settings.RenderSettings`,
:class:`~incandescent.imaging.pipeline.DisplaySettings`, :class:`~incandescent.camera.Camera`,
:class:`~incandescent.volume.grid.Remap` and :class:`~incandescent.volume.grid.Volume` — so the
rules live in one place; their ``ValueError``/``TypeError`` become pydantic errors located at the
section. Relative paths are resolved by :mod:`incandescent.config.load`, not here.

Sections and keys (defaults in brackets)::

    [volume]            path (required), preset, preset_options = {name = number},
                        absorption (constant κ, 1/m), voxel_size_m, origin_m = [x, y, z]
    [volume.grids]      temperature, absorption, emission_scale, sodium_fraction, density, flame
                        (role = grid name in the file; absent = found by alias)
    [volume.temperature] offset, scale [0, 1] | range = [LOW, HIGH] (K); cutoff_K [0]
                        soot_alpha [1] (κ_λ = κ·(550 nm/λ)^α in spectral bins)
    [camera]            eye, target, up, fov_deg, projection, ortho_height_m (absent = default view)
    [render]            the RenderSettings fields (film and sampling)
    [integrator]        type ["emission_absorption"] and that integrator's parameters
                        (emission_absorption: spectral_bins [0]; paper2011: exponent [1.5],
                        gain, min_K [800]) — ``renderer.integrators``
    [emission]          observer ["cie1931_2"], constants ["codata2018"], line_table
    [display]           the DisplaySettings fields; space [= render.space]
    [output]            path, overwrite [false], stats (JSON path), backend ["auto"]
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import ClassVar, Literal, TypeVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from incandescent.camera.camera import Camera, default_camera
from incandescent.colorimetry.rgb_spaces import rgb_space
from incandescent.emission import Emission
from incandescent.imaging.pipeline import DisplaySettings
from incandescent.renderer.backends import BACKENDS
from incandescent.renderer.integrators import (
    EmissionAbsorption,
    Integrator,
    SingleScattering,
    integrator_from_dict,
)
from incandescent.renderer.lights import (
    POINT_K,
    SUN_K,
    DirectionalLight,
    EmissionLight,
    EnvironmentLight,
    EnvironmentMap,
    Light,
    PointLight,
    SpotLight,
)
from incandescent.renderer.settings import RenderSettings
from incandescent.sensor import Filter, Sensor
from incandescent.volume.grid import Remap, Volume, check_soot_alpha
from incandescent.volume.presets import ROLES, preset_parameters

__all__ = [
    "CameraSection",
    "DisplaySection",
    "EmissionSection",
    "GridNames",
    "IntegratorSection",
    "LightSection",
    "OutputSection",
    "RenderSection",
    "Scene",
    "TemperatureMap",
    "VolumeSection",
]

T = TypeVar("T")
Vec3 = tuple[float, float, float]
BACKEND_CHOICES = ("auto", *BACKENDS)


def _checked(build: Callable[[], T]) -> T:
    """Run a constructor; its ValueError/TypeError becomes one pydantic error with its message."""
    try:
        return build()
    except (ValueError, TypeError) as error:
        raise PydanticCustomError("setting", "{message}", {"message": str(error)}) from None


def _fail(message: str) -> PydanticCustomError:
    return PydanticCustomError("setting", "{message}", {"message": message})


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class GridNames(_Section):
    """Role → grid name in the volume file; a role left out is found through the aliases of
    :data:`incandescent.volume.presets.ROLE_ALIASES`."""

    temperature: str | None = None
    absorption: str | None = None
    emission_scale: str | None = None
    sodium_fraction: str | None = None
    density: str | None = None
    flame: str | None = None
    velocity: str | None = None

    def given(self) -> dict[str, str]:
        """The roles named explicitly."""
        return {role: getattr(self, role) for role in ROLES if getattr(self, role) is not None}


class TemperatureMap(_Section):
    """Raw field → kelvin: ``T = (raw − offset)·scale``, or ``range = [LOW, HIGH]`` mapping a
    normalised 0..1 field linearly to LOW..HIGH K; voxels below ``cutoff_K`` are vacuum."""

    offset: float | None = None
    scale: float | None = None
    cutoff_K: float = 0.0
    range: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _check(self) -> TemperatureMap:
        if self.range is not None:
            given = [k for k in ("offset", "scale") if getattr(self, k) is not None]
            if given:
                raise _fail(
                    f"give range = [LOW, HIGH] or offset/scale, not both (got range and "
                    f"{' and '.join(given)})"
                )
            low, high = self.range
            if not 0.0 <= low < high:
                raise _fail(
                    f"range = [LOW, HIGH] needs 0 <= LOW < HIGH (K); got {list(self.range)}"
                )
        _checked(self.remap)
        return self

    @property
    def is_identity(self) -> bool:
        """True when no offset, scale or range is given (raw values are kelvin)."""
        return self.range is None and self.offset is None and self.scale is None

    def remap(self) -> Remap:
        if self.range is not None:
            return Remap.from_range(*self.range, cutoff_K=self.cutoff_K)
        offset = 0.0 if self.offset is None else self.offset
        scale = 1.0 if self.scale is None else self.scale
        return Remap(offset=offset, scale=scale, cutoff_K=self.cutoff_K)


class VolumeSection(_Section):
    """Where the grids come from and how they become kelvin, κ and a world placement."""

    path: Path
    grids: GridNames = Field(default_factory=GridNames)
    temperature: TemperatureMap = Field(default_factory=TemperatureMap)
    preset: str | None = None
    preset_options: dict[str, float] = Field(default_factory=dict)
    absorption: float | None = None
    voxel_size_m: float | None = None
    origin_m: Vec3 | None = None
    #: The source's up axis: "y" (ours, Houdini) or "z" (Blender); None: the preset's, else "y".
    up_axis: Literal["y", "z"] | None = None
    #: Emitting species: name → fraction grid name in the file, or a constant fraction (0..1).
    species: dict[str, str | float] = Field(default_factory=dict)
    #: Order of the stored array axes (e.g. "zyx") where the file does not say it.
    axes: Literal["xyz", "xzy", "yxz", "yzx", "zxy", "zyx"] | None = None
    #: Voxels along the longest side of a VTK/OpenFOAM dataset resampled onto voxels
    #: (``io.vtk``); None: chosen from its cell count.
    resolution: int | None = Field(default=None, ge=1, le=4096)
    #: Up-resolve a simulated frame 2, 3 or 4× with sub-grid turbulence from its velocity grid
    #: (``simulation.upres``, Kim et al. 2008); None: as stored.
    upres: Literal[2, 3, 4] | None = None
    #: Units of the velocity grid (motion blur): metres per second, or voxels per frame; and a
    #: factor on it (Blender's Volume "Velocity Scale": Mantaflow stores cells per its own time
    #: unit, proportional to the domain's resolution, so a bake needs its factor).
    velocity_units: Literal["m/s", "voxels/frame"] = "m/s"
    velocity_scale: float = Field(default=1.0, ge=0.0, allow_inf_nan=False)
    #: The absorption's spectral law κ_λ = κ·(550 nm/λ)^α (``Volume.soot_alpha``).
    soot_alpha: float = 1.0
    #: Scattering σ_s: a constant (1/m) or the name of a grid in the file; or ``albedo``
    #: σ_s/(σ_s + κ); Henyey–Greenstein asymmetry ``phase_g``, a constant or a grid's name
    #: (``Volume.with_scattering``).
    scattering: float | str | None = None
    albedo: float | None = None
    phase_g: float | str = 0.0
    #: The scattering's spectral law σ_s,λ = σ_s·(550 nm/λ)^β in spectral bins
    #: (``Volume.scattering_alpha``; 0 grey, 4 Rayleigh).
    scattering_alpha: float = 0.0

    @model_validator(mode="after")
    def _check(self) -> VolumeSection:
        if self.preset is None and self.preset_options:
            raise _fail("preset_options given without a preset")
        if self.preset is not None:
            _checked(lambda: preset_parameters(self.preset or "", self.preset_options))
            if not self.temperature.is_identity:
                raise _fail(
                    f"preset {self.preset!r} maps temperature itself; remove temperature.offset/"
                    "scale/range (temperature.cutoff_K may stay)"
                )
        if self.absorption is not None and self.grids.absorption is not None:
            raise _fail(
                "give absorption (a constant, 1/m) or grids.absorption (a grid name), not both"
            )
        _checked(lambda: check_soot_alpha(self.soot_alpha))
        _checked(lambda: check_soot_alpha(self.scattering_alpha, "scattering_alpha"))
        _scattering_problem(self)
        one_voxel = np.ones((1, 1, 1))
        _checked(
            lambda: Volume.from_arrays(
                one_voxel,
                absorption=self.absorption,
                voxel_size_m=self.voxel_size_m,
                origin_m=self.origin_m,
                source="volume",
            )
        )
        return self


def _scattering_problem(section: VolumeSection) -> None:
    """σ_s, albedo and g checked as ``Volume.with_scattering`` checks them (on one voxel)."""
    if isinstance(section.scattering, str) and section.albedo is not None:
        raise _fail('give scattering (1/m, a grid name or "preset") or albedo, not both')
    if section.scattering == "preset" and section.preset is None:
        raise _fail('scattering = "preset" splits a preset\'s smoke: name the preset (blender, '
                    "houdini, embergen, openfoam)")  # fmt: skip
    constant = None if isinstance(section.scattering, str) else section.scattering
    g = 0.0 if isinstance(section.phase_g, str) else section.phase_g  # a grid: checked when read
    one = Volume.from_arrays(np.ones((1, 1, 1)), absorption=1.0, source="volume")
    try:
        one.with_scattering(constant, section.albedo, g)
    except ValueError as error:
        raise _fail(str(error).removeprefix("volume: ")) from None


class CameraSection(_Section):
    """A look-at camera; keys left out come from the default three-quarter view of the volume."""

    eye: Vec3 | None = None
    target: Vec3 | None = None
    up: Vec3 | None = None
    fov_deg: float | None = None
    projection: str | None = None
    ortho_height_m: float | None = None

    def given(self) -> dict[str, object]:
        return {k: v for k, v in self.__dict__.items() if v is not None}

    @model_validator(mode="after")
    def _check(self) -> CameraSection:
        given = self.given()
        if self.eye is not None and self.target is not None:
            _checked(lambda: Camera(**given))  # type: ignore[arg-type]
        else:  # scalars only: the view is not known until the volume is
            scalars = {k: v for k, v in given.items() if k not in ("eye", "target", "up")}
            _checked(lambda: Camera(eye=(0.0, 0.0, 1.0), **scalars))  # type: ignore[arg-type]
        return self


def _dataclass_default(cls: type, name: str) -> object:
    return cls.__dataclass_fields__[name].default  # type: ignore[attr-defined]


class RenderSection(_Section):
    """The fields of :class:`~incandescent.renderer.settings.RenderSettings` (same names, defaults
    and rules)."""

    width: int = RenderSettings.width
    height: int = RenderSettings.height
    step_voxels: float = RenderSettings.step_voxels
    supersample: int = RenderSettings.supersample
    jitter: bool = RenderSettings.jitter
    seed: int = RenderSettings.seed
    min_transmittance: float = RenderSettings.min_transmittance
    skip_empty: bool = RenderSettings.skip_empty
    macrocell_voxels: int = RenderSettings.macrocell_voxels
    space: str = RenderSettings.space
    layout: str = RenderSettings.layout
    shutter: tuple[float, float] | None = None
    fps: float = RenderSettings.fps

    @model_validator(mode="after")
    def _check(self) -> RenderSection:
        _checked(self.settings)
        _checked(lambda: rgb_space(self.space))
        return self

    def settings(self) -> RenderSettings:
        return RenderSettings(**self.model_dump())


class EmissionSection(_Section):
    """The fields of :class:`~incandescent.emission.Emission`: how the gas emits."""

    observer: str = Emission.observer
    constants: str = Emission.constants
    line_table: str | None = None

    @model_validator(mode="after")
    def _check(self) -> EmissionSection:
        _checked(self.emission)
        return self

    def emission(self) -> Emission:
        return Emission(**self.model_dump())


class IntegratorSection(BaseModel):
    """``type``: a name in :data:`~incandescent.renderer.integrators.INTEGRATORS`; every other
    key is a parameter of that integrator (as Mitsuba 3's plugin dicts), checked by building it."""

    model_config = ConfigDict(extra="allow", frozen=True, strict=True, allow_inf_nan=False)

    type: str = EmissionAbsorption.name

    @model_validator(mode="after")
    def _check(self) -> IntegratorSection:
        if "type" in self.model_fields_set:  # else lights may choose it: the scene checks it
            _checked(lambda: self.integrator(Emission()))
        return self

    def parameters(self) -> dict[str, object]:
        """The integrator's parameters given (every key but ``type``)."""
        return dict(self.model_extra or {})

    def integrator(self, emission: Emission, lights: tuple = ()) -> Integrator:
        """The integrator; one that takes emission models gets ``emission``, one that takes
        lights gets ``lights``."""
        spec = {"type": self.type, **self.parameters()}
        return integrator_from_dict(spec, emission=emission, lights=lights)


@functools.lru_cache(maxsize=4)
def _environment_map(path: Path, scale: float) -> EnvironmentMap:
    """The lat-long map in ``path`` (read once per path and scale: the scene builds its lights
    more than once)."""
    return EnvironmentMap.from_file(path, scale)


class LightSection(_Section):
    """One ``[[light]]``: ``type = "directional"`` (``direction`` toward it, ``illuminance_lux``
    or ``radiance_cd_m2`` of a disk ``angular_diameter_deg`` wide, ``disk_samples``) or
    ``"point"`` (``position_m``, ``intensity_cd``) or ``"spot"`` (also ``direction`` it shines
    along, ``cone_deg``, ``falloff_deg``), with ``temperature_K``; ``"environment"`` (a uniform
    sky: ``luminance_cd_m2``, ``temperature_K`` or flat), or ``"emission"`` (the volume's own
    emission, no keys) (``renderer.lights``).
    """

    type: Literal["directional", "point", "spot", "environment", "emission"] = "directional"
    direction: Vec3 | None = None
    illuminance_lux: float = 1.0
    radiance_cd_m2: float | None = None
    angular_diameter_deg: float = 0.0
    disk_samples: int = 16
    position_m: Vec3 | None = None
    intensity_cd: float = 1.0
    cone_deg: float = 30.0
    falloff_deg: float = 5.0
    luminance_cd_m2: float = 1.0
    map: Path | None = None
    scale: float = 1.0
    temperature_K: float | None = None

    #: the keys each type takes besides ``type``
    KEYS: ClassVar[dict[str, set[str]]] = {
        "directional": {
            "direction",
            "illuminance_lux",
            "radiance_cd_m2",
            "angular_diameter_deg",
            "disk_samples",
            "temperature_K",
        },
        "point": {"position_m", "intensity_cd", "temperature_K"},
        "spot": {
            "position_m",
            "direction",
            "intensity_cd",
            "cone_deg",
            "falloff_deg",
            "temperature_K",
        },
        "environment": {"luminance_cd_m2", "temperature_K", "map", "scale"},
        "emission": set(),
    }

    @model_validator(mode="after")
    def _check(self) -> LightSection:
        extra = sorted(self.model_fields_set - {"type"} - self.KEYS[self.type])
        if extra:
            takes = ", ".join(sorted(self.KEYS[self.type])) or "no keys"
            article = "an" if self.type[0] in "aeiou" else "a"
            raise _fail(f"{article} {self.type} light takes {takes}; got {', '.join(extra)}")
        if self.type == "environment" and self.map is not None:
            clash = sorted(self.model_fields_set & {"luminance_cd_m2", "temperature_K"})
            if clash:
                raise _fail(f"an environment map's colour and level are its pixels × scale; "
                            f"got {', '.join(clash)} too")  # fmt: skip
        if {"illuminance_lux", "radiance_cd_m2"} <= self.model_fields_set:
            raise _fail("a directional light is given by illuminance_lux or radiance_cd_m2 "
                        "(with angular_diameter_deg); got both")  # fmt: skip
        if self.type in ("emission", "environment"):
            _checked(self.light)
            return self
        needed = {"directional": ("direction",), "point": ("position_m",)}.get(
            self.type, ("position_m", "direction")
        )
        for key in needed:
            if getattr(self, key) is None:
                raise _fail(f"a {self.type} light needs {key}")
        _checked(self.light)
        return self

    def light(self) -> Light:
        if self.type == "emission":
            return EmissionLight()
        if self.type == "environment" and self.map is not None:
            return _environment_map(self.map, self.scale)
        if self.type == "environment":
            return EnvironmentLight(self.luminance_cd_m2, self.temperature_K)
        if self.type == "spot":
            temperature = POINT_K if self.temperature_K is None else self.temperature_K
            return SpotLight(self.position_m, self.intensity_cd, temperature, self.direction,  # type: ignore[arg-type]
                             self.cone_deg, self.falloff_deg)  # fmt: skip
        if self.type == "point":
            temperature = POINT_K if self.temperature_K is None else self.temperature_K
            return PointLight(self.position_m, self.intensity_cd, temperature)  # type: ignore[arg-type]
        temperature = SUN_K if self.temperature_K is None else self.temperature_K
        disk = (self.angular_diameter_deg, self.disk_samples)
        if self.radiance_cd_m2 is not None:
            return DirectionalLight.from_radiance(self.direction, self.radiance_cd_m2,
                                                  disk[0], temperature, disk[1])  # fmt: skip
        return DirectionalLight(self.direction, self.illuminance_lux, temperature, *disk)  # type: ignore[arg-type]


class DisplaySection(_Section):
    """The fields of :class:`~incandescent.imaging.pipeline.DisplaySettings`; ``space`` defaults
    to ``render.space``."""

    space: str | None = None
    white_balance: str | float | None = None
    exposure_ev: float = DisplaySettings.exposure_ev
    auto_exposure: bool = DisplaySettings.auto_exposure
    auto_percentile: float = DisplaySettings.auto_percentile
    iso: float | None = None
    shutter_s: float | None = None
    f_number: float | None = None
    tonemap: str = DisplaySettings.tonemap
    gamut: str = DisplaySettings.gamut
    bits: int = DisplaySettings.bits

    @model_validator(mode="after")
    def _check(self) -> DisplaySection:
        _checked(lambda: self.settings("srgb"))
        return self

    def settings(self, default_space: str) -> DisplaySettings:
        fields = self.model_dump()
        fields["space"] = self.space or default_space
        return DisplaySettings(**fields)


#: The most batches a time budget may render (each a seed apart; far more than any budget).
MAX_BATCHES = 1_000_000


class OutputSection(_Section):
    """Where results go; ``backend`` is ``auto`` or one of the render backends; ``layers``: the
    scattering render's compositing layers in the EXR (``renderer.layers``); ``denoise``: OIDN
    on the image written (``imaging.denoise``; a preview, no longer an unbiased estimate);
    ``batches``: render that many batches of samples (each with the next seed) and average
    them, writing after each; ``time_budget_s``: render batches while the next one fits in
    that many seconds (at least one; ``batches``, if given, the most); ``accumulate``: continue
    the output EXR's batches."""

    path: Path | None = None
    overwrite: bool = False
    stats: Path | None = None
    backend: str = "auto"
    layers: bool = False
    denoise: bool = False
    accumulate: bool = False
    batches: int = Field(default=1, ge=1)
    time_budget_s: float | None = Field(default=None, gt=0, allow_inf_nan=False)

    @property
    def most_batches(self) -> int:
        """The most batches to render: ``batches``, or with a time budget and no ``batches``
        given, as many as fit (bounded by :data:`MAX_BATCHES`)."""
        if self.time_budget_s is not None and "batches" not in self.model_fields_set:
            return MAX_BATCHES
        return self.batches

    @model_validator(mode="after")
    def _check(self) -> OutputSection:
        if self.backend not in BACKEND_CHOICES:
            raise _fail(
                f"unknown backend {self.backend!r}; expected one of: {', '.join(BACKEND_CHOICES)}"
            )
        if self.layers and self.path is not None and self.path.suffix.lower() != ".exr":
            raise _fail(f"layers are EXR layers: give an .exr output; got {self.path}")
        if self.accumulate and self.path is not None and self.path.suffix.lower() != ".exr":
            raise _fail(f"an accumulated render continues an .exr; got {self.path}")
        if self.layers and self.denoise:
            raise _fail("denoise the beauty or write layers, not both (denoised layers would not "
                        "add up to the denoised beauty)")  # fmt: skip
        return self


class FilterSection(_Section):
    """One filter in front of a ``[sensor]`` (``sensor.Filter``; its defaults)."""

    kind: Literal["nd", "bandpass", "ir_cut", "csv"]
    density: float = Filter.density
    centre_nm: float = Filter.centre_nm
    width_nm: float = Filter.width_nm
    peak: float = Filter.peak
    edge_nm: float = Filter.edge_nm
    path: str | None = Filter.path


class SensorSection(_Section):
    """A camera's sensor (``sensor.Sensor``, whose defaults these are; a render with one writes
    a raw image), the noise draw (``noise``, ``seed``) and the spectral bins its render takes."""

    sensitivity: str = Sensor.sensitivity
    f_number: float = Sensor.f_number
    lens_transmittance: float = Sensor.lens_transmittance
    filters: list[FilterSection] = Field(default_factory=list)
    exposure_s: float = Sensor.exposure_s
    pixel_pitch_um: float = Sensor.pixel_pitch_um
    peak_qe: float = Sensor.peak_qe
    gain_e_per_dn: float = Sensor.gain_e_per_dn
    full_well_e: float = Sensor.full_well_e
    read_noise_e: float = Sensor.read_noise_e
    dark_current_e_s: float = Sensor.dark_current_e_s
    black_level_dn: int = Sensor.black_level_dn
    bits: int = Sensor.bits
    pattern: str = Sensor.pattern
    cos4: bool = Sensor.cos4
    noise: bool = True
    seed: int = 0
    spectral_bins: int = Field(default=32, ge=1, le=471)
    #: The sensor's size in pixels (both or neither): the render's film, and what a raw file
    #: read for pyrometry must measure.
    width_px: int | None = Field(default=None, ge=2)
    height_px: int | None = Field(default=None, ge=2)

    @model_validator(mode="after")
    def _check(self) -> SensorSection:
        _checked(self.sensor)
        if (self.width_px is None) != (self.height_px is None):
            raise _fail("give the sensor's width_px and height_px together")
        return self

    def sensor(self):
        """The ``Sensor`` this section describes."""
        skip = {"filters", "noise", "seed", "spectral_bins", "width_px", "height_px"}
        fields = self.model_dump(exclude=skip)
        filters = tuple(Filter(**f.model_dump()) for f in self.filters)
        return Sensor(**fields, filters=filters)


class Scene(_Section):
    """A validated scene: build with :func:`incandescent.config.load_scene` or
    :func:`incandescent.config.scene_from_dict`."""

    volume: VolumeSection
    camera: CameraSection = Field(default_factory=CameraSection)
    render: RenderSection = Field(default_factory=RenderSection)
    integrator: IntegratorSection = Field(default_factory=IntegratorSection)
    emission: EmissionSection = Field(default_factory=EmissionSection)
    light: list[LightSection] = Field(default_factory=list)
    display: DisplaySection = Field(default_factory=DisplaySection)
    output: OutputSection = Field(default_factory=OutputSection)
    sensor: SensorSection | None = None

    def render_settings(self) -> RenderSettings:
        return self.render.settings()

    def render_integrator(self) -> Integrator:
        """The ``[integrator]`` with the ``[emission]`` models and the ``[[light]]`` lights;
        lights with no integrator named make it ``single_scattering``."""
        lights = tuple(section.light() for section in self.light)
        spec = self.integrator
        if lights and "type" not in spec.model_fields_set:
            spec = spec.model_copy(update={"type": SingleScattering.name})
        built = spec.integrator(self.emission.emission(), lights)
        if lights and not hasattr(built, "lights"):
            raise ValueError(
                f"[[light]] lights need an integrator that scatters (single_scattering); "
                f"integrator {built.name!r} does not"
            )
        return built

    @model_validator(mode="after")
    def _check_lights(self) -> Scene:
        _checked(self.render_integrator)
        return self

    def display_settings(self) -> DisplaySettings:
        """Display settings; the RGB space is ``display.space`` or else ``render.space``."""
        return self.display.settings(self.render.space)

    def remap(self) -> Remap:
        """The temperature remap (with a preset: identity plus ``cutoff_K``)."""
        return self.volume.temperature.remap()

    def camera_or_none(self) -> Camera | None:
        """The camera when the scene fixes ``eye`` and ``target``; else None (the view depends on
        the volume: use :meth:`camera_for`)."""
        if self.camera.eye is None or self.camera.target is None:
            return None
        return Camera(**self.camera.given())  # type: ignore[arg-type]

    def camera_for(self, volume: Volume) -> Camera:
        """The scene's camera, with keys left out taken from the default view of ``volume``
        (framing its content box, as ``incandescent render`` does without ``--eye``)."""
        fixed = self.camera_or_none()
        if fixed is not None:
            return fixed
        given = self.camera.given()
        fov = given.get("fov_deg", _dataclass_default(Camera, "fov_deg"))
        bounds = volume.content_bounds_m
        base = default_camera(bounds, fov_deg=fov)  # type: ignore[arg-type]
        eye, target = given.get("eye", base.eye), given.get("target", base.target)
        _check_view(eye, target, given, bounds)  # type: ignore[arg-type]
        return base.replace(**given)


#: Eye and target closer than this fraction of the gas box's diagonal coincide.
COINCIDE_OF_BOX = 1e-9


def _check_view(eye: Vec3, target: Vec3, given: dict, bounds: tuple) -> None:
    """Refuse a camera whose eye is its target (within a billionth of the gas box's diagonal, m),
    naming the scene keys: a default target is the centre of the gas."""
    diagonal = float(np.linalg.norm(np.subtract(bounds[1], bounds[0])))
    distance = float(np.linalg.norm(np.subtract(target, eye)))
    if distance > COINCIDE_OF_BOX * diagonal and distance > 0.0:
        return
    eye_key = "camera.eye" if "eye" in given else "the default camera.eye (a three-quarter view)"
    target_key = (
        "camera.target" if "target" in given else "the default camera.target (the gas's centre)"
    )
    raise ValueError(
        f"{eye_key} {tuple(eye)} coincides with {target_key} {tuple(target)} ({distance:.3g} m "
        "apart); give camera.eye and camera.target apart"
    )
