"""Cost of spectral mode vs the grey-κ table mode on one scene (march time, medians).

Usage: python benchmarks/spectral_cost.py OUT.json [--size 128] [--resolution 256] [--rounds 5]

Each variant (table mode; spectral with 4, 8, 16 bins, α = 1) is rendered once untimed (kernel
compilation), then all variants are timed in interleaved rounds (DESIGN.md §6).
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from incandescent import scenes
from incandescent.renderer import EmissionAbsorption, RenderSettings, render

VARIANTS = {"table": 0, "4 bins": 4, "8 bins": 8, "16 bins": 16}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args(argv)
    volume = scenes.plume(args.size)
    base = RenderSettings(width=args.resolution, height=args.resolution)
    integrators = {name: EmissionAbsorption(spectral_bins=n) for name, n in VARIANTS.items()}
    times: dict[str, list[float]] = {name: [] for name in VARIANTS}
    for integrator in integrators.values():
        render(volume, settings=base, backend="cpu", integrator=integrator)
    for _ in range(args.rounds):
        for name, integrator in integrators.items():
            image = render(volume, settings=base, backend="cpu", integrator=integrator)
            times[name].append(image.metadata["seconds"])
    table = statistics.median(times["table"])
    report = {
        name: {"median_ms": statistics.median(t) * 1e3, "vs_table": statistics.median(t) / table}
        for name, t in times.items()
    }
    for name, row in report.items():
        print(f"{name:>8}: {row['median_ms']:8.1f} ms  ({row['vs_table']:.2f}× table mode)")
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    return report


if __name__ == "__main__":
    main()
