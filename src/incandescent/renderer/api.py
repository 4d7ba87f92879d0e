"""``render()``: volume + camera + settings → HDRImage. Pure: no file I/O, no global state."""

from __future__ import annotations

import platform
from collections.abc import Callable

import numpy as np

from incandescent._version import __version__
from incandescent.budget import Limits
from incandescent.camera import Camera, Rig, default_camera
from incandescent.emission import EmissionModel
from incandescent.renderer.backends import MarchInputs, resolve_backend, run_march
from incandescent.renderer.backends.bricks import brick_bytes
from incandescent.renderer.backends.common import upper_samples_per_ray
from incandescent.renderer.film import HDRImage, resolve_pixels
from incandescent.renderer.integrators import EmissionAbsorption, Integrator
from incandescent.renderer.layout import blur_rings, layout_volume
from incandescent.renderer.rays import image_lanes, lane_order, prepare_rays, ray_spec
from incandescent.renderer.settings import RenderSettings
from incandescent.spectra.lut import T_MAX_K
from incandescent.volume import Volume
from incandescent.volume.macrocells import dilated
from incandescent.volume.sparse import SparseVolume


def _check_ceiling(volume: Volume | SparseVolume) -> None:
    """The tables end at T_MAX_K, which no volume from ``Volume.from_arrays`` exceeds
    (``volume.grid.T_CEILING_K``); a Volume built otherwise is refused here."""
    if volume.max_temperature_K > T_MAX_K:
        raise ValueError(
            f"volume's hottest voxel {volume.max_temperature_K:.4g} K is above the "
            f"{T_MAX_K:g} K ceiling of the emission tables"
        )


#: Host and device bytes per camera ray of a render (lane order, loop state, per-ray outputs and
#: their float64 copies, pixel assembly); the reference backend's lockstep NumPy march far more.
#: Peak RSS growth measured at 1024² and 2048²: 133 B/ray (cpu); 471 B/ray at 512² (reference).
BYTES_PER_RAY = {"reference": 1024, "cpu": 256, "cuda": 256}


def _check_types(volume, camera, settings, integrator) -> None:
    for value, kind, name in (
        (volume, (Volume, SparseVolume), "volume"),
        (camera, (Camera, Rig, type(None)), "camera"),
        (settings, (RenderSettings, type(None)), "settings"),
        (integrator, (Integrator, type(None)), "integrator"),
    ):
        if not isinstance(value, kind):
            want = " or ".join(k.__name__ for k in kind).replace("NoneType", "None")
            raise TypeError(
                f"{name} must be an incandescent {want}; got {type(value).__name__} {value!r:.60}"
            )


def render_estimate(
    volume: Volume | SparseVolume, settings: RenderSettings, backend: str
) -> tuple[float, float]:
    """(bytes, samples) a render needs at most: the device grids plus per-ray state, and one
    sample per step along the box diagonal for every ray (the upper bound: no skipping, no
    early termination)."""
    rays = float(settings.width * settings.height * settings.supersample**2)
    if isinstance(volume, SparseVolume):
        grid_bytes = brick_bytes(volume, packed=True)
    else:
        voxels = float(np.prod(volume.shape))
        scattering = 2 * (volume.scattering_per_m is not None)  # σ_s and a light's shadow grid
        grids = 1 + (volume.emission_scale is not None) + scattering
        grid_bytes = voxels * (8 + 4 * (grids - 1 + len(volume.species)))
    samples = rays * upper_samples_per_ray(volume.shape, settings.step_voxels)
    return grid_bytes + rays * BYTES_PER_RAY[backend], samples


def check_budget(
    volume: Volume | SparseVolume, settings: RenderSettings, backend: str, limits: Limits
) -> None:
    """Refuse a render whose memory or samples exceed ``limits`` (:mod:`incandescent.budget`)."""
    need, samples = render_estimate(volume, settings, backend)
    what = f"rendering {settings.width}×{settings.height} of a {volume.shape} volume"
    limits.check_memory(need, what)
    limits.check_samples(samples, f"{what} at step {settings.step_voxels:g} voxels")


def render(
    volume: Volume | SparseVolume,
    camera: Camera | Rig | None = None,
    settings: RenderSettings | None = None,
    backend: str | None = "auto",
    limits: Limits | None = None,
    progress: Callable[[float], None] | None = None,
    models: tuple[EmissionModel, ...] | None = None,
    integrator: Integrator | None = None,
) -> HDRImage:
    """Render ``volume`` seen by ``camera`` (default: a three-quarter view framing the gas).

    Returns absolute XYZ (Y in cd/m²) with metadata: backend, device, samples, seconds, settings.
    The render is estimated first and refused (:class:`~incandescent.budget.BudgetError`) when
    it exceeds ``limits`` (default: the memory available now and 1e11 samples). A Ctrl-C during
    the march is honoured within about a second (the fast backends march in chunks of rays,
    calling ``progress(fraction of rays done)`` after each). ``integrator``: how light is
    transported (``incandescent.renderer.integrators``; default: grey emission–absorption).
    ``models``: the emission models (``incandescent.emission``; default: the integrator's for
    the volume).
    """
    _check_types(volume, camera, settings, integrator)
    settings, limits = settings or RenderSettings(), limits or Limits()
    integrator = integrator or EmissionAbsorption()
    camera = camera or default_camera(volume.content_bounds_m)
    name = resolve_backend(backend)
    _check_ceiling(volume)
    _check_blur(volume, settings, name)
    if models is None:
        models = integrator.models(volume)
    models = integrator.check_models(models)
    volume = layout_volume(volume, settings, integrator, models, name, limits)
    check_budget(volume, settings, name, limits)
    inputs = _march_inputs(volume, camera, settings, name, integrator, models)
    result = run_march(inputs, name, progress)
    return _assemble(inputs, result, name, camera)


def _march_inputs(volume, camera, settings, backend: str, integrator, models) -> MarchInputs:
    cells = None
    if settings.skip_empty and backend != "reference" and isinstance(volume, SparseVolume):
        cells = volume.macrocells(settings.macrocell_voxels)  # κ only (``layout``)
    elif settings.skip_empty and backend != "reference":
        cells = volume.macrocells(settings.macrocell_voxels, *integrator.occupancy(models))
    if cells is not None:
        cells = dilated(cells, blur_rings(volume, settings))
    rays = prepare_rays(camera, volume, settings) if backend == "reference" else None
    spec = ray_spec(camera, volume, settings)
    return MarchInputs(integrator, rays, volume, models, cells, settings, spec)


def _check_blur(volume, settings: RenderSettings, backend: str) -> None:
    """A shutter needs a velocity grid, and a backend that advects (not the reference)."""
    if settings.shutter is None:
        return
    if volume.velocity_m_s is None:
        raise ValueError(
            f"shutter {settings.shutter} is set but the volume has no velocity grid to blur "
            "along (give one: Volume.from_arrays(velocity_m_s=...), or the scene's "
            "volume.grids.velocity)"
        )
    if backend == "reference":
        raise ValueError("motion blur runs on the cpu and cuda backends, not the reference")


def _scatter_rays(values: np.ndarray, index, inputs: MarchInputs, fill: float, reduce=np.mean):
    """Per-ray values (rows ``index`` of all camera rays, or all of them) → pixels."""
    s = inputs.settings
    if index is lane_order(s.width, s.height, s.supersample)[2]:  # the Dr.Jit kernels' lanes
        samples = np.take(values, image_lanes(s.width, s.height, s.supersample), axis=0)
        samples = samples.reshape((s.height, s.width, s.supersample**2) + values.shape[1:])
        return samples[:, :, 0] if s.supersample == 1 else reduce(samples, axis=2)
    full = values
    if index is not None:
        n_total = s.width * s.height * s.supersample**2
        full = np.full((n_total,) + values.shape[1:], fill, dtype=np.float64)
        full[index] = values
    return resolve_pixels(full, s.width, s.height, s.supersample, reduce)


def _assemble(inputs: MarchInputs, result, backend: str, camera: Camera | Rig) -> HDRImage:
    values = _scatter_rays(result.xyz, result.ray_index, inputs, 0.0)
    xyz, display_rgb = inputs.integrator.film(values)
    index = result.ray_index
    tr = _scatter_rays(result.transmittance, index, inputs, 1.0).astype(np.float32)
    depth = _scatter_rays(result.depth_m, index, inputs, np.inf, np.min).astype(np.float32)
    s = inputs.settings
    metadata = {
        "backend": backend,
        "device": result.device,
        "samples": result.samples,
        "seconds": result.seconds,
        "absorption": inputs.volume.absorption_source,
        "temperature": inputs.volume.temperature_source,
        "max_temperature_K": inputs.volume.max_temperature_K,
        **inputs.integrator.metadata(),
        "step_voxels": s.step_voxels,
        "supersample": s.supersample,
        "seed": s.seed,
        "camera": repr(camera),
        "incandescent_version": __version__,
        "python": platform.python_version(),
        "emission_models": ", ".join(model.name for model in inputs.models) or "none",
        "layout": "sparse" if isinstance(inputs.volume, SparseVolume) else "dense",
    }
    return HDRImage(xyz, tr, s.space, metadata, depth, display_rgb)
