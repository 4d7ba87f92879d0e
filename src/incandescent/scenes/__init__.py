"""Built-in scenes, and the one registry that ``demo``, ``bench`` and the galleries read.

Modules: :mod:`~incandescent.scenes.synthetic` (plume, soot plume, sparse flame),
:mod:`~incandescent.scenes.species` (coloured, sooty and clean flames),
:mod:`~incandescent.scenes.paper` (the 2011 paper's soot sphere and moving-plate sequence).
Scenes only build volumes; rendering them is the caller's.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from incandescent.camera import Camera
from incandescent.imaging import DisplaySettings
from incandescent.scenes import species
from incandescent.scenes.synthetic import (
    AMBIENT_K,
    explosion_shell,
    plume,
    plume_temperature,
    simulated_campfire,
    simulated_explosion,
    soot_plume,
    sparse_flame,
)
from incandescent.volume import Volume
from incandescent.volume.sparse import SparseVolume

__all__ = [
    "AMBIENT_K",
    "COLOURED_FLAME_NAMES",
    "explosion_shell",
    "SCENES",
    "Scene",
    "plume",
    "plume_temperature",
    "scene",
    "soot_plume",
    "sparse_flame",
]

#: The coloured flames' names, one per emitting species (``scenes.species.COLOURED_FLAMES``).
COLOURED_FLAME_NAMES = tuple(flame.name for flame in species.COLOURED_FLAMES)


@dataclass(frozen=True)
class Scene:
    """A named built-in scene: ``build(n)`` makes its n³-ish volume.

    ``camera()`` and ``display`` are the scene's own view and display (None: the default
    three-quarter camera and display); ``label`` describes it with ``{n}`` for the size."""

    name: str
    label: str
    build: Callable[[int], Volume | SparseVolume]
    default_size: int = 96
    camera: Callable[[], Camera] | None = None
    display: DisplaySettings | None = None
    #: how its smoke is lit, as a scene file says it (``[volume] albedo``/``phase_g`` and the
    #: ``[[light]]`` tables, ``config.schema``): None, the gas only emits and absorbs
    lighting: Mapping | None = None


def _sphere(n: int) -> Volume:
    from incandescent.scenes.paper import paper_sphere  # the plate's solver stays unimported

    return paper_sphere(n)


#: Line colours lie far outside sRGB: the species flames are shown gamut-clipped.
_FLAME_DISPLAY = DisplaySettings(gamut="clip")


def _flame(name: str, build: Callable[[int], Volume], label: str) -> Scene:
    return Scene(name, label, build, 96, species.flame_camera, _FLAME_DISPLAY)


#: The lit demos' smoke, our choice for a picture: albedo 0.35 (soot aggregates scatter less
#: than they absorb; large ones reach ~0.2–0.4 in Rayleigh–Debye–Gans theory, Sorensen 2001,
#: Aerosol Sci. Technol. 35:648), forward scattering g = 0.3; lit by the fire itself, a dim
#: bluish sky (2000 cd/m²) and, for the explosion, a sun.
_SMOKE = {"albedo": 0.35, "phase_g": 0.3}
_SKY = {"type": "environment", "luminance_cd_m2": 2000.0, "temperature_K": 9000.0}
_FIRE_LIGHT = {"type": "emission"}
_SUN = {"type": "directional", "direction": (0.5, 0.8, 0.3), "illuminance_lux": 2e4}

SCENES: dict[str, Scene] = {
    "plume": Scene("plume", "plume {n}³", plume, 128),
    "sparse": Scene("sparse", "small flame in an empty {n}³ box", sparse_flame, 128),
    "soot": Scene("soot", "plume {n}³ with a graded κ grid", soot_plume, 128),
    "fire": Scene(
        "fire", "a simulated campfire (Nguyen et al. 2002), 48 cells", simulated_campfire, 48
    ),
    "campfire": Scene(
        "campfire",
        "the simulated campfire, its smoke lit by its flames and the sky",
        simulated_campfire,
        48,
        lighting={**_SMOKE, "lights": [_FIRE_LIGHT, _SKY]},
    ),
    "explosion": Scene(
        "explosion",
        "a simulated explosion (1 s), its smoke lit by its fireball, a sky and a sun",
        simulated_explosion,
        48,
        lighting={**_SMOKE, "lights": [_FIRE_LIGHT, _SKY, _SUN]},
    ),
    "shell": Scene("shell", "fireball shell in an empty {n}³ box (sparse)", explosion_shell, 256),
    "sphere": Scene("sphere", "the 2011 paper's soot sphere {n}³", _sphere, 64),
    **{
        name: _flame(name, functools.partial(species.coloured_flame, name), f"{name} flame {{n}}³")
        for name in COLOURED_FLAME_NAMES
    },
    "sooty": _flame("sooty", species.sooty_flame, "sooty flame {n}³"),
    "clean": _flame("clean", species.clean_flame, "clean flame {n}³"),
}


def scene(name: str) -> Scene:
    """The registered scene ``name``; the error lists the names."""
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}; expected one of: {', '.join(SCENES)}")
    return SCENES[name]
