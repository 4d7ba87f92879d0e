"""Sequences on a Dask cluster: a real LocalCluster (``--workers``) and a real ``dask scheduler``
with two ``dask worker`` processes (``--scheduler``): every frame once, the serial render's
pixels, resume and re-render rules, a failing frame reported, a killed worker survived."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.scenes import plume_temperature

pytest.importorskip("distributed")
pytestmark = pytest.mark.slow

ARGS = ["--width", "32", "--height", "24"]


def _sequence(folder: Path, n: int = 6, size: int = 24) -> str:
    for i in range(n):
        np.save(folder / f"f_{i:04d}.npy", np.roll(plume_temperature(size), i, axis=1))
    return str(folder / "f_####.npy")


class _Run:
    """A CLI run: exit code and its output with line wrapping undone."""

    def __init__(self, result) -> None:
        self.exit_code, self.output = result.exit_code, " ".join(result.output.split())


def _animate(*args) -> _Run:
    return _Run(CliRunner().invoke(app, ["animate", *map(str, args)]))


def _frames(folder: Path) -> list[np.ndarray]:
    out = []
    for path in sorted(folder.glob("frame_*.png")):
        with Image.open(path) as image:
            out.append(np.asarray(image))
    return out


def test_local_workers_render_the_serial_frames_once_and_resume(tmp_path):
    pattern = _sequence(tmp_path)
    serial = _animate(pattern, "-o", tmp_path / "serial.gif", *ARGS)
    assert serial.exit_code == 0, serial.output
    first = _animate(pattern, "-o", tmp_path / "dist.gif", *ARGS, "--workers", 2)
    assert first.exit_code == 0, first.output
    assert "(6 rendered, 0 reused)" in first.output
    a, b = _frames(tmp_path / "serial_frames"), _frames(tmp_path / "dist_frames")
    assert len(a) == len(b) == 6 and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    with Image.open(tmp_path / "dist.gif") as video:
        assert video.n_frames == 6
    again = _animate(pattern, "-o", tmp_path / "dist.gif", *ARGS, "--workers", 2, "--overwrite")
    assert again.exit_code == 0 and "(6 rendered" in again.output  # --overwrite: all again
    rerun = _animate(pattern, "-o", tmp_path / "frames", *ARGS, "--workers", 2)
    assert "(6 rendered, 0 reused)" in rerun.output
    rerun = _animate(pattern, "-o", tmp_path / "frames", *ARGS, "--workers", 2)
    assert "(0 rendered, 6 reused)" in rerun.output


def test_a_touched_input_renders_that_frame_again_and_new_settings_all(tmp_path):
    pattern = _sequence(tmp_path)
    out = tmp_path / "frames"
    assert _animate(pattern, "-o", out, *ARGS, "--workers", 2).exit_code == 0
    touched = tmp_path / "f_0003.npy"
    os.utime(touched, ns=(time.time_ns(), time.time_ns() + 10_000_000))
    again = _animate(pattern, "-o", out, *ARGS, "--workers", 2)
    assert again.exit_code == 0 and "(1 rendered, 5 reused)" in again.output
    changed = _animate(pattern, "-o", out, "--width", 40, "--height", 24, "--workers", 2)
    assert changed.exit_code == 2 and "rendered from other input, settings" in changed.output
    changed = _animate(pattern, "-o", out, "--width", 40, "--height", 24, "--workers", 2,
                       "--overwrite")  # fmt: skip
    assert changed.exit_code == 0 and "(6 rendered, 0 reused)" in changed.output


def test_a_corrupt_frame_is_reported_by_name_and_the_others_finish(tmp_path):
    pattern = _sequence(tmp_path)
    (tmp_path / "f_0002.npy").write_bytes(b"\x93NUMPY garbage")
    result = _animate(pattern, "-o", tmp_path / "frames", *ARGS, "--workers", 2)
    assert result.exit_code == 101, result.output  # 100 + one frame
    assert "frame 2 failed:" in result.output and "f_0002.npy" in result.output
    assert len(list((tmp_path / "frames").glob("frame_*.png"))) == 5


def _start(args: list[str], log: Path) -> subprocess.Popen:
    dask = shutil.which("dask", path=str(Path(sys.executable).parent))
    assert dask is not None
    return subprocess.Popen([dask, *args], stdout=log.open("w"), stderr=subprocess.STDOUT,
                            start_new_session=True)  # fmt: skip


def _wait_for_workers(address: str, n: int) -> None:
    from distributed import Client

    with Client(address, timeout="20s") as client:
        client.wait_for_workers(n, timeout=60)


@pytest.fixture
def cluster(tmp_path):
    """``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (one thread each)."""
    port = 8786 + os.getpid() % 1000
    address = f"tcp://127.0.0.1:{port}"
    procs = [_start(["scheduler", "--host", "127.0.0.1", "--port", str(port),
                     "--dashboard-address", ":0"], tmp_path / "scheduler.log")]  # fmt: skip
    time.sleep(2.0)
    for i in range(2):
        procs.append(_start(["worker", address, "--nthreads", "1", "--nworkers", "1",
                             "--name", f"w{i}"], tmp_path / f"worker{i}.log"))  # fmt: skip
    try:
        _wait_for_workers(address, 2)
        yield address, procs
    finally:
        for proc in reversed(procs):
            with_group = proc.pid
            try:
                os.killpg(with_group, signal.SIGTERM)
            except ProcessLookupError:
                pass
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(with_group, signal.SIGKILL)


def test_an_existing_cluster_renders_the_serial_frames(tmp_path, cluster):
    address, _ = cluster
    pattern = _sequence(tmp_path)
    assert _animate(pattern, "-o", tmp_path / "serial", *ARGS).exit_code == 0
    result = _animate(pattern, "-o", tmp_path / "remote.gif", *ARGS, "--scheduler", address)
    assert result.exit_code == 0, result.output
    a, b = _frames(tmp_path / "serial"), _frames(tmp_path / "remote_frames")
    assert len(b) == 6 and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_a_worker_killed_mid_run_costs_no_frame(tmp_path, cluster):
    """SIGKILL one of the two workers while frames render: its frames are retried on the other,
    none is lost or corrupt, and a rerun renders nothing."""
    address, procs = cluster
    pattern = _sequence(tmp_path, n=16, size=96)
    out = tmp_path / "frames"
    args = ["animate", pattern, "-o", str(out), "--width", "160", "--height", "120",
            "--scheduler", address]  # fmt: skip
    run = subprocess.Popen([sys.executable, "-m", "incandescent.cli", *args],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)  # fmt: skip
    deadline = time.time() + 120
    while not list(out.glob("frame_*.png")) and time.time() < deadline:
        time.sleep(0.05)
    os.killpg(procs[1].pid, signal.SIGKILL)  # a worker (and its nanny) dies mid-run
    output, _ = run.communicate(timeout=300)
    assert run.returncode == 0, output
    frames = _frames(out)
    assert len(frames) == 16 and all(f.shape == (120, 160, 3) for f in frames)
    rerun = _animate(pattern, "-o", out, "--width", 160, "--height", 120, "--scheduler", address)
    assert rerun.exit_code == 0 and "(0 rendered, 16 reused)" in rerun.output


def test_simulated_frames_render_on_workers_while_the_next_is_simulated(tmp_path):
    """simulate --render --workers --exposure: each frame goes to the cluster once written; the
    video has every frame, recorded so that a later run with the same view reuses them all."""
    out, video = tmp_path / "fire", tmp_path / "fire.gif"
    args = ["simulate", "candle", "-o", out, "--resolution", 16, "--frames", 4, "--render",
            video, "--width", 24, "--height", 32, "--exposure", 0]  # fmt: skip
    result = _Run(CliRunner().invoke(app, [*map(str, args), "--workers", "2"]))
    assert result.exit_code == 0, result.output
    with Image.open(video) as gif:
        assert gif.n_frames == 4
    frames = sorted((tmp_path / "fire_frames").glob("frame_*.png"))
    written = [p.stat().st_mtime_ns for p in frames]
    video.unlink()
    serial = _Run(CliRunner().invoke(app, list(map(str, args))))  # in-process this time
    assert serial.exit_code == 0 and video.stat().st_size > 0
    assert [p.stat().st_mtime_ns for p in frames] == written  # recorded, so not rendered again
    video.unlink()
    auto = _Run(CliRunner().invoke(app, list(map(str, args[:-2]))))  # auto exposure: refused
    assert auto.exit_code == 2 and "rendered from other input, settings" in auto.output
