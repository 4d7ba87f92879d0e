"""The 2011 paper's plate video: a fixed camera on the plate box, one exposure for every frame."""

from __future__ import annotations

from pathlib import Path

from incandescent.animation.render import fixed_display, render_video
from incandescent.animation.video import AnimationSummary
from incandescent.camera import Camera, default_camera
from incandescent.renderer import Integrator, RenderSettings


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
    integrator: Integrator | None = None,
) -> AnimationSummary:
    """Render the plate sequence to ``output`` (.mp4, .gif, or a folder of PNG frames), resuming
    from frames already in the frame folder. One exposure for all frames: auto exposure of the
    frame where the gas holds the most heat (none for the paper's display-referred sums)."""
    from incandescent.scenes.paper import PlateScene

    scene = scene or PlateScene()
    camera = plate_camera(scene)
    frames = list(scene.frames())
    hottest = max(range(len(frames)), key=lambda i: scene.excess_heat(frames[i]))
    display = fixed_display(
        scene.volume(frames[hottest]), camera, settings, backend, integrator=integrator
    )
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
        integrator=integrator,
    )
