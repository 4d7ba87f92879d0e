"""The ``incandescent`` command line: each command parses its flags (:mod:`.flags`), builds the
scene or job and calls the Python API (``api``, ``animation``, ``cluster``, ``fire_video``).
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import signal
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape

from incandescent._version import __version__
from incandescent.cli import flags
from incandescent.cli.flags import (
    DEMOS,
    PLATE_SIZE,
    RS,
    Given,
    command,
    console,
    fail,
    integrator_name,
    overrides,
    say,
)
from incandescent.io.formats import SCENE_SUFFIXES
from incandescent.scenes import SCENES

app = typer.Typer(
    help="Physically based volumetric rendering of incandescent gas (flames, explosions, plumes).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts show defaults in [brackets]: no markup in them
    add_completion=False,
)


#: Exit status after Ctrl-C (SIGINT) or SIGTERM: 128 + SIGINT, as shells report it.
EXIT_INTERRUPTED = 130


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning (e.g. a scene key of an earlier release) as one line, without source lines."""
    say(f"warning: {message}")


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
        say("interrupted: no output was left half-written")
        raise typer.Exit(code=EXIT_INTERRUPTED) from None
    except MemoryError:
        raise fail("out of memory; make the input, image or step smaller") from None
    except (ValueError, TypeError, OSError, RuntimeError) as error:
        raise fail(str(error) or type(error).__name__) from None


@contextlib.contextmanager
def _render_progress() -> Iterator[Callable[[float], None]]:
    """A transient progress bar on a terminal (nothing elsewhere, and rich's progress module is
    then not imported: ~10 ms of each scripted render); yields ``report(fraction)``."""
    if not console.is_terminal:
        yield lambda fraction: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    columns = (TextColumn("rendering"), BarColumn(), TextColumn("{task.percentage:>3.0f} %"))
    bar = Progress(*columns, TimeRemainingColumn(), console=console, transient=True)
    task = bar.add_task("render", total=1.0)
    with bar:
        yield lambda fraction: bar.update(task, completed=fraction)


def _terminate(signum, frame) -> None:
    raise KeyboardInterrupt  # so that cleanups run and temporary files go


def _scene(source: Path, overrides: dict):
    """The scene a CLI call describes: a scene file with the flags over it, or a volume file."""
    from incandescent.config import load_scene, scene_from_dict

    if source.suffix.lower() in SCENE_SUFFIXES:
        return load_scene(source, overrides)
    return scene_from_dict({"volume": {"path": str(source)}}, None, overrides, source=str(source))


def _limits(given: Given):
    from incandescent.budget import DEFAULT_MAX_SAMPLES, GIB, Limits
    from incandescent.io import openvdb

    max_memory, max_samples = given.values.get("max_memory"), given.values.get("max_samples")
    for flag, value in (("--max-memory", max_memory), ("--max-samples", max_samples)):
        if value is not None and not value > 0:  # also refuses nan
            raise ValueError(f"{flag} must be a number > 0; got {value}")
    memory = None if max_memory is None else max_memory * GIB
    openvdb.set_memory_budget(memory)  # the OpenVDB worker's reads are bounded too
    return Limits(memory, DEFAULT_MAX_SAMPLES if max_samples is None else max_samples)


def _summary(image, written: list[Path]) -> None:
    meta = image.metadata
    say(f"rendered {image.width}×{image.height} on {meta['backend']} ({meta['device']}): "
        f"{meta['samples']:,} samples in {meta['seconds'] * 1e3:.1f} ms; "
        f"absorption {meta['absorption']}")  # fmt: skip
    for path in written:
        say(f"  wrote {path}")


# --- commands -------------------------------------------------------------------------------


VERBOSE_HELP = "Log backend selection and timings."


@app.callback()
def main(
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help=VERBOSE_HELP)] = False,
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
@command(flags.RENDER)
def render(o: Given) -> None:
    """Render a volume file, or a scene file, to an image."""
    from incandescent import api

    with _guarded():
        limits = _limits(o)
        scene = _scene(o.source, overrides(o))
        if scene.sensor is not None:
            shot, written = api.photograph_scene(scene, o.source, limits)
        else:
            with _render_progress() as progress:
                image, written = api.render_scene(scene, o.source, limits, progress)
    if scene.sensor is not None:
        _raw_summary(shot, written)
    else:
        _summary(image, written)


def _raw_summary(shot, written: list[Path]) -> None:
    height, width = shot.mosaic.shape
    peak = shot.electrons.max(axis=(0, 1))
    say(f"exposed {width}×{height} {shot.sensor.pattern} for {shot.sensor.exposure_s:g} s: "
        f"brightest R/G/B {peak[0]:.0f}/{peak[1]:.0f}/{peak[2]:.0f} e⁻ (full well "
        f"{shot.sensor.full_well_e:g})")  # fmt: skip
    for path in written:
        say(f"  wrote {path}")


@app.command()
@command(flags.DEMO)
def demo(o: Given) -> None:
    """Render a built-in scene: plume, sparse, the paper's sphere, or the paper's plate video.

    The plate video resumes: frames already in its frame folder, made with the same settings,
    are not rendered again.
    """
    from incandescent import api
    from incandescent.renderer.integrators import integrator_from_dict

    if o.name not in DEMOS:
        raise fail(f"unknown demo {o.name!r}; expected one of: {', '.join(DEMOS)}")
    video = o.name == "plate"
    output = o.output or Path(f"{o.name}.mp4" if video else f"{o.name}.png")
    with _guarded():
        limits = _limits(o)
        width, height = PLATE_SIZE if video else (RS.width, RS.height)
        settings = api.RenderSettings(width=o.width or width, height=o.height or height)
        integrator = integrator_from_dict({"type": integrator_name(None, o.brightness)})
        if video:
            _demo_plate(output, settings, integrator, o)
            return
        api.check_image_outputs(output, None, o.overwrite)
        with console.status(f"building the {o.name} scene…"):
            volume = api.demo_volume(o.name, o.size, limits)
            volume, lit = api.demo_lighting(o.name, volume, o.max_bounces,
                                            in_scatter=o.in_scatter or "per-sample")  # fmt: skip
        integrator = lit or integrator
        scene = SCENES[o.name]
        with console.status(f"rendering {settings.width}×{settings.height}…"):
            camera = scene.camera and scene.camera()
            image = api.render(volume, camera, settings, o.backend, limits, integrator=integrator)
        written = [api.save_image(image, output, scene.display, overwrite=o.overwrite)]
    _summary(image, written)


def _demo_plate(output: Path, settings, integrator, o: Given) -> None:
    from incandescent.animation import render_plate_video
    from incandescent.scenes.paper import PlateScene

    if o.frames < 1:
        raise ValueError(f"--frames must be >= 1; got {o.frames}")
    start = time.perf_counter()
    render_plate_video(output, settings, PlateScene(n_frames=o.frames), backend=o.backend,
                       overwrite=o.overwrite, integrator=integrator)  # fmt: skip
    say(f"plate: {o.frames} frames in {time.perf_counter() - start:.1f} s")


@app.command()
@command(flags.INFO)
def info(o: Given) -> None:
    """List a volume file's grids: type, active voxels and box, value range and sum, placement;
    warn about grids named like temperature that cannot be kelvin, and name the preset a known
    cache needs."""
    from incandescent import api
    from incandescent.io.vtk import is_openfoam

    path, axes = o.path, o.axes
    if path.is_dir() and not is_openfoam(path):
        _simulation_info(path, o.as_json)
        return
    with _guarded():
        if path.suffix.lower() in SCENE_SUFFIXES:  # a scene: describe the volume file it names
            spec = _scene(path, {}).volume
            if not o.as_json:
                say(f"{path}: a scene file; its volume is {spec.path}")
            path, axes = spec.path, axes or spec.axes
        grids, notes, bad = api.grid_report(path, axes)
    if o.as_json:
        records, nulls = api.strict_json(
            [g.as_json() | {"finite": g.name not in bad} for g in grids]
        )
        report = {"path": str(path), "grids": records, "warnings": notes + nulls}
        typer.echo(json.dumps(report, indent=2, allow_nan=False))
        return
    _info_table(path, grids)
    for text in notes:
        console.print(f"[yellow]note:[/] {escape(text)}", highlight=False, soft_wrap=True)


def _simulation_info(folder: Path, as_json: bool) -> None:
    """``info`` of a simulation's folder: its per-frame diagnostics (``diagnostics.jsonl``)."""
    from incandescent.simulation import diagnostics

    with _guarded():
        if not (folder / diagnostics.DIAGNOSTICS).is_file():
            name = diagnostics.DIAGNOSTICS
            raise ValueError(f"{folder}: a folder without {name}; info reads a volume file, or "
                             "a folder written by incandescent simulate")  # fmt: skip
        records = diagnostics.read(folder)
    if as_json:
        typer.echo(json.dumps({"path": str(folder), "frames": records}, indent=2))
        return
    _diagnostics_table(folder, records)


#: The columns of ``info FOLDER``: (record key, heading, format).
DIAGNOSTIC_COLUMNS = (
    ("frame", "frame", "{}"), ("time_s", "t (s)", "{:.3f}"), ("steps", "steps", "{}"),
    ("cfl_max", "CFL max", "{:.2f}"), ("max_speed_m_s", "max |u| (m/s)", "{:.3g}"),
    ("kinetic_energy_J", "kinetic (J)", "{:.3g}"), ("hot_volume_m3", "> 1000 K (m³)", "{:.3g}"),
    ("pressure_iterations_max", "CG iterations", "{}"),
    ("pressure_residual_max", "CG residual", "{:.1e}"),
)  # fmt: skip


def _diagnostics_table(folder: Path, records: list[dict]) -> None:
    from rich.table import Table

    table = Table(title=escape(f"{folder}: simulation diagnostics"))
    for _, heading, _ in DIAGNOSTIC_COLUMNS:
        table.add_column(heading)
    shown = lambda r, k, f: "—" if r.get(k) is None else f.format(r[k])  # noqa: E731
    for r in records:
        row = [shown(r, key, fmt) for key, _, fmt in DIAGNOSTIC_COLUMNS]
        table.add_row(*row, style="yellow" if r.get("capped") else None)
    Console(width=180).print(table)
    capped = [r["frame"] for r in records if r.get("capped")]
    if capped:
        listed = ", ".join(map(str, capped[:20]))
        console.print(f"[yellow]note:[/] {len(capped)} frames hit max_steps_per_frame (over the "
                      f"CFL setting): {listed}", highlight=False)  # fmt: skip


def _info_table(path: Path, grids) -> None:
    from rich.table import Table

    table = Table(title=escape(str(path)))
    for column in ("grid", "type", "active voxels", "shape (x, y, z)", "min", "max", "placement"):
        table.add_column(column)
    num = lambda v: "—" if v is None else f"{v:.4g}"  # noqa: E731
    for g in grids:
        active = "—" if g.active_voxels is None else f"{g.active_voxels:,}"
        cells = (g.name, g.value_type, active, str(g.shape), num(g.value_min), num(g.value_max))
        table.add_row(*(escape(c) for c in (*cells, g.placement)))
    Console(width=180).print(table)


@app.command()
@command(flags.CONVERT)
def convert(o: Given) -> None:
    """Convert a volume to .npz or .vdb: the grids the renderer would use (temperature in K,
    absorption in 1/m, emission scale, fractions), placed, y up; .vdb is written by OpenVDB."""
    from incandescent import api
    from incandescent.config.carry import carried
    from incandescent.dcc import save_dcc_volume
    from incandescent.io.atomic import check_output
    from incandescent.io.output import VOLUME_OUTPUT_SUFFIXES, save_volume

    with _guarded():
        limits = _limits(o)
        to = _dcc_target(o.for_target, o.output)
        check_output(o.output, o.overwrite, VOLUME_OUTPUT_SUFFIXES, "volume")
        _check_vdb_writer(o.output)
        scene = _scene(o.source, overrides(o))
        check_output(o.output, o.overwrite, inputs=[o.source, scene.volume.path])
        spec, velocity, left_out = carried(scene.volume, scene.emission.line_table, limits)
        volume = api.volume_from_section(spec, scene.remap(), limits, "dense", velocity=velocity)
        assert isinstance(volume, api.Volume)  # a dense read
        if to is None:
            written = save_volume(volume, o.output, overwrite=o.overwrite)
        else:
            written = save_dcc_volume(volume, o.output, to, scene.emission.emission(), o.overwrite)
    say(f"converted {o.source} ({volume.shape[0]}×{volume.shape[1]}×{volume.shape[2]} voxels, "
        f"voxel {volume.voxel_size_m:g} m) to {written}")  # fmt: skip
    for note in left_out:
        say(f"left out: {note}")
    if to is not None:
        say(f"  for {to.name}: {to.up} up; grids {', '.join(_dcc_names(to, volume))} "
            "(docs/blender.md: the one-line shader set-up)")  # fmt: skip


def _dcc_target(name: str | None, output: Path):
    """The ``--for`` target (None without one); it needs a ``.vdb`` output."""
    if name is None:
        return None
    from incandescent.dcc import target

    to = target(name)
    if output.suffix.lower() != ".vdb":
        raise ValueError(f"--for {name}: writes .vdb files; got output {output}")
    return to


def _dcc_names(to, volume) -> list[str]:
    names = [to.density, to.temperature, to.flame, to.emission]
    return names + ([to.velocity] if volume.velocity_m_s is not None else [])


def _check_vdb_writer(output: Path) -> None:
    """A ``.vdb`` output needs OpenVDB: say so before any work, naming the output."""
    if output.suffix.lower() != ".vdb":
        return
    from incandescent.io import openvdb

    problem = openvdb.problem()
    if problem is not None:
        raise ValueError(f"cannot write {output}: {problem}")


@app.command()
@command(flags.ANIMATE)
def animate(o: Given) -> None:
    """Render a sequence of volume files to MP4/GIF/PNG frames with one camera and one exposure.

    The camera frames the first file's box; the exposure is auto exposure of the middle frame.
    Re-running resumes: frames already in OUTPUT_frames/ that were made from the same files,
    settings and version (its manifest.json says) are not rendered again; frames made otherwise
    are refused unless --overwrite. One run at a time writes an output. With --workers or
    --scheduler the frames are Dask tasks (each reads its file, renders and writes its PNG); the
    exit status is then 100 + the number of frames that failed (at most 125).
    """
    from incandescent import animation, cluster

    with _guarded():
        limits = _limits(o)
        cluster.resolve(o.workers, o.scheduler)  # the worker count and address, before any work
        animation.plan_output(o.output, None, o.overwrite)  # before reading or rendering
        scene, paths = _sequence_scene(o.source, overrides(o))
        animation.keep_frame_memory()  # this process renders a sequence: frames reuse freed memory
        job = animation.sequence_job(scene, paths, limits, o.orbit)
        start = time.perf_counter()
        try:
            cluster.render_job(job, o.output, o.workers, o.scheduler, overwrite=o.overwrite,
                               fps=scene.render.fps)  # fmt: skip
        except animation.FramesFailed as failed:
            for index, reason in sorted(failed.failures.items()):
                say(f"frame {index} failed: {reason}")
            say(f"error: {failed}")
            raise typer.Exit(code=min(100 + len(failed.failures), 125)) from None
    say(f"animate: {len(paths)} frames in {time.perf_counter() - start:.1f} s")


def _sequence_scene(source: str, overrides: dict):
    """(scene, frame files): a scene file whose ``[volume] path`` is a glob or #### pattern, or
    the pattern itself (the scene of its first file)."""
    from incandescent.animation import expand_sequence, video_scene
    from incandescent.config import load_scene

    if Path(source).suffix.lower() in SCENE_SUFFIXES:
        scene = load_scene(Path(source), overrides)
        return video_scene(scene), expand_sequence(str(scene.volume.path))
    paths = expand_sequence(source)
    return video_scene(_scene(paths[0], overrides)), paths


@app.command()
@command(flags.SIMULATE)
def simulate(o: Given) -> None:
    """Simulate a fire (Nguyen, Fedkiw & Jensen 2002) into frames the renderer reads.

    Frames hold temperature (K), absorption (soot, 1/m), the blue core's CH and C2 fractions and
    the velocity (m/s). A checkpoint after each frame lets an interrupted run resume: run the
    same command again. --render renders the frames afterwards (fixed camera and exposure)."""
    from incandescent import fire_video
    from incandescent.renderer.backends import resolve_backend
    from incandescent.simulation import settings as fire_settings

    with _guarded():
        limits = _limits(o)
        changes = (
            {} if o.settings_file is None else fire_settings.read_settings_file(o.settings_file)
        )
        named = None if o.settings_file is None else str(o.settings_file)
        settings = _fire_settings(o, changes, named)
        for key, flag, value in (("seed", "--seed", o.seed), ("wind_m_s", "--wind", o.wind)):
            if value is not None:
                changes = changes | {key: value}
                settings = _fire_settings(o, changes, flag)
        if o.upres is not None:
            from incandescent.simulation.upres import check_factor

            check_factor(o.upres, "--upres")
            if o.render_to is None:
                raise ValueError(f"--upres {o.upres} up-resolves what --render renders; add it")
        view = o.render_to and fire_video.FireRender(o.render_to, o.width, o.height, o.exposure,
                                                     o.workers, o.scheduler, o.upres)  # fmt: skip
        to = _dcc_target(o.for_target, Path("frame.vdb"))
        with _simulation_progress(o.frames) as on_frame:
            on_frame = on_frame if to is None else _also_for(to, o.output, on_frame, limits)
            fire_video.simulate_to(settings, o.resolution, o.frames, o.output, view,
                                   resolve_backend(o.backend), "." + o.frame_format.lstrip("."),
                                   o.overwrite, on_frame, limits)  # fmt: skip
        if o.render_to is not None:
            say(f"  rendered {o.render_to}")


def _fire_settings(o: Given, changes: dict, source: str | None):
    """The preset's settings with ``changes`` (from ``source``); the pool preset's from --pool."""
    from incandescent.simulation import pool, settings

    if o.preset_name != "pool":
        if o.pool is not None:
            raise ValueError(f"--pool {o.pool} sets the pool preset; got preset {o.preset_name!r}")
        return settings.from_changes(o.preset_name, changes, source)
    parts = (o.pool or "0.5:100:methane").split(":")
    try:
        diameter, heat = float(parts[0]), float(parts[1])
    except (ValueError, IndexError):
        diameter = heat = math.nan
    if len(parts) > 3 or not (diameter > 0 and heat > 0):
        raise ValueError(f"--pool must be D:Q[:FUEL], D in m and Q in kW > 0; got {o.pool!r}")
    fuel = parts[2] if len(parts) == 3 else "methane"
    return pool.pool_fire(diameter, heat, fuel, changes, source)


def _also_for(to, out_dir: Path, on_frame: Callable, limits) -> Callable:
    """``on_frame`` that first writes each frame for ``to`` into ``out_dir/TARGET/``."""
    from incandescent.dcc import convert_file

    folder = out_dir / to.name

    def both(report) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        convert_file(report.path, folder / f"{report.path.stem}.vdb", to, limits, overwrite=True)
        on_frame(report)

    return both


@contextlib.contextmanager
def _simulation_progress(frames: int) -> Iterator[Callable]:
    """A progress bar with steps per second and the time left; yields the per-frame callback."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    text = TextColumn("frame {task.completed:.0f}/{task.total:.0f} · {task.fields[rate]}")
    bar = Progress(TextColumn("simulating"), BarColumn(), text, TimeRemainingColumn(),
                   console=console, disable=not console.is_terminal)  # fmt: skip
    task = bar.add_task("simulate", total=frames, rate="")
    done = {"steps": 0, "seconds": 0.0}

    def on_frame(report) -> None:
        done["steps"] += len(report.steps)
        done["seconds"] += report.seconds
        last, record = report.steps[-1], report.record
        steps_s = done["steps"] / max(done["seconds"], 1e-9)
        rate = (
            f"{steps_s:.1f} steps/s, CFL {record['cfl_max']:.2f}, max |u| "
            + f"{record['max_speed_m_s']:.3g} m/s, pressure {_iterations(last)}"
        )
        bar.update(task, completed=report.frame, rate=rate)
        if record["capped"]:
            console.print(f"[yellow]warning:[/] frame {report.frame}: {_capped(record)}",
                          highlight=False)  # fmt: skip
        if not console.is_terminal:
            say(f"  frame {report.frame}: {len(report.steps)} steps in {report.seconds:.2f} s, "
                f"CFL {record['cfl_max']:.2f}, max |u| {record['max_speed_m_s']:.3g} m/s, "
                f"pressure {_iterations(last)} to "
                f"{last.pressure_residual:.1e} -> {report.path}")  # fmt: skip

    with bar:
        yield on_frame


def _iterations(report) -> str:
    """ "1 iteration" / "12 iterations": the last step's pressure solve."""
    n = report.pressure_iterations
    return f"{n} iteration" + ("" if n == 1 else "s")


def _capped(record: dict) -> str:
    """The step cap's warning: the frame's steps, its CFL number and what to change."""
    return (f"hit max_steps_per_frame ({record['steps']} steps): its last step moved gas "
            f"{record['cfl_max']:.2f} cells, over the cfl setting; raise max_steps_per_frame "
            "or lower the driving settings")  # fmt: skip


@app.command()
@command(flags.PYROMETRY)
def pyrometry(o: Given) -> None:
    """Map the temperature of a raw camera image by two-colour (red/green) pyrometry."""
    from incandescent.pyrometry.files import pyrometry_file

    with _guarded():
        sensor, shape = None, None
        if o.sensor is not None:
            from incandescent.config.schema import SensorSection

            section = SensorSection(**flags._sensor(o.sensor))
            sensor = section.sensor()
            if section.width_px is not None:
                shape = (section.height_px, section.width_px)
        if (o.blackbody is None) != (o.blackbody_k is None):
            raise ValueError("--blackbody FILE and --blackbody-k K go together")
        if o.blackbody is not None and o.calibration is not None:
            raise ValueError("give --calibration or --blackbody, not both")
        blackbody = None if o.blackbody is None else (o.blackbody, o.blackbody_k)
        result, written = pyrometry_file(o.raw, o.output, sensor, shape, o.alpha, o.calibration,
                                         o.max_sigma, o.overwrite, blackbody)  # fmt: skip
    usable = result.usable
    median = float(np.nanmedian(result.temperature_K)) if usable.any() else float("nan")
    say(f"{usable.sum():,} of {usable.size:,} superpixels usable ({result.saturated.sum():,} "
        f"saturated); median T {median:.0f} K")  # fmt: skip
    say(f"  wrote {written}")


def _weights(text: str) -> tuple[float, ...]:
    """--tv-continuation's comma-separated weights; a one-line error naming a bad one."""
    try:
        return tuple(float(w) for w in text.split(",") if w.strip())
    except ValueError:
        raise ValueError(
            f"--tv-continuation {text!r}: expected comma-separated numbers, e.g. 1e-3,3e-4"
        ) from None


@app.command()
@command(flags.RECONSTRUCT)
def reconstruct(o: Given) -> None:
    """Reconstruct a flame's temperature from calibrated views (emission tomography)."""
    from incandescent.inverse import files
    from incandescent.inverse.reconstruct import Settings
    from incandescent.inverse.reconstruct import reconstruct as solve

    checkpoint = files.checkpoint_path(o.output)
    with _guarded():
        from incandescent.io.atomic import check_output

        check_output(o.output, o.overwrite, (".npz", ".vdb"), "volume")
        views = files.read_views(o.views, o.cameras)
        grid = files.grid_from(o.like, o.bounds, o.size, o.absorption)
        for view in views:
            view.check_sees(grid)
        settings = Settings(iterations=o.iterations, levels=o.levels, tv_weight=o.tv,
                            tv_eps_K=o.tv_eps, axisymmetric=o.axisymmetric,
                            dark_fraction=o.dark_fraction, gauss_newton=o.gauss_newton,
                            absorption=o.solve_absorption, noise=o.noise,
                            continuation_iterations=o.continuation_iterations,
                            tv_continuation=_weights(o.tv_continuation))  # fmt: skip
        if o.resume and not checkpoint.exists():
            raise ValueError(f"--resume: no checkpoint {checkpoint} to resume from")
        try:
            result = solve(views, grid, settings, o.backend, _loss_line(), checkpoint, o.resume)
        except KeyboardInterrupt:
            _interrupted(checkpoint)
        written = files.write_result(result, views, o.output, o.overwrite)
        checkpoint.unlink(missing_ok=True)
    worst = max(e["relative_l1"] for e in files.view_errors(result, views))
    say(f"loss {result.losses[0]:.3g} → {result.losses[-1]:.3g} in {len(result.losses)} "
        f"evaluations; views within {100 * worst:.2f} % (L1, worst view)")  # fmt: skip
    for path in written:
        say(f"  wrote {path}")


def _interrupted(checkpoint: Path) -> None:
    """Ctrl-C during a reconstruction: where it can resume from; exit status 130."""
    if checkpoint.exists():
        say(f"interrupted: {checkpoint} holds the last finished round; run again with --resume")
    else:
        say("interrupted before the first round finished: no checkpoint to resume from")
    raise typer.Exit(code=EXIT_INTERRUPTED)


def _loss_line() -> Callable[[int, int, float], None]:
    """The progress of a reconstruction: a line every 10 evaluations (level, evaluation, loss)."""

    def report(level: int, evaluation: int, loss: float) -> None:
        if evaluation == 1 or evaluation % 10 == 0:
            say(f"grid 1/{2**level} evaluation {evaluation}: loss {loss:.4g}")

    return report


@app.command()
@command(flags.VIEW)
def view(o: Given) -> None:
    """Look at a fire interactively in the browser: orbit, expose, remap, scrub time, probe.

    Serves the viewer on 127.0.0.1 (a random token in the URL guards every request) until
    Ctrl-C; "copy command" and "save scene file" in the page reproduce its view with render.
    """
    from incandescent import viewer

    with _guarded():
        if o.host != viewer.LOOPBACK:
            say(f"warning: --host {o.host}: other machines can reach the viewer (the token in "
                "the URL still guards it; anyone with the URL sees your inputs)")  # fmt: skip
        server = viewer.serve(o.source, overrides(o), o.backend, _limits(o), o.host, o.port,
                              flags.command_line)  # fmt: skip
        say(f"incandescent view: {server.url}")
        say("  Ctrl-C stops it")
        if not o.no_browser:
            import webbrowser

            webbrowser.open(server.url)
        with contextlib.suppress(KeyboardInterrupt):
            server.run()  # until Ctrl-C (uvicorn returns, or raises it again)
    _stopped()


def _stopped() -> None:
    """The viewer's end after Ctrl-C: exit status 130 at once. A render in flight runs on a
    thread of Dr.Jit's C++ that the interpreter's shutdown would abort (SIGABRT); the viewer
    writes no file, so nothing is left to finish."""
    import os
    import sys

    say("stopped: Ctrl-C")
    sys.stderr.flush()
    sys.stdout.flush()
    os._exit(EXIT_INTERRUPTED)


@app.command()
@command(flags.BENCH)
def bench(o: Given) -> None:
    """Benchmark the backends on named synthetic scenes (samples/s, ms/frame), or the fire
    solver (--fire)."""
    from incandescent import benchmark

    if o.fire is not None:
        _bench_fire(o)
        return
    if o.pixels is not None and o.resolution is not None and o.pixels != o.resolution:
        raise fail("--pixels and its deprecated spelling --resolution disagree; give --pixels")
    pixels = next((v for v in (o.pixels, o.resolution) if v is not None), 512)
    try:
        report = benchmark.run(o.scenes.split(","), o.size, pixels, o.repeat, o.reference,
                               progress=None if o.as_json else console, cold=o.cold)  # fmt: skip
    except (ValueError, RuntimeError) as error:
        raise fail(str(error)) from None
    if o.as_json:
        typer.echo(json.dumps(report, indent=2))
    else:
        benchmark.print_table(report, Console())


def _bench_fire(o: Given) -> None:
    """``bench --fire SIZES``: the fire solver's cost (``simulation.cost``)."""
    from incandescent.renderer.backends import available_backends
    from incandescent.simulation import cost

    try:
        sizes = cost.parse_sizes(o.fire)
        if o.repeat < 1:
            raise ValueError(f"--repeat {o.repeat}: expected at least 1")
        backends = [b for b in ("cuda", "cpu") if b in available_backends()]
        rows = cost.run(sizes, o.repeat, backends, None if o.as_json else say)
    except (ValueError, RuntimeError) as error:
        raise fail(str(error)) from None
    if o.as_json:
        from incandescent.benchmark import cpu_description

        report = {"incandescent": __version__, "cpu": cpu_description(), "fire": rows}
        typer.echo(json.dumps(report, indent=2))
    else:
        cost.print_table(rows, Console())


if __name__ == "__main__":  # pragma: no cover
    app()
