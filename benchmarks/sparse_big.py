"""A 1024³-domain volume with ~3 % of its voxels hot, rendered sparse at 512² on this machine.

The fireball shell (``scenes.explosion_shell``) is built leaf by leaf, never dense; the render
marches its 9³ bricks. Reports the leaves, the build and render times (first frame: brick pool
and macrocells built; then a warm frame), the peak resident memory of the process, and beside it
what the dense layout would need (its padded (κ, T) grid alone).

Usage: ``python benchmarks/sparse_big.py OUT.json [--size 1024]``.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

from incandescent.renderer import RenderSettings, render
from incandescent.renderer.api import render_estimate
from incandescent.scenes import explosion_shell


def peak_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=1024)
    a = parser.parse_args()
    began = time.perf_counter()
    volume = explosion_shell(a.size)
    built = time.perf_counter() - began
    settings = RenderSettings(width=512, height=512)
    frames = []
    for _ in range(3):
        began = time.perf_counter()
        image = render(volume, None, settings, backend="cpu")
        frames.append((time.perf_counter() - began, image.metadata["seconds"]))
    hot = int((volume.leaf_temperature_K > 0).sum())
    n = a.size
    report = {
        "scene": f"explosion_shell({n}) at 512², layout {image.metadata['layout']}",
        "hot_voxel_fraction": hot / n**3,
        "leaves": len(volume.leaf_coords),
        "leaf_fraction": volume.leaf_fraction,
        "build_s": built,
        "first_render_s": frames[0][0],
        "first_march_s": frames[0][1],
        "warm_render_s": min(f[0] for f in frames[1:]),
        "warm_march_s": min(f[1] for f in frames[1:]),
        "samples": image.metadata["samples"],
        "peak_rss_gib": peak_rss_bytes() / 2**30,
        "sparse_estimate_gib": render_estimate(volume, settings, "cpu")[0] / 2**30,
        "dense_grid_gib": 8.0 * (n + 2) ** 3 / 2**30,
    }
    a.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
