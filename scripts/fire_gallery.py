"""Render the four fire presets side by side: ``docs/fire-presets.png``.

    python scripts/fire_gallery.py [--resolution 48] [--frames 24]

Each preset (candle, torch, campfire, explosion) is simulated on the cpu backend (seed 0) into a
temporary folder (the explosion for half the frames: by 1 s its fireball leaves the top of its
domain) and its last frame rendered with the blackbody of T and soot and the CH/C₂
lines of the reaction zone, auto-exposed per panel (the presets differ in brightness by orders of
magnitude), then the four panels are written side by side.
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

OUT = Path(__file__).resolve().parents[1] / "docs/fire-presets.png"


def panel(name: str, resolution: int, frames: int, size: tuple[int, int]) -> np.ndarray:
    with tempfile.TemporaryDirectory() as tmp:
        last = simulate(preset(name), resolution, frames, tmp, backend="cpu")[-1].path
        spec = VolumeSection(path=last, species={"CH": "CH", "C2": "C2"})
        volume = api.volume_from_section(spec, api.Remap(), layout="dense")
        camera = api.camera_from(volume, fov_deg=35.0, frame_content=False)
        settings = api.RenderSettings(width=size[0], height=size[1])
        image = api.render(volume, camera, settings, "cpu")
        return display_pixels(image, api.DisplaySettings())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=48)
    parser.add_argument("--frames", type=int, default=24)
    a = parser.parse_args()
    frames = {name: a.frames // 2 if name == "explosion" else a.frames for name in PRESETS}
    panels = [panel(name, a.resolution, frames[name], (192, 288)) for name in PRESETS]
    Image.fromarray(np.concatenate(panels, axis=1)).save(OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
