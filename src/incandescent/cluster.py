"""Frames on a Dask cluster: each task reads its own volume file, renders it and writes its PNG.

``animate --workers N`` starts a ``distributed.LocalCluster`` of N single-threaded worker
processes (Dr.Jit's thread count set so that N workers × threads ≤ the cores); ``--scheduler
tcp://HOST:PORT`` (or ``$INCANDESCENT_SCHEDULER``) uses an existing cluster. What travels to a
worker is a :class:`FrameTask` — the frame's volume section (a path and how to read it), camera,
render and display settings and the PNG's path — never a volume or an image: workers need the
package installed and the inputs and outputs on storage they share with the client. The client
keeps the manifest (written as each frame completes), so resume works whatever the number of
workers. A task that dies with its worker is retried (``RETRIES``); one that fails by itself
(a corrupt input) is reported by frame and file while the others finish.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from incandescent.camera import Camera
    from incandescent.config import VolumeSection
    from incandescent.imaging import DisplaySettings
    from incandescent.renderer import RenderSettings
    from incandescent.volume import Remap

#: Times a frame is tried again when its worker dies (SIGKILL, out of memory).
RETRIES = 2
SCHEDULER_ENV = "INCANDESCENT_SCHEDULER"


@dataclass(frozen=True)
class FrameTask:
    """Everything a worker needs to make frame ``index`` (all small and picklable)."""

    index: int
    volume: VolumeSection  # the file and how to read it
    remap: Remap
    layout: str
    blur_fps: float | None
    camera: Camera
    settings: RenderSettings
    display: DisplaySettings
    backend: str
    png: Path
    threads: int | None = None  # Dr.Jit threads on the worker (None: its default)


def render_task(task: FrameTask) -> tuple[int, tuple[int, ...]]:
    """On a worker: read, render, write the PNG atomically; (index, image shape)."""
    from incandescent import api
    from incandescent.imaging import display_pixels
    from incandescent.io.images import write_png

    if task.threads:
        from incandescent.renderer.backends.jit import drjit_module

        drjit_module().set_thread_count(task.threads)
    volume = api.volume_from_section(
        task.volume, task.remap, layout=task.layout, blur_fps=task.blur_fps
    )
    image = api.render(volume, task.camera, task.settings, task.backend)
    pixels = display_pixels(image, task.display)
    write_png(task.png, pixels, overwrite=True, metadata={"frame": str(task.index)})
    return task.index, tuple(pixels.shape)


def _client_module():
    try:
        import distributed
    except ImportError:  # pragma: no cover - the dependency is declared
        raise RuntimeError(
            "rendering on a cluster needs Dask: pip install 'incandescent[cluster]'"
        ) from None
    return distributed


@contextlib.contextmanager
def connect(workers: int | None, scheduler: str | None) -> Iterator[tuple[Any, int | None]]:
    """(Dask client, Dr.Jit threads per task) for ``workers`` local processes or an existing
    ``scheduler`` (default ``$INCANDESCENT_SCHEDULER``); (None, None) for neither: in-process."""
    scheduler = scheduler or os.environ.get(SCHEDULER_ENV) or None
    if workers is None and scheduler is None:
        yield None, None
        return
    distributed = _client_module()
    logging.getLogger("distributed").setLevel(logging.ERROR)  # its lifecycle chatter on stderr
    if scheduler is not None:
        with distributed.Client(scheduler, timeout="20s") as client:
            yield client, None
        return
    count = int(workers or 0)
    if count < 1:
        raise ValueError(f"--workers must be >= 1; got {workers}")
    threads = max(1, (os.cpu_count() or 1) // count)
    cluster = distributed.LocalCluster(
        n_workers=count,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.ERROR,
    )
    with cluster, distributed.Client(cluster) as client:
        yield client, threads


def run_tasks(
    client, tasks: list[FrameTask], on_done: Callable[[int, tuple[int, ...]], None]
) -> dict[int, str]:
    """Submit ``tasks``, call ``on_done(index, shape)`` as each finishes; the frames that failed:
    index → one line naming its file and the error. Ctrl-C cancels what is left."""
    distributed = _client_module()
    futures = client.map(render_task, tasks, retries=RETRIES, pure=False)
    by_future = {f.key: t for f, t in zip(futures, tasks, strict=True)}
    failures: dict[int, str] = {}
    try:
        for future in distributed.as_completed(futures):
            task = by_future[future.key]
            try:
                index, shape = future.result()
            except Exception as error:  # noqa: BLE001 - reported per frame, the others go on
                failures[task.index] = f"{task.volume.path}: {type(error).__name__}: {error}"
                continue
            on_done(index, shape)
    except KeyboardInterrupt:
        client.cancel(futures)
        raise
    return failures


def distributor(client, task_of: Callable[[int], FrameTask]):
    """For ``animation``'s ``distribute``: frames ``todo`` as tasks ``task_of(i)`` on
    ``client``; None without a client (render in-process)."""
    if client is None:
        return None

    def distribute(todo: list[int], on_done) -> dict[int, str]:
        return run_tasks(client, [task_of(i) for i in todo], on_done)

    return distribute
