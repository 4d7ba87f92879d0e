"""Scene files and dicts → a validated :class:`Scene` (pydantic, unknown keys are errors).

>>> from incandescent.config import load_scene
>>> scene = load_scene("examples/flame.toml", overrides={"render": {"width": 64}})  # doctest: +SKIP
>>> scene.render_settings().width  # doctest: +SKIP
64
"""

from incandescent.config.load import SceneError, load_scene, merge_overrides, scene_from_dict
from incandescent.config.schema import (
    CameraSection,
    DisplaySection,
    GridNames,
    OutputSection,
    RenderSection,
    Scene,
    TemperatureMap,
    VolumeSection,
)

__all__ = [
    "CameraSection",
    "DisplaySection",
    "GridNames",
    "OutputSection",
    "RenderSection",
    "Scene",
    "SceneError",
    "TemperatureMap",
    "VolumeSection",
    "load_scene",
    "merge_overrides",
    "scene_from_dict",
]
