"""Video files: H.264 MP4 and animated GIF written atomically from uint8 RGB frames, and PNG
frames read back. Rendering sequences (frames, resume, manifest, lock) is
:mod:`incandescent.animation`'s.

MP4 needs the ``imageio-ffmpeg`` package (it bundles an ``ffmpeg`` binary); GIF uses Pillow.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent.io.atomic import atomic_write
from incandescent.io.formats import VIDEO_SUFFIXES

PathLike = str | os.PathLike


# --- checks ---------------------------------------------------------------------------------


def _check_fps(fps: float) -> float:
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.integer, np.floating)):
        raise TypeError(f"fps must be a number; got {type(fps).__name__} {fps!r}")
    if not np.isfinite(fps) or not 0 < fps <= 1000:
        raise ValueError(f"fps must be in (0, 1000] frames per second; got {fps!r}")
    return float(fps)


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


__all__ = ["VIDEO_SUFFIXES", "read_frames", "write_gif", "write_mp4"]
