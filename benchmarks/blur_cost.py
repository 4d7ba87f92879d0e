"""What motion blur costs: the same frame with and without a shutter, side by side.

The 256³ plume (1 m box) rising at up to 3 m/s (v_y ∝ T/T_max, plus a swirl of 1 m/s), 512²,
2×2 rays per pixel (4 time samples per pixel with the shutter), shutter (−0.25, 0.25) frames at
24 fps (a 180° shutter: the gas moves up to 3.8 voxels); cases timed in interleaved rounds,
medians of the march time, and the samples each takes (the blurred march samples the dilated
macrocells and reads the velocity grid first).

Usage: ``python benchmarks/blur_cost.py OUT.json [--rounds 5] [--size 256]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import numpy as np

from incandescent.camera import default_camera
from incandescent.renderer import RenderSettings, render
from incandescent.scenes import plume


def rising(volume, speed_m_s: float = 3.0, swirl_m_s: float = 1.0):
    """The volume with a velocity grid: up ∝ T/T_max, and a swirl about the vertical axis."""
    n = volume.shape[0]
    x, _, z = np.meshgrid(
        *(np.linspace(-1, 1, s) for s in volume.shape), indexing="ij", sparse=True
    )
    velocity = np.zeros(volume.shape + (3,), dtype=np.float32)
    velocity[..., 1] = speed_m_s * volume.temperature_K / volume.max_temperature_K
    velocity[..., 0] = -swirl_m_s * z * np.ones((1, n, 1))
    velocity[..., 2] = swirl_m_s * x * np.ones((1, n, 1))
    return volume.with_velocity(velocity)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--size", type=int, default=256)
    a = parser.parse_args()
    volume = rising(plume(a.size))
    camera = default_camera(volume.bounds_m)
    sharp = RenderSettings(width=512, height=512, supersample=2)
    cases = {"no blur, 2×2 rays": sharp, "blur, 2×2 rays": sharp.replace(shutter=(-0.25, 0.25))}
    runs: dict[str, list] = {k: [] for k in cases}
    for settings in cases.values():
        render(volume, camera, settings, backend="cpu")
    for _ in range(a.rounds):
        for key, settings in cases.items():
            image = render(volume, camera, settings, backend="cpu")
            runs[key].append((image.metadata["seconds"], image.metadata["samples"]))
    report = {
        key: {"ms_per_frame": statistics.median(r[0] for r in rows) * 1e3, "samples": rows[0][1]}
        for key, rows in runs.items()
    }
    a.out.write_text(json.dumps({"rounds": a.rounds, "size": a.size, "cases": report}, indent=2))
    for key, r in report.items():
        print(f"{key:20s} {r['ms_per_frame']:8.1f} ms  {r['samples']:>12,d} samples")


if __name__ == "__main__":
    main()
