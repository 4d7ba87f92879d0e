"""Issue 25, `convert` and `.vdb` outputs: a written `.vdb` reads back through OpenVDB before it
replaces anything (a real full tmpfs), the input is never the output, OpenVDB's absence is said
before any work naming the output, and a round trip keeps every grid the renderer uses."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _cli_errors import one_line_error
from _mounts import skip_without_private_mounts
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.io import openvdb

runner = CliRunner()
needs_openvdb = pytest.mark.skipif(openvdb.problem() is not None, reason=str(openvdb.problem()))


def _error(result, *fragments: str) -> str:
    return one_line_error(result, *fragments)


@pytest.fixture(scope="module")
def frame(tmp_path_factory) -> Path:
    """A simulated frame: temperature, soot, CH, C2 and velocity grids."""
    out = tmp_path_factory.mktemp("sim") / "fire"
    args = ["simulate", "candle", "-o", str(out), "--resolution", "16", "--frames", "1"]
    result = runner.invoke(app, [*args, "--backend", "cpu"])
    assert result.exit_code == 0, result.output
    return out / "fire_0001.npz"


def _in_tmpfs(size: str, folder: Path, script: str) -> subprocess.CompletedProcess:
    skip_without_private_mounts()
    folder.mkdir()
    full = f"mount -t tmpfs -o size={size} tmpfs {folder} && {script}"
    return subprocess.run(["unshare", "-rm", "sh", "-c", full], capture_output=True, text=True)


@needs_openvdb
@pytest.mark.parametrize("overwrite", [False, True])
def test_a_vdb_that_does_not_fit_is_never_committed(tmp_path, frame, overwrite):
    """A 64 KiB tmpfs: a good small .vdb written first (and kept byte for byte), then the disk
    filled so the next .vdb is cut short; convert must fail naming the output, leaving the old."""
    mount = tmp_path / "mnt"
    cli = f"{sys.executable} -m incandescent.cli convert {frame}"
    keep = f"cp -a {mount}/out.vdb {tmp_path}/before.vdb"
    target = "out.vdb --overwrite" if overwrite else "new.vdb"
    script = (
        f"{cli} {mount}/out.vdb >/dev/null && {keep} && "
        f"(dd if=/dev/zero of={mount}/fill bs=1k 2>/dev/null; truncate -s -6K {mount}/fill) && "
        f"{cli} {mount}/{target}; echo rc=$? >&2; rm {mount}/fill; ls -a {mount} >&2; "
        f"cp -a {mount}/out.vdb {tmp_path}/after.vdb"
    )
    result = _in_tmpfs("160k", mount, script)
    assert "rc=2" in result.stderr, result.stdout + result.stderr
    assert "Traceback" not in result.stderr
    name = "out.vdb" if overwrite else "new.vdb"
    assert f"{mount}/{name}" in result.stderr
    assert (tmp_path / "before.vdb").read_bytes() == (tmp_path / "after.vdb").read_bytes()
    listing = result.stderr.split("rc=2", 1)[1].split()
    assert sorted(listing) == [".", "..", "out.vdb"], listing  # no new.vdb, no temporary


@pytest.mark.parametrize("how", ["symlink", "hardlink"])
def test_convert_never_writes_over_its_input(tmp_path, frame, how):
    source = tmp_path / "in.npz"
    shutil.copy(frame, source)
    link = tmp_path / "link.npz"
    link.symlink_to(source) if how == "symlink" else link.hardlink_to(source)
    before = source.read_bytes()
    _error(runner.invoke(app, ["convert", str(source), str(link), "--overwrite"]), "input")
    assert source.read_bytes() == before


def test_convert_without_openvdb_says_so_first_naming_the_output(tmp_path, monkeypatch):
    monkeypatch.setattr(openvdb, "problem", lambda: "OpenVDB's Python module was not found")
    missing = tmp_path / "no-such-input.npz"  # checked after: the output's problem comes first
    line = _error(
        runner.invoke(app, ["convert", str(missing), str(tmp_path / "o.vdb")]), "o.vdb", "OpenVDB"
    )
    assert ".tmp" not in line and "no-such-input" not in line
    assert list(tmp_path.iterdir()) == []


@needs_openvdb
def test_a_simulated_frame_keeps_every_grid_through_vdb(tmp_path, frame):
    out = tmp_path / "frame.vdb"
    result = runner.invoke(app, ["convert", str(frame), str(out)])
    assert result.exit_code == 0, result.output
    names = {g["name"] for g in openvdb.describe(out)}
    assert {"temperature", "CH", "C2", "velocity"} <= names
    back = tmp_path / "back.npz"
    assert runner.invoke(app, ["convert", str(out), str(back)]).exit_code == 0
    with np.load(frame) as a, np.load(back) as b:
        for name in ("temperature", "CH", "C2", "velocity"):
            np.testing.assert_allclose(b[name], a[name].astype(np.float32), atol=1e-6)
    blurred = runner.invoke(
        app,
        ["render", str(out), "-o", str(tmp_path / "b.png"), "--width", "16", "--height", "16",
         "--shutter", "-0.25:0.25", "--species", "CH=CH,C2=C2"],
    )  # fmt: skip
    assert blurred.exit_code == 0, blurred.output


def test_convert_names_the_grids_it_leaves_out(tmp_path):
    source = tmp_path / "in.npz"
    hot = np.full((4, 4, 4), 1500.0, np.float32)
    np.savez(source, temperature=hot, pressure=np.ones((4, 4, 4), np.float32))
    result = runner.invoke(app, ["convert", str(source), str(tmp_path / "o.npz")])
    assert result.exit_code == 0, result.output
    assert "left out: grid 'pressure'" in result.output


@pytest.mark.parametrize(
    ("script", "said"),
    [
        ("sleep 30", "did not answer within 2 s"),  # mute
        ("echo hello; cat", "answered"),  # talks, but not our protocol
        ("echo '{\"ok\": true}'; cat", "answered"),  # JSON, but not the worker's hello
        ("exit 0", "did not answer"),
    ],
    ids=["mute", "garbage", "wrong-hello", "dies"],
)
def test_a_worker_that_is_not_ours_is_named_in_time(tmp_path, monkeypatch, script, said):
    fake = tmp_path / "python3"
    fake.write_text(f"#!/bin/sh\n{script}\n")
    fake.chmod(0o755)
    monkeypatch.setenv(openvdb.ENV_VAR, str(fake))
    monkeypatch.setattr(openvdb, "START_TIMEOUT_S", 2.0)
    openvdb.interpreter.cache_clear()
    try:
        start = time.monotonic()
        problem = openvdb.problem()
        assert time.monotonic() - start < 2.0 + 3.0
    finally:
        monkeypatch.undo()
        openvdb.interpreter.cache_clear()
    assert problem is not None and f"worker under {fake}" in problem and said in problem
    assert "$INCANDESCENT_OPENVDB_PYTHON" in problem


@needs_openvdb
@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e30], ids=["nan", "inf", "1e30"])
def test_a_sparse_vdb_with_bad_velocities_is_one_line_when_blurred(tmp_path, bad):
    T = np.zeros((16, 16, 16), np.float32)
    T[4:12, 4:12, 4:12] = 1500.0
    v = np.zeros((16, 16, 16, 3), np.float32)
    v[8, 8, 8] = (bad, 0.0, 0.0)
    path = tmp_path / "v.vdb"
    openvdb.write(path, {"temperature": T, "velocity": v}, 0.01, (0.0, 0.0, 0.0), {})
    start = time.monotonic()
    result = runner.invoke(
        app,
        ["render", str(path), "-o", str(tmp_path / "o.png"), "--width", "16", "--height", "16",
         "--layout", "sparse", "--shutter", "-0.25:0.25"],
    )  # fmt: skip
    assert time.monotonic() - start < 20
    line = _error(result, "v.vdb", "velocity")
    assert "non-finite" in line or "voxels in a frame" in line


def _sparse_file(path: Path, box: int, count: int, seed: int) -> None:
    """``count`` hot voxels and their velocities scattered over a ``box``³ index box, written by
    OpenVDB itself (the system Python's pyopenvdb): never a dense array of the box."""
    script = f"""
import numpy as np, pyopenvdb as vdb
rng = np.random.default_rng({seed})
t, v = vdb.FloatGrid(), vdb.Vec3SGrid()
t.name, v.name = "temperature", "velocity"
ta, va = t.getAccessor(), v.getAccessor()
for p in rng.integers(0, {box}, size=({count}, 3)):
    ijk = tuple(int(x) for x in p)
    ta.setValueOn(ijk, float(rng.uniform(1000, 2000)))
    va.setValueOn(ijk, tuple(float(x) for x in rng.normal(0, 0.01, 3)))
for g in (t, v):
    g.transform = vdb.createLinearTransform(voxelSize=0.001)
vdb.write({str(path)!r}, grids=[t, v])
"""
    subprocess.run([openvdb.interpreter(), "-c", script], check=True, env=openvdb._clean_env())


@needs_openvdb
@pytest.mark.parametrize("up", ["y", "z"])
def test_few_voxels_in_a_big_box_read_as_leaves_equal_the_dense_read(tmp_path, up):
    """The active-value walk (few voxels per leaf of the box) gives the leaves the dense read
    has, turned the same way for z-up, vectors too."""
    from incandescent.config import VolumeSection
    from incandescent.config.assemble import volume_from_section
    from incandescent.volume import Remap

    path = tmp_path / "few.vdb"
    _sparse_file(path, 96, 40, seed=3)
    spec = VolumeSection(path=path, up_axis=up)
    dense = volume_from_section(spec, Remap(), layout="dense", blur_fps=24.0)
    sparse = volume_from_section(spec, Remap(), layout="sparse", blur_fps=24.0)
    back = sparse.to_dense()
    np.testing.assert_array_equal(back.temperature_K, dense.temperature_K)
    np.testing.assert_array_equal(back.velocity_m_s, dense.velocity_m_s)


@needs_openvdb
def test_a_few_hundred_voxels_over_a_2000_cube_render_sparse_quickly(tmp_path):
    path = tmp_path / "wide.vdb"
    _sparse_file(path, 2000, 300, seed=1)
    start = time.monotonic()
    result = runner.invoke(
        app,
        ["render", str(path), "-o", str(tmp_path / "w.png"), "--width", "32", "--height", "32",
         "--layout", "sparse"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert time.monotonic() - start < 25  # the worker's own read limit is 30 s


@pytest.fixture(scope="module")
def small_vdb(tmp_path_factory) -> Path:
    """A real ~30 KB .vdb written by OpenVDB: scattered hot voxels and their absorption."""
    path = tmp_path_factory.mktemp("vdb") / "good.vdb"
    rng = np.random.default_rng(5)
    temp = np.where(rng.random((24, 24, 24)) < 0.3, 1500.0, 0.0).astype(np.float32)
    grids = {"temperature": temp, "absorption": (temp > 0).astype(np.float32) * 5}
    openvdb.write(path, grids, 0.01, (0.0, 0.0, 0.0), {})
    return path


@needs_openvdb
@pytest.mark.parametrize("seed", range(12))
def test_a_bit_flipped_vdb_reads_or_fails_in_one_line_under_the_budget(tmp_path, small_vdb, seed):
    """Four seeded bit flips: a clean render or one line naming the file, within the budget
    (some flips make OpenVDB allocate gigabytes: under 256 MiB they fail at once) and in time
    (a dead worker is 'crashed', not 'did not finish within 30 s')."""
    data = bytearray(small_vdb.read_bytes())
    rng = np.random.default_rng(seed)
    for at in rng.integers(0, len(data), 4):
        data[at] ^= 1 << int(rng.integers(0, 8))
    bad = tmp_path / "flipped.vdb"
    bad.write_bytes(bytes(data))
    args = ["render", str(bad), "-o", str(tmp_path / "o.png"), "--width", "8", "--height", "8"]
    start = time.monotonic()
    run = subprocess.run(
        [sys.executable, "-m", "incandescent.cli", *args, "--max-memory", "0.25"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    elapsed = time.monotonic() - start
    assert run.returncode in (0, 2), run.stdout + run.stderr
    assert elapsed < 25, run.stderr  # the worker's read limit is 30 s: nothing may hang to it
    if run.returncode == 2:
        lines = [line for line in run.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and "flipped.vdb" in lines[0] and "Traceback" not in lines[0]
        assert "did not finish" not in lines[0], lines[0]
    if seed in (0, 6):  # these flips claim huge sizes: refused by the worker's cap, not swapped
        assert "256 MiB allowed" in run.stderr, run.stderr


@needs_openvdb
def test_the_worker_runs_under_the_memory_budget(small_vdb):
    """The worker's address space is capped at its mapping at start plus --max-memory."""
    openvdb.set_memory_budget(256 * 2**20)
    try:
        openvdb.describe(small_vdb, sums=True)  # a new file: the worker (re)started for it
        worker = openvdb._WORKERS[openvdb.interpreter()]
        limits = Path(f"/proc/{worker.process.pid}/limits").read_text()
        line = next(x for x in limits.splitlines() if x.startswith("Max address space"))
        assert line.split()[3] != "unlimited" and int(line.split()[3]) < 8 * 2**30, line
    finally:
        openvdb.set_memory_budget(None)


@needs_openvdb
def test_the_read_back_compares_active_voxel_counts(tmp_path):
    """The verify step of a .vdb write: a file whose grid lost voxels (a cut-short write that
    OpenVDB still parses) is refused; the file as written passes."""
    from incandescent.io.output import _check_vdb

    T = np.zeros((8, 8, 8), np.float32)
    T[2:5, 2:5, 2:5] = 1500.0
    v = np.zeros((8, 8, 8, 3), np.float32)
    v[3, 3, 3] = (0.0, 0.0, 1.0)
    path = tmp_path / "t.vdb"
    openvdb.write(path, {"temperature": T, "velocity": v}, 0.01, (0.0, 0.0, 0.0), {})
    _check_vdb(path, {"temperature": T, "velocity": v})
    more = T.copy()
    more[7, 7, 7] = 1.0
    with pytest.raises(ValueError, match="'temperature' holds 27 active voxels, not the 28"):
        _check_vdb(path, {"temperature": more, "velocity": v})
