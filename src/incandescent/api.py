"""The public API in one place: what the CLI, scripts and notebooks call."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from incandescent.budget import Limits
from incandescent.camera import Camera, default_camera
from incandescent.config.assemble import load_volume, volume_from_section
from incandescent.imaging import DisplaySettings, to_display
from incandescent.io.output import save_volume, write_json
from incandescent.output import save_image
from incandescent.renderer import HDRImage, RenderSettings, render
from incandescent.renderer.integrators import SingleScattering
from incandescent.renderer.layers import with_layers
from incandescent.volume import Remap, Volume
from incandescent.volume.sparse import SparseVolume

if TYPE_CHECKING:
    from incandescent.config import Scene

__all__ = [
    "Camera",
    "DisplaySettings",
    "HDRImage",
    "Limits",
    "Remap",
    "RenderSettings",
    "Volume",
    "camera_from",
    "check_image_outputs",
    "demo_volume",
    "grid_report",
    "strict_json",
    "image_stats",
    "render_scene",
    "start_backend",
    "load_volume",
    "volume_from_section",
    "render",
    "save_image",
    "save_volume",
    "to_display",
    "write_json",
]


def camera_from(
    volume: Volume | SparseVolume,
    eye=None,
    target=None,
    fov_deg: float = 40.0,
    frame_content: bool = True,
) -> Camera:
    """The default three-quarter camera — framing the gas, or the whole box when
    ``frame_content`` is false (animations) — with any of eye/target/fov overridden."""
    bounds = volume.content_bounds_m if frame_content else volume.bounds_m
    camera = default_camera(bounds, fov_deg=fov_deg)
    changes = {k: v for k, v in (("eye", eye), ("target", target)) if v is not None}
    return camera.replace(**changes) if changes else camera


def check_image_outputs(
    image: Path, stats: Path | None, overwrite: bool, inputs: list[Path] | None = None
) -> None:
    """Fail before rendering, not after: unsupported suffix, existing file without overwrite,
    missing or read-only folder, a folder or device in the way, an output that is one of
    ``inputs`` by any name (``io.atomic.check_output``), the stats file the image itself."""
    from incandescent.io.atomic import check_output, same_file
    from incandescent.io.formats import IMAGE_SUFFIXES, STATS_SUFFIXES

    inputs = inputs or []
    target = check_output(image, overwrite, IMAGE_SUFFIXES, "image", inputs=inputs)
    if stats is not None:
        written = check_output(stats, overwrite, STATS_SUFFIXES, "stats", inputs=inputs)
        if same_file(written, target):
            raise ValueError(f"--stats {stats} is the image output itself; give another file")


def start_backend(path: Path, backend: str | None) -> str:
    """The render backend resolved before the volume is read: a .vdb's OpenVDB worker starts (a
    process of its own) while it loads here (Dr.Jit, ~80 ms), and a backend that cannot run is an
    error before any reading."""
    if path.suffix.lower() == ".vdb":
        from incandescent.io import openvdb

        openvdb.start()
    from incandescent.renderer.backends import resolve_backend

    return resolve_backend(backend)


def photograph_scene(scene: Scene, source: Path, limits: Limits | None = None):
    """The raw exposure of ``scene`` through its ``[sensor]`` (``photograph``), written to its
    ``[output]`` path (.dng, .tiff, .npy, with a JSON sidecar), every output checked first;
    (the ``Photograph``, the files written)."""
    from incandescent.io.atomic import check_output
    from incandescent.io.raw import RAW_SUFFIXES, sidecar_path, write_raw
    from incandescent.photograph import photograph

    out, section = scene.output, scene.sensor
    assert section is not None, "a scene with a [sensor]"
    if out.path is None:
        raise ValueError("no output: give -o OUT.dng|.tiff|.npy or [output] path")
    inputs = [source, scene.volume.path]
    check_output(out.path, out.overwrite, RAW_SUFFIXES, "raw image", inputs=inputs)
    check_output(sidecar_path(out.path), out.overwrite, (".json",), "sidecar", inputs=inputs)
    if out.layers or out.denoise or out.batches > 1 or out.accumulate or out.stats:
        raise ValueError("a [sensor] render writes one raw exposure: no layers, denoise, "
                         "batches, accumulate or stats")  # fmt: skip
    backend = start_backend(scene.volume.path, out.backend)
    settings = scene.render_settings()
    if section.width_px is not None:
        settings = settings.replace(width=section.width_px, height=section.height_px)
    volume = volume_from_section(scene.volume, scene.remap(), limits, settings.layout)
    camera = scene.camera_for(volume)  # type: ignore[arg-type]
    shot = photograph(volume, camera, settings, section.sensor(), backend, section.seed,
                      section.noise, section.spectral_bins)  # fmt: skip
    written = write_raw(out.path, shot.raw(), out.overwrite)
    return shot, [written, sidecar_path(written)]


def render_scene(
    scene: Scene, source: Path, limits: Limits | None = None, progress=None
) -> tuple[HDRImage, list[Path]]:
    """Render ``scene`` (read from ``source``: a scene or volume file) to its ``[output]`` path
    and stats file, every output checked first; (the image, the files written)."""
    from incandescent.io.atomic import all_or_nothing

    out = scene.output
    if out.path is None:
        raise ValueError("no output: give -o OUT.exr|.png or [output] path in the scene file")
    table = scene.emission.line_table
    inputs = [source, scene.volume.path, *([] if table is None else [Path(table)])]
    continuing = out.accumulate and out.path.exists()
    check_image_outputs(out.path, out.stats, out.overwrite or continuing, inputs)
    integrator = scene.render_integrator()
    if out.layers and not isinstance(integrator, SingleScattering):
        raise ValueError(
            f"layers split scattered light: they need lights and a scattering integrator; "
            f"got {integrator.name!r}"
        )
    backend = start_backend(scene.volume.path, out.backend)
    settings = scene.render_settings()
    blur_fps = settings.fps if settings.shutter is not None else None
    volume = volume_from_section(scene.volume, scene.remap(), limits, settings.layout, blur_fps)
    start = time.perf_counter()
    camera = scene.camera_for(volume)  # type: ignore[arg-type]  # a SparseVolume has its bounds too

    def frame(integrator, settings=settings):
        return render(volume, camera, settings, backend, limits, progress, integrator=integrator)

    if out.accumulate or out.batches > 1 or out.time_budget_s is not None:
        return _accumulate(scene, frame, integrator, settings, start)
    image = with_layers(frame, integrator) if out.layers else frame(integrator)
    if out.denoise:
        image = denoised(image)
    with all_or_nothing():  # the image and its stats, or neither
        written = [save_image(image, out.path, scene.display_settings(), out.overwrite)]
        if out.stats is not None:
            stats = image_stats(image, start)
            written.append(write_json(out.stats, stats, overwrite=out.overwrite))
    return image, written


#: Successive batches of an accumulated render take seeds this far apart (mod 2³¹).
BATCH_SEED_STRIDE = 0x2545F491


def scene_fingerprint(scene: Scene) -> str:
    """What must not change between batches of an accumulated render: the scene without its
    ``[output]`` and the render's seed (SHA-256 of its JSON)."""
    import hashlib
    import json

    data = scene.model_dump(mode="json", exclude={"output"})
    data["render"].pop("seed", None)
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def _prior_batches(scene: Scene, fingerprint: str) -> tuple[HDRImage | None, int]:
    """(the accumulated image in ``[output] path`` and its number of batches) to continue, or
    (None, 0); refused, naming the file, when it was rendered from another scene."""
    from incandescent.colorimetry import rgb_to_xyz
    from incandescent.io.images import read_exr

    path = scene.output.path
    if not (scene.output.accumulate and path is not None and path.exists()):
        return None, 0
    if path.suffix.lower() != ".exr":
        raise ValueError(f"{path}: an accumulated render continues an .exr (its linear values)")
    rgb, meta, extra = read_exr(path)
    if meta.get("accumulate_fingerprint") != fingerprint:
        raise ValueError(
            f"{path}: not an accumulated render of this scene and settings (seed aside); give "
            "another output, or --overwrite without --accumulate"
        )
    space = meta.get("colour_space", "srgb")
    xyz = rgb_to_xyz(rgb, space).astype(np.float32)
    prior = HDRImage(xyz, (1.0 - extra["A"]).astype(np.float32), space, dict(meta))
    return prior, int(meta["accumulate_batches"])


def _combined(prior: HDRImage | None, batch: HDRImage, done: int) -> HDRImage:
    """The mean of ``done`` batches (``prior``) and one more (equal weights: equal samples)."""
    from dataclasses import replace

    if prior is None or done == 0:
        return batch
    w = 1.0 / (done + 1)
    xyz = (prior.scene_xyz * (1 - w) + batch.scene_xyz * w).astype(np.float32)
    tr = (prior.transmittance * (1 - w) + batch.transmittance * w).astype(np.float32)
    return replace(batch, xyz=xyz, transmittance=tr)


def _accumulate(scene: Scene, frame, integrator, settings, start: float):
    """``[output] batches`` more batches of the render, each with the next seed, averaged into
    the output EXR (continuing the file there with ``accumulate``) and written after each batch:
    an interrupted run keeps its finished batches."""
    from dataclasses import replace

    out = scene.output
    assert out.path is not None, "render_scene checked the output"
    if out.layers or out.denoise:
        raise ValueError("accumulated renders write the plain image: not with layers or denoise")
    fingerprint = scene_fingerprint(scene)
    image, done = _prior_batches(scene, fingerprint)
    spp = int(getattr(integrator, "spp", 1))
    written: list[Path] = []
    began = time.perf_counter()
    for here in range(out.most_batches):
        if not another_batch_fits(time.perf_counter() - began, here, out.time_budget_s):
            break
        seed = (settings.seed + done * BATCH_SEED_STRIDE) % 2**31
        batch = frame(integrator, replace(settings, seed=seed))
        image, done = _combined(image, batch, done), done + 1
        meta = {"accumulate_fingerprint": fingerprint, "accumulate_batches": done,
                "accumulate_seeds": f"{settings.seed} + k·{BATCH_SEED_STRIDE}, k < {done}",
                "spp_total": done * spp}  # fmt: skip
        if out.time_budget_s is not None:
            meta["time_budget_s"] = out.time_budget_s
        image = replace(image, metadata={**image.metadata, **meta})
        written = [save_image(image, out.path, scene.display_settings(), overwrite=True)]
    assert image is not None, "batches >= 1"
    if out.stats is not None:
        written.append(write_json(out.stats, image_stats(image, start), overwrite=True))
    return image, written


def another_batch_fits(elapsed_s: float, done: int, budget_s: float | None) -> bool:
    """Whether a render that spent ``elapsed_s`` seconds on ``done`` batches starts another
    within ``budget_s`` seconds (None: no budget): always the first; then only if the time so
    far plus one more batch at the mean time per batch fits."""
    if budget_s is None or done == 0:
        return True
    return elapsed_s * (done + 1) / done <= budget_s


def denoised(image: HDRImage) -> HDRImage:
    """``image`` through OIDN (``imaging.denoise``) in its RGB space, back to XYZ; the
    metadata names the denoiser."""
    from dataclasses import replace

    from incandescent.colorimetry import rgb_to_xyz
    from incandescent.imaging.denoise import DENOISER, denoise_rgb

    if image.xyz is None:
        raise ValueError(
            "denoising needs a physical (XYZ) render, not the 2011 paper's display RGB"
        )
    xyz = rgb_to_xyz(denoise_rgb(image.rgb(), image.luminance), image.space).astype(np.float32)
    return replace(image, xyz=xyz, metadata={**image.metadata, "denoised": DENOISER})


def image_stats(image: HDRImage, start: float) -> dict:
    """A render's statistics (``render --stats``); ``start``: when it began (perf_counter)."""
    meta = image.metadata
    return {
        "samples": int(meta["samples"]),
        "seconds": float(meta["seconds"]),
        "total_seconds": time.perf_counter() - start,
        "backend": meta["backend"],
        "device": meta["device"],
        "absorption": meta["absorption"],
        "temperature": meta["temperature"],
        "width": image.width,
        "height": image.height,
        "max_luminance_cd_m2": None if image.xyz is None else float(image.luminance.max()),
    }


#: Smallest ``--size`` of a demo scene.
MIN_DEMO_SIZE = 8
#: Peak bytes per voxel of building a demo scene (float64 NumPy fields, then the Volume):
#: tracemalloc peaks measured 21 (sparse) to 57 (sphere), rounded up.
DEMO_BYTES_PER_VOXEL = 64


def demo_volume(name: str, size: int | None = None, limits: Limits | None = None):
    """The built-in scene ``name`` (``scenes.SCENES``) built at ``size`` voxels (None: its
    default), its memory checked first."""
    from incandescent.scenes import SCENES

    scene = SCENES[name]
    if size is not None:
        if size < MIN_DEMO_SIZE:
            raise ValueError(f"--size must be >= {MIN_DEMO_SIZE} voxels; got {size}")
        (limits or Limits()).check_memory(
            float(size) ** 3 * DEMO_BYTES_PER_VOXEL, f"a {size}³ demo scene"
        )
    return scene.build(size or scene.default_size)


def demo_lighting(
    name: str, volume, max_bounces: int | None = None, spp: int = 2, in_scatter: str = "per-sample"
):
    """(volume, integrator) of demo ``name`` lit as its scene says (``Scene.lighting``), with
    ``max_bounces`` orders (None: 1; 0: emission–absorption, today's image) and its sampled
    lights ``in_scatter`` (``SingleScattering``); (volume, None) for a scene without
    lighting."""
    from incandescent.config.schema import LightSection
    from incandescent.renderer.integrators import MultipleScattering, SingleScattering
    from incandescent.scenes import SCENES

    lighting = SCENES[name].lighting
    if lighting is None or max_bounces == 0:
        return volume, None
    if max_bounces is not None and max_bounces < 0:
        raise ValueError(
            f"--max-bounces must be 0 (no scattering), 1 (single) or more; got {max_bounces}"
        )
    lit = volume.with_scattering(albedo=lighting["albedo"], phase_g=lighting["phase_g"])
    lights = tuple(LightSection(**spec).light() for spec in lighting["lights"])
    if max_bounces is None or max_bounces == 1:
        return lit, SingleScattering(lights=lights, spp=spp, in_scatter=in_scatter)
    return lit, MultipleScattering(
        lights=lights, spp=spp, max_bounces=max_bounces, in_scatter=in_scatter
    )


def grid_report(path: Path, axes: str | None = None) -> tuple[list, list[str], dict[str, str]]:
    """What ``incandescent info`` says about a volume file: its grids (``io.volumes.describe``),
    the warnings (a file's; a grid named like temperature that cannot be kelvin; its notes; NaN
    or infinite values) and grid name → what is not finite in it."""
    import numpy as np

    from incandescent.io.volumes import describe, file_warnings

    with np.errstate(invalid="ignore", over="ignore"):  # NaN/inf: reported below, once
        grids = describe(path, axes)
        bad = _nonfinite_grids(path, axes, grids)
    warnings = file_warnings(path, grids) + [w for g in grids for w in _grid_warnings(g, bad)]
    return grids, warnings, bad


def _grid_warnings(g, nonfinite: dict[str, str]) -> list[str]:
    import numpy as np

    from incandescent.volume.presets import kelvin_warning

    warning = None
    if g.value_max is not None and np.isfinite(g.value_max):
        warning = kelvin_warning(g.name, np.array([g.value_max]))
    bad = nonfinite.get(g.name)
    bad = bad and f"{g.name}: {bad}; render refuses a grid it uses with NaN or infinite values"
    return [t for t in (warning, g.note and f"{g.name}: {g.note}", bad) if t]


def _nonfinite_grids(path: Path, axes: str | None, grids) -> dict[str, str]:
    """Grid name → what is not finite in it (``_validate.nonfinite``, the rule render applies):
    a dense file's grids are read again one at a time (its summary skips NaN); a .vdb's
    summary (OpenVDB's range and sum over the active values) shows NaN and ±inf itself."""
    import numpy as np

    from incandescent import _validate
    from incandescent.io.formats import VDB_SUFFIXES
    from incandescent.io.volumes import open_grids

    readable = [g for g in grids if g.readable]
    if path.suffix.lower() in VDB_SUFFIXES:
        stats = {g.name: (g.value_min, g.value_max, g.value_sum) for g in readable}
        shown = lambda values: ", ".join("—" if v is None else f"{v:.4g}" for v in values)  # noqa: E731
        return {
            name: f"holds NaN or infinite values (min, max, sum: {shown(values)})"
            for name, values in stats.items()
            if any(v is not None and not np.isfinite(v) for v in values)
        }
    source, out = open_grids(path, axes), {}
    for g in readable:
        values = source.read([g.name]).arrays[g.name]
        found = _validate.nonfinite(values) if np.issubdtype(values.dtype, np.number) else None
        if found is not None:
            out[g.name] = f"{found[0]:,} of {values.size:,} values are NaN or infinite (first "
            out[g.name] += f"{found[1]})"
    return out


def strict_json(records: list[dict]) -> tuple[list[dict], list[str]]:
    """``records`` with every NaN or ±inf number as null (JSON has no such numbers), and one
    warning per grid naming the fields that became null."""
    import math

    out, warnings = [], []
    for record in records:
        nulled = {k: v for k, v in record.items() if isinstance(v, float) and not math.isfinite(v)}
        out.append(record | dict.fromkeys(nulled))
        if nulled:
            shown = ", ".join(f"{k} {v}" for k, v in nulled.items())
            warnings.append(f"{record['name']}: {shown} (not JSON numbers) shown as null")
    return out, warnings
