"""Issue 25, Dask: `animate --workers/--scheduler` checks the worker count and the address before
anything starts, names where an address came from, bounds the whole connection (handshake
included) by a stated timeout, calls a server that does not speak Dask what it is, resumes after
a SIGKILL without --overwrite, and reports a failing frame without Dask's traceback."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from incandescent import cluster
from incandescent.cli import app
from incandescent.scenes import plume_temperature

pytest.importorskip("distributed")

ARGS = ["--width", "32", "--height", "24"]


def _sequence(folder: Path, n: int = 4, size: int = 24) -> str:
    for i in range(n):
        np.save(folder / f"f_{i:04d}.npy", np.roll(plume_temperature(size), i, axis=1))
    return str(folder / "f_####.npy")


def _animate(*args) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["animate", *map(str, args)])
    return result.exit_code, result.output


def _error_line(output: str) -> str:
    """The one error line of a failed command (and nothing like a traceback around it)."""
    lines = [line for line in output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), output
    assert "Traceback" not in output
    return lines[0]


@pytest.fixture(autouse=True)
def _no_env(monkeypatch):
    monkeypatch.delenv(cluster.SCHEDULER_ENV, raising=False)
    monkeypatch.delenv(cluster.TIMEOUT_ENV, raising=False)


@pytest.fixture
def no_local_cluster(monkeypatch):
    """Starting a LocalCluster fails the test: the checks come before any process."""
    import distributed

    def refuse(*args, **kwargs):
        raise AssertionError("a LocalCluster was started")

    monkeypatch.setattr(distributed, "LocalCluster", refuse)


# --- item 2: --workers is bounded before anything starts -------------------------------------


def test_a_huge_worker_count_is_refused_before_reading_or_starting_anything(no_local_cluster):
    limit, _ = cluster.worker_limit()
    code, output = _animate("no/such/f_####.npy", "-o", "out", *ARGS, "--workers", 1000)
    line = _error_line(output)
    assert code == 2 and "--workers 1000" in line and f"the {limit} worker processes" in line
    assert "per core" in line and "MiB" in line  # how the limit was derived
    assert "no/such" not in line  # refused before the input is looked at


def test_the_limit_is_derived_from_cores_and_memory(monkeypatch):
    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    monkeypatch.setattr(cluster, "_memory_bytes", lambda: 2 * cluster.WORKER_MEMORY_BYTES)
    assert cluster.worker_limit()[0] == 2  # memory binds
    monkeypatch.setattr(cluster, "_memory_bytes", lambda: 1 << 50)
    assert cluster.worker_limit()[0] == 64 * cluster.WORKERS_PER_CORE  # cores bind
    assert cluster.check_workers(128) == 128
    with pytest.raises(ValueError, match="--workers 129 is more than the 128"):
        cluster.check_workers(129)
    for bad in (0, -3, True):
        with pytest.raises(ValueError, match="--workers"):
            cluster.check_workers(bad)


def test_workers_and_scheduler_together_are_refused(no_local_cluster):
    code, output = _animate("x_####.npy", "-o", "o", "--workers", 2, "--scheduler", "tcp://h:1")
    assert code == 2 and "not both" in _error_line(output)


# --- items 3, 4: the address is checked and named with its source ----------------------------


@pytest.mark.parametrize(
    ("address", "said"),
    [
        ("tcp://127.0.0.1:99999", "port 99999 is not in 1-65535"),
        ("tcp://127.0.0.1:0", "port 0 is not in 1-65535"),
        ("tcp://127.0.0.1:http", "port http is not in 1-65535"),
        ("http://127.0.0.1:8786", "expected tcp://HOST:PORT"),
        ("tcp://127.0.0.1", "expected tcp://HOST:PORT"),
        ("tcp://:8786", "expected tcp://HOST:PORT"),
    ],
)
def test_a_bad_address_is_refused_at_once_naming_the_flag(address, said, no_local_cluster):
    start = time.monotonic()
    code, output = _animate("no/such/f_####.npy", "-o", "out", *ARGS, "--scheduler", address)
    line = _error_line(output)
    assert code == 2 and said in line and f"{address} (from --scheduler)" in line
    assert time.monotonic() - start < 10  # not a connection timeout


def test_an_address_from_the_environment_is_named_as_coming_from_there(monkeypatch):
    monkeypatch.setenv(cluster.SCHEDULER_ENV, "tcp://127.0.0.1:99999")
    code, output = _animate("no/such/f_####.npy", "-o", "out", *ARGS)
    line = _error_line(output)
    assert code == 2 and "tcp://127.0.0.1:99999 (from $INCANDESCENT_SCHEDULER)" in line
    with socket.socket() as sock:  # a port nobody listens on (bound, never listening)
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
        monkeypatch.setenv(cluster.SCHEDULER_ENV, f"127.0.0.1:{port}")
        with pytest.raises(ConnectionError, match=r"from \$INCANDESCENT_SCHEDULER\): .*refused"):
            cluster.probe(cluster.resolve(None, None))


def test_a_bad_timeout_variable_is_named(monkeypatch):
    for bad in ("soon", "0", "-1", "nan", "inf"):
        monkeypatch.setenv(cluster.TIMEOUT_ENV, bad)
        with pytest.raises(ValueError, match=r"\$INCANDESCENT_SCHEDULER_TIMEOUT="):
            cluster.connect_timeout_s()
    monkeypatch.setenv(cluster.TIMEOUT_ENV, "2.5")
    assert cluster.connect_timeout_s() == 2.5


# --- items 5, 6: servers that accept and then do not speak Dask ------------------------------


@contextlib.contextmanager
def _server(answer: Callable[[socket.socket], None]) -> Iterator[str]:
    """A TCP server on 127.0.0.1 that calls ``answer(conn)`` on each connection and keeps it
    open until the test ends; yields its tcp:// address."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    held: list[socket.socket] = []
    stop = threading.Event()

    def serve() -> None:
        listener.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:
                continue
            held.append(conn)
            with contextlib.suppress(OSError):
                answer(conn)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(5)
        for conn in held:
            conn.close()
        listener.close()


def _silent(conn: socket.socket) -> None:
    pass


def test_a_server_that_accepts_and_stays_silent_fails_within_the_timeout(monkeypatch, tmp_path):
    monkeypatch.setenv(cluster.TIMEOUT_ENV, "2")
    pattern = _sequence(tmp_path, n=2)
    with _server(_silent) as address:
        start = time.monotonic()
        code, output = _animate(pattern, "-o", tmp_path / "out", *ARGS, "--scheduler", address)
        elapsed = time.monotonic() - start
    line = _error_line(output)
    assert code == 2 and f"{address} (from --scheduler)" in line
    assert "did not answer as a Dask scheduler" in line and "2 s" in line
    assert elapsed < 2 * 2 + 15  # the stated timeout, not minutes


def _sends(payload: bytes) -> Callable[[socket.socket], None]:
    return lambda conn: conn.sendall(payload)


def _sends_and_closes(payload: bytes) -> Callable[[socket.socket], None]:
    def answer(conn: socket.socket) -> None:
        conn.sendall(payload)
        conn.shutdown(socket.SHUT_RDWR)

    return answer


@pytest.mark.parametrize(
    "answer",
    [
        _sends(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n"),
        _sends(struct.pack("<Q", 1 << 60) + b"\0" * 64),  # a huge length-prefixed frame
        _sends(struct.pack("<Q", 0xFFFF_FFFF_FFFF_FFFF)),
        _sends_and_closes(struct.pack("<Q", 40) + bytes(range(40))),  # small, not msgpack
        _sends(struct.pack("<Q", 24) + b"\xff" * 24),
        _sends_and_closes(b"hi"),
    ],
    ids=["http", "huge", "max", "garbage-frame", "ff-frame", "short"],
)
def test_a_server_that_answers_garbage_is_not_a_dask_scheduler(answer, monkeypatch, tmp_path):
    monkeypatch.setenv(cluster.TIMEOUT_ENV, "3")
    with _server(answer) as address:
        code, output = _animate("no_####.npy", "-o", tmp_path / "o", *ARGS, "--scheduler", address)
        if code == 2 and "no files match" in output:  # the address passed: probe it directly
            with pytest.raises(ConnectionError) as raised:
                cluster.probe(cluster.resolve(None, address))
            output = f"error: {raised.value}"
    line = _error_line(output)
    assert f"at {address} (from --scheduler)" in line
    assert "did not answer as a Dask scheduler" in line
    assert "memory" not in line.lower() and "struct" not in line


def test_a_garbage_answer_on_the_cli_is_one_line_before_any_render(monkeypatch, tmp_path):
    monkeypatch.setenv(cluster.TIMEOUT_ENV, "3")
    pattern = _sequence(tmp_path, n=2)
    with _server(_sends(struct.pack("<Q", 1 << 60))) as address:
        code, output = _animate(pattern, "-o", tmp_path / "o", *ARGS, "--scheduler", address)
    assert code == 2 and "did not answer as a Dask scheduler" in _error_line(output)
    assert not (tmp_path / "o").exists() or not list((tmp_path / "o").glob("frame_*.png"))


# --- a real local cluster: items 1 and 7 -----------------------------------------------------


def _cli(*args: object) -> list[str]:
    return [sys.executable, "-m", "incandescent.cli", "animate", *map(str, args)]


@pytest.mark.slow
def test_a_frame_failing_on_a_worker_is_one_line_without_dask_traceback(tmp_path):
    pattern = _sequence(tmp_path, n=4)
    (tmp_path / "f_0003.npy").write_bytes(b"\x93NUMPY garbage")  # not the key frame (2)
    run = subprocess.run(_cli(pattern, "-o", tmp_path / "out", *ARGS, "--workers", 2),
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    both = run.stdout + run.stderr
    assert run.returncode == 101, both
    assert "frame 3 failed:" in both and "f_0003.npy" in both
    assert "Traceback" not in both and "Compute Failed" not in both
    assert both.count("f_0003.npy: unsupported") == 2  # our two lines, the file named once each
    assert len(list((tmp_path / "out").glob("frame_*.png"))) == 3


@pytest.mark.slow
def test_animate_workers_killed_mid_run_resumes_without_overwrite(tmp_path):
    """SIGKILL the whole `animate --workers 2` (client, nannies, workers) once some frames are
    on disk: the rerun without --overwrite reuses every finished frame and renders the rest."""
    pattern = _sequence(tmp_path, n=12, size=64)
    out = tmp_path / "frames"
    args = [pattern, "-o", out, "--width", 96, "--height", 72, "--workers", 2]
    run = subprocess.Popen(_cli(*args), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           start_new_session=True)  # fmt: skip
    deadline = time.time() + 180
    while len(list(out.glob("frame_*.png"))) < 2 and time.time() < deadline:
        time.sleep(0.02)
    os.killpg(run.pid, signal.SIGKILL)
    run.wait(timeout=30)
    finished = {p.name for p in out.glob("frame_*.png")}
    assert len(finished) >= 2  # the lock (flock) died with the run
    rerun = subprocess.run(_cli(*args), capture_output=True, text=True, timeout=300)
    both = " ".join((rerun.stdout + rerun.stderr).split())
    assert rerun.returncode == 0, both
    assert "rendered from other input" not in both
    reused = int(both.split(" reused)")[0].rsplit("rendered, ", 1)[1])
    assert reused >= len(finished) and len(list(out.glob("frame_*.png"))) == 12


# --- item 2, one deadline: every step of the connection together ------------------------------


def _drips(conn: socket.socket) -> None:
    """Dask's first 8 bytes one at a time, 0.6 s apart (each recv alone would be in time)."""
    for byte in struct.pack("<Q", 100):
        conn.sendall(bytes([byte]))
        time.sleep(0.6)


def test_a_server_that_drips_bytes_fails_within_one_timeout_in_total(monkeypatch):
    monkeypatch.setenv(cluster.TIMEOUT_ENV, "2")
    with _server(_drips) as address:
        start = time.monotonic()
        with pytest.raises(ConnectionError, match=r"did not answer as a Dask scheduler within 2 s"):
            cluster.probe(cluster.resolve(None, address))
        elapsed = time.monotonic() - start
    assert elapsed < 2 + 3  # 8 drips x 0.6 s would be 4.8 s: one deadline, not one per recv


def test_the_clients_own_connection_is_bounded_by_the_same_timeout(monkeypatch):
    """Past the probe, ``distributed.Client`` connects again, and Dask's ``connect`` does not
    bound the handshake: a server that stays silent then must fail within the timeout too."""
    monkeypatch.setenv(cluster.TIMEOUT_ENV, "2")
    monkeypatch.setattr(cluster, "probe", lambda target, deadline=None: None)
    with _server(_silent) as address:
        start = time.monotonic()
        with pytest.raises(ConnectionError) as raised:
            with cluster.connect(None, address):
                pytest.fail("connected to a silent server")
        elapsed = time.monotonic() - start
    line = str(raised.value)
    assert f"{address} (from --scheduler)" in line and "\n" not in line
    assert elapsed < 2 + 5


# --- Ctrl-C and a busy default port: nothing but our lines ----------------------------------


def _sigint_default() -> None:
    """In the child: SIGINT as a terminal leaves it (a background job may inherit it ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow
def test_ctrl_c_of_animate_workers_is_one_line_and_resumes_without_overwrite(tmp_path):
    """SIGINT to the whole process group, as a terminal's Ctrl-C sends it: the workers leave it
    to the client (no KeyboardInterrupt tracebacks from them), exit 130, and the rerun without
    --overwrite reuses every finished frame."""
    pattern = _sequence(tmp_path, n=16, size=64)
    out = tmp_path / "frames"
    args = [pattern, "-o", out, "--width", 240, "--height", 180, "--workers", 2]
    run = subprocess.Popen(_cli(*args), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           start_new_session=True, preexec_fn=_sigint_default)  # fmt: skip
    deadline = time.time() + 180
    while len(list(out.glob("frame_*.png"))) < 2 and time.time() < deadline:
        time.sleep(0.02)
    os.killpg(run.pid, signal.SIGINT)
    output, _ = run.communicate(timeout=60)
    finished = {p.name for p in out.glob("frame_*.png")}
    assert run.returncode == 130, output
    assert "Traceback" not in output and "KeyboardInterrupt" not in output, output
    assert "interrupted: no output was left half-written" in output
    rerun = subprocess.run(_cli(*args), capture_output=True, text=True, timeout=300)
    both = " ".join((rerun.stdout + rerun.stderr).split())
    assert rerun.returncode == 0, both
    reused = int(both.split(" reused)")[0].rsplit("rendered, ", 1)[1])
    assert reused >= len(finished) and len(list(out.glob("frame_*.png"))) == 16


@pytest.mark.slow
def test_local_workers_say_nothing_when_the_default_dashboard_port_is_taken(tmp_path):
    """Dask's scheduler serves HTTP even without a dashboard, on 8787 by default; with that
    port taken it warned on stderr: the local scheduler now takes a free port."""
    holder = socket.socket()
    with contextlib.suppress(OSError):  # taken already: the case under test as well
        holder.bind(("", 8787))
        holder.listen()
    pattern = _sequence(tmp_path, n=3)
    run = subprocess.run(_cli(pattern, "-o", tmp_path / "out", *ARGS, "--workers", 2),
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    holder.close()
    assert run.returncode == 0, run.stderr
    assert "Warning" not in run.stderr and "8787" not in run.stderr, run.stderr


# --- item 6 in-process: killed right after a frame's commit -----------------------------------


def test_animate_interrupted_just_after_a_frame_is_committed_resumes_without_overwrite(
    tmp_path, monkeypatch
):
    """The window the issue hit: a frame on disk whose run died before it wrote the manifest
    again. The entry is written before the frame, so the rerun reuses both finished frames."""
    from incandescent.animation import sequence

    pattern, out, real, written = (
        _sequence(tmp_path, n=4),
        tmp_path / "out",
        sequence.write_png,
        [],
    )

    def commits_then_dies(path, *args, **kwargs):
        real(path, *args, **kwargs)
        written.append(path)
        if len(written) == 2:
            raise KeyboardInterrupt  # as if Ctrl-C came between this commit and anything after

    monkeypatch.setattr(sequence, "write_png", commits_then_dies)
    code, output = _animate(pattern, "-o", out, *ARGS)
    assert code == 130 and "interrupted" in output, output
    assert sorted(p.name for p in out.glob("frame_*.png")) == [p.name for p in written]
    monkeypatch.setattr(sequence, "write_png", real)
    code, output = _animate(pattern, "-o", out, *ARGS)
    assert code == 0 and "2 rendered, 2 reused" in " ".join(output.split()), output


def test_distributed_s_ctrl_c_race_in_sync_is_not_a_traceback():
    """distributed's ``sync`` can be interrupted before it has made its future; its cancel
    callback then raises a NameError that tornado logs with a traceback (seen once in CI on
    ``animate --workers`` Ctrl-C). ``connect`` filters exactly that record out of tornado's
    log; other callback errors still show."""
    import logging

    from incandescent.cluster import _drop_sync_cancel_race

    def record(callback: str) -> logging.LogRecord:
        return logging.LogRecord("tornado.application", logging.ERROR, __file__, 1,
                                 "Exception in callback %r", (callback,), None)  # fmt: skip

    race = "functools.partial(<function sync.<locals>.cancel at 0x7f>)"
    assert not _drop_sync_cancel_race(record(race))
    assert _drop_sync_cancel_race(record("functools.partial(<function other at 0x7f>)"))
