"""Issue 10: every finding of the hostile-user trial, through the command line as a user meets it.

Each case asserts the exact behaviour: the exit status, one error line naming the culprit, no
traceback, and nothing replaced or left behind. Real processes where the finding needs them
(two concurrent runs, SIGINT/SIGTERM, read-only and full file systems).
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _mounts import skip_without_private_mounts
from PIL import Image
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.scenes import plume_temperature

runner = CliRunner()


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


def _error(result, *fragments: str) -> str:
    """The one error line of a failed command; asserts exit 2, no traceback, the fragments."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, result.output
    assert lines[0].strip() != "error:", result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def _listing(folder: Path) -> dict[str, bytes | str]:
    """Every entry under ``folder`` with its content (files) or kind, to show nothing changed."""
    out: dict[str, bytes | str] = {}
    for path in sorted(folder.rglob("*")):
        mode = path.lstat().st_mode
        out[str(path.relative_to(folder))] = path.read_bytes() if stat.S_ISREG(mode) else oct(mode)
    return out


@pytest.fixture
def volume(tmp_path) -> Path:
    path = tmp_path / "hot.npy"
    np.save(path, plume_temperature(12))
    return path


SMALL = ("--width", 16, "--height", 12)


def _cli_process(*args, **kwargs) -> subprocess.Popen:
    """The command line in a real process; SIGINT not ignored (as in an interactive shell)."""
    return subprocess.Popen(
        [sys.executable, "-m", "incandescent.cli", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        **kwargs,
    )


# --- wrong results, exit 0 ----------------------------------------------------------------------


@pytest.fixture
def sequence(tmp_path) -> str:
    base = plume_temperature(10)
    for i in range(4):
        np.save(tmp_path / f"fire_{i:04d}.npy", base * (0.85 + 0.05 * i))
    return str(tmp_path / "fire_####.npy")


def test_animate_rerun_with_another_width_is_refused_then_rerendered(tmp_path, sequence):
    out = tmp_path / "fire.gif"
    assert _run("animate", sequence, "-o", out, "--width", 64, "--height", 32).exit_code == 0
    before = out.read_bytes()
    _error(_run("animate", sequence, "-o", out, "--width", 80, "--height", 32), "already exists")
    assert out.read_bytes() == before
    out.unlink()  # the frames alone: made with another width, so they are not reused
    _error(
        _run("animate", sequence, "-o", out, "--width", 80, "--height", 32),
        "holds 4 frame(s)",
        "--overwrite",
    )
    result = _run("animate", sequence, "-o", out, "--width", 80, "--height", 32, "--overwrite")
    assert result.exit_code == 0, result.output
    assert "4 rendered, 0 reused" in " ".join(result.output.split())
    with Image.open(out) as video:
        assert video.size == (80, 32)


def test_animate_exposure_change_with_overwrite_renders_again(tmp_path, sequence):
    out = tmp_path / "fire"
    assert _run("animate", sequence, "-o", out, "--width", 24, "--height", 16).exit_code == 0
    before = np.asarray(Image.open(out / "frame_00002.png"), dtype=float)
    result = _run(
        "animate", sequence, "-o", out, "--width", 24, "--height", 16, "--exposure", 2,
        "--overwrite",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "4 rendered, 0 reused" in " ".join(result.output.split())
    after = np.asarray(Image.open(out / "frame_00002.png"), dtype=float)
    assert after.sum() > before.sum() and (after >= before).all()  # +2 EV: brighter everywhere


@pytest.mark.slow
def test_two_animate_runs_on_one_output_the_second_fails_at_once(tmp_path):
    base = plume_temperature(64)
    for i in range(60):
        np.save(tmp_path / f"f_{i:04d}.npy", base * (0.9 + 0.003 * i))
    pattern, out = str(tmp_path / "f_####.npy"), tmp_path / "clip.gif"
    common = ("animate", pattern, "-o", out, "--width", 320, "--height", 240, "--backend", "cpu")
    first = _cli_process(*common, "--step", 0.05)  # ~10 s on 2 cores
    lock = tmp_path / "clip_frames" / ".lock"
    deadline = time.monotonic() + 60
    while not (lock.exists() and lock.read_text().strip()) and time.monotonic() < deadline:
        time.sleep(0.05)
    began = time.monotonic()
    second = _cli_process(*common, "--exposure", 3)
    second_out = second.communicate(timeout=60)[0]
    second_seconds = time.monotonic() - began
    first_still_running = first.poll() is None
    first_out = first.communicate(timeout=300)[0]
    assert first.returncode == 0, first_out
    assert second.returncode == 2, second_out
    assert f"being written by another incandescent run (pid {first.pid})" in second_out
    assert first_still_running and second_seconds < 20  # it fails at once, not after the first
    keys = json.loads((tmp_path / "clip_frames" / "manifest.json").read_text())["frames"]
    assert len(keys) == 60 and len(set(keys.values())) == 60  # every frame from the first run
    with Image.open(out) as video:
        assert video.n_frames >= 2


def test_a_stale_lock_of_a_killed_run_is_taken_over(tmp_path, sequence):
    folder = tmp_path / "out_frames"
    folder.mkdir()
    (folder / ".lock").write_text("999999999\n")  # no such process holds it
    result = _run("animate", sequence, "-o", tmp_path / "out.gif", *SMALL)
    assert result.exit_code == 0, result.output


def _special_files(tmp_path) -> list[Path]:
    fifo = tmp_path / "pipe.png"
    os.mkfifo(fifo)
    files = [fifo]
    try:
        os.mknod(tmp_path / "null.png", stat.S_IFCHR | 0o600, os.makedev(1, 3))
        files.append(tmp_path / "null.png")
    except PermissionError:  # no CAP_MKNOD: the FIFO case still runs
        pass
    return files


def test_overwrite_never_replaces_a_device_or_fifo(tmp_path, volume):
    for special in _special_files(tmp_path):
        _error(
            _run("render", volume, "-o", special, *SMALL, "--overwrite"),
            str(special),
            "not a regular file",
        )
        assert not stat.S_ISREG(special.lstat().st_mode)
        stats = special.with_suffix(".json")
        special.rename(stats)
        _error(
            _run("render", volume, "-o", tmp_path / "ok.png", "--stats", stats, "--overwrite"),
            str(stats),
            "not a regular file",
        )
        assert not stat.S_ISREG(stats.lstat().st_mode)
        assert not (tmp_path / "ok.png").exists()


def test_overwrite_through_a_symlink_replaces_the_file_it_names(tmp_path, volume):
    real = tmp_path / "real.png"
    real.write_bytes(b"old")
    link = tmp_path / "link.png"
    link.symlink_to(real)
    assert _run("render", volume, "-o", link, *SMALL, "--overwrite").exit_code == 0
    assert link.is_symlink() and real.read_bytes().startswith(b"\x89PNG")


def test_demo_size_zero_is_refused(tmp_path):
    _error(_run("demo", "plume", "--size", 0, "-o", tmp_path / "d.png"), "--size must be >= 8")
    assert list(tmp_path.iterdir()) == []


# --- unbounded work -----------------------------------------------------------------------------


def test_npy_header_claiming_a_huge_array_is_refused_from_the_header(tmp_path):
    from numpy.lib import format as npy

    path = tmp_path / "huge.npy"
    with open(path, "wb") as handle:
        header = {"descr": "<f4", "fortran_order": False, "shape": (100000, 100000, 100000)}
        npy.write_array_header_1_0(handle, header)
        handle.write(b"\0" * 4000)
    started = time.monotonic()
    _error(_run("render", path, "-o", tmp_path / "o.png"), "huge.npy", "(100000, 100000, 100000)")
    assert time.monotonic() - started < 5


def _zip_bomb(path: Path, n: int) -> None:
    """An .npz whose one grid inflates to n³ float32 zeros (a 1000:1 compression ratio)."""
    import zipfile

    from numpy.lib import format as npy

    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        with archive.open("temperature.npy", "w", force_zip64=True) as member:
            header = {"descr": "<f4", "fortran_order": False, "shape": (n, n, n)}
            npy.write_array_header_1_0(member, header)
            zeros = bytes(1 << 22)
            for _ in range(n**3 * 4 // len(zeros)):
                member.write(zeros)


def test_npz_that_inflates_past_the_memory_limit_is_refused_before_inflating(tmp_path):
    path = tmp_path / "bomb.npz"
    _zip_bomb(path, 256)  # 64 MiB inflated from ~64 KiB
    assert path.stat().st_size < 1 << 20
    _error(
        _run("render", path, "-o", tmp_path / "o.png", "--max-memory", 0.25),
        "bomb.npz",
        "needs about",
        "--max-memory",
    )


@pytest.mark.parametrize("hot_K", [1e9, 1e30])
def test_voxels_hotter_than_the_table_ceiling_are_refused(tmp_path, hot_K):
    temp = np.full((6, 6, 6), 1500.0)
    temp[3, 2, 1] = hot_K
    np.save(tmp_path / "hot.npy", temp)
    started = time.monotonic()
    line = _error(_run("render", tmp_path / "hot.npy", "-o", tmp_path / "o.png"), "(3, 2, 1)")
    assert "100000 K ceiling" in line and time.monotonic() - started < 10


def test_a_step_of_a_billionth_voxel_is_refused_by_the_sample_budget(tmp_path, volume):
    _error(
        _run("render", volume, "-o", tmp_path / "o.png", "--step", 1e-9),
        "ray-march samples",
        "--max-samples",
    )
    result = _run("render", volume, "-o", tmp_path / "o.png", *SMALL, "--max-samples", 10)
    _error(result, "more than the limit of 10")


def test_the_largest_image_is_refused_by_the_memory_budget(tmp_path, volume):
    _error(
        _run("render", volume, "-o", tmp_path / "o.png", "--width", 32768, "--height", 32768),
        "32768×32768",
        "of memory",
    )


def test_demo_size_4000_is_refused_by_the_memory_budget(tmp_path):
    started = time.monotonic()
    _error(_run("demo", "plume", "--size", 4000, "-o", tmp_path / "d.png"), "4000³", "GiB")
    assert time.monotonic() - started < 10 and list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_long_render_stops_within_a_second_of_ctrl_c(tmp_path, sig):
    np.save(tmp_path / "p.npy", plume_temperature(96))
    out = tmp_path / "long.exr"
    args = ("render", tmp_path / "p.npy", "-o", out, "--width", 2048, "--height", 2048)
    process = _cli_process(*args, "--step", 0.02, "--backend", "cpu")  # ~15 s on 2 cores
    time.sleep(6)
    assert process.poll() is None, "the render finished before it could be interrupted"
    sent = time.monotonic()
    process.send_signal(sig)
    output = process.communicate(timeout=30)[0]
    assert time.monotonic() - sent < 3, output
    assert process.returncode == 130, output
    assert "interrupted" in output and "Traceback" not in output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.npy"]  # no image, no temp file


# --- errors that came too late or unclear -------------------------------------------------------


@pytest.mark.parametrize("name", ["out.jpg", "out.tiff", "out"])
def test_unsupported_output_suffix_is_refused_before_reading(tmp_path, name):
    path = tmp_path / "huge.npy"  # reading it would be refused too: the output goes first
    path.write_bytes(b"\x93NUMPY")
    line = _error(_run("render", path, "-o", tmp_path / name), "unsupported image format")
    assert str(tmp_path / name) in line


def test_output_that_is_a_folder_is_refused(tmp_path, volume):
    (tmp_path / "out.png").mkdir()
    _error(_run("render", volume, "-o", tmp_path / "out.png", "--overwrite"), "it is a folder")


def _in_private_mount(mount_options: str, folder: Path, *args) -> subprocess.CompletedProcess:
    """Run the CLI with a tmpfs mounted on ``folder`` in a private mount namespace."""
    skip_without_private_mounts()
    folder.mkdir()
    command = " ".join(map(str, [sys.executable, "-m", "incandescent.cli", *args]))
    script = f"mount -t tmpfs -o {mount_options} tmpfs {folder} && {command}"
    return subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True)


def test_read_only_output_folder_is_refused_before_rendering(tmp_path, volume):
    folder = tmp_path / "ro"
    result = _in_private_mount("ro", folder, "render", volume, "-o", folder / "o.png", *SMALL)
    assert result.returncode == 2, result.stdout + result.stderr
    assert "read-only file system" in result.stderr and "rendered" not in result.stderr
    assert "Traceback" not in result.stderr


def test_full_disk_is_one_line_and_leaves_nothing(tmp_path, volume):
    folder = tmp_path / "full"
    args = ("render", volume, "-o", folder / "o.exr", "--width", 256, "--height", 256)
    result = _in_private_mount("size=16k", folder, *args, "--stats", folder / "s.json")
    assert result.returncode == 2, result.stdout + result.stderr
    assert "No space left on device" in result.stderr and "Traceback" not in result.stderr
    assert list(folder.iterdir()) == []  # the mount is gone: the folder is ours again, empty


def test_failed_stats_write_leaves_no_image(tmp_path, volume, monkeypatch):
    from incandescent.io import atomic

    real = atomic._commit

    def failing(item):
        if item.target.suffix == ".json":
            raise atomic.OutputError(f"cannot write {item.target}: Input/output error")
        real(item)

    monkeypatch.setattr(atomic, "_commit", failing)
    result = _run(
        "render", volume, "-o", tmp_path / "o.png", *SMALL, "--stats", tmp_path / "s.json"
    )
    _error(result, "s.json", "Input/output error")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hot.npy"]


def test_random_bytes_named_npy_are_not_a_numpy_file(tmp_path):
    path = tmp_path / "noise.npy"
    path.write_bytes(np.random.default_rng(0).bytes(4096))
    _error(_run("render", path, "-o", tmp_path / "o.png"), "noise.npy", "not a NumPy .npy array")


def test_deeply_nested_json_scene_names_the_file(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 5000 + "]" * 5000)
    _error(_run("render", path, "-o", tmp_path / "o.png"), "deep.json", "nested too deeply")


def test_binary_line_table_names_the_file(tmp_path, volume):
    table = tmp_path / "lines.csv"
    table.write_bytes(b"\xff\xfe\x00\x81binary")
    result = _run("render", volume, "-o", tmp_path / "o.png", "--species", "Na=0.1",
                  "--line-table", table, *SMALL)  # fmt: skip
    _error(result, "lines.csv", "not a UTF-8 text line table")


def test_huge_exposure_is_a_range_error(tmp_path, volume):
    result = _run("render", volume, "-o", tmp_path / "o.png", *SMALL, "--exposure", "1e308")
    _error(result, "exposure_ev must be within ±100 stops")


def test_tiny_fov_is_blamed_on_the_fov(tmp_path, volume):
    _error(_run("render", volume, "-o", tmp_path / "o.png", "--fov", 1e-9), "fov_deg must be in")


def test_tiny_voxel_size_is_blamed_on_the_voxel_size(tmp_path, volume):
    result = _run("render", volume, "-o", tmp_path / "o.png", "--voxel-size", 1e-12)
    _error(result, "voxel_size_m must be in [1e-09, 1e+06] m; got 1e-12")


def test_folder_given_as_volume(tmp_path):
    (tmp_path / "cache.npy").mkdir()
    _error(_run("render", tmp_path / "cache.npy", "-o", tmp_path / "o.png"), "is a folder")


def test_fifo_given_as_volume_is_not_opened(tmp_path):
    os.mkfifo(tmp_path / "pipe.npy")  # opening it for reading would block forever
    _error(_run("render", tmp_path / "pipe.npy", "-o", tmp_path / "o.png"), "is a FIFO")


def test_info_on_a_scene_file_describes_its_volume(tmp_path, volume):
    scene = tmp_path / "scene.toml"
    scene.write_text(f'[volume]\npath = "{volume.name}"\n')
    result = _run("info", scene)
    assert result.exit_code == 0, result.output
    assert "a scene file; its volume is" in result.output and "temperature" in result.output


def test_api_wrong_types_are_type_errors_naming_the_argument():
    import incandescent as inc

    volume = inc.Volume.from_arrays(np.full((4, 4, 4), 1500.0))
    with pytest.raises(TypeError, match="settings must be an incandescent RenderSettings"):
        inc.render(volume, None, {"width": 8})  # type: ignore[arg-type]
    want = "camera must be an incandescent Camera or Rig or None; got str"
    with pytest.raises(TypeError, match=want):
        inc.render(volume, "front")  # type: ignore[arg-type]


def test_numpy_integers_are_accepted_as_sizes():
    import incandescent as inc

    settings = inc.RenderSettings(width=np.int64(64), height=np.int32(8))
    assert settings.width == 64 and type(settings.width) is int
    assert "got 0" in str(pytest.raises(ValueError, inc.RenderSettings, width=np.int64(0)).value)


def test_square_brackets_in_paths_survive_in_messages(tmp_path, volume):
    folder = tmp_path / "[x]"
    folder.mkdir()
    result = _run("render", volume, "-o", folder / "[a].png", *SMALL)
    assert result.exit_code == 0, result.output
    assert f"wrote {folder / '[a].png'}" in result.output
    _error(_run("render", volume, "-o", folder / "[a].png", *SMALL), "[x]/[a].png already exists")


@pytest.mark.parametrize(
    ("flag", "value", "message"),
    [
        ("--eye", "1,2", "--eye must be three numbers"),
        ("--target", "a,b,c", "--target must be three numbers"),
        ("--species", "Na", "--species entries must be NAME=FRACTION"),
        ("--temperature-range", "hot", "--temperature-range must be LOW:HIGH"),
    ],
)
def test_flag_errors_print_one_line(tmp_path, volume, flag, value, message):
    _error(_run("render", volume, "-o", tmp_path / "o.png", flag, value), message)


def test_stale_temporary_files_of_a_killed_encode_are_swept(tmp_path, sequence):
    out = tmp_path / "fire.mp4"
    dead = tmp_path / f".fire.mp4.999999999.{'0' * 32}.tmp"  # pid 999999999 does not exist
    dead.write_bytes(b"half an mp4")
    live = tmp_path / f".fire.mp4.{os.getpid()}.{'1' * 32}.tmp"  # a running writer's: kept
    live.write_bytes(b"being written")
    assert _run("animate", sequence, "-o", out, *SMALL).exit_code == 0
    assert not dead.exists() and live.exists() and out.stat().st_size > 0


def test_interrupted_mp4_encode_leaves_no_temporary_file(tmp_path, sequence, monkeypatch):
    from incandescent.animation import video

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(video, "read_frames", interrupted)
    result = _run("animate", sequence, "-o", tmp_path / "fire.mp4", *SMALL)
    assert result.exit_code == 130, result.output
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert not (tmp_path / "fire.mp4").exists()
