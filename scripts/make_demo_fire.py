"""Make the simulated campfire the ``fire`` demo scene ships (``scenes/data/campfire.npz``), or
the explosion of the ``explosion`` demo (``scenes/data/explosion.npz``).

    python scripts/make_demo_fire.py [--resolution 48] [--frames 30]
    python scripts/make_demo_fire.py --preset explosion --frames 24

Runs ``incandescent.simulate`` on the ``campfire`` preset (seed 0, cpu backend) and keeps the last
frame's temperature, absorption and CH/C₂ fractions as float32 (the velocity is left out: the demo
does not blur), compressed. Simulating takes ~6 s here (with Dr.Jit's kernel cache empty), most
of a first demo's time again and more on a slower machine, so the frame ships with the package;
this script says how it was made and remakes it.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from incandescent.simulation import preset, simulate

DATA = Path(__file__).resolve().parents[1] / "src/incandescent/scenes/data"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=48)
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--preset", default="campfire", choices=("campfire", "explosion"))
    a = parser.parse_args()
    out = DATA / f"{a.preset}.npz"
    with tempfile.TemporaryDirectory() as tmp:
        reports = simulate(preset(a.preset), a.resolution, a.frames, tmp, backend="cpu")
        with np.load(reports[-1].path) as frame:
            keep = {k: frame[k] for k in ("temperature", "absorption", "CH", "C2")}
            placement = {k: frame[k] for k in ("voxel_size_m", "origin_m")}
    grids = {k: v.astype(np.float32) for k, v in keep.items()}
    np.savez_compressed(out, **placement, **grids)
    print(f"wrote {out} ({out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
