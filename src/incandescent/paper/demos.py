"""The paper's demo scenes rendered end to end: the soot sphere image and the 250-frame plate video,
in paper or physical brightness. The CLI's ``incandescent demo sphere|plate`` calls these.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from incandescent.camera import Camera, default_camera
from incandescent.imaging import DisplaySettings, auto_exposure_scale
from incandescent.io.output import display_pixels
from incandescent.io.video import AnimationSummary, animate
from incandescent.paper.scenes import PlateScene
from incandescent.render import HDRImage, RenderSettings, render
from incandescent.volume import Volume


def plate_camera(scene: PlateScene) -> Camera:
    """A fixed three-quarter view of the whole plate box (the same for every frame)."""
    return default_camera(scene.volume(scene.frame(0)).bounds_m, fov_deg=35.0)


def fixed_display(
    scene: PlateScene, camera: Camera, settings: RenderSettings, backend: str
) -> DisplaySettings:
    """Display settings with one exposure for the whole video (auto exposure per frame flickers):
    the auto exposure of the frame where the gas holds the most heat, rendered small."""
    if settings.brightness == "paper":
        return DisplaySettings()
    frames = list(scene.frames())
    hottest = max(range(len(frames)), key=lambda i: scene.excess_heat(frames[i]))
    preview = settings.replace(
        width=max(8, settings.width // 4), height=max(8, settings.height // 4)
    )
    image = render(scene.volume(frames[hottest]), camera, preview, backend=backend)
    ev = math.log2(auto_exposure_scale(image.luminance))
    return DisplaySettings(auto_exposure=False, exposure_ev=ev)


def render_plate_video(
    output: str | Path,
    settings: RenderSettings,
    scene: PlateScene | None = None,
    backend: str | None = "auto",
    overwrite: bool = False,
    progress: bool = True,
) -> AnimationSummary:
    """Render the plate sequence to ``output`` (.mp4, .gif, or a folder of PNG frames), resuming
    from frames already in the frame folder."""
    scene = scene or PlateScene()
    camera = plate_camera(scene)
    display = fixed_display(scene, camera, settings, backend or "auto")

    def render_frame(volume: Volume) -> np.ndarray:
        return display_pixels(render(volume, camera, settings, backend=backend), display)

    def volume_at(index: int) -> Volume:
        return scene.volume(scene.frame(index))

    return animate(
        volume_at, scene.n_frames, output, render_frame, overwrite=overwrite, progress=progress
    )


def render_sphere(settings: RenderSettings, n: int = 64, backend: str | None = "auto") -> HDRImage:
    """The paper's first blackbody scene: a ~3000 K sphere of transparent soot."""
    from incandescent.paper.scenes import paper_sphere

    return render(paper_sphere(n), settings=settings, backend=backend)
