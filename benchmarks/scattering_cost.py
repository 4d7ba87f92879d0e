"""Cost of single scattering of a sun vs emission–absorption on the same frame (march time,
medians of interleaved rounds; DESIGN.md §6). Issue 27's target: single scattering ≤ 4× the
emission-only render.

Usage: python benchmarks/scattering_cost.py OUT.json [--resolution 256] [--rounds 5] [--backend cpu]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

from incandescent.renderer import EmissionAbsorption, RenderSettings, render
from incandescent.renderer.integrators import SingleScattering
from incandescent.renderer.lights import DirectionalLight
from incandescent.scenes import SCENES


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--backend", default="cpu", help="cpu or cuda")
    args = parser.parse_args(argv)
    scene = SCENES["fire"]
    dark = scene.build(None)
    lit = dark.with_scattering(albedo=0.7, phase_g=0.3)
    camera = scene.camera() if scene.camera else None
    s = RenderSettings(width=args.resolution, height=args.resolution)
    sun = DirectionalLight((0.6, 0.7, 0.4), 1e4)
    variants = {
        "emission_absorption": (dark, EmissionAbsorption()),
        "single_scattering": (lit, SingleScattering(lights=(sun,))),
        "single_scattering_march": (lit, SingleScattering(lights=(sun,), shadows="march")),
    }
    times: dict[str, list[float]] = {name: [] for name in variants}
    for volume, integrator in variants.values():  # compile
        render(volume, camera, s, args.backend, integrator=integrator)
    for _ in range(args.rounds):
        for name, (volume, integrator) in variants.items():
            image = render(volume, camera, s, args.backend, integrator=integrator)
            times[name].append(image.metadata["seconds"])
    medians = {name: statistics.median(t) for name, t in times.items()}
    report = {
        "scene": f"fire demo {dark.shape}, {args.resolution}² px, albedo 0.7, one sun",
        "backend": args.backend,
        "median_ms": {k: v * 1e3 for k, v in medians.items()},
        "single_over_emission": medians["single_scattering"] / medians["emission_absorption"],
        "march_over_emission": medians["single_scattering_march"] / medians["emission_absorption"],
    }
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2))
    return report


if __name__ == "__main__":
    main()
