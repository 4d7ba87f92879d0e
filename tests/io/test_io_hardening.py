"""Issue 10 below the command line: atomic outputs, frame manifests and locks, budgets, the
``.npy``/``.npz`` header reader and the scene loader under fuzzing, and the chunked march."""

from __future__ import annotations

import io
import json
import os
import stat
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import incandescent as inc
from incandescent.animation import render_sequence
from incandescent.api import DisplaySettings, load_volume
from incandescent.budget import BudgetError, Limits
from incandescent.config import SceneError, load_scene
from incandescent.io import atomic
from incandescent.io.output import write_json
from incandescent.io.volumes import _npy_header, open_grids
from incandescent.scenes import plume

# --- atomic outputs -----------------------------------------------------------------------------


def test_check_output_names_what_is_in_the_way(tmp_path):
    os.mkfifo(tmp_path / "p.png")
    with pytest.raises(atomic.OutputError, match=r"p\.png: it is a FIFO \(named pipe\), not a"):
        atomic.check_output(tmp_path / "p.png", overwrite=True)
    with pytest.raises(ValueError, match=r"unsupported image format \('\.jpg'\); expected .exr"):
        atomic.check_output(tmp_path / "a.jpg", suffixes=(".exr", ".png"), what="image")
    with pytest.raises(FileNotFoundError, match="folder .*nowhere does not exist"):
        atomic.check_output(tmp_path / "nowhere" / "a.png")
    (tmp_path / "f").write_text("")
    with pytest.raises(NotADirectoryError, match="is not a folder"):
        atomic.check_output(tmp_path / "f" / "a.png")
    assert atomic.check_output(tmp_path / "new.png") == tmp_path / "new.png"


def test_all_or_nothing_commits_every_output_or_none(tmp_path):
    with atomic.all_or_nothing():
        write_json(tmp_path / "a.json", {"a": 1})
        write_json(tmp_path / "b.json", {"b": 2})
        assert not (tmp_path / "a.json").exists()  # staged, not yet in place
    assert json.loads((tmp_path / "b.json").read_text()) == {"b": 2}

    def failing_batch():
        with atomic.all_or_nothing():
            write_json(tmp_path / "c.json", {"c": 3})
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        failing_batch()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.json"]


def test_a_failed_commit_undoes_the_new_outputs_of_its_batch(tmp_path):
    (tmp_path / "b.json").write_text("old")

    def racing_batch():
        with atomic.all_or_nothing():
            write_json(tmp_path / "a.json", {"a": 1})
            write_json(tmp_path / "b.json", {"b": 2}, overwrite=True)
            (tmp_path / "a.json").write_text("appeared meanwhile")  # refused at commit

    with pytest.raises(FileExistsError):
        racing_batch()
    assert (tmp_path / "a.json").read_text() == "appeared meanwhile"
    assert (tmp_path / "b.json").read_text() == "old"  # never committed
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_write_errors_become_one_line_naming_the_path(tmp_path):
    def full(tmp):
        raise OSError(28, "No space left on device")

    with pytest.raises(atomic.OutputError) as caught:
        atomic.atomic_write(tmp_path / "x.bin", full)
    assert str(caught.value) == f"cannot write {tmp_path / 'x.bin'}: No space left on device"
    assert list(tmp_path.iterdir()) == []


def test_sweep_removes_only_temporaries_of_dead_processes(tmp_path):
    target = tmp_path / "v.mp4"
    dead = tmp_path / f".v.mp4.999999999.{'a' * 32}.tmp"
    mine = tmp_path / f".v.mp4.{os.getpid()}.{'b' * 32}.tmp"
    other = tmp_path / f".w.mp4.999999999.{'c' * 32}.tmp"  # another output's
    for path in (dead, mine, other):
        path.write_text("")
    assert atomic.sweep_stale_temps(target) == [dead]
    assert mine.exists() and other.exists()


def test_lock_is_exclusive_and_names_the_owner(tmp_path):
    lock = tmp_path / ".lock"
    with atomic.exclusive_lock(lock, "out.mp4"):
        assert lock.read_text() == f"{os.getpid()}\n"
        with (
            pytest.raises(atomic.OutputError, match=rf"out.mp4 is being .* \(pid {os.getpid()}\)"),
            atomic.exclusive_lock(lock, "out.mp4"),
        ):
            pass
    with atomic.exclusive_lock(lock, "out.mp4"):  # released: free again
        pass


# --- frames know what made them -----------------------------------------------------------------


def _volumes(n: int):
    return [inc.Volume.from_arrays(np.full((2, 2, 2), 1000.0 + i)) for i in range(n)]


def _grey(volume) -> np.ndarray:
    return np.full((4, 4, 3), int(volume.max_temperature_K) % 256, np.uint8)


def test_frames_are_reused_only_under_the_same_key(tmp_path):
    calls = []

    def render_frame(volume):
        calls.append(volume.max_temperature_K)
        return _grey(volume)

    folder = tmp_path / "seq"
    render_sequence(_volumes(3), 3, folder, render_frame, False, frame_key=lambda i: f"a{i}")
    render_sequence(_volumes(3), 3, folder, render_frame, False, frame_key=lambda i: f"a{i}")
    assert len(calls) == 3
    with pytest.raises(FileExistsError, match="3 frame.*other input, settings or version"):
        render_sequence(_volumes(3), 3, folder, render_frame, False, frame_key=lambda i: "b")
    render_sequence(_volumes(3), 3, folder, render_frame, False, lambda i: "b", overwrite=True)
    assert len(calls) == 6
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["frames"] == {"0": "b", "1": "b", "2": "b"}


def test_a_frame_without_a_manifest_entry_is_not_reused(tmp_path):
    """A run killed between writing a frame and recording it: the frame is refused as unknown."""
    folder = tmp_path / "seq"
    render_sequence(_volumes(2), 2, folder, _grey, False, frame_key=lambda i: "k")
    manifest = folder / "manifest.json"
    data = json.loads(manifest.read_text())
    del data["frames"]["1"]
    manifest.write_text(json.dumps(data))
    with pytest.raises(FileExistsError, match="frame_00001.png"):
        render_sequence(_volumes(2), 2, folder, _grey, False, frame_key=lambda i: "k")


def test_animation_key_covers_input_settings_camera_and_display():
    from incandescent.animation import frame_key

    camera = inc.Camera(eye=(0, 0, 3))
    base = ("file 1 2", camera, inc.RenderSettings(), DisplaySettings())
    key = frame_key(*base)
    assert frame_key(*base) == key
    assert frame_key("file 1 3", *base[1:]) != key
    assert frame_key(base[0], camera.replace(fov_deg=30), *base[2:]) != key
    assert frame_key(*base[:2], inc.RenderSettings(width=80), base[3]) != key
    assert frame_key(*base[:3], DisplaySettings(exposure_ev=4)) != key


# --- budgets ------------------------------------------------------------------------------------


def test_render_budget_refuses_before_marching():
    volume = inc.Volume.from_arrays(np.full((64, 64, 64), 1500.0))
    settings = inc.RenderSettings(width=64, height=64, step_voxels=0.01)
    with pytest.raises(BudgetError, match=r"up to 4\.5e\+07 ray-march samples.*limit of 1e\+06"):
        inc.render(volume, None, settings, "cpu", Limits(max_samples=1e6))
    with pytest.raises(BudgetError, match="needs about .* more than the 1 MiB allowed"):
        inc.render(volume, None, settings, "cpu", Limits(max_memory_bytes=2**20))


def test_limits_validate_themselves():
    with pytest.raises(ValueError, match="max_samples must be a number > 0; got 0"):
        Limits(max_samples=0)


def test_npz_budget_uses_the_member_header_not_the_data(tmp_path):
    path = tmp_path / "g.npz"
    np.savez(path, temperature=np.full((32, 32, 32), 1500.0))
    with pytest.raises(BudgetError, match=r"reading temperature from .*g\.npz needs about"):
        open_grids(path, limits=Limits(max_memory_bytes=1e5)).read(["temperature"])
    assert open_grids(path).read(["temperature"]).arrays["temperature"].shape == (32, 32, 32)


# --- fuzzing the header reader and the scene loader ---------------------------------------------


def _npy_bytes() -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.arange(24, dtype=np.float32).reshape(2, 3, 4))
    return buffer.getvalue()


def test_a_header_with_a_bytes_key_is_a_corrupt_header():
    """One flipped byte makes `, 'fortran_order'` the bytes literal `,B'fortran_order'`, which
    NumPy's header check sorts beside str keys (TypeError; found by the fuzzing below in CI)."""
    raw = bytearray(_npy_bytes())
    raw[26] = ord("B")
    with pytest.raises(ValueError, match=r"^fuzz\.npy: corrupt \.npy header"):
        _npy_header(io.BytesIO(bytes(raw)), "fuzz.npy")


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_npy_header_reader_raises_only_value_error(data):
    raw = bytearray(_npy_bytes())
    for _ in range(data.draw(st.integers(1, 6))):
        raw[data.draw(st.integers(0, 127))] = data.draw(st.integers(0, 255))
    raw = raw[: data.draw(st.integers(0, len(raw)))]
    try:
        header = _npy_header(io.BytesIO(bytes(raw)), "fuzz.npy")
    except ValueError as error:  # anything else fails the test
        message = str(error)
    else:
        assert header.dtype.kind in "biuf" and header.data_bytes >= 0
        return
    assert message.startswith("fuzz.npy: ")


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_corrupt_npy_files_give_one_clear_error(tmp_path, data):
    raw = bytearray(_npy_bytes())
    for _ in range(data.draw(st.integers(1, 6))):
        raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    raw = raw[: data.draw(st.integers(0, len(raw)))]
    path = tmp_path / "fuzz.npy"
    path.write_bytes(bytes(raw))
    try:
        load_volume(path)
    except (ValueError, TypeError) as error:  # anything else fails the test
        message = str(error)
    else:
        return
    assert "fuzz.npy" in message


_SCENE = b"""[volume]
path = "v.npy"
voxel_size_m = 0.01
[volume.temperature]
range = [300.0, 2000.0]
[camera]
eye = [0.0, 0.0, 2.0]
[render]
width = 64
"""


@settings(
    max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data(), suffix=st.sampled_from([".toml", ".json"]))
def test_scene_loader_raises_only_scene_errors(tmp_path, data, suffix):
    text = _SCENE if suffix == ".toml" else json.dumps(_toml_as_dict()).encode()
    raw = bytearray(text)
    for _ in range(data.draw(st.integers(1, 6))):
        raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    if data.draw(st.booleans()):
        raw = bytearray(b"[" * data.draw(st.integers(0, 3000))) + raw
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(bytes(raw))
    try:
        load_scene(path)
    except SceneError as error:  # anything else fails the test
        message = str(error)
    else:
        return
    assert message.startswith(str(path))


def _toml_as_dict() -> dict:
    import tomllib

    return tomllib.loads(_SCENE.decode())


# --- the chunked march --------------------------------------------------------------------------


def test_chunked_march_equals_one_launch(monkeypatch):
    """Ctrl-C needs the march in chunks; chunks must not change a single sample."""
    from incandescent.renderer.backends import chunks

    volume = plume(24)
    settings = inc.RenderSettings(width=48, height=40, supersample=2)
    whole = inc.render(volume, None, settings, "cpu")
    monkeypatch.setattr(chunks, "FIRST_CHUNK_SAMPLES", 1.0)
    monkeypatch.setattr(chunks, "MIN_CHUNK_RAYS", 1000)
    monkeypatch.setattr(chunks, "MAX_CHUNK_SAMPLES", 1000 * 80.0)
    fractions = []
    chunked = inc.render(volume, None, settings, "cpu", progress=fractions.append)
    assert len(fractions) >= 6 and fractions[-1] == 1.0
    assert fractions == sorted(fractions)
    np.testing.assert_array_equal(chunked.xyz, whole.xyz)
    np.testing.assert_array_equal(chunked.transmittance, whole.transmittance)
    assert chunked.metadata["samples"] == whole.metadata["samples"]


def test_special_file_kinds_are_named():
    assert atomic._kind(stat.S_IFCHR) == "character device"
    assert atomic._kind(stat.S_IFSOCK) == "socket"


def test_zip_member_header_claiming_more_than_stored_is_truncated(tmp_path):
    path = tmp_path / "t.npz"
    buffer = io.BytesIO()
    np.save(buffer, np.zeros((4, 4, 4), np.float32))
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("temperature.npy", buffer.getvalue()[:-100])
    with pytest.raises(ValueError, match=r"grid 'temperature': header claims shape \(4, 4, 4\)"):
        open_grids(path).read(["temperature"])
