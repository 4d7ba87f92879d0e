"""The paper's demo scenes rendered end to end: the soot sphere image and the 250-frame plate video,
in paper or physical brightness. The CLI's ``incandescent demo sphere|plate`` calls these.
"""

from __future__ import annotations

from pathlib import Path

from incandescent.animation import fixed_display, render_video
from incandescent.camera import Camera, default_camera
from incandescent.io.video import AnimationSummary
from incandescent.paper.scenes import PlateScene
from incandescent.render import HDRImage, RenderSettings, render


def plate_camera(scene: PlateScene) -> Camera:
    """A fixed three-quarter view of the whole plate box (the same for every frame)."""
    return default_camera(scene.volume(scene.frame(0)).bounds_m, fov_deg=35.0)


def render_plate_video(
    output: str | Path,
    settings: RenderSettings,
    scene: PlateScene | None = None,
    backend: str | None = "auto",
    overwrite: bool = False,
    progress: bool = True,
) -> AnimationSummary:
    """Render the plate sequence to ``output`` (.mp4, .gif, or a folder of PNG frames), resuming
    from frames already in the frame folder. One exposure for all frames: auto exposure of the
    frame where the gas holds the most heat."""
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


def render_sphere(settings: RenderSettings, n: int = 64, backend: str | None = "auto") -> HDRImage:
    """The paper's first blackbody scene: a ~3000 K sphere of transparent soot."""
    from incandescent.paper.scenes import paper_sphere

    return render(paper_sphere(n), settings=settings, backend=backend)
