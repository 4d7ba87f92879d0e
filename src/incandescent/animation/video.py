"""Videos from frame sequences: render the missing frames (:mod:`.sequence`), then assemble the
MP4/GIF (:mod:`incandescent.io.video`) through a temporary file moved into place."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from incandescent.animation.sequence import (
    LOCK_NAME,
    Distribute,
    PathLike,
    RenderFrame,
    VolumeSource,
    _check_count,
    _frame_folder,
    _render_missing,
    frame_path,
    plan_output,
)
from incandescent.io.atomic import exclusive_lock
from incandescent.io.video import _check_fps, read_frames, write_gif, write_mp4


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


def _assemble(frames: list[Path], output: Path, suffix: str | None, fps: float, overwrite: bool):
    """The video made from the frame PNGs, or None for a folder output."""
    if suffix == ".mp4":
        return write_mp4(read_frames(frames), output, fps=fps, overwrite=overwrite)
    if suffix == ".gif":
        return write_gif(read_frames(frames), output, fps=fps, overwrite=overwrite)
    return None


def assemble_video(frame_dir: PathLike, n_frames: int, output: PathLike, fps: float,
                   overwrite: bool = False) -> Path | None:  # fmt: skip
    """The video ``output`` (.mp4/.gif) made from frames 0 … n_frames − 1 already in
    ``frame_dir`` (rendered elsewhere and recorded with :func:`record_frames`); the folder is
    locked meanwhile. None for a folder output."""
    output = Path(os.fspath(output))
    folder, suffix = plan_output(output, frame_dir, overwrite)
    frames = [frame_path(folder, i) for i in range(_check_count(n_frames))]
    with exclusive_lock(folder / LOCK_NAME, str(output)):
        return _assemble(frames, output, suffix, _check_fps(fps), overwrite)


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
    distribute: Distribute | None = None,
) -> AnimationSummary:
    """Render a sequence to PNG frames, then assemble ``output`` from them.

    ``output`` ending in ``.mp4`` (H.264, :func:`write_mp4`) or ``.gif`` (:func:`write_gif`) is
    a video assembled from the frames in ``frame_dir`` (default: ``<output stem>_frames/`` next
    to it), which stay there, so a rerun after an interruption renders only the missing frames.
    Any other ``output`` (a folder, or a name without suffix) receives the PNG frames themselves.
    An existing video is refused before any rendering unless ``overwrite``. Frames already in
    the folder are reused when ``frame_key`` matches their manifest entry (see
    :func:`render_sequence`); ``overwrite`` renders them all again. ``distribute`` renders the
    missing frames elsewhere (``incandescent.cluster``). The frame folder is locked
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
            volumes, n_frames, folder, render_frame, progress, frame_key, overwrite, distribute
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
