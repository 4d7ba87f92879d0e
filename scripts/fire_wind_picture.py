"""Render a pool fire in four winds side by side: ``docs/fire-wind.png``.

    python scripts/fire_wind_picture.py [--resolution 64] [--frames 72] [--combustion front]
    python scripts/fire_wind_picture.py --combustion mixing --frames 384   # fire-wind-diffusion.png

A 0.5 m, 50 kW methane pool (``pool_fire``) in winds of 0, 1, 2 and 4 m/s along +x (left to
right in the picture), each simulated on the cpu backend (seed 0) and its last frame rendered
as ``fire_gallery.py`` renders the presets (same camera rule and display; one exposure per panel).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from fire_gallery import last_frame
from PIL import Image

from incandescent.simulation.pool import pool_fire

OUT = Path(__file__).resolve().parents[1] / "docs/fire-wind.png"
WINDS_M_S = (0.0, 1.0, 2.0, 4.0)


def panel(wind: float, resolution: int, frames: int, combustion: str) -> np.ndarray:
    settings = pool_fire(0.5, 50.0, changes={"wind_m_s": wind}, combustion=combustion)
    return last_frame(settings, resolution, frames, (192, 256))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--frames", type=int, default=72)
    parser.add_argument("--combustion", default="front", choices=("front", "mixing"))
    a = parser.parse_args()
    panels = [panel(wind, a.resolution, a.frames, a.combustion) for wind in WINDS_M_S]
    out = OUT if a.combustion == "front" else OUT.with_name("fire-wind-diffusion.png")
    Image.fromarray(np.concatenate(panels, axis=1)).save(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
