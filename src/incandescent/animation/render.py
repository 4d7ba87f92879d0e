"""Rendering a sequence: one exposure for all frames, and the job that describes a sequence.

Per-frame auto exposure makes a video flicker, so :func:`fixed_display` chooses one exposure from
a key frame (rendered small) and every frame uses it. :class:`SequenceJob` is a sequence of
volume files to render — each frame's ``[volume]`` section, the remap, the camera (or a camera
path), render and display settings, the integrator, the backend and the limits; it reads a frame
(:meth:`SequenceJob.volume_at`), keys it (:meth:`SequenceJob.key`), and builds the
:class:`FrameTask` a cluster worker renders (:meth:`SequenceJob.task`: the one place a task is
made), so ``animate``, the fire simulation's renders and the paper's plate share one pipeline.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from incandescent.animation.sequence import (
    Distribute,
    file_identity,
    frame_key,
    frame_path,
)
from incandescent.animation.video import AnimationSummary, animate
from incandescent.budget import Limits
from incandescent.camera import Camera
from incandescent.config.assemble import volume_from_section
from incandescent.imaging import DisplaySettings, auto_exposure_scale
from incandescent.imaging.pipeline import display_pixels
from incandescent.renderer import Integrator, RenderSettings, render
from incandescent.volume import Remap, Volume

if TYPE_CHECKING:
    from incandescent.config import Scene, VolumeSection
    from incandescent.volume.sparse import SparseVolume

CameraPath = Camera | Callable[[int], Camera]


def fixed_display(
    key_volume: Volume | SparseVolume,
    camera: Camera,
    settings: RenderSettings,
    backend: str | None = "auto",
    base: DisplaySettings | None = None,
    integrator: Integrator | None = None,
) -> DisplaySettings:
    """``base`` with auto exposure replaced by the fixed exposure that auto exposure picks for
    ``key_volume`` (rendered at a quarter of the size); unchanged for a display-referred
    integrator (no exposure) or when ``base`` already has auto exposure off."""
    base = base or DisplaySettings()
    if (integrator is not None and integrator.display_referred) or not base.auto_exposure:
        return base
    preview = settings.replace(
        width=max(8, settings.width // 4), height=max(8, settings.height // 4)
    )
    image = render(key_volume, camera, preview, backend=backend, integrator=integrator)
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
    volume_at: Callable[[int], Volume | SparseVolume],
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
    distribute: Distribute | None = None,
    integrator: Integrator | None = None,
) -> AnimationSummary:
    """Render frames 0 … n_frames − 1 of ``volume_at`` to ``output`` (.mp4, .gif or a folder),
    seen by ``camera`` — one camera, or a path ``frame ↦ Camera`` (``incandescent.camera.paths``)
    — with ``integrator`` (default: emission–absorption).

    ``frame_input(i)`` describes frame i's input without reading it (a file's path, size and
    modification time; a scene's parameters). It goes, with the package version, the render and
    display settings and the frame's camera, into the key each frame is recorded under
    (:func:`frame_key`): a frame on disk is reused only when its key matches, and ``overwrite``
    renders every frame again. The backend is not part of the key (backends agree to 1e-4).
    ``limits`` bound each frame's render (:mod:`incandescent.budget`). ``distribute``: render
    the missing frames on a cluster instead (``incandescent.cluster``; then ``volume_at`` is not
    called for them).
    """
    camera_at = camera if callable(camera) else (lambda _: camera)
    describe = frame_input or (lambda _: "")

    def key(index: int) -> str:
        return frame_key(describe(index), camera_at(index), settings, display, integrator)

    def frame(index: int) -> Any:  # the volume travels with its camera to render_frame
        return volume_at(index), camera_at(index)

    def render_frame(item: Any) -> np.ndarray:
        volume, cam = item
        image = render(volume, cam, settings, backend, limits, integrator=integrator)
        return display_pixels(image, display)

    return animate(
        frame,
        n_frames,
        output,
        render_frame,
        fps=fps,
        overwrite=overwrite,
        progress=progress,
        frame_key=key,
        distribute=distribute,
    )


@dataclass(frozen=True)
class FrameTask:
    """Everything a worker needs to make frame ``index`` (all small and picklable); made by
    :meth:`SequenceJob.task`, rendered by ``incandescent.cluster.render_task``."""

    index: int
    volume: VolumeSection  # the file and how to read it
    remap: Remap
    layout: str
    blur_fps: float | None
    camera: Camera
    settings: RenderSettings
    display: DisplaySettings
    backend: str
    png: Path
    threads: int | None = None  # Dr.Jit threads on the worker (None: its default)
    integrator: Integrator | None = None  # how light is transported (None: the default)


@dataclass(frozen=True)
class SequenceJob:
    """A sequence of volume files to render with one camera (or path) and one display.

    ``volumes``: frame i's ``[volume]`` section (its path and how to read it); ``layout``: the
    device layout of every frame (None: ``settings.layout``); ``label``: what, besides its file's
    identity, describes a frame's input in its key (:func:`frame_key`) — the scene's volume
    section and remap for ``animate``."""

    volumes: tuple[VolumeSection, ...]
    camera: CameraPath
    settings: RenderSettings
    display: DisplaySettings = field(default_factory=DisplaySettings)
    remap: Remap = field(default_factory=Remap)
    integrator: Integrator | None = None
    backend: str = "auto"
    limits: Limits | None = None
    layout: str | None = None
    label: str = ""

    @property
    def n_frames(self) -> int:
        return len(self.volumes)

    @property
    def blur_fps(self) -> float | None:
        """The frame rate motion blur reads velocities at (None: no shutter)."""
        return self.settings.fps if self.settings.shutter is not None else None

    def camera_at(self, index: int) -> Camera:
        return self.camera(index) if callable(self.camera) else self.camera

    def volume_at(self, index: int) -> Volume | SparseVolume:
        """Frame ``index``'s volume, read as its section says."""
        layout = self.layout or self.settings.layout
        spec = self.volumes[index]
        return volume_from_section(spec, self.remap, self.limits, layout, self.blur_fps)

    def frame_input(self, index: int) -> str:
        """Frame ``index``'s input without reading it: its file's identity and the label."""
        return f"{file_identity(self.volumes[index].path)} {self.label}"

    def key(self, index: int) -> str:
        """The key frame ``index`` is recorded under in the manifest (:func:`frame_key`)."""
        return frame_key(self.frame_input(index), self.camera_at(index), self.settings,
                         self.display, self.integrator)  # fmt: skip

    def task(self, index: int, frame_dir: Path, threads: int | None = None) -> FrameTask:
        """The cluster task of frame ``index``, writing its PNG into ``frame_dir``."""
        layout = self.layout or self.settings.layout
        return FrameTask(index, self.volumes[index], self.remap, layout, self.blur_fps,
                         self.camera_at(index), self.settings, self.display, self.backend,
                         frame_path(frame_dir, index), threads, self.integrator)  # fmt: skip

    def with_fixed_exposure(self, key: int, camera: Camera | None = None) -> SequenceJob:
        """This job with the exposure that auto exposure picks for frame ``key`` (seen by
        ``camera``, default the frame's own) fixed for every frame (:func:`fixed_display`)."""
        seen = camera or self.camera_at(key)
        display = fixed_display(self.volume_at(key), seen, self.settings, self.backend,
                                self.display, self.integrator)  # fmt: skip
        return replace(self, display=display)

    def render(
        self,
        output: str | Path,
        *,
        overwrite: bool = False,
        progress: bool = True,
        fps: float = 25.0,
        distribute: Distribute | None = None,
    ) -> AnimationSummary:
        """Render the sequence to ``output`` (:func:`render_video`), resuming."""
        return render_video(self.volume_at, self.n_frames, output, self.camera, self.settings,
                            self.display, backend=self.backend, overwrite=overwrite,
                            progress=progress, fps=fps, frame_input=self.frame_input,
                            limits=self.limits, distribute=distribute,
                            integrator=self.integrator)  # fmt: skip


#: What a video's frames are unless the scene or a flag says otherwise (``animate``): frame size
#: and frame rate (also the rate the shutter's velocities are read at).
VIDEO_RENDER = {"width": 640, "height": 360, "fps": 25.0}


def video_scene(scene: Scene) -> Scene:
    """``scene`` with :data:`VIDEO_RENDER`'s values for the ``[render]`` keys it does not set."""
    unset = {k: v for k, v in VIDEO_RENDER.items() if k not in scene.render.model_fields_set}
    return scene.model_copy(update={"render": scene.render.model_copy(update=unset)})


def sequence_job(
    scene: Scene, paths: list[Path], limits: Limits | None = None, orbit_deg: float = 0.0
) -> SequenceJob:
    """The job of rendering ``paths`` as ``scene`` says (its volume section read for every file,
    remap, camera, render, integrator, display and backend): the camera frames the first file's
    box (orbiting ``orbit_deg`` about the vertical over the sequence), and the exposure is auto
    exposure of the middle frame, fixed for all."""
    from incandescent.api import camera_from
    from incandescent.camera import paths as camera_paths

    specs = tuple(scene.volume.model_copy(update={"path": p}) for p in paths)
    # a provisional camera: the real one frames the first frame, which the job reads
    job = SequenceJob(specs, Camera(eye=(0.0, 0.0, 1.0)), scene.render_settings(),
                      scene.display_settings(), scene.remap(), scene.render_integrator(),
                      scene.output.backend, limits,
                      label=f"{scene.volume!r} {scene.remap()!r}")  # fmt: skip
    given = scene.camera.given()
    eye, target = given.pop("eye", None), given.pop("target", None)
    fov = float(given.pop("fov_deg", 40.0))  # type: ignore[arg-type]
    camera = camera_from(job.volume_at(0), eye, target, fov, frame_content=False)
    camera = camera.replace(**given) if given else camera
    path = camera_paths.orbit(camera, len(paths), orbit_deg) if orbit_deg else camera
    return replace(job, camera=path).with_fixed_exposure(len(paths) // 2, camera)
