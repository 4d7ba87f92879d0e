"""``render()``: volume + camera + settings → HDRImage. Pure: no file I/O, no global state."""

from __future__ import annotations

import functools
import platform

import numpy as np

from incandescent import __version__
from incandescent.camera import Camera, default_camera
from incandescent.colorimetry import rgb_to_xyz
from incandescent.render.backends import MarchInputs, resolve_backend, run_march
from incandescent.render.film import HDRImage, resolve_pixels
from incandescent.render.rays import prepare_rays, ray_spec
from incandescent.render.settings import RenderSettings
from incandescent.spectra.bins import bin_luts, make_bins
from incandescent.spectra.lines import LineTable, build_species_lut, load_lines, species_names
from incandescent.spectra.lut import EmissionLUT, build_emission_lut
from incandescent.volume import Volume


@functools.lru_cache(maxsize=16)
def _cached_lut(t_max_K: float, kind: str, observer: str, constants: str) -> EmissionLUT:
    """Tables of ``kind``: "blackbody" XYZ, or the paper's 19-sample sums ("paper") and 590 nm
    term ("sodium")."""
    if kind == "paper":
        from incandescent.paper.colour import paper_spectrum_xyz as fn
    elif kind == "sodium":
        from incandescent.paper.colour import paper_sodium_xyz as fn
    else:
        from incandescent.spectra.blackbody import blackbody_xyz

        return build_emission_lut(t_max_K, lambda t: blackbody_xyz(t, observer, constants))
    return build_emission_lut(t_max_K, fn)


def _lut_t_max(volume: Volume) -> float:
    t_max = max(1e5, float(np.nextafter(np.float32(volume.max_temperature_K), np.inf)) * 1.001)
    return float(np.ceil(t_max / 100.0) * 100.0) if t_max > 1e5 else 1e5


def emission_lut(volume: Volume, settings: RenderSettings, kind: str | None = None) -> EmissionLUT:
    """The T ↦ XYZ table for this volume's temperature range (cached by range and physics)."""
    kind = kind or ("paper" if settings.brightness == "paper" else "blackbody")
    return _cached_lut(_lut_t_max(volume), kind, settings.observer, settings.constants)


def render(
    volume: Volume,
    camera: Camera | None = None,
    settings: RenderSettings | None = None,
    backend: str | None = "auto",
) -> HDRImage:
    """Render ``volume`` seen by ``camera`` (default: a three-quarter view framing the gas).

    Returns absolute XYZ (Y in cd/m²) with metadata: backend, device, samples, seconds, settings.
    """
    if not isinstance(volume, Volume):
        raise TypeError(f"volume must be an incandescent.Volume; got {type(volume).__name__}")
    settings = settings or RenderSettings()
    camera = camera or default_camera(volume.content_bounds_m)
    name = resolve_backend(backend)
    inputs = _march_inputs(volume, camera, settings, name)
    result = run_march(inputs, name)
    return _assemble(inputs, result, name, camera)


def _march_inputs(volume, camera, settings, backend: str) -> MarchInputs:
    paper = settings.brightness == "paper"
    cells = None
    if settings.skip_empty and backend != "reference":
        cells = volume.macrocells(
            settings.macrocell_voxels, settings.paper_min_K if paper else None
        )
    rays = prepare_rays(camera, volume, settings) if backend == "reference" else None
    sodium = None
    if paper and volume.sodium_fraction is not None:
        sodium = emission_lut(volume, settings, "sodium")
    table: LineTable | None = None
    species: tuple[tuple[str, EmissionLUT], ...] = ()
    if volume.species and not paper:
        table = _line_table(settings.line_table)
        species = tuple(
            (name, _species_lut(settings.line_table, name, _lut_t_max(volume), settings.observer))
            for name in volume.species
        )
    lut = emission_lut(volume, settings)
    spectral = _spectral_tables(volume, settings) if settings.spectral_bins else ()
    spec = ray_spec(camera, volume, settings)
    return MarchInputs(rays, volume, lut, cells, settings, sodium, species, table, spectral, spec)


def _spectral_tables(volume: Volume, settings: RenderSettings):
    if volume.species:
        raise ValueError(
            "spectral_bins with species lines is not supported yet; render species with "
            "spectral_bins = 0 (grey κ)"
        )
    return _cached_bins(
        settings.spectral_bins,
        float(settings.soot_alpha),
        _lut_t_max(volume),
        settings.observer,
        settings.constants,
    )


@functools.lru_cache(maxsize=8)
def _cached_bins(n: int, alpha: float, t_max_K: float, observer: str, constants: str):
    bins = make_bins(n, alpha, observer)
    tables = bin_luts(bins, t_max_K, observer, constants)
    return tuple(zip((float(s) for s in bins.kappa_scale), tables, strict=True))


@functools.lru_cache(maxsize=8)
def _line_table(path: str | None) -> LineTable:
    return load_lines(path)


@functools.lru_cache(maxsize=64)
def _species_lut(path: str | None, name: str, t_max_K: float, observer: str) -> EmissionLUT:
    """The species' T ↦ XYZ-per-metre table; unknown names list the table's species."""
    table = _line_table(path)
    known = species_names(table)
    if name not in known:
        raise ValueError(
            f"volume has a fraction grid for species {name!r}, which the line table "
            f"{table.origin} does not list; it has: {', '.join(known)}"
        )
    return build_species_lut(table, name, t_max_K, observer=observer)


def _scatter_rays(values: np.ndarray, index, inputs: MarchInputs, fill: float, reduce=np.mean):
    """Per-ray values (rows ``index`` of all camera rays, or all of them) → pixels."""
    s = inputs.settings
    full = values
    if index is not None:
        n_total = s.width * s.height * s.supersample**2
        full = np.full((n_total,) + values.shape[1:], fill, dtype=np.float64)
        full[index] = values
    return resolve_pixels(full, s.width, s.height, s.supersample, reduce)


def _assemble(inputs: MarchInputs, result, backend: str, camera: Camera) -> HDRImage:
    values = _scatter_rays(result.xyz, result.ray_index, inputs, 0.0)
    if inputs.settings.brightness == "paper":  # the paper's RGB sums, capped at 255
        values = rgb_to_xyz(np.minimum(values, 255.0), "srgb")
    xyz = values.astype(np.float32)
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
        "max_temperature_K": inputs.volume.max_temperature_K,
        "brightness": s.brightness,
        "observer": s.observer,
        "planck_constants": s.constants,
        "step_voxels": s.step_voxels,
        "supersample": s.supersample,
        "seed": s.seed,
        "camera": repr(camera),
        "incandescent_version": __version__,
        "python": platform.python_version(),
    }
    return HDRImage(xyz, tr, s.space, metadata, depth)
