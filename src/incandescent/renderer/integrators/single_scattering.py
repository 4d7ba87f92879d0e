"""Single scattering of directional lights, with emission–absorption (grey band; spectral bins:
``spectral_scattering``).

The medium absorbs with κ, scatters with σ_s (``Volume.scattering_per_m``, Henyey–Greenstein
phase with ``Volume.phase_g``) and extinguishes with σ_t = κ + σ_s. Along a camera ray, the
radiative transfer equation with the in-scattering of each light taken once (the single-
scattering approximation; Chandrasekhar 1960, §1; pbrt-v4's volpath with maxdepth 1) is

    dL/ds = −σ_t L + κ·S(T) + Σ_lights σ_s·p(ω_l·ω)·E_l·Tr_l(x)

with S the emission models' source function, E_l the light's XYZ irradiance and Tr_l(x) the
transmittance from x toward the light. Per segment of constant coefficients (the march's
lattice, ``backends.common``), exactly:

    L += Tr·η·(1 − e^{−σ_tΔs})/σ_t,   Tr ← Tr·e^{−σ_tΔs},   η = κS + Ση_lines + Σ σ_s p E Tr_l

with Tr_l from a deterministic shadow march toward the light (midpoints of segments of the
render's step, to the box; no jitter, the same on every backend): ``shadows = "grid"`` (the
default) marches once from every voxel centre and interpolates that transmittance grid
trilinearly at each sample (a "light volume" / deep shadow map: one lookup per sample instead of
a march; error O((σ_t h)²) where Tr varies fast across a voxel), ``"march"`` marches from every
sample (exact to the march's own step). The sampled lights (the fire's own light, skies) are
estimated at every sample (``in_scatter = "per-sample"``) or interpolated from a per-camera
cache of them at the voxel centres (``"cache"``, ``in_scatter_cache``). Without a scattering
grid this is emission–absorption exactly (its traced and float64 programs).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from incandescent import _validate
from incandescent.emission.blackbody import blackbody_lut
from incandescent.renderer import rays
from incandescent.renderer.backends.camera_rays import clip_to_box
from incandescent.renderer.backends.common import THIN_STEP, Segment, trilinear
from incandescent.renderer.integrators import emission_absorption as ea
from incandescent.renderer.integrators import in_scatter_cache as cache
from incandescent.renderer.integrators.emission_light import (
    LightCells,
    ReferenceEmissionLight,
    TracedEmissionLight,
)
from incandescent.renderer.integrators.environment_map import (
    ReferenceEnvironmentMap,
    TracedEnvironmentMap,
)
from incandescent.renderer.integrators.monte_carlo import ReferenceMonteCarlo, TracedMonteCarlo
from incandescent.renderer.lights import (
    DirectionalLight,
    EmissionLight,
    EnvironmentLight,
    EnvironmentMap,
    FixedLight,
    Light,
    PointLight,
    SpotLight,
    henyey_greenstein,
)

#: How a light's transmittance reaches a sample: interpolated from a grid marched once from
#: every voxel centre, or marched from the sample itself.
SHADOWS = ("grid", "march")
#: The shadow march stops once the optical depth toward the light exceeds this (e^−40 ≈ 4e-18).
MAX_SHADOW_DEPTH = 40.0
#: Most Monte Carlo sample pairs per scattering sample (``spp``).
MAX_SPP = 4096
#: The spectral-bins programs ("traced", "reference"): ``spectral_scattering`` subclasses this
#: module's and registers them here on import (``integrators/__init__`` imports it).
SPECTRAL: dict[str, Any] = {}


@dataclass(frozen=True)
class SingleScattering(ea.EmissionAbsorption):
    """Emission–absorption plus the single scattering of ``lights`` (grey or binned). With an
    :class:`EmissionLight`, each scattering sample of a camera ray averages ``spp`` Monte Carlo
    sample pairs of the volume's own emission (``emission_light``); the other lights are
    deterministic. The Monte Carlo marches (the fire's light along its lines, a sky's
    shadows, free flights) step ``path_step_voxels`` (at least the render's step): a coarser
    quadrature than the camera ray's, measured to change pbrt-v4's D2 agreement by < 0.1 % at
    1.6× the speed. ``in_scatter = "cache"`` estimates the sampled lights once per render at
    the voxel centres (``cache_pairs`` samples each) for this camera and interpolates them at
    every sample instead (``in_scatter_cache``: biased by the interpolation and, as
    1/``cache_pairs``, by interpolating ln J)."""

    lights: tuple[Light, ...] = ()
    shadows: str = "grid"
    spp: int = 4
    path_step_voxels: float = 1.0
    in_scatter: str = "per-sample"
    cache_pairs: int = cache.CACHE_PAIRS
    #: voxels per side of the cache's cells (``in_scatter_cache.CACHE_VOXELS``)
    cache_voxels: int = 1

    name = "single_scattering"

    def __post_init__(self) -> None:
        super().__post_init__()
        lights = tuple(self.lights)
        for light in lights:
            if not isinstance(light, Light):
                raise TypeError(
                    "a light must be an incandescent DirectionalLight, PointLight, EmissionLight, "
                    f"EnvironmentLight or EnvironmentMap; got {light!r}"
                )
        object.__setattr__(self, "lights", lights)
        _validate.choice(self.shadows, "shadows", SHADOWS)
        object.__setattr__(self, "spp", _samples(self.spp, "spp"))
        object.__setattr__(self, "cache_pairs", _samples(self.cache_pairs, "cache_pairs"))
        step = _validate.positive_scalar(self.path_step_voxels, "path_step_voxels")
        object.__setattr__(self, "path_step_voxels", float(step))
        _validate.choice(self.in_scatter, "in_scatter", cache.IN_SCATTER)
        if self.cache_voxels not in cache.CACHE_VOXELS or isinstance(self.cache_voxels, bool):
            raise ValueError(f"cache_voxels must be one of {cache.CACHE_VOXELS}; got "
                             f"{self.cache_voxels!r}")  # fmt: skip
        object.__setattr__(self, "cache_voxels", int(self.cache_voxels))
        problem = cache.refusal(self)
        if problem is not None:
            raise ValueError(problem)

    def occupancy(self, models) -> tuple[str, Callable | None]:
        """Where the emission models may emit, or the gas scatters (σ_s > 0)."""
        key, grid = super().occupancy(models)

        def with_scattering(volume) -> NDArray:
            base = volume.absorption_per_m if grid is None else grid(volume)
            sigma = volume.scattering_per_m
            return base if sigma is None else np.maximum(base, sigma)

        return f"{key} + scattering", with_scattering

    def sparse_problem(self, models) -> str | None:
        return "the single_scattering integrator marches dense grids"

    def metadata(self) -> dict[str, object]:
        out = {**super().metadata(), "integrator": self.name, "lights": repr(self.lights)}
        sampled = self.max_bounces >= 2 or any(not isinstance(x, FixedLight) for x in self.lights)
        if sampled and self.in_scatter == "cache":
            extra = {"cache_voxels": self.cache_voxels} if self.cache_voxels != 1 else {}
            return out | {"in_scatter": "cache", "cache_pairs": self.cache_pairs, **extra}
        return out | ({"spp": self.spp} if sampled else {})

    #: Orders of scattering (1 here; :class:`MultipleScattering` sets more).
    max_bounces: ClassVar[int] = 1

    @property
    def emission_light(self) -> bool:
        """Does the volume's own emission light it?"""
        return any(isinstance(light, EmissionLight) for light in self.lights)

    def traced(self, kernel):
        if kernel.volume.scattering_per_m is None:
            return super().traced(kernel)
        if not kernel.bands.grey:
            return SPECTRAL["traced"](kernel, self)
        return _Traced(kernel, self)

    def reference(self, inputs):
        if inputs.volume.scattering_per_m is None:
            return super().reference(inputs)
        if not inputs.bands.grey:
            return SPECTRAL["reference"](inputs, self)
        return _Reference(inputs, self)


def _samples(value, name: str) -> int:
    """``spp`` or ``cache_pairs``: an integer in 1..:data:`MAX_SPP`."""
    integer = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
    if not integer or not 1 <= value <= MAX_SPP:
        raise ValueError(f"{name} must be an integer in 1..{MAX_SPP}; got {value!r}")
    return int(value)


def _fixed(lights: tuple[Light, ...]) -> list[FixedLight]:
    """The lights with a position or direction (directional, point), a sun's disk as its
    directions (``DirectionalLight.disk``: one shadow each)."""
    out: list[FixedLight] = []
    for light in lights:
        if isinstance(light, DirectionalLight):
            out.extend(light.disk())
        elif isinstance(light, PointLight):
            out.append(light)
    return out


def _maps(integrator) -> list[EnvironmentMap]:
    """The lat-long skies among the lights."""
    return [light for light in integrator.lights if isinstance(light, EnvironmentMap)]


def _paths(integrator) -> bool:
    """Does the integrator trace paths (more than one order, and a light for them to find)?"""
    return integrator.max_bounces >= 2 and bool(integrator.lights)


def _emitting_cells(integrator, volume, lut) -> LightCells | None:
    """The emission light's cells of power (κ·Y(T) from ``lut``; in spectral bins from the
    whole blackbody, not the first bin's table), or None without an emitting one."""
    if not integrator.emission_light:
        return None
    if integrator.spectral_bins:
        lut = blackbody_lut(integrator.emission.observer, integrator.emission.constants)
    cells = LightCells.of(volume, lut)
    return cells if cells.emits else None


def _skies(integrator) -> list[EnvironmentLight]:
    """The uniform skies among the lights."""
    return [light for light in integrator.lights if isinstance(light, EnvironmentLight)]


def _sampled_lights(integrator, volume, lut) -> tuple | None:
    """(the emission light's cells if it emits, else None; the uniform skies; the lat-long
    skies) — what the Monte Carlo estimators sample — or None where they have nothing to do (no
    such light and no paths). Grey and spectral, traced and float64 alike start from it."""
    cells = _emitting_cells(integrator, volume, lut)
    skies, maps = _skies(integrator), _maps(integrator)
    if cells is None and not skies and not maps and not _paths(integrator):
        return None
    return cells, skies, maps


def _sky_xyz(skies: list[EnvironmentLight]) -> NDArray | None:
    """The uniform skies' total XYZ radiance, or None without one."""
    return np.sum([light.xyz() for light in skies], axis=0) if skies else None


def path_step(step_voxels: float, integrator) -> np.float32:
    """The Monte Carlo marches' step, voxels: ``path_step_voxels``, at least the render's."""
    return np.float32(max(float(step_voxels), integrator.path_step_voxels))


def _in_voxels(light: FixedLight, volume) -> tuple[float, float, float]:
    """A light's direction (directional) or its position in the volume's voxel coordinates."""
    if isinstance(light, DirectionalLight):
        return light.direction
    origin = np.asarray(volume.origin_m, dtype=np.float64)
    where = (np.asarray(light.position_m) - origin) / volume.voxel_size_m
    return tuple(float(v) for v in where)  # type: ignore[return-value]


def _exit_voxels(p, direction, shape, minimum) -> Any:
    """Distance (voxels) from positions p along a fixed unit ``direction`` to the box's exit."""
    t = None
    for a, (n, l) in enumerate(zip(shape, direction, strict=True)):
        if l == 0.0:
            continue
        t_axis = ((float(n) if l > 0 else 0.0) - p[a]) * (1.0 / l)
        t = t_axis if t is None else minimum(t, t_axis)
    assert t is not None, "a light's direction is never zero"
    return t


class _Traced(ea._Traced):
    """The traced step: emission, extinction σ_t = κ + σ_s, and each light scattered once."""

    def __init__(self, kernel, integrator: SingleScattering) -> None:
        super().__init__(kernel)
        vol = kernel.volume
        self.scattering = kernel.grid(("scattering",), vol.scattering_per_m)
        g = vol.phase_g
        self.g = g if isinstance(g, float) else None
        self.g_grid = None if self.g is not None else kernel.grid(("phase_g",), g)
        #: the step of the Monte Carlo marches, voxels
        self.path_dt = path_step(kernel.dt, integrator)
        lights = _fixed(integrator.lights)
        self.lights = [(light, _in_voxels(light, vol), light.xyz()) for light in lights]
        self.sampled = self.monte_carlo(integrator)
        #: ln Ĵ_c's X, Y, Z grids (``in_scatter = "cache"``), else None
        self.cache = None
        if integrator.in_scatter == "cache" and self.sampled is not None:
            cache.check_camera(kernel.ray_spec, vol)
            self.cell = integrator.cache_voxels
            self.cache, self.sampled = cache.traced(self, self.sampled, self.cell), None
        self.shadow_grids = None
        if integrator.shadows == "grid":
            self.shadow_grids = [self.transmittance_grid(i) for i in range(len(self.lights))]

    def monte_carlo(self, integrator) -> TracedMonteCarlo | None:
        """The estimator of the sampled lights and paths, or None without them."""
        K = self.kernel
        sampled = _sampled_lights(integrator, K.volume, K.first_table)
        if sampled is None:
            return None
        cells, skies, maps = sampled
        emitter = None if cells is None else TracedEmissionLight(self, cells)
        traced_maps = [TracedEnvironmentMap(self, sky_map) for sky_map in maps]
        lights = (emitter, _sky_xyz(skies), traced_maps)
        spp = integrator.cache_pairs if integrator.in_scatter == "cache" else integrator.spp
        return TracedMonteCarlo(self, lights, spp, integrator.max_bounces, K.seed)

    def g_at(self, p, c=None):
        """Traced: the Henyey–Greenstein g at positions p (or trilinear corners c): the
        volume's constant, or its grid interpolated."""
        if self.g_grid is None:
            return self.g
        K = self.kernel
        return K.trilinear(self.g_grid, K.corners(p) if c is None else c)

    def geometry(self, index: int, p):
        """Traced: (unit direction toward light ``index``, the march's length in voxels — to the
        light or the box —, the inverse-square factor in 1/m²) at positions p."""
        K = self.kernel
        dr, m = K.dr, K.m
        light, where, _ = self.lights[index]
        if isinstance(light, DirectionalLight):
            exit_voxels = dr.maximum(_exit_voxels(p, where, K.shape, dr.minimum), 0.0)
            return m.Array3f(*where), exit_voxels, 1.0
        v = m.Array3f(*where) - p
        r = dr.maximum(dr.norm(v), 1e-6)
        d = v / r
        _, t_box = clip_to_box(dr, m, p, d, K.shape)
        distance_m = r * K.ds_per_voxel
        return d, dr.clip(t_box, 0.0, r), 1.0 / (distance_m * distance_m)

    def transmittance_grid(self, index: int):
        """Light ``index``'s transmittance marched from every voxel centre, evaluated now (one
        kernel), C order: what :meth:`in_scattered` interpolates."""
        return self.from_centres(index, self.transmittance_along)

    def from_centres(self, index: int, along):
        """``along(p, d, length)`` toward light ``index`` from every voxel centre p, evaluated
        now (one kernel), C order."""
        K = self.kernel
        m = K.m
        centres = np.indices(K.shape, dtype=np.float32).reshape(3, -1) + np.float32(0.5)
        p = m.Array3f(*(m.Float(a) for a in centres))
        d, length, _ = self.geometry(index, p)
        out = along(p, d, length)
        K.dr.eval(out)
        return out

    def segment(self, p, d, k, dt, end):
        """Traced: step k of a march from p along unit d in steps of ``dt`` voxels, cut at
        ``end``: its start a and end b (voxels), the trilinear corners c of its midpoint and κ,
        T and σ_s there — what every shadow march and free flight reads per step."""
        K = self.kernel
        dr = K.dr
        a = k * dt
        b = dr.minimum(a + dt, end)
        c = K.corners(dr.fma(d, 0.5 * (a + b), p))
        kappa, temp = K.medium_at(c)
        return a, b, c, kappa, temp, K.trilinear(self.scattering, c)

    def transmittance_along(self, p, d, length, dt=None):
        """Traced: e^{−∫σ_t ds} from p along d for ``length`` voxels (midpoint rule, steps of
        ``dt`` voxels: the render's step by default)."""
        K = self.kernel
        dr, m = K.dr, K.m
        dt = K.dt if dt is None else dt

        def cond(k, tau):
            return (k * dt < length) & (tau < MAX_SHADOW_DEPTH)

        def body(k, tau):
            a, b, _, kappa, _, sigma_s = self.segment(p, d, k, dt, length)
            sigma_t = kappa + sigma_s
            return k + 1.0, dr.fma(sigma_t, (b - a) * K.ds_per_voxel, tau)

        _, tau = dr.while_loop((m.Float(0.0), m.Float(0.0)), cond, body, labels=("k", "tau"))
        return dr.exp(-tau)

    def direct(self, p, c, view):
        """Traced: Σ_lights p(cos θ)·E·Tr_light of the directional and point lights at p (trilinear
        corners c) seen along the unit ``view`` (XYZ per sr)."""
        K = self.kernel
        dr, m = K.dr, K.m
        out = m.Array3f(0.0)
        for index, (_, _, xyz) in enumerate(self.lights):
            d, length, falloff = self.geometry(index, p)
            if self.shadow_grids is not None:
                shadow = K.trilinear(self.shadow_grids[index], c)
            else:
                shadow = self.transmittance_along(p, d, length)
            weight = henyey_greenstein(dr.dot(d, view), self.g_at(p, c)) * shadow * falloff
            light = self.lights[index][0]
            if isinstance(light, SpotLight):  # the light shines along its axis toward −d
                weight = weight * light.factor(-dr.dot(d, m.Array3f(*light.direction)), dr.clip)
            out = dr.fma(m.Array3f(*(float(v) for v in xyz)), weight, out)
        return out

    def in_scattered(self, sigma_s):
        """Traced: σ_s·J at the sample (XYZ per metre): the lights' part exactly, the sampled
        lights' and the paths' by Monte Carlo (``monte_carlo``)."""
        K = self.kernel
        out = self.direct(K.position, K.at, K.ray_direction) * sigma_s
        if self.cache is not None:
            out = K.dr.fma(cache.lookup(K, self.cache, self.cell), sigma_s, out)
        if self.sampled is not None:
            out = out + self.sampled.estimate(sigma_s)
        return out

    def interacts(self, kappa, temp, sampled):
        K = self.kernel
        self.sigma_s = K.trilinear(self.scattering, K.at)
        present, emits = super().interacts(kappa, temp, sampled)
        return present | (self.sigma_s > 0.0), emits

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        K = self.kernel
        dr = K.dr
        sigma_s = self.sigma_s
        sigma_t = kappa + sigma_s
        eta = self.emission_coefficient(0, kappa, temp, sampled)
        if K.scale is not None:
            eta = eta * K.trilinear(K.scale, c)
        eta = eta + self.in_scattered(sigma_s)
        x = sigma_t * ds_m
        e = dr.exp(-x)
        series = 1.0 - x * (0.5 - x * (1.0 / 6.0))
        weight = dr.select(x < THIN_STEP, ds_m * series, (1.0 - e) / sigma_t)
        return tr * e, dr.fma(eta, tr * weight, L)


class _ReferenceLights:
    """Float64 light geometry and shadows shared by the grey and the spectral references (they
    set ``inputs`` and ``lights``: (light, direction or position in voxels, XYZ) triples)."""

    inputs: Any
    lights: list

    def medium(self, p: NDArray) -> tuple:
        """(κ, σ_s, T, the models' sampled grids, whether each emits) at positions p (m, 3)."""
        inputs, vol = self.inputs, self.inputs.volume
        kappa, sigma_s = trilinear(vol.absorption_per_m, p), trilinear(vol.scattering_per_m, p)
        temp, sampled = trilinear(vol.temperature_K, p), ea._sampled(inputs, p)
        emits = ea._present(kappa, sampled) & (temp >= inputs.lut.t_min_K)
        return kappa, sigma_s, temp, sampled, emits

    def g_at(self, p: NDArray) -> float | NDArray:
        """The Henyey–Greenstein g at positions p (m, 3): the constant, or the grid's."""
        g = self.inputs.volume.phase_g
        return g if isinstance(g, float) else trilinear(g, p)

    def geometry(self, index: int, p: NDArray) -> tuple[NDArray, NDArray, NDArray | float]:
        """(unit directions toward light ``index``, march lengths in voxels, 1/r² in 1/m²)."""
        vol = self.inputs.volume
        light, where, _ = self.lights[index]
        if isinstance(light, DirectionalLight):
            length = np.maximum(_exit_voxels(p.T, where, vol.shape, np.minimum), 0.0)
            return np.broadcast_to(where, p.shape), length, 1.0
        v = where - p
        r = np.maximum(np.linalg.norm(v, axis=1), 1e-6)
        d = v / r[:, None]
        _, t_box = rays.clip_to_box(p, d, np.asarray(vol.shape, dtype=np.float64))
        return d, np.clip(t_box, 0.0, r), 1.0 / (r * vol.voxel_size_m) ** 2

    def transmittance_along(self, p: NDArray, d: NDArray, length: NDArray, dt=None) -> NDArray:
        """e^{−∫σ_t ds} from p along d for ``length`` voxels (midpoint rule, step ``dt``)."""
        tau_kappa, tau_sigma = self.optical_depths(p, d, length, dt)
        return np.exp(-(tau_kappa + tau_sigma))

    def optical_depths(self, p: NDArray, d: NDArray, length: NDArray, dt=None, most=1.0):
        """(∫κ ds, ∫σ_s ds) from p along d for ``length`` voxels (midpoint rule, steps of ``dt``
        voxels: the render's by default), stopping once ``most``·(their sum) passes
        :data:`MAX_SHADOW_DEPTH` (``most``: the smallest spectral scale of either)."""
        vol = self.inputs.volume
        dt = self.inputs.settings.step_voxels if dt is None else dt
        tau_k, tau_s, k = np.zeros(len(p)), np.zeros(len(p)), 0
        while True:
            a = k * dt
            live = (a < length) & (most * (tau_k + tau_s) < MAX_SHADOW_DEPTH)
            if not live.any():
                return tau_k, tau_s
            b = np.minimum(a + dt, length[live])
            q = p[live] + d[live] * (0.5 * (a + b))[:, None]
            metres = (b - a) * vol.voxel_size_m
            tau_k[live] += trilinear(vol.absorption_per_m, q) * metres
            tau_s[live] += trilinear(vol.scattering_per_m, q) * metres
            k += 1


class _Reference(_ReferenceLights, ea._Reference):
    """Float64: exact emission terms, the lights' in-scattering with a float64 shadow march."""

    def __init__(self, inputs, integrator: SingleScattering) -> None:
        super().__init__(inputs)
        vol = inputs.volume
        self.path_dt = float(path_step(inputs.settings.step_voxels, integrator))
        lights = _fixed(integrator.lights)
        self.lights = [(light, np.asarray(_in_voxels(light, vol)), light.xyz()) for light in lights]
        self.sampled = None
        sampled = _sampled_lights(integrator, vol, inputs.lut)
        if sampled is not None:
            cells, skies, maps = sampled
            emitter = None if cells is None else ReferenceEmissionLight(self, cells)
            ref_maps = [ReferenceEnvironmentMap(self, sky_map) for sky_map in maps]
            sampled_lights = (emitter, _sky_xyz(skies), ref_maps)
            seed = inputs.settings.seed
            cached = integrator.in_scatter == "cache"
            spp = integrator.cache_pairs if cached else integrator.spp
            self.sampled = ReferenceMonteCarlo(
                self, sampled_lights, spp, integrator.max_bounces, seed
            )
        self.cache = None
        if integrator.in_scatter == "cache" and self.sampled is not None:
            cache.check_camera(inputs.ray_spec, vol)
            self.cell = integrator.cache_voxels
            self.cache, self.sampled = cache.reference(inputs, self.sampled, self.cell), None
        self.shadow_grids = None
        if integrator.shadows == "grid":
            centres = np.indices(vol.shape, dtype=np.float64).reshape(3, -1).T + 0.5
            self.shadow_grids = [
                self.transmittance_along(centres, *self.geometry(i, centres)[:2]).reshape(vol.shape)
                for i in range(len(self.lights))
            ]

    def direct(self, p, view) -> NDArray:
        """The directional and point lights' part of J at p seen along unit ``view`` (m, 3)."""
        g = self.g_at(p)
        out = np.zeros((len(p), 3))
        for index, (_, _, xyz) in enumerate(self.lights):
            d, length, falloff = self.geometry(index, p)
            if self.shadow_grids is not None:
                shadow = trilinear(self.shadow_grids[index], p)
            else:
                shadow = self.transmittance_along(p, d, length)
            cos = np.einsum("ij,ij->i", view, d)
            weight = henyey_greenstein(cos, g) * shadow * falloff
            light = self.lights[index][0]
            if isinstance(light, SpotLight):
                weight = weight * light.factor(-(d @ np.asarray(light.direction)), np.clip)
            out += weight[:, None] * xyz
        return out

    def emitted(self, kappa, temp, sampled, emits) -> NDArray:
        """η of the emission models (κ·S + the lines), exact; 0 where a sample does not emit."""
        eta = np.zeros(temp.shape + (3,))
        if emits.any():
            eta[emits] = self.emission_coefficient(kappa, temp, sampled, emits)
        return eta

    def emitted_at(self, p: NDArray, kappa: NDArray) -> NDArray:
        """η (XYZ per m) at positions p where the absorption is ``kappa``, emission scale
        included."""
        inputs, vol = self.inputs, self.inputs.volume
        temp, sampled = trilinear(vol.temperature_K, p), ea._sampled(inputs, p)
        emits = ea._present(kappa, sampled) & (temp >= inputs.lut.t_min_K)
        eta = self.emitted(kappa, temp, sampled, emits)
        if vol.emission_scale is not None:
            eta *= trilinear(vol.emission_scale, p)[:, None]
        return eta

    def step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        vol, inputs = self.inputs.volume, self.inputs
        r, p, ds_m = segment.r, segment.p, segment.ds_m
        kappa, sigma_s, temp, sampled, emits = self.medium(p)
        eta = self.emitted(kappa, temp, sampled, emits)
        if vol.emission_scale is not None:
            eta *= trilinear(vol.emission_scale, p)[:, None]
        lit = sigma_s > 0
        if lit.any() and self.lights:
            direction = inputs.rays.direction[r[lit]]
            eta[lit] += sigma_s[lit, None] * self.direct(p[lit], direction)
        if lit.any() and self.cache is not None:
            q = p[lit] / self.cell
            J = np.exp(np.stack([trilinear(grid, q) for grid in self.cache], axis=1))
            eta[lit] += sigma_s[lit, None] * J
        if lit.any() and self.sampled is not None:
            rows = r[lit]
            direction, index = inputs.rays.direction[rows], inputs.rays.ray_index[rows]
            assert segment.k is not None, "the reference march numbers its segments"
            step = segment.k[lit]
            eta[lit] += self.sampled.estimate(p[lit], sigma_s[lit], direction, index, step)
        sigma_t = kappa + sigma_s
        x = sigma_t * ds_m
        weight = np.where(x > 0, -np.expm1(-x) / np.where(x > 0, sigma_t, 1.0), ds_m)
        xyz[r] += (tr[r] * weight)[:, None] * eta
        tr[r] *= np.exp(-x)
        return emits
