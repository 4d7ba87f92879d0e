"""Render a pool fire burnt three ways side by side: ``docs/pool-diffusion.png``.

    python scripts/pool_fire_picture.py [--resolution 64] [--frames 312]

A 0.5 m, 50 kW methane pool (``pool_fire``) simulated on the cpu backend (seed 0) as the
premixed equivalent (``combustion = "front"``, the air's inertia everywhere), as a diffusion
flame without the low-Mach expansion (``"mixing"``, ``expansion = false``) and as the default
diffusion flame (the ideal gas's inertia and its expansion), each one's last frame rendered as
``fire_gallery.py`` renders the presets (same camera rule and display; one exposure per panel).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from fire_gallery import last_frame
from PIL import Image

from incandescent.simulation.pool import heskestad_height_m, pool_fire

OUT = Path(__file__).resolve().parents[1] / "docs/pool-diffusion.png"
SIZE = (192, 384)  # width, height: the pool's 1.5 × 2 m domain, and its camera's margin


#: The panels, left to right: pool_fire's combustion and changes.
PANELS = (("front", {}), ("mixing", {"expansion": False}), ("mixing", {}))


def panel(combustion: str, changes: dict, resolution: int, frames: int) -> np.ndarray:
    settings = pool_fire(0.5, 50.0, combustion=combustion, changes=changes)
    return last_frame(settings, resolution, frames, SIZE)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument(
        "--frames", type=int, default=312, help="at 24 frames a second: 13 s, three fill times"
    )
    a = parser.parse_args()
    panels = [panel(*p, a.resolution, a.frames) for p in PANELS]
    Image.fromarray(np.concatenate(panels, axis=1)).save(OUT)
    print(f"wrote {OUT} (Heskestad: {heskestad_height_m(50.0, 0.5):.2f} m)")


if __name__ == "__main__":
    main()
