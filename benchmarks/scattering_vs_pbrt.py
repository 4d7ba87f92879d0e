"""Our Monte Carlo scattering against pbrt-v4's volpath at equal noise, on pbrt's own reference
scenes (``tests/data/pbrt_d1``, ``pbrt_d2``; issue 27's target: ≥ 100× on the fire-in-smoke
scene, D2 — a cloud lit only by its glowing core).

Both renderers are unbiased (their agreement is the tests' business: ``tests/renderer/
test_multiple_scattering.py``), so the error against a converged image is their noise. pbrt's
was measured on these 2 cores against its 8192-spp render and fitted as k/√spp
(``noise.json``: k per pixel and per 8×8-pixel block, seconds per spp). Ours: the RMS relative
difference of two renders with different seeds, / √2, over the same pixels (more than 1 % of
the peak), at one setting; time to a noise e is then t·(σ/e)² for both (noise ∝ 1/√work).
Times are medians of interleaved rounds, march only (no compilation).

Usage: python benchmarks/scattering_vs_pbrt.py OUT.json [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import numpy as np

from incandescent import RenderSettings, render
from incandescent.renderer.integrators import MultipleScattering, SingleScattering
from incandescent.renderer.lights import DirectionalLight, EmissionLight
from incandescent.scenes import pbrt as pbrt_scenes

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"


def _noise(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(per-pixel, per-8×8-block) RMS relative noise of one render from two seeds."""
    mask = a > 0.01 * a.max()
    pixel = np.sqrt(np.mean(((b[mask] - a[mask]) / a[mask]) ** 2) / 2)
    blocks = [x.reshape(8, 8, 8, 8).mean(axis=(1, 3)) for x in (a, b)]
    bright = blocks[0] > 0.01 * blocks[0].max()
    block = np.sqrt(np.mean(((blocks[1] - blocks[0])[bright] / blocks[0][bright]) ** 2) / 2)
    return float(pixel), float(block)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    if args.rounds < 2:
        parser.error(
            f"--rounds must be >= 2 (the noise is two seeds' difference); got {args.rounds}"
        )
    pbrt = json.loads((DATA / "pbrt_d1" / "noise.json").read_text())
    sun = DirectionalLight((2**-0.5, 2**-0.5, 0.0), 1.0, 5778.0)
    fire = EmissionLight()
    cases = {  # name: (pbrt key, volume, integrator, supersample)
        "D2_glowing_core_ms": (
            pbrt_scenes.glowing_core(DATA / "pbrt_d2"),
            MultipleScattering(lights=(fire,), spp=8),
            1,
        ),
        "D2_glowing_core_ss": (
            pbrt_scenes.glowing_core(DATA / "pbrt_d2"),
            SingleScattering(lights=(fire,), spp=4),
            2,
        ),
        "D1_sunlit_sphere_ms": (
            pbrt_scenes.sunlit_sphere(DATA / "pbrt_d1"),
            MultipleScattering(lights=(sun,), spp=8),
            2,
        ),
        "D1_sunlit_sphere_ss": (
            pbrt_scenes.sunlit_sphere(DATA / "pbrt_d1"),
            SingleScattering(lights=(sun,), shadows="march"),
            2,
        ),
    }
    times: dict[str, list[float]] = {name: [] for name in cases}
    images: dict[str, list[np.ndarray]] = {name: [] for name in cases}
    for _ in range(args.rounds):
        for name, (volume, integrator, ss) in cases.items():
            seed = len(images[name])
            settings = RenderSettings(width=64, height=64, supersample=ss, seed=seed)
            image = render(volume, pbrt_scenes.CAMERA, settings, "cpu", integrator=integrator)
            times[name].append(image.metadata["seconds"])
            images[name].append(image.luminance)
    report: dict = {"machine": "2 cores (pbrt's figures: the same machine class, 2 threads)"}
    for name, (_, integrator, ss) in cases.items():
        ours_s = statistics.median(times[name])
        pixel, block = _noise(images[name][0], images[name][1])
        theirs = pbrt[name]
        row = {"ours_s": ours_s, "ours_pixel_noise": pixel, "ours_block_noise": block,
               "ours_setting": f"{integrator.name}, {integrator.metadata().get('spp', 'no')} "
                               f"Monte Carlo samples, {ss}×{ss} rays per pixel"}  # fmt: skip
        for kind, noise in (("pixel", pixel), ("block", block)):
            if noise == 0:  # deterministic (single scattering of a sun): no Monte Carlo noise
                row[f"speedup_at_equal_{kind}_noise"] = None
                continue
            pbrt_s = theirs["s_per_spp"] * (theirs[f"k_{kind}"] / noise) ** 2
            row[f"pbrt_s_to_our_{kind}_noise"] = pbrt_s
            row[f"speedup_at_equal_{kind}_noise"] = pbrt_s / ours_s
        report[name] = row
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2))
    return report


if __name__ == "__main__":
    main()
