"""Render the fire presets side by side: ``docs/fire-presets.png``.

    python scripts/fire_gallery.py [--resolution 48] [--frames 24] [--pool-seconds 4]

Each preset (candle, torch, campfire, explosion) and three methane pool fires (D = 0.2, 0.5 and
1 m at 20, 100 and 400 kW; diffusion flames, ``pool_fire``'s default) is simulated on the cpu
backend (seed 0) into a temporary folder (the explosion for half the frames: by 1 s its
fireball leaves the top of its domain; the pools for ``--pool-seconds``: their fuel takes
seconds to fill the pool's cells, ``benchmarks/fire_validation.py``'s fill time) and its last
frame rendered with the blackbody of T and soot and the CH/C₂ lines of the reaction zone,
auto-exposed per panel (the presets differ in brightness by orders of magnitude), then the
panels are written side by side.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from incandescent import api
from incandescent.config import VolumeSection
from incandescent.imaging import display_pixels
from incandescent.simulation import PRESETS, preset, simulate
from incandescent.simulation.pool import pool_fire

OUT = Path(__file__).resolve().parents[1] / "docs/fire-presets.png"


POOLS = {"pool 0.2 m": (0.2, 20.0), "pool 0.5 m": (0.5, 100.0), "pool 1 m": (1.0, 400.0)}


def settings_of(name: str):
    return pool_fire(*POOLS[name]) if name in POOLS else preset(name)


def last_frame(settings, resolution: int, frames: int, size: tuple[int, int]) -> np.ndarray:
    """The display pixels of the last of ``frames`` frames of ``settings`` simulated at
    ``resolution``: T, soot and the CH/C₂ lines, auto-exposed, the volume's own camera."""
    with tempfile.TemporaryDirectory() as tmp:
        last = simulate(settings, resolution, frames, tmp, backend="cpu")[-1].path
        spec = VolumeSection(path=last, species={"CH": "CH", "C2": "C2"})
        volume = api.volume_from_section(spec, api.Remap(), layout="dense")
        camera = api.camera_from(volume, fov_deg=35.0, frame_content=False)
        settings = api.RenderSettings(width=size[0], height=size[1])
        image = api.render(volume, camera, settings, "cpu")
        return display_pixels(image, api.DisplaySettings())


def panel(name: str, resolution: int, frames: int, size: tuple[int, int]) -> np.ndarray:
    return last_frame(settings_of(name), resolution, frames, size)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=48)
    parser.add_argument("--frames", type=int, default=24)
    parser.add_argument("--pool-seconds", type=float, default=4.0)
    a = parser.parse_args()
    names = [*PRESETS, *POOLS]
    frames = {name: a.frames // 2 if name == "explosion" else a.frames for name in names}
    for name in POOLS:
        frames[name] = round(a.pool_seconds * settings_of(name).fps)
    panels = [panel(name, a.resolution, frames[name], (192, 288)) for name in names]
    Image.fromarray(np.concatenate(panels, axis=1)).save(OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
