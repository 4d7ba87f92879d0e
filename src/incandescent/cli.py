"""The ``incandescent`` command line: thin typer commands over the Python API."""

from __future__ import annotations

import contextlib
import json
import logging
import signal
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape

from incandescent._version import __version__
from incandescent.io.formats import SCENE_SUFFIXES
from incandescent.scenes import SCENES

if TYPE_CHECKING:
    from incandescent.volume import Volume
    from incandescent.volume.sparse import SparseVolume

app = typer.Typer(
    help="Physically based volumetric rendering of incandescent gas (flames, explosions, plumes).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts show defaults in [brackets]: no markup in them
    add_completion=False,
)
console = Console(stderr=True)

#: The built-in scenes (``incandescent.scenes.SCENES``) and the paper's plate video.
DEMOS = (*SCENES, "plate")


#: Exit status after Ctrl-C (SIGINT) or SIGTERM: 128 + SIGINT, as shells report it.
EXIT_INTERRUPTED = 130


class _Failed(Exception):
    """Raised by _fail inside a guarded block: the message is printed, exit status 2."""


def _fail(message: str) -> typer.Exit:
    """Print ``message`` as one error (no markup interpreted, no wrapping); exit status 2."""
    console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return typer.Exit(code=2)


def _say(message: str) -> None:
    """Print ``message`` verbatim (paths may hold [brackets]) without wrapping."""
    console.print(message, highlight=False, markup=False, soft_wrap=True)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning (e.g. a scene key of an earlier release) as one line, without source lines."""
    _say(f"warning: {message}")


@contextlib.contextmanager
def _guarded() -> Iterator[None]:
    """Turn every expected failure of a command into one line and exit status 2, and Ctrl-C or
    SIGTERM into exit status 130; outputs are atomic, so an interrupted command leaves none
    half-written (an animation keeps its finished frames)."""
    try:
        yield
    except typer.Exit:  # a RuntimeError subclass: already reported
        raise
    except KeyboardInterrupt:
        _say("interrupted: no output was left half-written")
        raise typer.Exit(code=EXIT_INTERRUPTED) from None
    except MemoryError:
        raise _fail("out of memory; make the input, image or step smaller") from None
    except (ValueError, TypeError, OSError, RuntimeError) as error:
        raise _fail(str(error) or type(error).__name__) from None


@contextlib.contextmanager
def _render_progress() -> Iterator[Callable[[float], None]]:
    """A transient progress bar on a terminal (nothing elsewhere, and rich's progress module is
    then not imported: ~10 ms of each scripted render); yields ``report(fraction)``."""
    if not console.is_terminal:
        yield lambda fraction: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("rendering"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f} %"),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    )
    task = bar.add_task("render", total=1.0)
    with bar:
        yield lambda fraction: bar.update(task, completed=fraction)


def _terminate(signum, frame) -> None:
    raise KeyboardInterrupt  # so that cleanups run and temporary files go


def _limits(max_memory: float | None, max_samples: float | None):
    from incandescent.budget import DEFAULT_MAX_SAMPLES, GIB, Limits

    for flag, value in (("--max-memory", max_memory), ("--max-samples", max_samples)):
        if value is not None and not value > 0:  # also refuses nan
            raise ValueError(f"{flag} must be a number > 0; got {value}")
    memory = None if max_memory is None else max_memory * GIB
    from incandescent.io import openvdb

    openvdb.set_memory_budget(memory)  # the OpenVDB worker's reads are bounded too
    return Limits(memory, DEFAULT_MAX_SAMPLES if max_samples is None else max_samples)


MAX_MEMORY_HELP = "Refuse work estimated to need more memory, GiB [the memory available now]."
MAX_SAMPLES_HELP = "Refuse renders estimated to take more ray-march samples [1e11]."


# --- options shared by render, animate and convert (one definition each) ------------------
OPT_ABSORPTION = typer.Option(
    None,
    help="Constant absorption κ in 1/m [the file's absorption grid, else 1/L where T >= 500 K,"
    " L = the box's largest side].",
)
OPT_VOXEL_SIZE = typer.Option(None, help="Voxel side in m [file's, else largest side 1 m].")
OPT_TEMPERATURE_GRID = typer.Option(
    None, help="Name of the temperature grid [temperature, heat or temp]."
)
OPT_PRESET = typer.Option(None, help="Source preset: blender | houdini | embergen.")
OPT_UP_AXIS = typer.Option(None, help="The source's up axis: y | z [preset's, else y].")
OPT_AXES = typer.Option(
    None, help="Order of the stored array axes, e.g. zyx (files that do not say) [xyz]."
)
OPT_OFFSET = typer.Option(None, help="Temperature remap: T = (raw − offset)·scale [0].")
OPT_SCALE = typer.Option(None, help="Temperature remap scale, K per raw unit [1].")
OPT_CUTOFF = typer.Option(None, help="Voxels below this many K are vacuum [0].")
OPT_TEMPERATURE_RANGE = typer.Option(
    None, help="LOW:HIGH — map a normalised 0..1 field linearly to LOW..HIGH K."
)
OPT_SPECIES = typer.Option(
    None,
    help="Emitting species, NAME=FRACTION or NAME=GRID, comma-separated (e.g. Na=0.02,"
    "Li=lithium); lines from the shipped table or --line-table.",
)
OPT_LINE_TABLE = typer.Option(None, help="Species line table (.csv/.toml) [shipped].")
OPT_LAYOUT = typer.Option(
    None, help="Grid layout: auto | dense | sparse (occupied 8³ bricks only) [auto]."
)
OPT_SHUTTER = typer.Option(
    None,
    help="Motion blur: shutter OPEN:CLOSE in frames around each frame's instant, e.g. "
    "-0.25:0.25 (a 180° shutter) [off; needs a velocity grid].",
)
OPT_VELOCITY_GRID = typer.Option(None, help="Velocity grid for motion blur [velocity, vel, v].")
OPT_VELOCITY_UNITS = typer.Option(None, help="Velocity grid units: m/s | voxels/frame [m/s].")


def _nonnegative(flag: str) -> Callable[[float | None], float | None]:
    """A typer callback refusing a negative or non-finite value of ``flag`` as it is parsed,
    before the command reads anything (every command sharing the option gets it)."""

    def check(value: float | None) -> float | None:
        if value is not None and not 0.0 <= value < float("inf"):  # also refuses nan
            raise _fail(f"{flag} must be a finite number >= 0; got {value!r}")
        return value

    return check


OPT_VELOCITY_SCALE = typer.Option(
    None,
    help="Factor on the velocity grid (Blender's), >= 0 [1].",
    callback=_nonnegative("--velocity-scale"),
)
OPT_MAX_MEMORY = typer.Option(None, help=MAX_MEMORY_HELP)
OPT_MAX_SAMPLES = typer.Option(None, help=MAX_SAMPLES_HELP)


def _vector(text: str | None, name: str) -> tuple[float, float, float] | None:
    if text is None:
        return None
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3:
        raise _fail(f"--{name} must be three numbers X,Y,Z in m; got {text!r}")
    return values  # type: ignore[return-value]


@app.callback()
def main(
    verbose: bool = typer.Option(
        False, "--verbose", "-v", help="Log backend selection and timings."
    ),
) -> None:
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, format="%(message)s")
    warnings.showwarning = _show_warning
    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _terminate)


@app.command()
def version() -> None:
    """Print the version."""
    typer.echo(__version__)


@app.command()
def render(
    source: Path = typer.Argument(
        ...,
        help="A volume file (.npy .npz .vdb .nvdb .h5 .hdf5 .nc) or a scene file (.toml, .json) "
        "whose values the options below override.",
    ),
    output: Path = typer.Option(None, "--output", "-o", help="Output image: .exr (HDR) or .png."),
    width: int = typer.Option(None, help="Image width in pixels [512]."),
    height: int = typer.Option(None, help="Image height in pixels [512]."),
    step: float = typer.Option(None, help="Ray-march step in voxels [0.5]."),
    supersample: int = typer.Option(None, help="N for N×N rays per pixel [1]."),
    seed: int = typer.Option(None, help="Jitter seed [0]."),
    absorption: float = OPT_ABSORPTION,
    voxel_size: float = OPT_VOXEL_SIZE,
    temperature_grid: str = OPT_TEMPERATURE_GRID,
    preset: str = OPT_PRESET,
    up_axis: str = OPT_UP_AXIS,
    axes: str = OPT_AXES,
    offset: float = OPT_OFFSET,
    scale: float = OPT_SCALE,
    cutoff: float = OPT_CUTOFF,
    temperature_range: str = OPT_TEMPERATURE_RANGE,
    eye: str = typer.Option(None, help="Camera position X,Y,Z in m [three-quarter view]."),
    target: str = typer.Option(None, help="Point looked at, X,Y,Z in m [centre of the gas]."),
    fov: float = typer.Option(None, help="Vertical field of view in degrees [40]."),
    backend: str = typer.Option(
        None, help="auto | cpu | cuda | reference [auto; env INCANDESCENT_BACKEND]."
    ),
    exposure: float = typer.Option(None, help="Exposure compensation in EV (PNG) [0]."),
    auto_exposure: bool = typer.Option(
        None, "--auto-exposure/--no-auto-exposure", help="Auto exposure (PNG) [on]."
    ),
    tonemap: str = typer.Option(None, help="PNG tone map: clip | reinhard | filmic [filmic]."),
    space: str = typer.Option(None, help="RGB space: srgb | rec2020 | display_p3 | acescg."),
    brightness: str = typer.Option(
        None, help="physical (absolute Planck, emission–absorption) | paper (the 2011 method)."
    ),
    integrator: str = typer.Option(
        None, help="emission_absorption | paper2011 (the [integrator] type) [emission_absorption]."
    ),
    spectral_bins: int = typer.Option(
        None, help="emission_absorption: N spectral bins for soot's κ_λ (0: grey) [0]."
    ),
    sodium: float = typer.Option(None, help="Constant sodium fraction 0..1 (species Na)."),
    paper_exponent: float = typer.Option(None, help="Paper mode: brightness ∝ T^exponent [1.5]."),
    species: str = OPT_SPECIES,
    line_table: Path = OPT_LINE_TABLE,
    stats: Path = typer.Option(None, help="Write render statistics (JSON) to this file."),
    overwrite: bool = typer.Option(None, "--overwrite", help="Replace existing output files."),
    layout: str = OPT_LAYOUT,
    shutter: str = OPT_SHUTTER,
    fps: float = typer.Option(None, help="Frames per second, for the shutter [24]."),
    velocity_grid: str = OPT_VELOCITY_GRID,
    velocity_units: str = OPT_VELOCITY_UNITS,
    velocity_scale: float = OPT_VELOCITY_SCALE,
    max_memory: float = OPT_MAX_MEMORY,
    max_samples: float = OPT_MAX_SAMPLES,
) -> None:
    """Render a volume file, or a scene file, to an image."""
    from incandescent import api
    from incandescent.io.atomic import all_or_nothing

    flags = dict(locals())
    with _guarded():
        limits = _limits(max_memory, max_samples)
        scene = _scene(source, _overrides(flags))
        out = scene.output
        if out.path is None:
            raise ValueError("no output: give -o OUT.exr|.png or [output] path in the scene file")
        _check_outputs(out.path, out.stats, out.overwrite, _inputs(source, scene))
        backend = _start_backends(scene.volume.path, out.backend)
        settings, transport = scene.render_settings(), scene.render_integrator()
        blur_fps = settings.fps if settings.shutter is not None else None
        volume = api.volume_from_section(
            scene.volume, scene.remap(), limits, settings.layout, blur_fps
        )
        start = time.perf_counter()
        camera = scene.camera_for(volume)
        with _render_progress() as progress:
            image = api.render(
                volume, camera, settings, backend, limits, progress, integrator=transport
            )
        with all_or_nothing():  # the image and its stats, or neither
            written = [api.save_image(image, out.path, scene.display_settings(), out.overwrite)]
            if out.stats is not None:
                stats_data = _stats(image, start)
                written.append(api.write_json(out.stats, stats_data, overwrite=out.overwrite))
    _summary(image, written)


def _start_backends(path: Path, backend: str | None) -> str:
    """The render backend resolved before the volume is read: a .vdb's OpenVDB worker starts (a
    process of its own) while it loads here (Dr.Jit, ~80 ms), and a backend that cannot run is an
    error before any reading."""
    if path.suffix.lower() == ".vdb":
        from incandescent.io import openvdb

        openvdb.start()
    from incandescent.renderer.backends import resolve_backend

    return resolve_backend(backend)


def _scene(source: Path, overrides: dict):
    """The scene a CLI call describes: a scene file with the flags over it, or a volume file."""
    from incandescent.config import load_scene, scene_from_dict

    if source.suffix.lower() in SCENE_SUFFIXES:
        return load_scene(source, overrides)
    return scene_from_dict({"volume": {"path": str(source)}}, None, overrides, source=str(source))


def _species(text: str | None) -> dict | None:
    """``Na=0.02,Li=lithium`` → {"Na": 0.02, "Li": "lithium"} (a number or a grid name)."""
    if text is None:
        return None
    out: dict[str, float | str] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise _fail(f"--species entries must be NAME=FRACTION or NAME=GRID; got {item!r}")
        try:
            out[name] = float(value)
        except ValueError:
            out[name] = value
    return out


def _pair(text: str | None, flag: str, expected: str) -> list[float] | None:
    """``A:B`` → [A, B] (None when the flag was not given)."""
    if text is None:
        return None
    low, sep, high = text.partition(":")
    try:
        if not sep:
            raise ValueError
        return [float(low), float(high)]
    except ValueError:
        raise _fail(f"{flag} must be {expected}; got {text!r}") from None


def _integrator_name(name: str | None, brightness: str | None) -> str | None:
    """``--integrator NAME``, or ``--brightness physical|paper`` read as one (None: neither)."""
    from incandescent.config.legacy import BRIGHTNESS_INTEGRATORS

    if brightness is not None and brightness not in BRIGHTNESS_INTEGRATORS:
        raise _fail(f"--brightness must be physical or paper; got {brightness!r}")
    by_brightness = None if brightness is None else BRIGHTNESS_INTEGRATORS[brightness]
    if name is not None and by_brightness is not None and name != by_brightness:
        raise _fail(f"--integrator {name} and --brightness {brightness} disagree; give one")
    return name or by_brightness


def _with_sodium(species: dict | None, sodium: float | None) -> dict | None:
    """``--species`` with ``--sodium F`` as species Na."""
    if sodium is None:
        return species
    if species and "Na" in species:
        raise _fail("--sodium is the fraction of species Na, also given in --species; give one")
    return {**(species or {}), "Na": sodium}


def _overrides(f: dict) -> dict:
    """Nested scene keys for the flags that were given (None = not given)."""
    low_high = None
    if f.get("temperature_range") is not None:
        low, _, high = f["temperature_range"].partition(":")
        try:
            low_high = [float(low), float(high)]
        except ValueError:
            raise _fail(
                f"--temperature-range must be LOW:HIGH in K (e.g. 800:2200); "
                f"got {f['temperature_range']!r}"
            ) from None
    return {
        "volume": {
            "absorption": f.get("absorption"),
            "voxel_size_m": f.get("voxel_size"),
            "preset": f.get("preset"),
            "up_axis": f.get("up_axis"),
            "species": _with_sodium(_species(f.get("species")), f.get("sodium")),
            "axes": f.get("axes"),
            "grids": {"temperature": f.get("temperature_grid"), "velocity": f.get("velocity_grid")},
            "velocity_units": f.get("velocity_units"),
            "velocity_scale": f.get("velocity_scale"),
            "temperature": {
                "offset": f.get("offset"),
                "scale": f.get("scale"),
                "cutoff_K": f.get("cutoff"),
                "range": low_high,
            },
        },
        "camera": {
            "eye": _vector(f.get("eye"), "eye"),
            "target": _vector(f.get("target"), "target"),
            "fov_deg": f.get("fov"),
        },
        "render": {
            "width": f.get("width"),
            "height": f.get("height"),
            "step_voxels": f.get("step"),
            "supersample": f.get("supersample"),
            "seed": f.get("seed"),
            "space": f.get("space"),
            "layout": f.get("layout"),
            "shutter": _pair(
                f.get("shutter"), "--shutter", "OPEN:CLOSE in frames (e.g. -0.25:0.25)"
            ),
            "fps": f.get("fps"),
        },
        "integrator": {
            "type": _integrator_name(f.get("integrator"), f.get("brightness")),
            "spectral_bins": f.get("spectral_bins"),
            "exponent": f.get("paper_exponent"),
        },
        "emission": {
            "line_table": None if f.get("line_table") is None else str(f.get("line_table")),
        },
        "display": {
            "exposure_ev": f.get("exposure"),
            "auto_exposure": f.get("auto_exposure"),
            "tonemap": f.get("tonemap"),
        },
        "output": {
            "path": f.get("output"),
            "stats": f.get("stats"),
            "overwrite": f.get("overwrite"),
            "backend": f.get("backend"),
        },
    }


def _check_outputs(
    image: Path, stats: Path | None, overwrite: bool, inputs: list[Path] | None = None
) -> None:
    """Fail before rendering, not after: unsupported suffix, existing file without --overwrite,
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


def _inputs(source: Path, scene) -> list[Path]:
    """The files a render reads: the command's argument (a volume or a scene file), the volume
    the scene names, and its line table."""
    table = scene.emission.line_table
    return [source, scene.volume.path, *([] if table is None else [Path(table)])]


def _stats(image, start: float) -> dict:
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


def _summary(image, written: list[Path]) -> None:
    meta = image.metadata
    _say(
        f"rendered {image.width}×{image.height} on {meta['backend']} ({meta['device']}): "
        f"{meta['samples']:,} samples in {meta['seconds'] * 1e3:.1f} ms; "
        f"absorption {meta['absorption']}"
    )
    for path in written:
        _say(f"  wrote {path}")


def _demo_volume(name: str, size: int | None) -> Volume | SparseVolume:
    scene = SCENES[name]
    return scene.build(size or scene.default_size)


#: Smallest ``--size`` of a demo scene.
MIN_DEMO_SIZE = 8
#: Peak bytes per voxel of building a demo scene (float64 NumPy fields, then the Volume):
#: tracemalloc peaks measured 21 (sparse) to 57 (sphere), rounded up.
DEMO_BYTES_PER_VOXEL = 64


def _check_demo_size(size: int | None, limits) -> None:
    if size is None:
        return
    if size < MIN_DEMO_SIZE:
        raise ValueError(f"--size must be >= {MIN_DEMO_SIZE} voxels; got {size}")
    limits.check_memory(float(size) ** 3 * DEMO_BYTES_PER_VOXEL, f"a {size}³ demo scene")


@app.command()
def demo(
    name: str = typer.Argument("fire", help=f"Scene: {', '.join(DEMOS)}."),
    output: Path = typer.Option(
        None,
        "--output",
        "-o",
        help="Output: .png/.exr for images (default NAME.png); .mp4, .gif or a folder of PNG "
        "frames for plate (default plate.mp4).",
    ),
    size: int = typer.Option(None, help="Grid resolution (plume/sparse/soot 128, sphere 64, 96)."),
    width: int = typer.Option(None, help="Image width (512; plate 320)."),
    height: int = typer.Option(None, help="Image height (512; plate 240)."),
    frames: int = typer.Option(250, help="plate: number of frames."),
    brightness: str = typer.Option("physical", help="physical | paper (the 2011 method)."),
    backend: str = typer.Option("auto", help="auto | cpu | cuda | reference."),
    overwrite: bool = typer.Option(
        False, help="Replace an existing output (plate: and render every frame again)."
    ),
    max_memory: float = OPT_MAX_MEMORY,
    max_samples: float = OPT_MAX_SAMPLES,
) -> None:
    """Render a built-in scene: plume, sparse, the paper's sphere, or the paper's plate video.

    The plate video resumes: frames already in its frame folder, made with the same settings,
    are not rendered again.
    """
    from incandescent import api

    if name not in DEMOS:
        raise _fail(f"unknown demo {name!r}; expected one of: {', '.join(DEMOS)}")
    video = name == "plate"
    output = output or Path(f"{name}.mp4" if video else f"{name}.png")
    with _guarded():
        limits = _limits(max_memory, max_samples)
        settings = api.RenderSettings(
            width=width or (320 if video else 512), height=height or (240 if video else 512)
        )
        integrator = _brightness_integrator(brightness)
        if video:
            _demo_plate(output, settings, integrator, frames, backend, overwrite)
            return
        _check_outputs(output, None, overwrite)
        _check_demo_size(size, limits)
        with console.status(f"building the {name} scene…"):
            volume = _demo_volume(name, size)
        scene = SCENES[name]
        display, camera = scene.display, scene.camera and scene.camera()
        with console.status(f"rendering {settings.width}×{settings.height}…"):
            image = api.render(volume, camera, settings, backend, limits, integrator=integrator)
        written = [api.save_image(image, output, display, overwrite=overwrite)]
    _summary(image, written)


def _brightness_integrator(brightness: str):
    """The integrator ``--brightness physical|paper`` names."""
    from incandescent.renderer.integrators import integrator_from_dict

    return integrator_from_dict({"type": _integrator_name(None, brightness)})


def _demo_plate(output: Path, settings, integrator, frames: int, backend: str, overwrite: bool):
    from incandescent.animation import render_plate_video
    from incandescent.scenes.paper import PlateScene

    if frames < 1:
        raise ValueError(f"--frames must be >= 1; got {frames}")
    scene = PlateScene(n_frames=frames)
    start = time.perf_counter()
    render_plate_video(
        output, settings, scene, backend=backend, overwrite=overwrite, integrator=integrator
    )
    _say(f"plate: {frames} frames in {time.perf_counter() - start:.1f} s")


@app.command()
def info(
    path: Path = typer.Argument(..., help="A volume file: .npy .npz .vdb .nvdb .h5 .hdf5 .nc."),
    axes: str = OPT_AXES,
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (for scripts)."),
) -> None:
    """List a volume file's grids: type, active voxels and box, value range and sum, placement;
    warn about grids named like temperature that cannot be kelvin, and name the preset a known
    cache needs."""
    from incandescent.io.volumes import describe, file_warnings

    with _guarded():
        if path.suffix.lower() in SCENE_SUFFIXES:  # a scene: describe the volume file it names
            spec = _scene(path, {}).volume
            if not as_json:
                _say(f"{path}: a scene file; its volume is {spec.path}")
            path, axes = spec.path, axes or spec.axes
        with np.errstate(invalid="ignore", over="ignore"):  # NaN/inf: reported below, once
            grids = describe(path, axes)
            bad = _nonfinite_voxels(path, axes, grids)
    warnings = file_warnings(path, grids) + [w for g in grids for w in _grid_warnings(g, bad)]
    if as_json:
        records = [g.as_json() | {"finite": g.name not in bad} for g in grids]
        records, nulls = _strict_json(records)
        report = {"path": str(path), "grids": records, "warnings": warnings + nulls}
        typer.echo(json.dumps(report, indent=2, allow_nan=False))
        return
    _info_table(path, grids)
    for text in warnings:
        console.print(f"[yellow]note:[/] {escape(text)}", highlight=False, soft_wrap=True)


def _grid_warnings(g, nonfinite: dict[str, str] | None = None) -> list[str]:
    from incandescent.volume.presets import kelvin_warning

    warning = None
    if g.value_max is not None and np.isfinite(g.value_max):
        warning = kelvin_warning(g.name, np.array([g.value_max]))
    bad = (nonfinite or {}).get(g.name)
    bad = bad and f"{g.name}: {bad}; render refuses a grid it uses with NaN or infinite values"
    return [t for t in (warning, g.note and f"{g.name}: {g.note}", bad) if t]


def _nonfinite_voxels(path: Path, axes: str | None, grids) -> dict[str, str]:
    """Grid name → what is not finite in it (``_validate.nonfinite``, the rule render applies):
    a dense file's grids are read again one at a time (its summary skips NaN); a .vdb's
    summary (OpenVDB's range and sum over the active values) shows NaN and ±inf itself."""
    from incandescent import _validate
    from incandescent.io.formats import VDB_SUFFIXES
    from incandescent.io.volumes import open_grids

    readable = [g for g in grids if g.readable]
    if path.suffix.lower() in VDB_SUFFIXES:
        stats = {g.name: (g.value_min, g.value_max, g.value_sum) for g in readable}
        return {
            name: f"holds NaN or infinite values (min, max, sum: {_nums(values)})"
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


def _nums(values) -> str:
    return ", ".join(_num(v) for v in values)


def _strict_json(records: list[dict]) -> tuple[list[dict], list[str]]:
    """``records`` with every NaN or ±inf number as null (JSON has no such numbers), and one
    warning per grid naming the fields that became null."""
    out, warnings = [], []
    for record in records:
        nulled = {k: v for k, v in record.items() if isinstance(v, float) and not np.isfinite(v)}
        out.append(record | dict.fromkeys(nulled))
        if nulled:
            shown = ", ".join(f"{k} {v}" for k, v in nulled.items())
            warnings.append(f"{record['name']}: {shown} (not JSON numbers) shown as null")
    return out, warnings


def _info_table(path: Path, grids) -> None:
    from rich.table import Table

    table = Table(title=escape(str(path)))
    columns = ("grid", "type", "active voxels", "shape (x, y, z)", "min", "max", "placement")
    for column in columns:
        table.add_column(column)
    for g in grids:
        active = "—" if g.active_voxels is None else f"{g.active_voxels:,}"
        cells = (g.name, g.value_type, active, str(g.shape), _num(g.value_min), _num(g.value_max))
        table.add_row(*(escape(c) for c in (*cells, g.placement)))
    Console(width=180).print(table)


def _num(value: float | None) -> str:
    return "—" if value is None else f"{value:.4g}"


@app.command()
def convert(
    source: Path = typer.Argument(..., help="A volume file (any readable format) or a scene file."),
    output: Path = typer.Argument(..., help="Output: .npz (dense, placed) or .vdb (sparse)."),
    preset: str = OPT_PRESET,
    temperature_grid: str = OPT_TEMPERATURE_GRID,
    offset: float = OPT_OFFSET,
    scale: float = OPT_SCALE,
    cutoff: float = OPT_CUTOFF,
    temperature_range: str = OPT_TEMPERATURE_RANGE,
    absorption: float = OPT_ABSORPTION,
    voxel_size: float = OPT_VOXEL_SIZE,
    up_axis: str = OPT_UP_AXIS,
    axes: str = OPT_AXES,
    overwrite: bool = typer.Option(False, "--overwrite", help="Replace an existing output."),
    max_memory: float = OPT_MAX_MEMORY,
) -> None:
    """Convert a volume to .npz or .vdb: the grids the renderer would use (temperature in K,
    absorption in 1/m, emission scale, fractions), placed, y up; .vdb is written by OpenVDB."""
    from incandescent import api
    from incandescent.io.atomic import check_output
    from incandescent.io.output import VOLUME_OUTPUT_SUFFIXES, save_volume

    flags = dict(locals())
    with _guarded():
        limits = _limits(max_memory, None)
        check_output(output, overwrite, VOLUME_OUTPUT_SUFFIXES, "volume")
        _check_vdb_writer(output)
        scene = _scene(source, _overrides(flags))
        check_output(output, overwrite, inputs=[source, scene.volume.path])
        from incandescent.config.carry import carried
        from incandescent.volume import Volume

        spec, velocity, left_out = carried(scene.volume, scene.emission.line_table, limits)
        volume = api.volume_from_section(spec, scene.remap(), limits, "dense", velocity=velocity)
        assert isinstance(volume, Volume)  # a dense read
        written = save_volume(volume, output, overwrite=overwrite)
    _say(f"converted {source} ({volume.shape[0]}×{volume.shape[1]}×{volume.shape[2]} voxels, "
         f"voxel {volume.voxel_size_m:g} m) to {written}")  # fmt: skip
    for note in left_out:
        _say(f"left out: {note}")


def _check_vdb_writer(output: Path) -> None:
    """A ``.vdb`` output needs OpenVDB: say so before any work, naming the output."""
    if output.suffix.lower() != ".vdb":
        return
    from incandescent.io import openvdb

    problem = openvdb.problem()
    if problem is not None:
        raise ValueError(f"cannot write {output}: {problem}")


@app.command()
def animate(
    pattern: str = typer.Argument(
        ..., help="Volume files of a sequence: a glob ('cache/*.npz') or a #### frame pattern."
    ),
    output: Path = typer.Option(
        ..., "--output", "-o", help="Output .mp4, .gif, or a folder for PNG frames."
    ),
    width: int = typer.Option(640, help="Frame width in pixels."),
    height: int = typer.Option(360, help="Frame height in pixels."),
    step: float = typer.Option(0.5, help="Ray-march step in voxels."),
    absorption: float = OPT_ABSORPTION,
    voxel_size: float = OPT_VOXEL_SIZE,
    temperature_grid: str = OPT_TEMPERATURE_GRID,
    preset: str = OPT_PRESET,
    up_axis: str = OPT_UP_AXIS,
    axes: str = OPT_AXES,
    species: str = OPT_SPECIES,
    line_table: Path = OPT_LINE_TABLE,
    offset: float = OPT_OFFSET,
    scale: float = OPT_SCALE,
    cutoff: float = OPT_CUTOFF,
    temperature_range: str = OPT_TEMPERATURE_RANGE,
    eye: str = typer.Option(None, help="Camera position X,Y,Z in m (default: three-quarter view)."),
    target: str = typer.Option(None, help="Point looked at, X,Y,Z in m."),
    fov: float = typer.Option(40.0, help="Vertical field of view in degrees."),
    brightness: str = typer.Option("physical", help="physical | paper."),
    exposure: float = typer.Option(
        0.0, help="Exposure compensation in EV over the fixed exposure."
    ),
    fps: float = typer.Option(25.0, help="Frames per second of the video."),
    orbit: float = typer.Option(
        0.0, help="Orbit the camera this many degrees about the vertical axis over the video."
    ),
    backend: str = typer.Option("auto", help="auto | cpu | cuda | reference."),
    overwrite: bool = typer.Option(
        False, help="Replace an existing video and render every frame again."
    ),
    layout: str = OPT_LAYOUT,
    shutter: str = OPT_SHUTTER,
    velocity_grid: str = OPT_VELOCITY_GRID,
    velocity_units: str = OPT_VELOCITY_UNITS,
    velocity_scale: float = OPT_VELOCITY_SCALE,
    workers: int = typer.Option(
        None,
        help="Render on a local Dask cluster of N worker processes (at most 2 per core and one "
        "per 512 MiB of memory) [in-process].",
    ),
    scheduler: str = typer.Option(
        None,
        help="Render on an existing Dask cluster: tcp://HOST:PORT, which must answer within "
        "20 s ($INCANDESCENT_SCHEDULER_TIMEOUT) [$INCANDESCENT_SCHEDULER].",
    ),
    max_memory: float = OPT_MAX_MEMORY,
    max_samples: float = OPT_MAX_SAMPLES,
) -> None:
    """Render a sequence of volume files to MP4/GIF/PNG frames with one camera and one exposure.

    The camera frames the first file's box; the exposure is auto exposure of the middle frame.
    Re-running resumes: frames already in OUTPUT_frames/ that were made from the same files,
    settings and version (its manifest.json says) are not rendered again; frames made otherwise
    are refused unless --overwrite. One run at a time writes an output. With --workers or
    --scheduler the frames are Dask tasks (each reads its file, renders and writes its PNG); the
    exit status is then 100 + the number of frames that failed (at most 125).
    """
    flags = dict(locals())
    from incandescent import api, cluster
    from incandescent.animation import (
        FramesFailed,
        expand_sequence,
        file_identity,
        fixed_display,
        frame_path,
        keep_frame_memory,
        key_frame,
        plan_output,
        render_video,
    )
    from incandescent.camera import paths as paths_module

    with _guarded():
        limits = _limits(max_memory, max_samples)
        cluster.resolve(workers, scheduler)  # the worker count and address, before any work
        frame_dir, _ = plan_output(output, None, overwrite)  # before reading or rendering
        paths = expand_sequence(pattern)
        keep_frame_memory()  # this process renders a sequence: frames reuse freed memory
        overrides = _overrides(flags)  # the same schema as `render` ...
        overrides.pop("output")  # ... except the output, a video or a folder here
        scene = _scene(paths[0], overrides)
        settings = scene.render_settings()
        blur_fps = settings.fps if settings.shutter is not None else None

        def volume_at(index: int):
            spec = scene.volume.model_copy(update={"path": paths[index]})
            return api.volume_from_section(spec, scene.remap(), limits, settings.layout, blur_fps)

        def frame_input(index: int) -> str:
            return f"{file_identity(paths[index])} {scene.volume!r} {scene.remap()!r}"

        first = volume_at(0)
        camera = api.camera_from(
            first, _vector(eye, "eye"), _vector(target, "target"), fov, frame_content=False
        )
        settings = scene.render_settings()  # width, height, step: flags
        integrator = scene.render_integrator()  # brightness, line table: flags
        path = paths_module.orbit(camera, len(paths), orbit) if orbit else camera
        display = fixed_display(
            volume_at(key_frame(paths)),
            camera,
            settings,
            backend,
            api.DisplaySettings(exposure_ev=exposure),
            integrator,
        )
        start = time.perf_counter()
        camera_at = path if callable(path) else (lambda _: path)

        def task(index: int, threads: int | None) -> cluster.FrameTask:
            spec = scene.volume.model_copy(update={"path": paths[index]})
            return cluster.FrameTask(index, spec, scene.remap(), settings.layout, blur_fps,
                                     camera_at(index), settings, display, backend,
                                     frame_path(frame_dir, index), threads,
                                     integrator)  # fmt: skip

        with cluster.connect(workers, scheduler) as (client, threads):
            distribute = cluster.distributor(client, lambda i: task(i, threads))
            try:
                render_video(
                    volume_at,
                    len(paths),
                    output,
                    path,
                    settings,
                    display,
                    backend=backend,
                    overwrite=overwrite,
                    fps=fps,
                    frame_input=frame_input,
                    limits=limits,
                    distribute=distribute,
                    integrator=integrator,
                )
            except FramesFailed as failed:
                for index, reason in sorted(failed.failures.items()):
                    _say(f"frame {index} failed: {reason}")
                _say(f"error: {failed}")
                raise typer.Exit(code=min(100 + len(failed.failures), 125)) from None
    _say(f"animate: {len(paths)} frames in {time.perf_counter() - start:.1f} s")


@app.command()
def simulate(
    preset_name: str = typer.Argument(
        ..., metavar="PRESET", help="candle | torch | campfire | explosion."
    ),
    output: Path = typer.Option(..., "--output", "-o", help="Folder for the frames (fire_####)."),
    resolution: int = typer.Option(64, help="Cells along the domain's longest side."),
    frames: int = typer.Option(48, help="Frames to simulate."),
    settings_file: Path = typer.Option(
        None, "--settings", help="A .toml/.json of FireSettings fields over the preset's."
    ),
    seed: int = typer.Option(None, help="Seed of the sources' turbulence [preset's: 0]."),
    frame_format: str = typer.Option("npz", "--format", help="Frame files: npz | vdb."),
    backend: str = typer.Option("auto", help="auto | cpu | cuda | reference."),
    render_to: Path = typer.Option(
        None, "--render", help="Also render the frames to this .mp4/.gif/folder."
    ),
    width: int = typer.Option(320, help="Rendered frame width."),
    height: int = typer.Option(480, help="Rendered frame height."),
    workers: int = typer.Option(None, help="--render on a local Dask cluster of N workers."),
    scheduler: str = typer.Option(None, help="--render on an existing Dask cluster."),
    exposure: float = typer.Option(
        None,
        help="--render with this fixed exposure (EV) [auto: from the middle frame, after the "
        "simulation]; each frame is then rendered as soon as it is written (with "
        "--workers/--scheduler on the cluster, while the next is simulated).",
    ),
    overwrite: bool = typer.Option(False, help="Start again even if OUTPUT holds another run."),
    max_memory: float = OPT_MAX_MEMORY,
) -> None:
    """Simulate a fire (Nguyen, Fedkiw & Jensen 2002) into frames the renderer reads.

    Frames hold temperature (K), absorption (soot, 1/m), the blue core's CH and C2 fractions and
    the velocity (m/s). A checkpoint after each frame lets an interrupted run resume: run the
    same command again. --render renders the frames afterwards (fixed camera and exposure)."""
    from incandescent.renderer.backends import resolve_backend
    from incandescent.simulation import run
    from incandescent.simulation import settings as fire_settings

    with _guarded():
        limits = _limits(max_memory, None)
        changes = _settings_changes(settings_file)
        named = None if settings_file is None else str(settings_file)
        settings = fire_settings.from_changes(preset_name, changes, named)
        if seed is not None:
            settings = fire_settings.from_changes(preset_name, changes | {"seed": seed}, "--seed")
        suffix = "." + frame_format.lstrip(".")
        name = resolve_backend(backend)
        if render_to is not None:
            from incandescent.animation import plan_output

            plan_output(render_to, None, overwrite)
        overlap = render_to is not None and exposure is not None
        with _simulation_progress(frames) as on_frame:
            if overlap:
                run.simulate_and_render(settings, resolution, frames, output, render_to,
                                        exposure, width, height, name, suffix, overwrite,
                                        workers, scheduler, on_frame, limits)  # fmt: skip
            else:
                run.simulate(settings, resolution, frames, output, name, suffix, overwrite,
                             on_frame, limits)  # fmt: skip
        if render_to is not None and not overlap:
            display = None
            if exposure is not None:
                from incandescent.imaging import DisplaySettings

                display = DisplaySettings(exposure_ev=exposure, auto_exposure=False)
            run.render_frames(output, frames, render_to, width, height, settings.fps,
                              backend, overwrite, suffix, True, workers, scheduler,
                              display)  # fmt: skip
        if render_to is not None:
            _say(f"  rendered {render_to}")


def _settings_changes(path: Path | None) -> dict:
    """FireSettings fields from a TOML/JSON file (validated with the preset's)."""
    if path is None:
        return {}
    from incandescent.simulation.settings import read_settings_file

    return read_settings_file(path)


@contextlib.contextmanager
def _simulation_progress(frames: int) -> Iterator[Callable]:
    """A progress bar with steps per second and the time left; yields the per-frame callback."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("simulating"),
        BarColumn(),
        TextColumn("frame {task.completed:.0f}/{task.total:.0f} · {task.fields[rate]}"),
        TimeRemainingColumn(),
        console=console,
        disable=not console.is_terminal,
    )
    task = bar.add_task("simulate", total=frames, rate="")
    done = {"steps": 0, "seconds": 0.0}

    def on_frame(report) -> None:
        done["steps"] += len(report.steps)
        done["seconds"] += report.seconds
        last = report.steps[-1]
        steps_s = done["steps"] / max(done["seconds"], 1e-9)
        rate = f"{steps_s:.1f} steps/s, pressure {last.pressure_iterations} iterations"
        bar.update(task, completed=report.frame, rate=rate)
        if not console.is_terminal:
            _say(f"  frame {report.frame}: {len(report.steps)} steps in {report.seconds:.2f} s, "
                 f"pressure {last.pressure_iterations} iterations to "
                 f"{last.pressure_residual:.1e} -> {report.path}")  # fmt: skip

    with bar:
        yield on_frame


@app.command()
def bench(
    as_json: bool = typer.Option(False, "--json", help="Print the results as JSON."),
    scenes: str = typer.Option(
        "plume,sparse,soot", help="Comma-separated scenes: plume, sparse, soot."
    ),
    size: int = typer.Option(256, help="Grid resolution of the scenes."),
    resolution: int = typer.Option(512, help="Image width and height."),
    repeat: int = typer.Option(5, help="Timed repetitions per case (median reported)."),
    reference: bool = typer.Option(True, help="Include the NumPy reference (at 1/4 resolution)."),
    cold: bool = typer.Option(
        False, "--cold", help="Also time frames that each render a new volume (cold)."
    ),
) -> None:
    """Benchmark the backends on named synthetic scenes (samples/s, ms/frame)."""
    from incandescent import benchmark

    try:
        report = benchmark.run(
            scenes.split(","),
            size,
            resolution,
            repeat,
            reference,
            progress=None if as_json else console,
            cold=cold,
        )
    except (ValueError, RuntimeError) as error:
        raise _fail(str(error)) from None
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    else:
        benchmark.print_table(report, Console())


if __name__ == "__main__":  # pragma: no cover
    app()
