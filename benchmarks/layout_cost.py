"""Dense vs sparse layout side by side: march ms, whole render() warm and cold, grid bytes.

Scenes at 512², default camera framing the box: the 256³ plume (dense gas, ~40 % of the leaves
occupied) and the 256³ sparse flame (a small flame in an empty box). Every case is rendered once
untimed (compilation, layouts), then the cases are timed in interleaved rounds; medians.

Usage: ``python benchmarks/layout_cost.py OUT.json [--rounds 7] [--size 256]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from incandescent.camera import default_camera
from incandescent.renderer import RenderSettings, render
from incandescent.renderer.api import render_estimate
from incandescent.renderer.layout import _sparse_of
from incandescent.scenes import SCENES


def frame(volume, camera, settings, cold=False) -> tuple[float, float, int]:
    """(march s, whole render() s, samples); ``cold``: a new Volume of the same grids."""
    volume = volume.replace() if cold else volume
    began = time.perf_counter()
    image = render(volume, camera, settings, backend="cpu")
    total = time.perf_counter() - began
    return image.metadata["seconds"], total, image.metadata["samples"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--size", type=int, default=256)
    a = parser.parse_args()
    cases = {}
    for name in ("plume", "sparse"):
        volume = SCENES[name].build(a.size)
        camera = default_camera(volume.bounds_m)
        for layout in ("dense", "sparse"):
            settings = RenderSettings(width=512, height=512, layout=layout)
            cases[f"{name} {layout}"] = (volume, camera, settings, False)
            cases[f"{name} {layout} cold"] = (volume, camera, settings, True)
    runs: dict[str, list] = {k: [] for k in cases}
    for case in cases.values():
        frame(*case)
    for _ in range(a.rounds):
        for key, case in cases.items():
            runs[key].append(frame(*case))
    report = {}
    for key, (volume, _, settings, _) in cases.items():
        shown = _sparse_of(volume) if settings.layout == "sparse" else volume
        report[key] = {
            "ms_per_frame": statistics.median(r[0] for r in runs[key]) * 1e3,
            "total_ms": statistics.median(r[1] for r in runs[key]) * 1e3,
            "samples": runs[key][0][2],
            "grid_bytes_estimate": render_estimate(shown, settings, "cpu")[0],
            "leaf_fraction": _sparse_of(volume).leaf_fraction,
        }
    a.out.write_text(json.dumps({"rounds": a.rounds, "size": a.size, "cases": report}, indent=2))
    for key, r in report.items():
        print(
            f"{key:19s} {r['ms_per_frame']:7.1f} ms  {r['total_ms']:7.1f} ms total  "
            f"{r['samples']:>10,d} samples  "
            f"{r['grid_bytes_estimate'] / 2**20:7.1f} MiB  leaves {r['leaf_fraction']:.3f}"
        )


if __name__ == "__main__":
    main()
