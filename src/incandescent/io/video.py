"""Frame sequences and videos: resumable PNG sequences, H.264 MP4 and animated GIF, all atomic.

A sequence is rendered into a folder of ``frame_00000.png, frame_00001.png, …``; each PNG is
written atomically (:func:`incandescent.io.images.write_png`), so an interrupted run leaves only
whole frames, and a rerun renders only the frames that are missing or unreadable. Videos are
assembled from those PNGs afterwards, again through a temporary file moved into place, so a
video is never half-written and an existing one is never replaced unless asked.

MP4 needs the ``imageio-ffmpeg`` package (it bundles an ``ffmpeg`` binary); GIF uses Pillow.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent.io.atomic import atomic_write, check_output, exclusive_lock
from incandescent.io.images import write_png
from incandescent.io.output import write_json
from incandescent.volume import Volume

PathLike = str | os.PathLike
#: Video containers :func:`animate` writes, by suffix; any other output is a folder of PNGs.
VIDEO_SUFFIXES = (".mp4", ".gif")
#: Name of frame i in a sequence folder.
FRAME_NAME = "frame_{:05d}.png"

RenderFrame = Callable[[Volume], NDArray[np.uint8]]
VolumeSource = Iterable[Volume] | Callable[[int], Volume]


def frame_path(frame_dir: PathLike, index: int) -> Path:
    """``frame_dir/frame_00042.png`` for ``index`` 42."""
    return Path(os.fspath(frame_dir)) / FRAME_NAME.format(index)


# --- checks ---------------------------------------------------------------------------------


def _check_fps(fps: float) -> float:
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.integer, np.floating)):
        raise TypeError(f"fps must be a number; got {type(fps).__name__} {fps!r}")
    if not np.isfinite(fps) or not 0 < fps <= 1000:
        raise ValueError(f"fps must be in (0, 1000] frames per second; got {fps!r}")
    return float(fps)


def _check_count(n_frames: int) -> int:
    if isinstance(n_frames, bool) or not isinstance(n_frames, (int, np.integer)):
        raise TypeError(f"n_frames must be an integer; got {type(n_frames).__name__} {n_frames!r}")
    if n_frames < 1:
        raise ValueError(f"n_frames must be >= 1; got {n_frames!r}")
    return int(n_frames)


def _check_frame(frame: object, index: int, shape: tuple[int, ...] | None) -> NDArray[np.uint8]:
    """A frame must be uint8 (H, W, 3), the same size as the first."""
    arr = np.asarray(frame)
    if arr.dtype != np.uint8:
        raise TypeError(f"frame {index} must be uint8 RGB (H, W, 3); got dtype {arr.dtype}")
    if arr.ndim != 3 or arr.shape[2] != 3 or 0 in arr.shape:
        raise ValueError(f"frame {index} must have shape (H, W, 3) with H, W >= 1; got {arr.shape}")
    if shape is not None and arr.shape != shape:
        raise ValueError(f"frame {index} has shape {arr.shape}; frame 0 had {shape}")
    return arr


def _checked_frames(frames: Iterable[NDArray[np.uint8]]) -> Iterator[NDArray[np.uint8]]:
    shape = None
    for index, frame in enumerate(frames):
        arr = _check_frame(frame, index, shape)
        shape = arr.shape
        yield arr
    if shape is None:
        raise ValueError("no frames to write: the frame sequence is empty")


# --- MP4 and GIF ----------------------------------------------------------------------------


def _even(frame: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Repeat the last row/column of an odd-sized frame once (yuv420p needs even sizes)."""
    h, w = frame.shape[:2]
    if h % 2 == 0 and w % 2 == 0:
        return frame
    return np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def write_mp4(
    frames: Iterable[NDArray[np.uint8]],
    path: PathLike,
    fps: float = 25.0,
    overwrite: bool = False,
    crf: int = 18,
) -> Path:
    """Encode uint8 RGB frames (H, W, 3) as an H.264 MP4 (yuv420p) with ffmpeg, atomically.

    Parameters
    ----------
    frames:
        uint8 RGB arrays of one size, consumed once (a generator is fine: frames stream to
        ffmpeg). yuv420p needs an even width and height: an odd-sized frame gets its last row
        and/or column repeated once, so the video is at most 1 pixel larger than the frames.
    path:
        Destination ``.mp4``; its directory must exist.
    fps:
        Frame rate, frames per second.
    overwrite:
        Replace an existing file (otherwise ``FileExistsError`` before anything is encoded).
    crf:
        x264 constant rate factor, 0 (lossless) … 51 (worst); 18 is visually lossless.

    Returns
    -------
    The path written. Needs ``imageio-ffmpeg`` (ImportError naming it otherwise).
    """
    fps = _check_fps(fps)
    if isinstance(crf, bool) or not isinstance(crf, (int, np.integer)) or not 0 <= crf <= 51:
        raise ValueError(f"crf must be an integer in 0..51; got {crf!r}")
    ffmpeg = _imageio_ffmpeg()

    def write(tmp: Path) -> None:
        stream = _checked_frames(frames)
        first = _even(next(stream))
        writer = ffmpeg.write_frames(
            str(tmp),
            (first.shape[1], first.shape[0]),
            fps=fps,
            codec="libx264",
            pix_fmt_out="yuv420p",
            quality=None,
            macro_block_size=1,  # never rescale: sizes are made even above
            output_params=["-crf", str(int(crf)), "-movflags", "+faststart", "-f", "mp4"],
        )
        writer.send(None)
        try:
            writer.send(np.ascontiguousarray(first).tobytes())
            for frame in stream:
                writer.send(np.ascontiguousarray(_even(frame)).tobytes())
        finally:
            writer.close()

    return atomic_write(path, write, overwrite)


def _imageio_ffmpeg():
    try:
        import imageio_ffmpeg
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise ImportError(
            "writing MP4 needs the imageio-ffmpeg package: pip install imageio-ffmpeg "
            "(or write a .gif or a folder of PNG frames instead)"
        ) from err
    return imageio_ffmpeg


def write_gif(
    frames: Iterable[NDArray[np.uint8]],
    path: PathLike,
    fps: float = 25.0,
    overwrite: bool = False,
) -> Path:
    """Write uint8 RGB frames (H, W, 3) as a looping animated GIF with Pillow, atomically.

    GIF stores 256 colours per frame (Pillow chooses an adaptive palette for each) and frame
    times in hundredths of a second, so ``fps`` is rounded to a whole number of 10 ms; Pillow
    merges identical consecutive frames into one longer frame. All frames are held in memory.
    Raises ``FileExistsError`` if ``path`` exists and ``overwrite`` is false.
    """
    from PIL import Image

    duration_ms = 10 * max(1, round(100.0 / _check_fps(fps)))

    def write(tmp: Path) -> None:
        images = [Image.fromarray(frame, mode="RGB") for frame in _checked_frames(frames)]
        images[0].save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=images[1:],
            duration=duration_ms,
            loop=0,
        )

    return atomic_write(path, write, overwrite)


def read_frames(paths: Iterable[PathLike]) -> Iterator[NDArray[np.uint8]]:
    """The frames of PNG files as uint8 RGB arrays (H, W, 3), read lazily one at a time."""
    from PIL import Image

    for path in paths:
        with Image.open(os.fspath(path)) as image:
            if image.mode not in ("RGB", "L", "P", "RGBA"):
                raise ValueError(f"{path}: expected an 8-bit image; got mode {image.mode}")
            yield np.asarray(image.convert("RGB"))


# --- rendering a sequence -------------------------------------------------------------------


def _png_size(path: Path) -> tuple[int, int] | None:
    """(width, height) of a readable PNG file, None if it is missing, truncated or corrupt."""
    from PIL import Image

    if not path.is_file():
        return None
    try:
        with Image.open(path) as image:
            size = image.size
            image.verify()  # reads every chunk and checks its CRC: catches truncation
    except Exception:  # Pillow raises OSError, SyntaxError, ValueError… for bad files
        return None
    return size if image.format == "PNG" else None


def _existing_frames(frame_dir: Path, n_frames: int) -> dict[int, tuple[int, int]]:
    """Readable frames already in the folder, index → (width, height)."""
    done = {}
    for i in range(n_frames):
        size = _png_size(frame_path(frame_dir, i))
        if size is not None:
            done[i] = size
    return done


#: The record of what made each frame of a sequence, beside the frames.
MANIFEST_NAME = "manifest.json"
#: The lock file in a frame folder that one run holds while it writes there.
LOCK_NAME = ".lock"


def _read_manifest(frame_dir: Path) -> dict[str, str]:
    """Frame index (as text) → the key of what made it; {} if there is no readable manifest."""
    import json

    try:
        data = json.loads((frame_dir / MANIFEST_NAME).read_text(encoding="utf-8"))
        frames = data["frames"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    ok = isinstance(frames, dict) and all(isinstance(v, str) for v in frames.values())
    return frames if ok else {}


def _write_manifest(frame_dir: Path, keys: dict[str, str]) -> None:
    from incandescent._version import __version__

    data = {"format": 1, "written_by": f"incandescent {__version__}", "frames": keys}
    write_json(frame_dir / MANIFEST_NAME, data, overwrite=True)


def _reusable(frame_dir: Path, n_frames: int, key_of: Callable[[int], str], rerender: bool):
    """(frames to keep: index → (width, height), manifest entries to keep); frames made with
    another key are refused unless ``rerender``, which discards every frame."""
    if rerender:
        return {}, {}
    manifest = _read_manifest(frame_dir)
    present = _existing_frames(frame_dir, n_frames)
    stale = [i for i in present if manifest.get(str(i)) != key_of(i)]
    if stale:
        raise FileExistsError(
            f"{frame_dir} holds {len(stale)} frame(s) (first: {FRAME_NAME.format(stale[0])}) "
            "rendered from other input, settings or version; pass --overwrite (overwrite=True) "
            "to render every frame again, or use another output"
        )
    return present, {str(i): manifest[str(i)] for i in present}


def _volume_stream(volumes: VolumeSource, n_frames: int, todo: set[int]) -> Iterator[tuple]:
    """(index, volume) for the indices in ``todo``; an iterable is advanced through every frame."""
    if callable(volumes):
        for i in sorted(todo):
            yield i, volumes(i)
        return
    count = 0
    for i, volume in zip(range(n_frames), volumes, strict=False):  # stop at n
        count += 1
        if i in todo:
            yield i, volume
    if count < n_frames:
        raise ValueError(f"volumes ran out after {count} frame(s); expected n_frames={n_frames}")


def _progress(enabled: bool, total: int, done: int):
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bar = Progress(
        TextColumn("[bold]rendering[/] {task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        disable=not enabled,
    )
    reused = f"({done} already done)" if done else ""
    return bar, bar.add_task(reused, total=total, rate="– frames/s")


def _rate(task) -> str:
    return "– frames/s" if task.speed is None else f"{task.speed:.2f} frames/s"


def _render_missing(
    volumes: VolumeSource,
    n_frames: int,
    frame_dir: Path,
    render_frame: RenderFrame,
    progress: bool,
    frame_key: Callable[[int], str] | None = None,
    rerender: bool = False,
) -> tuple[list[Path], int]:
    """Render the frames not yet in ``frame_dir`` (or made from another key); returns all frame
    paths and how many were rendered. The caller holds the folder's lock."""
    key_of = frame_key or (lambda _: "")
    done, keys = _reusable(frame_dir, n_frames, key_of, rerender)
    todo = set(range(n_frames)) - done.keys()
    sizes = set(done.values())
    shape = None if len(sizes) != 1 else tuple(reversed(sizes.pop())) + (3,)
    bar, task = _progress(progress, len(todo), len(done))
    with bar:
        for i, volume in _volume_stream(volumes, n_frames, todo):
            image = _check_frame(render_frame(volume), i, shape)
            shape = image.shape
            path = frame_path(frame_dir, i)
            write_png(path, image, overwrite=path.exists(), metadata={"frame": str(i)})
            keys[str(i)] = key_of(i)
            _write_manifest(frame_dir, keys)  # after the frame: a frame without entry is redone
            bar.advance(task)
            bar.update(task, rate=_rate(bar.tasks[0]))
    return [frame_path(frame_dir, i) for i in range(n_frames)], len(todo)


def _frame_folder(frame_dir: Path) -> Path:
    """Create the frame folder if needed; refuse anything that is not a writable folder."""
    if frame_dir.exists() and not frame_dir.is_dir():
        raise NotADirectoryError(f"frame folder {frame_dir} exists and is not a folder")
    if not frame_dir.exists():
        check_output(frame_dir, what="frame folder")  # its parent exists and is writable
        frame_dir.mkdir()
    check_output(frame_dir / MANIFEST_NAME, overwrite=True)  # the folder is writable
    return frame_dir


def render_sequence(
    volumes: VolumeSource,
    n_frames: int,
    frame_dir: PathLike,
    render_frame: RenderFrame,
    progress: bool = True,
    frame_key: Callable[[int], str] | None = None,
    overwrite: bool = False,
) -> list[Path]:
    """Render frames 0 … n_frames − 1 to ``frame_dir/frame_00000.png`` …, resuming.

    Parameters
    ----------
    volumes:
        The frames' volumes: an iterable (advanced through every frame, also those skipped, and
        read no further than ``n_frames``) or a function ``index → Volume`` (called only for the
        frames to render).
    n_frames:
        Number of frames.
    frame_dir:
        Folder for the PNG frames; created if missing.
    render_frame:
        ``Volume → uint8 RGB (H, W, 3)``, e.g. ``render`` followed by ``imaging.to_display``
        with a fixed exposure (auto exposure per frame makes a video flicker).
    progress:
        Show a progress bar (frames/s, ETA) on stderr.
    frame_key:
        ``index → str``: what makes frame i (input identity, settings, camera; see
        :func:`incandescent.animation.render_video`), recorded in ``manifest.json`` beside the
        frames. None: every frame has the key "".
    overwrite:
        Render every frame again, whatever is in the folder.

    Returns
    -------
    The paths of all n_frames PNG files, in order.

    Notes
    -----
    A frame is reused only when its PNG is readable and the manifest records the same key for
    it; a missing, truncated or corrupt one is (re)rendered, and one made from another key is
    refused (``FileExistsError``) unless ``overwrite``. Each PNG is written to a temporary file
    first and moved into place, and its manifest entry is written after it, so an interrupted run
    (exception, Ctrl-C, SIGKILL) leaves no partial or unrecorded frame that a rerun would reuse.
    One run at a time writes a folder: a second one fails at once (:class:`OutputError` naming
    the owner's pid). New frames must have the size of the frames kept (``ValueError``).
    """
    n_frames = _check_count(n_frames)
    folder = _frame_folder(Path(os.fspath(frame_dir)))
    with exclusive_lock(folder / LOCK_NAME, str(folder)):
        paths, _ = _render_missing(
            volumes, n_frames, folder, render_frame, progress, frame_key, overwrite
        )
    return paths


# --- animate --------------------------------------------------------------------------------


@dataclass(frozen=True)
class AnimationSummary:
    """What :func:`animate` wrote.

    Attributes
    ----------
    frames: the PNG frame paths, in order. frame_dir: their folder.
    video: the MP4/GIF written, or None when the output is the PNG folder itself.
    rendered, reused: frames rendered by this call, and frames found already done.
    fps: frame rate of the video. seconds: wall time of the call.
    """

    frames: tuple[Path, ...]
    frame_dir: Path
    video: Path | None
    rendered: int
    reused: int
    fps: float
    seconds: float

    def __str__(self) -> str:
        lines = [
            f"frames: {len(self.frames)} PNG in {self.frame_dir}/ "
            f"({self.rendered} rendered, {self.reused} reused) in {self.seconds:.1f} s"
        ]
        if self.video is not None:
            size_kb = self.video.stat().st_size / 1024
            lines.append(
                f"video:  {self.video} ({len(self.frames)} frames at {self.fps:g} fps, "
                f"{size_kb:.0f} KiB)"
            )
        return "\n".join(lines)


def plan_output(
    output: Path, frame_dir: PathLike | None, overwrite: bool
) -> tuple[Path, str | None]:
    """(frame folder, video suffix or None); checks the video destination before any rendering."""
    output = Path(os.fspath(output))
    suffix = output.suffix.lower()
    if output.is_dir() or not suffix:
        if frame_dir is not None and Path(os.fspath(frame_dir)) != output:
            raise ValueError(
                f"output {output} is a folder, so the frames go there; do not also pass "
                f"frame_dir={frame_dir}"
            )
        _probe_lock(output, output)
        return output, None
    if suffix not in VIDEO_SUFFIXES:
        raise ValueError(
            f"{output}: unsupported animation format {output.suffix!r}; expected "
            f"{', '.join(VIDEO_SUFFIXES)} or a folder (no suffix) for PNG frames"
        )
    check_output(output, overwrite, VIDEO_SUFFIXES, "animation")  # now, not after hours
    folder = output.with_name(f"{output.stem}_frames") if frame_dir is None else frame_dir
    _probe_lock(Path(os.fspath(folder)), output)
    return Path(os.fspath(folder)), suffix


def _probe_lock(folder: Path, output: Path) -> None:
    """Fail now, before any reading or rendering, if another run holds the folder's lock (the
    lock itself is taken later, by :func:`animate`)."""
    if (folder / LOCK_NAME).is_file():
        with exclusive_lock(folder / LOCK_NAME, str(output)):
            pass


def _assemble(frames: list[Path], output: Path, suffix: str | None, fps: float, overwrite: bool):
    """The video made from the frame PNGs, or None for a folder output."""
    if suffix == ".mp4":
        return write_mp4(read_frames(frames), output, fps=fps, overwrite=overwrite)
    if suffix == ".gif":
        return write_gif(read_frames(frames), output, fps=fps, overwrite=overwrite)
    return None


def animate(
    volumes: VolumeSource,
    n_frames: int,
    output: PathLike,
    render_frame: RenderFrame,
    fps: float = 25.0,
    frame_dir: PathLike | None = None,
    overwrite: bool = False,
    progress: bool = True,
    frame_key: Callable[[int], str] | None = None,
) -> AnimationSummary:
    """Render a sequence to PNG frames, then assemble ``output`` from them.

    ``output`` ending in ``.mp4`` (H.264, :func:`write_mp4`) or ``.gif`` (:func:`write_gif`) is
    a video assembled from the frames in ``frame_dir`` (default: ``<output stem>_frames/`` next
    to it), which stay there, so a rerun after an interruption renders only the missing frames.
    Any other ``output`` (a folder, or a name without suffix) receives the PNG frames themselves.
    An existing video is refused before any rendering unless ``overwrite``. Frames already in
    the folder are reused when ``frame_key`` matches their manifest entry (see
    :func:`render_sequence`); ``overwrite`` renders them all again. The frame folder is locked
    for the whole call, so a second run on the same output fails at once. With ``progress``, a
    progress bar and then the summary are printed to stderr. Returns the
    :class:`AnimationSummary`.
    """
    start = time.perf_counter()
    n_frames, fps = _check_count(n_frames), _check_fps(fps)
    output = Path(os.fspath(output))
    folder, suffix = plan_output(output, frame_dir, overwrite)
    folder = _frame_folder(folder)
    with exclusive_lock(folder / LOCK_NAME, str(output)):
        frames, rendered = _render_missing(
            volumes, n_frames, folder, render_frame, progress, frame_key, overwrite
        )
        video = _assemble(frames, output, suffix, fps, overwrite)
    seconds = time.perf_counter() - start
    summary = AnimationSummary(
        tuple(frames), folder, video, rendered, n_frames - rendered, fps, seconds
    )
    if progress:
        from rich.console import Console

        Console(stderr=True).print(str(summary), highlight=False, markup=False)
    return summary
