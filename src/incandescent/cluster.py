"""Frames on a Dask cluster: each task reads its own volume file, renders it and writes its PNG.

``animate --workers N`` starts a ``distributed.LocalCluster`` of N single-threaded worker
processes (Dr.Jit's thread count set so that N workers × threads ≤ the cores); N is at most
:func:`worker_limit` (``WORKERS_PER_CORE`` per core, and one per ``WORKER_MEMORY_BYTES`` of the
machine's memory), checked before anything starts. ``--scheduler tcp://HOST:PORT`` (or, without
``--workers``, ``$INCANDESCENT_SCHEDULER``) uses an existing cluster: the address is checked
first (``tcp://HOST:PORT``, port 1–65535), then the scheduler must answer Dask's handshake and an
``identity`` request, and the client connect, all within ``CONNECT_TIMEOUT_S`` seconds in total
(``$INCANDESCENT_SCHEDULER_TIMEOUT`` overrides it); errors name the address and where it came
from. What travels to a worker is a :class:`FrameTask` (made by ``animation.SequenceJob.task``)
— the frame's volume section (a path and how to read it), camera, render and display settings
and the PNG's path — never a volume or an image: workers need the package
installed and the inputs and outputs on storage they share with the client. The client keeps
the manifest (each frame's entry written before its PNG can exist, ``incandescent.animation``),
so resume works whatever the number of workers. A task that dies with its worker is retried
(``RETRIES``); one that fails by itself (a corrupt input) is reported by frame and file while the
others finish — local workers do not log its traceback, and leave Ctrl-C to the client, which
stops them (:func:`dask_setup`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import os
import signal
import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from incandescent.animation import AnimationSummary, FrameTask, SequenceJob

#: Times a frame is tried again when its worker dies (SIGKILL, out of memory).
RETRIES = 2
SCHEDULER_ENV = "INCANDESCENT_SCHEDULER"
#: Seconds the whole connection to a scheduler may take, all steps together: TCP connect, Dask's
#: handshake, its answer to an ``identity`` request and the client's own connection with its
#: handshake (``$INCANDESCENT_SCHEDULER_TIMEOUT`` overrides it).
CONNECT_TIMEOUT_S = 20.0
TIMEOUT_ENV = "INCANDESCENT_SCHEDULER_TIMEOUT"
#: ``--workers`` is at most this many processes per core ...
WORKERS_PER_CORE = 2
#: ... and at most one per this much of the machine's memory (bytes).
WORKER_MEMORY_BYTES = 512 << 20


def __getattr__(name: str) -> Any:
    """``cluster.FrameTask``: the task type, defined beside the job that makes it (``animation``)
    and imported only when asked for, so that a worker's preload of this module stays light."""
    if name == "FrameTask":
        from incandescent.animation.render import FrameTask

        return FrameTask
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def render_task(task: FrameTask) -> tuple[int, tuple[int, ...]]:
    """On a worker: read, render, write the PNG atomically; (index, image shape)."""
    from incandescent import api
    from incandescent.imaging import display_pixels
    from incandescent.io.images import write_png

    if task.threads:
        from incandescent._jit import drjit_module

        drjit_module().set_thread_count(task.threads)
    volume = api.volume_from_section(
        task.volume, task.remap, layout=task.layout, blur_fps=task.blur_fps
    )
    image = api.render(volume, task.camera, task.settings, task.backend, integrator=task.integrator)
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


# --- what to connect to: checked before anything starts ---------------------------------------


@dataclass(frozen=True)
class Target:
    """A checked cluster choice: ``workers`` local processes, or the scheduler at ``address``
    (``where``: the address and where it came from, for messages); neither: in-process."""

    workers: int | None = None
    address: str | None = None
    where: str = ""


def _memory_bytes() -> int:
    """The machine's physical memory in bytes (0 if unknown)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 0


def worker_limit() -> tuple[int, str]:
    """(most ``--workers`` allowed here, how that was derived): ``WORKERS_PER_CORE`` per core
    and one per ``WORKER_MEMORY_BYTES`` of memory, at least 1."""
    cores = os.cpu_count() or 1
    memory = _memory_bytes()
    by_memory = memory // WORKER_MEMORY_BYTES if memory else WORKERS_PER_CORE * cores
    limit = max(1, min(WORKERS_PER_CORE * cores, by_memory))
    why = (f"{WORKERS_PER_CORE} per core × {cores} core(s), at most one per "
           f"{WORKER_MEMORY_BYTES >> 20} MiB of {memory / 2**30:.1f} GiB memory")  # fmt: skip
    return limit, why


def check_workers(workers: object) -> int:
    """``--workers`` as a count in 1 … :func:`worker_limit`; ValueError naming the flag."""
    if isinstance(workers, bool) or not isinstance(workers, int):
        raise ValueError(f"--workers must be a whole number; got {workers!r}")
    limit, why = worker_limit()
    if workers < 1:
        raise ValueError(f"--workers must be >= 1; got {workers}")
    if workers > limit:
        raise ValueError(
            f"--workers {workers} is more than the {limit} worker processes allowed here "
            f"({why}); pass at most --workers {limit}, or --scheduler for a bigger cluster"
        )
    return workers


def check_address(text: str, where: str) -> str:
    """``tcp://HOST:PORT`` (``HOST:PORT`` taken as tcp) with a port in 1–65535, normalised;
    ValueError naming ``where`` (the flag or variable and the value) otherwise."""
    expected = "expected tcp://HOST:PORT"
    scheme, sep, rest = text.strip().partition("://")
    if not sep:
        scheme, rest = "tcp", text.strip()
    host, colon, port = rest.rpartition(":")
    if scheme.lower() != "tcp" or not colon or not host.strip("[]") or "/" in rest:
        raise ValueError(f"scheduler address {where}: {expected}")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ValueError(f"scheduler address {where}: port {port} is not in 1-65535; {expected}")
    return f"tcp://{host}:{int(port)}"


def connect_timeout_s() -> float:
    """``CONNECT_TIMEOUT_S``, or ``$INCANDESCENT_SCHEDULER_TIMEOUT`` (seconds > 0) if set."""
    text = os.environ.get(TIMEOUT_ENV, "").strip()
    if not text:
        return CONNECT_TIMEOUT_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"${TIMEOUT_ENV}={text!r}: expected a number of seconds > 0")
    return value


def resolve(workers: int | None, scheduler: str | None) -> Target:
    """The checked :class:`Target` of ``--workers``/``--scheduler`` (``$INCANDESCENT_SCHEDULER``
    when neither is given): nothing is started or contacted."""
    if workers is not None and scheduler:
        raise ValueError(f"pass --workers or --scheduler, not both (got --workers {workers} "
                         f"and --scheduler {scheduler})")  # fmt: skip
    if workers is not None:
        return Target(workers=check_workers(workers))
    env = os.environ.get(SCHEDULER_ENV, "")
    if scheduler:
        where = f"{scheduler} (from --scheduler)"
    elif env.strip():
        scheduler, where = env, f"{env} (from ${SCHEDULER_ENV})"
    else:
        return Target()
    return Target(address=check_address(scheduler, where), where=where)


# --- reaching a scheduler within a stated time --------------------------------------------------


async def _identity(address: str) -> Any:
    """The scheduler's answer to Dask's handshake and an ``identity`` request."""
    from distributed.comm import connect as comm_connect
    from distributed.core import send_recv

    comm = await comm_connect(address, timeout=connect_timeout_s())
    try:
        return await send_recv(comm, op="identity")
    finally:
        comm.abort()


def _left_s(deadline: float) -> float:
    """Seconds left until ``deadline`` (a ``time.monotonic()`` value), at least a few ms."""
    return max(0.01, deadline - time.monotonic())


def _bounded(work: Callable[[], Any], deadline: float, name: str) -> dict:
    """{'reply': work()} or {'error': …} or {} (not done by ``deadline``), run on a helper
    thread that is abandoned (a daemon) if ``work`` does not return in time: Dask's own
    ``connect`` does not bound its handshake."""
    box: dict = {}

    def call() -> None:
        try:
            box["reply"] = work()
        except BaseException as error:  # noqa: BLE001 - every failure is reported as one line
            box["error"] = error

    helper = threading.Thread(target=call, name=name, daemon=True)
    helper.start()
    helper.join(_left_s(deadline) + 0.5)
    return dict(box)


def _ask_identity(address: str, deadline: float) -> dict:
    """The scheduler's ``identity`` as :func:`_bounded` reports it."""
    timeout_s = _left_s(deadline)
    ask = lambda: asyncio.run(asyncio.wait_for(_identity(address), timeout_s))  # noqa: E731
    return _bounded(ask, deadline, "incandescent-scheduler-probe")


#: A scheduler's handshake is a few hundred bytes; an answer announcing more is not one (and
#: is not read: Dask would allocate what it announces).
MAX_HANDSHAKE_BYTES = 1 << 20


def _first_answer_bytes(address: str, where: str, deadline: float, timeout_s: float) -> int:
    """Connect by TCP and read the size the far end announces for its first message (Dask's
    server speaks first: its handshake) by ``deadline``; ConnectionError naming ``where`` if
    none comes (``timeout_s``: the whole connection's, for the message)."""
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), _left_s(deadline)) as sock:
            head = _read_bytes(sock, 8, deadline)
    except TimeoutError:
        head = None
    except OSError as error:
        raise ConnectionError(f"cannot reach the Dask scheduler at {where}: "
                              f"{error.strerror or error}") from None  # fmt: skip
    if head is None or len(head) < 8:
        how = f"within {timeout_s:g} s" if head is None else "(it closed the connection)"
        raise ConnectionError(_silent(where, how, timeout_s))
    return int(struct.unpack("<Q", head)[0])


def _read_bytes(sock: socket.socket, count: int, deadline: float) -> bytes:
    """Up to ``count`` bytes (fewer if the far end closes); TimeoutError past ``deadline``, even
    for a far end that sends a byte at a time."""
    head = b""
    while len(head) < count:
        if time.monotonic() >= deadline:
            raise TimeoutError
        sock.settimeout(_left_s(deadline))
        if not (chunk := sock.recv(count - len(head))):
            break
        head += chunk
    return head


def _silent(where: str, how: str, timeout_s: float) -> str:
    return (f"the server at {where} accepted the connection but did not answer as a Dask "
            f"scheduler {how}; the timeout is {timeout_s:g} s (${TIMEOUT_ENV})")  # fmt: skip


def probe(target: Target, deadline: float | None = None) -> None:
    """Fail (ConnectionError, one line naming the address and its source) unless the scheduler
    at ``target.address`` accepts a connection and answers as a Dask scheduler — handshake and
    ``identity`` — by ``deadline`` (``time.monotonic()``; default: :func:`connect_timeout_s`
    from now), all steps together."""
    timeout_s, address, where = connect_timeout_s(), str(target.address), target.where
    deadline = time.monotonic() + timeout_s if deadline is None else deadline
    announced = _first_answer_bytes(address, where, deadline, timeout_s)
    if announced > MAX_HANDSHAKE_BYTES:
        raise ConnectionError(f"the server at {where} did not answer as a Dask scheduler (its "
                              f"first message announces {announced} bytes)")  # fmt: skip
    answer = _ask_identity(address, deadline)
    error = answer.get("error")
    if not answer or isinstance(error, (asyncio.TimeoutError, TimeoutError)):
        raise ConnectionError(_silent(where, f"within {timeout_s:g} s", timeout_s))
    reply = answer.get("reply")
    if error is not None or not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        said = _what_it_said(error, reply)
        raise ConnectionError(f"the server at {where} did not answer as a Dask "
                              f"scheduler ({said})")  # fmt: skip


def _what_it_said(error: BaseException | None, reply: object) -> str:
    """Why an answer is not a Dask scheduler's, in words (not the parser's own error)."""
    if error is None:
        return f"it answered {reply!r:.80}"
    if isinstance(error, OSError) and "closed" in str(error).lower():
        return "it closed the connection"
    return "its answer is not in Dask's protocol"


# --- clients ------------------------------------------------------------------------------------


def dask_setup(worker: Any) -> None:
    """Run by Dask in each local worker process as it starts (``preload``; a restarted worker
    too): the worker does not log "Compute Failed" with the task's traceback — the client
    reports the frame in one line — and ignores SIGINT: Ctrl-C on a terminal reaches every
    process of the group, and the client, which stops its workers, is the one to answer it
    (a worker's KeyboardInterrupt is a traceback)."""
    logging.getLogger("distributed.worker").addFilter(_drop_compute_failed)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _drop_compute_failed(record: logging.LogRecord) -> bool:
    return not str(record.msg).startswith("Compute Failed")


def _drop_sync_cancel_race(record: logging.LogRecord) -> bool:
    """False for tornado's "Exception in callback" of ``distributed.utils.sync``'s ``cancel``:
    when Ctrl-C lands before ``sync`` has made its future, that callback raises a NameError
    (distributed's own race) and tornado logs its traceback; the client already answers the
    Ctrl-C in one line, so the traceback is dropped."""
    return "sync.<locals>.cancel" not in record.getMessage()


@contextlib.contextmanager
def connect(workers: int | None, scheduler: str | None) -> Iterator[tuple[Any, int | None]]:
    """(Dask client, Dr.Jit threads per task) for ``workers`` local processes or an existing
    ``scheduler`` (default ``$INCANDESCENT_SCHEDULER``); (None, None) for neither: in-process.
    Everything is checked (:func:`resolve`, :func:`probe`) before a process starts."""
    target = resolve(workers, scheduler)
    if target.workers is None and target.address is None:
        yield None, None
        return
    distributed = _client_module()
    logging.getLogger("distributed").setLevel(logging.ERROR)  # its lifecycle chatter on stderr
    tornado_log = logging.getLogger("tornado.application")
    if _drop_sync_cancel_race not in tornado_log.filters:
        tornado_log.addFilter(_drop_sync_cancel_race)
    if target.address is not None:
        with _remote_client(distributed, target) as client:
            yield client, None
        return
    count = target.workers or 1
    threads = max(1, (os.cpu_count() or 1) // count)
    cluster = distributed.LocalCluster(
        n_workers=count,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        # the scheduler's HTTP server (health checks) even without a dashboard: on a free port
        # of its own, not 8787 with a warning on stderr when another cluster holds that one
        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
        silence_logs=logging.ERROR,
        preload=[__name__],  # dask_setup
    )
    with cluster, distributed.Client(cluster) as client:
        yield client, threads


@contextlib.contextmanager
def _remote_client(distributed, target: Target) -> Iterator[Any]:
    """A client of the scheduler at ``target`` once it has answered (:func:`probe`), the probe
    and the client's connection within one :func:`connect_timeout_s` together."""
    timeout_s = connect_timeout_s()
    deadline = time.monotonic() + timeout_s
    probe(target, deadline)
    with _client_by(distributed, target, deadline, timeout_s) as client:
        yield client


def _client_by(distributed, target: Target, deadline: float, timeout_s: float) -> Any:
    """``distributed.Client(target.address)`` connected by ``deadline`` (its own ``timeout``
    does not cover Dask's handshake); ConnectionError naming the address otherwise."""
    make = lambda: distributed.Client(target.address, timeout=f"{_left_s(deadline)}s")  # noqa: E731
    answer = _bounded(make, deadline, "incandescent-scheduler-client")
    error = answer.get("error")
    if not answer or isinstance(error, (asyncio.TimeoutError, TimeoutError)):
        raise ConnectionError(_silent(target.where, f"within {timeout_s:g} s", timeout_s))
    if error is not None:
        raise ConnectionError(f"cannot connect to the Dask scheduler at {target.where}: "
                              f"{type(error).__name__}: {error}") from None  # fmt: skip
    return answer["reply"]


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
                failures[task.index] = _failure(task, error)
                continue
            on_done(index, shape)
    except KeyboardInterrupt:
        client.cancel(futures)
        raise
    return failures


def _failure(task: FrameTask, error: BaseException) -> str:
    """One line: the frame's file (unless the error names it already) and the error."""
    text = f"{type(error).__name__}: {error}"
    return text if str(task.volume.path) in str(error) else f"{task.volume.path}: {text}"


def distributor(client, task_of: Callable[[int], FrameTask]):
    """For ``animation``'s ``distribute``: frames ``todo`` as tasks ``task_of(i)`` on
    ``client``; None without a client (render in-process)."""
    if client is None:
        return None

    def distribute(todo: list[int], on_done) -> dict[int, str]:
        return run_tasks(client, [task_of(i) for i in todo], on_done)

    return distribute


def render_job(
    job: SequenceJob,
    output: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    **options: Any,
) -> AnimationSummary:
    """Render ``job`` to ``output`` (``SequenceJob.render``; ``options``: overwrite, progress,
    fps) — its missing frames as tasks on the cluster of ``workers`` / ``scheduler``
    (:func:`connect`), or in-process for neither."""
    from incandescent.animation import plan_output

    folder, _ = plan_output(Path(output), None, bool(options.get("overwrite")))
    with connect(workers, scheduler) as (client, threads):
        distribute = distributor(client, lambda i: job.task(i, folder, threads))
        return job.render(output, distribute=distribute, **options)
