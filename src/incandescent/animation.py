"""Rendering sequences of volumes to video with one camera and one exposure for every frame.

Per-frame auto exposure makes a video flicker, so :func:`fixed_display` chooses one exposure from a
key frame (rendered small) and every frame uses it. Frames are written by
:func:`incandescent.io.video.animate`: resumable PNG frames, then MP4/GIF.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from incandescent.budget import Limits
from incandescent.camera import Camera, default_camera
from incandescent.imaging import DisplaySettings, auto_exposure_scale
from incandescent.io.output import display_pixels
from incandescent.io.video import AnimationSummary, animate
from incandescent.renderer import RenderSettings, render
from incandescent.volume import Volume


def fixed_display(
    key_volume: Volume,
    camera: Camera,
    settings: RenderSettings,
    backend: str | None = "auto",
    base: DisplaySettings | None = None,
) -> DisplaySettings:
    """``base`` with auto exposure replaced by the fixed exposure that auto exposure picks for
    ``key_volume`` (rendered at a quarter of the size); unchanged for paper mode or when ``base``
    already has auto exposure off."""
    base = base or DisplaySettings()
    if settings.brightness == "paper" or not base.auto_exposure:
        return base
    preview = settings.replace(
        width=max(8, settings.width // 4), height=max(8, settings.height // 4)
    )
    image = render(key_volume, camera, preview, backend=backend)
    ev = math.log2(auto_exposure_scale(image.luminance)) + base.exposure_ev
    return DisplaySettings(
        space=base.space,
        white_balance=base.white_balance,
        exposure_ev=ev,
        auto_exposure=False,
        tonemap=base.tonemap,
        gamut=base.gamut,
        bits=base.bits,
    )


def render_video(
    volume_at: Callable[[int], Volume],
    n_frames: int,
    output: str | Path,
    camera: Camera | Callable[[int], Camera],
    settings: RenderSettings,
    display: DisplaySettings,
    backend: str | None = "auto",
    overwrite: bool = False,
    progress: bool = True,
    fps: float = 25.0,
    frame_input: Callable[[int], str] | None = None,
    limits: Limits | None = None,
) -> AnimationSummary:
    """Render frames 0 … n_frames − 1 of ``volume_at`` to ``output`` (.mp4, .gif or a folder),
    seen by ``camera`` — one camera, or a path ``frame ↦ Camera`` (``incandescent.camera.paths``).

    ``frame_input(i)`` describes frame i's input without reading it (a file's path, size and
    modification time; a scene's parameters). It goes, with the package version, the render and
    display settings and the frame's camera, into the key each frame is recorded under
    (:func:`frame_key`): a frame on disk is reused only when its key matches, and ``overwrite``
    renders every frame again. The backend is not part of the key (backends agree to 1e-4).
    ``limits`` bound each frame's render (:mod:`incandescent.budget`).
    """
    camera_at = camera if callable(camera) else (lambda _: camera)
    describe = frame_input or (lambda _: "")

    def key(index: int) -> str:
        return frame_key(describe(index), camera_at(index), settings, display)

    def frame(index: int) -> Any:  # the volume travels with its camera to render_frame
        return volume_at(index), camera_at(index)

    def render_frame(item: Any) -> np.ndarray:
        volume, cam = item
        return display_pixels(render(volume, cam, settings, backend, limits), display)

    return animate(
        frame,
        n_frames,
        output,
        render_frame,
        fps=fps,
        overwrite=overwrite,
        progress=progress,
        frame_key=key,
    )


def frame_key(
    frame_input: str, camera: Camera, settings: RenderSettings, display: DisplaySettings
) -> str:
    """A digest of everything that makes a frame's pixels: input, camera, settings, version."""
    import hashlib

    from incandescent._version import __version__

    text = "\n".join((__version__, frame_input, repr(camera), repr(settings), repr(display)))
    return hashlib.sha256(text.encode()).hexdigest()


def file_identity(path: str | Path) -> str:
    """A file's resolved path, size and modification time (ns): changes when the file does."""
    info = Path(path).stat()
    return f"{Path(path).resolve()} {info.st_size} {info.st_mtime_ns}"


def expand_sequence(pattern: str) -> list[Path]:
    """Files of a sequence: a glob (``cache/*.vdb``) or a ``####`` frame pattern, sorted."""
    import glob

    glob_pattern = pattern.replace("#", "[0-9]") if "#" in pattern else pattern
    paths = sorted(Path(p) for p in glob.glob(glob_pattern))
    if not paths:
        raise FileNotFoundError(f"no files match {pattern!r}")
    return paths


def key_frame(paths: Sequence[Path]) -> int:
    """The middle frame: a reasonable exposure key for a sequence we know nothing else about."""
    return len(paths) // 2


# --- the 2011 paper's plate video ---------------------------------------------------------------


def plate_camera(scene) -> Camera:
    """A fixed three-quarter view of the whole plate box (the same for every frame)."""
    return default_camera(scene.volume(scene.frame(0)).bounds_m, fov_deg=35.0)


def render_plate_video(
    output: str | Path,
    settings: RenderSettings,
    scene=None,
    backend: str | None = "auto",
    overwrite: bool = False,
    progress: bool = True,
) -> AnimationSummary:
    """Render the plate sequence to ``output`` (.mp4, .gif, or a folder of PNG frames), resuming
    from frames already in the frame folder. One exposure for all frames: auto exposure of the
    frame where the gas holds the most heat."""
    from incandescent.scenes.paper import PlateScene

    scene = scene or PlateScene()
    camera = plate_camera(scene)
    frames = list(scene.frames())
    hottest = max(range(len(frames)), key=lambda i: scene.excess_heat(frames[i]))
    display = fixed_display(scene.volume(frames[hottest]), camera, settings, backend)
    return render_video(
        lambda i: scene.volume(frames[i]),
        scene.n_frames,
        output,
        camera,
        settings,
        display,
        backend=backend,
        overwrite=overwrite,
        progress=progress,
        frame_input=lambda i: f"{scene!r} frame {i}",
    )
