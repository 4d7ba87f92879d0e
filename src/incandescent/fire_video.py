"""Rendering a simulated fire's frames (``simulation.run.simulate``) with the sequence pipeline.

:func:`fire_job` is the :class:`~incandescent.animation.SequenceJob` of a run's frames (one
camera on the whole domain: every frame has the same box; T, soot κ and the blue core's CH and
C₂ lines). :func:`render_frames` renders the frames afterwards (one exposure from the middle
frame); :func:`simulate_and_render` renders each frame as soon as it is written (a fixed
exposure), on a Dask cluster while the next is simulated, or here in turn with it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from incandescent import api, cluster
from incandescent.animation import (
    LOCK_NAME,
    AnimationSummary,
    FramesFailed,
    SequenceJob,
    assemble_video,
    plan_output,
    record_frames,
)
from incandescent.animation import frame_path as png_path
from incandescent.budget import Limits
from incandescent.config import VolumeSection
from incandescent.io.atomic import exclusive_lock
from incandescent.simulation.run import FrameReport, frame_path, simulate
from incandescent.simulation.settings import FireSettings
from incandescent.simulation.upres import check_factor

#: How a frame's input is described in its key, besides its file's identity.
FIRE_LABEL = "fire frame"


def frame_section(path: Path, upres: int | None = None) -> VolumeSection:
    """How a renderer reads a simulated frame: T, soot κ and the CH/C₂ lines (``upres``: up-
    resolved with sub-grid turbulence, ``simulation.upres``)."""
    species: dict[str, str | float] = {"CH": "CH", "C2": "C2"}
    factor = check_factor(upres, "--upres") if upres is not None else None
    return VolumeSection(path=path, species=species, absorption=None, upres=factor)  # type: ignore[arg-type]


def fire_job(
    paths: list[Path],
    width: int = 320,
    height: int = 480,
    backend: str = "auto",
    display: api.DisplaySettings | None = None,
    upres: int | None = None,
) -> SequenceJob:
    """The sequence job of a run's frames ``paths`` (the first one read for the camera)."""
    specs = tuple(frame_section(p, upres) for p in paths)
    first = api.volume_from_section(specs[0], api.Remap(), layout="dense")
    camera = api.camera_from(first, fov_deg=35.0, frame_content=False)
    settings = api.RenderSettings(width=width, height=height)
    display = display or api.DisplaySettings()
    return SequenceJob(specs, camera, settings, display, backend=backend, layout="dense",
                       label=FIRE_LABEL)  # fmt: skip


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
    display: api.DisplaySettings | None = None,
    upres: int | None = None,
) -> AnimationSummary:
    """Render simulated frames 1 … ``frames`` to ``video`` (.mp4, .gif or a folder) with
    ``animate``'s machinery (one camera on the whole domain, one exposure from the middle frame
    unless ``display`` is given, frames keyed and resumable). ``workers`` / ``scheduler``:
    render the frames as Dask tasks (``cluster``)."""
    paths = [frame_path(Path(out_dir), i, suffix) for i in range(1, frames + 1)]
    job = fire_job(paths, width, height, backend, display, upres)
    if display is None:
        job = job.with_fixed_exposure(len(paths) // 2)
    return cluster.render_job(job, video, workers, scheduler, overwrite=overwrite,
                              progress=progress, fps=fps)  # fmt: skip


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
    limits: Limits | None = None,
    upres: int | None = None,
) -> Path | None:
    """Simulate and render at once: each frame, once written, is rendered (with a fixed
    ``exposure_ev``: auto exposure would need the middle frame first) — as a task on the Dask
    cluster of ``workers`` / ``scheduler``, overlapping the simulation, or here, in turn with it;
    then the video is assembled from the frames."""
    out_dir = Path(out_dir)
    folder, _ = plan_output(Path(video), None, overwrite)
    folder.mkdir(parents=True, exist_ok=True)
    display = api.DisplaySettings(exposure_ev=exposure_ev, auto_exposure=False)
    paths = [frame_path(out_dir, i, suffix) for i in range(1, frames + 1)]
    lock = exclusive_lock(folder / LOCK_NAME, str(video))  # one run writes these frames
    with lock, cluster.connect(workers, scheduler) as (client, threads):
        jobs: list[SequenceJob] = []
        futures: dict = {}

        def submit(report: FrameReport) -> None:
            if on_frame is not None:
                on_frame(report)
            if not jobs:  # the camera needs the first frame
                jobs.append(fire_job(paths, width, height, backend, display, upres))
            job, index = jobs[0], report.frame - 1
            task = job.task(index, folder, threads)
            # Its manifest entry before its PNG (the old one removed): a killed run resumes.
            png_path(folder, index).unlink(missing_ok=True)
            record_frames(folder, {index: job.key(index)})
            if client is None:  # in-process: render it now, before the next frame
                futures[index] = _Done(task)
            else:
                futures[index] = client.submit(
                    cluster.render_task, task, retries=cluster.RETRIES, pure=False
                )

        simulate(settings, resolution, frames, out_dir, backend, suffix, overwrite, submit, limits)
        _raise_failures(futures, paths)
    return assemble_video(folder, frames, video, settings.fps, overwrite)


def _raise_failures(futures: dict, paths: list[Path]) -> None:
    """Wait for every frame's render; :class:`FramesFailed` naming those that failed."""
    failures = {}
    for index, future in futures.items():
        try:
            future.result()
        except Exception as error:  # noqa: BLE001 - reported per frame
            failures[index] = f"{paths[index]}: {type(error).__name__}: {error}"
    if failures:
        raise FramesFailed(failures)


class _Done:
    """A frame rendered in-process, answering like a Dask future (``result()``)."""

    def __init__(self, task: cluster.FrameTask) -> None:
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


@dataclass(frozen=True)
class FireRender:
    """How ``simulate --render`` renders the frames: to ``video`` at ``width`` × ``height``, on
    the cluster of ``workers`` / ``scheduler`` (neither: in-process), with a fixed
    ``exposure_ev`` — each frame then rendered as soon as it is written — or (None) auto
    exposure of the middle frame, after the simulation; ``upres``: each frame up-resolved."""

    video: Path
    width: int = 320
    height: int = 480
    exposure_ev: float | None = None
    workers: int | None = None
    scheduler: str | None = None
    upres: int | None = None


def simulate_to(
    settings: FireSettings,
    resolution: int,
    frames: int,
    out_dir: Path,
    view: FireRender | None = None,
    backend: str = "auto",
    suffix: str = ".npz",
    overwrite: bool = False,
    on_frame: Callable[[FrameReport], None] | None = None,
    limits: Limits | None = None,
) -> None:
    """Simulate into ``out_dir`` and, with ``view``, render the frames (:class:`FireRender`):
    at once with a fixed exposure, else afterwards."""
    sim = (settings, resolution, frames, out_dir, backend, suffix, overwrite, on_frame, limits)
    if view is None:
        simulate(*sim)
        return
    plan_output(view.video, None, overwrite)  # before any work
    v = view
    if v.exposure_ev is not None:
        simulate_and_render(settings, resolution, frames, out_dir, v.video, v.exposure_ev,
                            v.width, v.height, backend, suffix, overwrite, v.workers,
                            v.scheduler, on_frame, limits, v.upres)  # fmt: skip
        return
    simulate(*sim)
    render_frames(out_dir, frames, v.video, v.width, v.height, settings.fps, backend, overwrite,
                  suffix, True, v.workers, v.scheduler, upres=v.upres)  # fmt: skip
