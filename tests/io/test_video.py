"""Videos and frame sequences: real MP4 (ffmpeg) and GIF (Pillow) read back, resumable PNG
sequences, interrupted runs, refusal to overwrite."""

from __future__ import annotations

import os
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

from incandescent.animation import animate, frame_path, render_sequence
from incandescent.camera import Camera
from incandescent.imaging import DisplaySettings, to_display
from incandescent.io import images as images_module
from incandescent.io.video import read_frames, write_gif, write_mp4
from incandescent.renderer import RenderSettings, render
from incandescent.scenes.paper import PlateScene
from incandescent.volume import Volume


def _frames(n: int, height: int = 24, width: int = 32) -> list[np.ndarray]:
    """Distinct smooth test frames: a gradient whose brightness and red level change with i."""
    y, x = np.mgrid[0:height, 0:width]
    out = []
    for i in range(n):
        rgb = np.stack([np.full_like(x, 40 * i % 256), 8 * x % 256, 10 * y % 256], axis=-1)
        out.append(rgb.astype(np.uint8))
    return out


def _read_mp4(path: Path) -> tuple[dict, list[np.ndarray]]:
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]
    return meta, frames


def _volumes(n: int) -> list[Volume]:
    """Tiny volumes whose temperature encodes the frame index (for counting what got rendered)."""
    return [Volume.from_arrays(np.full((2, 2, 2), 1000.0 + i)) for i in range(n)]


class CountingRenderer:
    """render_frame stand-in: a frame coloured by the volume's temperature; counts its calls."""

    def __init__(self, fail_at: int | None = None) -> None:
        self.calls: list[int] = []
        self.fail_at = fail_at

    def __call__(self, volume: Volume) -> np.ndarray:
        index = int(round(volume.max_temperature_K - 1000.0))
        if index == self.fail_at:
            raise RuntimeError(f"renderer failed at frame {index}")
        self.calls.append(index)
        return np.full((6, 8, 3), (index * 20) % 256, dtype=np.uint8)


def _frame_files(folder) -> list[str]:
    """The PNG frames and any temporary files in a sequence folder (not its manifest, lock)."""
    return sorted(p for p in os.listdir(folder) if p.startswith("frame_") or p.endswith(".tmp"))


def test_mp4_round_trip(tmp_path):
    frames = _frames(7)
    out = write_mp4(frames, tmp_path / "clip.mp4", fps=10)
    meta, back = _read_mp4(out)
    assert len(back) == 7
    assert meta["size"] == (32, 24)
    assert meta["fps"] == pytest.approx(10)
    assert meta["codec"].startswith("h264")
    for orig, decoded in zip(frames, back, strict=True):  # lossy, but close on average
        assert np.abs(decoded.astype(float) - orig).mean() < 6


def test_mp4_odd_size_is_padded_to_even(tmp_path):
    out = write_mp4(iter(_frames(3, height=25, width=33)), tmp_path / "odd.mp4")
    meta, back = _read_mp4(out)
    assert meta["size"] == (34, 26)
    assert len(back) == 3


def test_gif_round_trip(tmp_path):
    out = write_gif(_frames(5), tmp_path / "clip.gif", fps=20)
    with Image.open(out) as gif:
        assert gif.n_frames == 5
        assert gif.size == (32, 24)
        assert gif.info["duration"] == 50
        assert gif.info["loop"] == 0


@pytest.mark.parametrize(("writer", "name"), [(write_mp4, "a.mp4"), (write_gif, "a.gif")])
def test_video_overwrite_refused_unless_asked(tmp_path, writer, name):
    target = tmp_path / name
    target.write_bytes(b"precious")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        writer(_frames(2), target)
    assert target.read_bytes() == b"precious"
    writer(_frames(2), target, overwrite=True)
    assert target.stat().st_size > 100
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary files left


@pytest.mark.parametrize(
    ("frames", "error", "match"),
    [
        ([], ValueError, "empty"),
        ([np.zeros((4, 4, 3))], TypeError, "uint8"),
        ([np.zeros((4, 4), np.uint8)], ValueError, r"\(H, W, 3\)"),
        ([np.zeros((4, 4, 3), np.uint8), np.zeros((4, 6, 3), np.uint8)], ValueError, "frame 1"),
    ],
)
def test_bad_frames_are_rejected_and_leave_nothing(tmp_path, frames, error, match):
    for name, writer in (("x.mp4", write_mp4), ("x.gif", write_gif)):
        with pytest.raises(error, match=match):
            writer(frames, tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_bad_fps_rejected(tmp_path):
    with pytest.raises(ValueError, match="fps"):
        write_mp4(_frames(2), tmp_path / "a.mp4", fps=0)


def test_png_sequence(tmp_path):
    renderer = CountingRenderer()
    paths = render_sequence(_volumes(4), 4, tmp_path / "seq", renderer, progress=False)
    assert paths == [tmp_path / "seq" / f"frame_{i:05d}.png" for i in range(4)]
    assert renderer.calls == [0, 1, 2, 3]
    back = list(read_frames(paths))
    assert [int(f[0, 0, 0]) for f in back] == [0, 20, 40, 60]
    assert back[0].shape == (6, 8, 3)


def test_resume_renders_only_missing_frames(tmp_path):
    folder = tmp_path / "seq"
    render_sequence(_volumes(5), 5, folder, CountingRenderer(), progress=False)
    frame_path(folder, 1).unlink()
    frame_path(folder, 3).unlink()
    renderer = CountingRenderer()
    render_sequence(_volumes(5), 5, folder, renderer, progress=False)
    assert renderer.calls == [1, 3]
    by_index = CountingRenderer()  # a function index → Volume is called only for missing frames
    frame_path(folder, 4).unlink()
    asked: list[int] = []
    render_sequence(
        lambda i: asked.append(i) or _volumes(5)[i], 5, folder, by_index, progress=False
    )
    assert asked == [4]
    assert by_index.calls == [4]


def test_corrupt_frame_is_rendered_again(tmp_path):
    folder = tmp_path / "seq"
    render_sequence(_volumes(3), 3, folder, CountingRenderer(), progress=False)
    data = frame_path(folder, 2).read_bytes()
    frame_path(folder, 2).write_bytes(data[: len(data) // 2])  # truncated, e.g. by a crash
    renderer = CountingRenderer()
    render_sequence(_volumes(3), 3, folder, renderer, progress=False)
    assert renderer.calls == [2]
    assert next(read_frames([frame_path(folder, 2)]))[0, 0, 0] == 40


def test_interrupted_run_leaves_no_partial_frame_and_resumes(tmp_path):
    folder = tmp_path / "seq"
    with pytest.raises(RuntimeError, match="frame 2"):
        render_sequence(_volumes(5), 5, folder, CountingRenderer(fail_at=2), progress=False)
    assert _frame_files(folder) == ["frame_00000.png", "frame_00001.png"]
    renderer = CountingRenderer()
    paths = render_sequence(_volumes(5), 5, folder, renderer, progress=False)
    assert renderer.calls == [2, 3, 4]
    assert len(list(read_frames(paths))) == 5


def test_interrupt_while_writing_a_frame_leaves_no_partial_file(tmp_path, monkeypatch):
    """Ctrl-C in the middle of writing frame 1's PNG: no frame_00001.png, no temporary file."""
    real_fsync, calls = os.fsync, []

    def interrupted_fsync(fd):
        calls.append(fd)
        if len(calls) == 2:
            raise KeyboardInterrupt
        real_fsync(fd)

    monkeypatch.setattr(images_module.os, "fsync", interrupted_fsync)
    folder = tmp_path / "seq"
    with pytest.raises(KeyboardInterrupt):
        render_sequence(_volumes(3), 3, folder, CountingRenderer(), progress=False)
    assert [p for p in os.listdir(folder) if p.endswith(".png") or p.endswith(".tmp")] == [
        "frame_00000.png"
    ]
    monkeypatch.setattr(images_module.os, "fsync", real_fsync)
    renderer = CountingRenderer()
    render_sequence(_volumes(3), 3, folder, renderer, progress=False)
    assert renderer.calls == [1, 2]


def test_sequence_errors(tmp_path):
    with pytest.raises(ValueError, match="ran out after 2"):
        render_sequence(_volumes(2), 3, tmp_path / "a", CountingRenderer(), progress=False)
    with pytest.raises(ValueError, match="frame 1 has shape"):
        render_sequence(
            _volumes(2),
            2,
            tmp_path / "b",
            lambda v: np.zeros((4 + int(v.max_temperature_K) % 2, 4, 3), np.uint8),
            progress=False,
        )
    with pytest.raises(TypeError, match="uint8"):
        render_sequence(_volumes(1), 1, tmp_path / "c", lambda v: np.zeros((4, 4, 3)), False)


def test_progress_bar_on_stderr(tmp_path, capsys):
    render_sequence(_volumes(3), 3, tmp_path / "seq", CountingRenderer(), progress=True)
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "3/3" in captured.err
    assert "frames/s" in captured.err


def test_animate_gif_and_folder(tmp_path, capsys):
    renderer = CountingRenderer()
    summary = animate(_volumes(4), 4, tmp_path / "anim.gif", renderer, fps=10)
    assert summary.video == tmp_path / "anim.gif"
    assert summary.frame_dir == tmp_path / "anim_frames"
    assert (summary.rendered, summary.reused) == (4, 0)
    with Image.open(summary.video) as gif:
        assert gif.n_frames == 4
    assert "anim.gif" in capsys.readouterr().err
    with pytest.raises(FileExistsError):  # refused before rendering anything
        animate(_volumes(4), 4, tmp_path / "anim.gif", renderer, progress=False)
    assert renderer.calls == [0, 1, 2, 3]
    (tmp_path / "anim.gif").unlink()  # frames made with the same key are reused
    again = animate(_volumes(4), 4, tmp_path / "anim.gif", renderer, progress=False)
    assert (again.rendered, again.reused) == (0, 4)
    again = animate(_volumes(4), 4, tmp_path / "anim.gif", renderer, overwrite=True)
    assert (again.rendered, again.reused) == (4, 0)  # overwrite renders every frame again
    folder = animate(_volumes(2), 2, tmp_path / "pngs", CountingRenderer(), progress=False)
    assert folder.video is None
    assert _frame_files(tmp_path / "pngs") == ["frame_00000.png", "frame_00001.png"]
    with pytest.raises(ValueError, match="unsupported animation format"):
        animate(_volumes(2), 2, tmp_path / "x.avi", CountingRenderer(), progress=False)


def test_animate_plate_scene_to_mp4_end_to_end(tmp_path):
    """A few frames of a small plate scene, really rendered (cpu backend), to an MP4."""
    scene = PlateScene(shape=(24, 16, 16), n_frames=4, speed_voxels_per_frame=4.0)
    camera = Camera(eye=(-0.1, 0.45, 0.0), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0))
    settings = RenderSettings(width=20, height=14)
    display = DisplaySettings(auto_exposure=False, exposure_ev=-31.0)

    def render_frame(volume: Volume) -> np.ndarray:
        return to_display(render(volume, camera, settings, backend="cpu").xyz, display)

    volumes = (scene.volume(t) for t in scene.frames())
    summary = animate(volumes, 4, tmp_path / "plate.mp4", render_frame, progress=False)
    meta, back = _read_mp4(tmp_path / "plate.mp4")
    assert len(back) == 4
    assert meta["size"] == (20, 14)
    assert summary.rendered == 4
    assert max(f.max() for f in read_frames(summary.frames)) > 0
