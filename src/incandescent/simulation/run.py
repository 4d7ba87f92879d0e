"""Running a fire: frames written as volumes, a checkpoint after each, resume after interruption.

``simulate(settings, resolution, frames, out_dir)`` advances the solver frame by frame (sub-steps
limited by the CFL number), writes ``fire_####.npz`` (or ``.vdb``, written by OpenVDB) with
temperature (K), absorption (1/m, from soot), the CH and C₂ fractions of the reaction zone and the
velocity (m/s), each atomically, then ``checkpoint.npz`` (every field of the solver's state, the
settings and the frame). A second run with the same settings and resolution continues after the
last checkpointed frame; other settings are refused unless ``overwrite``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from incandescent.io.atomic import atomic_write, check_output
from incandescent.simulation.settings import FireSettings
from incandescent.simulation.solver import FireSolver, FireState, StepReport, frame_fields
from incandescent.volume import Volume

CHECKPOINT = "checkpoint.npz"
FRAME_FORMATS = (".npz", ".vdb")


@dataclass(frozen=True)
class FrameReport:
    """One written frame: its path, the solver steps it took and their reports, wall seconds."""

    frame: int
    path: Path
    steps: list[StepReport]
    seconds: float


def frame_path(out_dir: Path, frame: int, suffix: str = ".npz") -> Path:
    return out_dir / f"fire_{frame:04d}{suffix}"


def frame_volume(solver: FireSolver, state: FireState) -> Volume:
    """The state as a Volume: the domain's floor centred under the origin, +y up."""
    f = frame_fields(solver, state)
    nx, _, nz = solver.shape
    origin = (-0.5 * nx * solver.h, 0.0, -0.5 * nz * solver.h)
    return Volume.from_arrays(
        f["temperature_K"],
        absorption=f["absorption_per_m"],
        voxel_size_m=solver.h,
        origin_m=origin,
        source="fire simulation",
        species={"CH": f["CH"], "C2": f["C2"]},
        absorption_source="soot × soot_kappa_per_m",
        temperature_source="simulated (K)",
        velocity_m_s=f["velocity_m_s"],
    )


def _identity(settings: FireSettings, resolution: int) -> str:
    return json.dumps({"settings": settings.model_dump(mode="json"), "resolution": resolution})


def _save_checkpoint(out_dir: Path, identity: str, frame: int, state: FireState, ops) -> None:
    arrays = {f"velocity_{a}": ops.numpy(state.velocity[a]) for a in range(3)}
    arrays |= {
        name: ops.numpy(getattr(state, name)) for name in ("phi", "temperature", "soot", "pressure")
    }

    def write(tmp: Path) -> None:
        with open(tmp, "xb") as handle:
            np.savez(
                handle,
                identity=np.asarray(identity),
                frame=np.int64(frame),
                time_s=np.float64(state.time_s),
                steps=np.int64(state.steps),
                **arrays,
            )

    atomic_write(out_dir / CHECKPOINT, write, overwrite=True)


def _load_checkpoint(out_dir: Path, identity: str, solver: FireSolver, overwrite: bool):
    """(last frame done, its state), or (0, the initial state)."""
    path = out_dir / CHECKPOINT
    if overwrite or not path.exists():
        return 0, solver.initial_state()
    with np.load(path, allow_pickle=False) as data:
        if str(data["identity"]) != identity:
            raise ValueError(
                f"{out_dir} holds frames of another simulation (other settings or resolution); "
                "pass --overwrite to start again"
            )
        ops = solver.ops
        phi, temperature, soot, p = (
            ops.array(data[name]) for name in ("phi", "temperature", "soot", "pressure")
        )
        state = FireState(
            [ops.array(data[f"velocity_{a}"]) for a in range(3)],
            phi,
            temperature,
            soot,
            p,
            time_s=float(data["time_s"]),
            steps=int(data["steps"]),
        )
        return int(data["frame"]), state


def advance_frame(solver: FireSolver, state: FireState) -> tuple[FireState, list[StepReport]]:
    """Steps to the next frame: Δt = CFL / max speed (cells/s), at most one frame, at least a
    frame / ``max_steps_per_frame``."""
    s = solver.settings
    remaining, reports = 1.0 / s.fps, []
    floor = remaining / s.max_steps_per_frame
    while remaining > 1e-12:
        speed = max(solver.ops.max_abs(v) for v in state.velocity) + s.flame_speed_m_s / solver.h
        dt = min(remaining, max(s.cfl / max(speed, 1e-9), floor))
        state, report = solver.step(state, dt)
        reports.append(report)
        remaining -= dt
    return state, reports


def simulate(
    settings: FireSettings,
    resolution: int,
    frames: int,
    out_dir: str | Path,
    backend: str = "cpu",
    suffix: str = ".npz",
    overwrite: bool = False,
    on_frame: Callable[[FrameReport], None] | None = None,
    limits=None,
) -> list[FrameReport]:
    """Simulate ``frames`` frames into ``out_dir`` (see the module docstring); ``on_frame`` is
    called after each frame is written (progress, rendering); ``limits`` (``budget.Limits``)
    bound the memory, checked first. Returns this run's frames."""
    if suffix not in FRAME_FORMATS:
        raise ValueError(f"frame format must be one of {FRAME_FORMATS}; got {suffix!r}")
    if not 1 <= frames <= 100_000:
        raise ValueError(f"frames must be 1..100000; got {frames}")
    out_dir = Path(out_dir)
    _check_memory(settings, resolution, backend, limits)
    out_dir.mkdir(parents=True, exist_ok=True)
    solver = FireSolver(settings, resolution, backend)
    identity = _identity(settings, resolution)
    done, state = _load_checkpoint(out_dir, identity, solver, overwrite)
    written = []
    for frame in range(done + 1, frames + 1):
        check_output(frame_path(out_dir, frame, suffix), True, FRAME_FORMATS, "frame")
        began = time.perf_counter()
        state, steps = advance_frame(solver, state)
        path = _write_frame(solver, state, frame_path(out_dir, frame, suffix))
        _save_checkpoint(out_dir, identity, frame, state, solver.ops)
        report = FrameReport(frame, path, steps, time.perf_counter() - began)
        written.append(report)
        if on_frame is not None:
            on_frame(report)
    return written


#: Values held per cell during a step: 3 velocities and 4 scalars (with their advected copies),
#: the multigrid's operator codes (1 per cell, ~1.15× over the levels), the CG vectors and the
#: temporaries of advection and of a frame's NumPy copies. Measured: a 128³ step peaks at 539 MB
#: resident, an 8³ one at 129 MB (the interpreter and Dr.Jit), so ~196 B = 49 values per cell.
VALUES_PER_CELL = 52


def _check_memory(settings: FireSettings, resolution: int, backend: str, limits=None) -> None:
    """Refuse a grid the machine's memory cannot hold, before any work (``budget.Limits``)."""
    from incandescent.budget import Limits
    from incandescent.simulation.solver import grid_shape

    shape, _ = grid_shape(settings, resolution)
    cells = float(np.prod(shape))
    value_bytes = 8.0 if backend == "reference" else 4.0
    (limits or Limits()).check_memory(
        cells * VALUES_PER_CELL * value_bytes,
        f"simulating a {shape[0]}×{shape[1]}×{shape[2]} grid",
    )


def _write_frame(solver: FireSolver, state: FireState, path: Path) -> Path:
    from incandescent.io.output import save_volume

    return save_volume(frame_volume(solver, state), path, overwrite=True)


def render_frames(
    out_dir: str | Path,
    frames: int,
    video: str | Path,
    width: int = 320,
    height: int = 480,
    fps: float = 24.0,
    backend: str = "auto",
    overwrite: bool = False,
    suffix: str = ".npz",
    progress: bool = True,
    workers: int | None = None,
    scheduler: str | None = None,
    display=None,
):
    """Render simulated frames 1 … ``frames`` to ``video`` (.mp4, .gif or a folder) with
    ``animate``'s machinery (one camera on the whole domain, one exposure from the middle frame,
    frames keyed and resumable): blackbody from T and soot κ, the blue core by its CH and C₂
    lines. ``workers`` / ``scheduler``: render the frames as Dask tasks (``cluster``)."""
    from incandescent import api
    from incandescent.animation import fixed_display, render_video

    out_dir = Path(out_dir)
    paths = [frame_path(out_dir, i, suffix) for i in range(1, frames + 1)]
    specs = [_frame_spec(p) for p in paths]

    def volume_at(index: int):
        return api.volume_from_section(specs[index], api.Remap(), layout="dense")

    camera, settings = _render_view(paths[0], width, height)
    if display is None:
        display = fixed_display(volume_at(len(paths) // 2), camera, settings, backend)
    describe = _describe(paths)

    from incandescent import cluster
    from incandescent.animation import plan_output

    folder, _ = plan_output(Path(video), None, overwrite)
    with cluster.connect(workers, scheduler) as (client, threads):

        def task_of(i: int) -> cluster.FrameTask:
            return _fire_task(i, paths[i], camera, settings, display, backend, folder, threads)

        distribute = cluster.distributor(client, task_of)
        return render_video(
            volume_at,
            len(paths),
            video,
            camera,
            settings,
            display,
            backend=backend,
            overwrite=overwrite,
            progress=progress,
            fps=fps,
            frame_input=describe,
            distribute=distribute,
        )


def _frame_spec(path: Path):
    """How a renderer reads a simulated frame: T, soot κ and the CH/C₂ lines."""
    from incandescent.config import VolumeSection

    return VolumeSection(path=path, species={"CH": "CH", "C2": "C2"}, absorption=None)


def _fire_task(index, path, camera, settings, display, backend, folder, threads):
    """The render task of simulated frame ``path`` (PNG ``index`` in ``folder``)."""
    from incandescent import cluster
    from incandescent.animation import frame_path as png_path
    from incandescent.volume import Remap

    return cluster.FrameTask(index, _frame_spec(path), Remap(), "dense", None, camera, settings,
                             display, backend, png_path(folder, index), threads)  # fmt: skip


def _render_view(first: Path, width: int, height: int):
    """(camera on the whole domain, render settings): every frame has the same box."""
    from incandescent import api

    volume = api.volume_from_section(_frame_spec(first), api.Remap(), layout="dense")
    camera = api.camera_from(volume, fov_deg=35.0, frame_content=False)
    return camera, api.RenderSettings(width=width, height=height)


def _describe(paths: list[Path]) -> Callable[[int], str]:
    from incandescent.animation import file_identity

    return lambda index: f"{file_identity(paths[index])} fire frame"


def simulate_and_render(
    settings: FireSettings,
    resolution: int,
    frames: int,
    out_dir: str | Path,
    video: str | Path,
    exposure_ev: float,
    width: int = 320,
    height: int = 480,
    backend: str = "auto",
    suffix: str = ".npz",
    overwrite: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    on_frame: Callable[[FrameReport], None] | None = None,
    limits=None,
):
    """Simulate and render at once: each frame, once written, is rendered (with a fixed
    ``exposure_ev``: auto exposure would need the middle frame first) — as a task on the Dask
    cluster of ``workers`` / ``scheduler``, overlapping the simulation, or here, in turn with it;
    then the video is assembled from the frames."""
    from incandescent import api, cluster
    from incandescent.animation import (
        LOCK_NAME,
        FramesFailed,
        assemble_video,
        frame_key,
        plan_output,
        record_frames,
    )
    from incandescent.io.atomic import exclusive_lock

    out_dir = Path(out_dir)
    folder, _ = plan_output(Path(video), None, overwrite)
    folder.mkdir(parents=True, exist_ok=True)
    display = api.DisplaySettings(exposure_ev=exposure_ev, auto_exposure=False)
    paths = [frame_path(out_dir, i, suffix) for i in range(1, frames + 1)]
    describe = _describe(paths)
    lock = exclusive_lock(folder / LOCK_NAME, str(video))  # one run writes these frames
    with lock, cluster.connect(workers, scheduler) as (client, threads):
        view: dict = {}
        futures: dict = {}

        def submit(report: FrameReport) -> None:
            if on_frame is not None:
                on_frame(report)
            if not view:
                view["camera"], view["settings"] = _render_view(report.path, width, height)
            index = report.frame - 1
            task = _fire_task(index, report.path, view["camera"], view["settings"], display,
                              backend, folder, threads)  # fmt: skip
            if client is None:  # in-process: render it now, before the next frame
                futures[index] = _Done(task)
            else:
                futures[index] = client.submit(
                    cluster.render_task, task, retries=cluster.RETRIES, pure=False
                )

        simulate(settings, resolution, frames, out_dir, backend, suffix, overwrite, submit, limits)
        failures, keys = {}, {}
        for index, future in futures.items():
            try:
                future.result()
            except Exception as error:  # noqa: BLE001 - reported per frame
                failures[index] = f"{paths[index]}: {type(error).__name__}: {error}"
                continue
            keys[index] = frame_key(describe(index), view["camera"], view["settings"], display)
        record_frames(folder, keys)
        if failures:
            raise FramesFailed(failures)
    return assemble_video(folder, frames, video, settings.fps, overwrite)


class _Done:
    """A frame rendered in-process, answering like a Dask future (``result()``)."""

    def __init__(self, task) -> None:
        from incandescent import cluster

        self.value: tuple | None = None
        self.error: Exception | None = None
        try:
            self.value = cluster.render_task(task)
        except (ValueError, OSError, RuntimeError) as error:
            self.error = error

    def result(self):
        if self.error is not None:
            raise self.error
        return self.value
