"""Cost, noise and bias of single scattering of the fire's own light, per sample vs the
per-camera in-scatter cache, against the emission-only render of the same frame (issue 27's
target: single scattering ≤ 4× it).

The fire demo frame (albedo 0.7, g = 0.3, lit only by its own emission: ``EmissionLight``), the
same setup as docs/scattering.md's "35–41×" figure. Times are the renders' march seconds (the
one-off work — shadow grids, the cache — included, compilation excluded), medians of
``--rounds`` interleaved rounds. Noise: the RMS difference of two seeds' renders / √2, per
pixel and on 8×8-pixel blocks, relative to the converged image's RMS; the camera rays are not
jittered (``--jitter`` to jitter them), so the noise is the fire's light's alone. Bias: the
mean of the two seeds against a converged per-sample render (``--converged-spp`` pairs a
sample), as the image's mean luminance and as the RMS over 8×8 blocks (which still holds the
two seeds' block noise / √2). The verdicts: the cheapest cache whose noise, pixel and block
(or pixel alone: the cache's noise is blotches of a voxel's size, which 8×8 blocks do not
average away), is no worse than the per-sample default's (``spp`` 4).

Usage: python benchmarks/fire_light_cost.py OUT.json [--resolution 128] [--rounds 5]
       [--backend cpu|cuda] [--pairs 1,2,4,8,16] [--cells 1,2] [--converged-spp 64] [--jitter]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import numpy as np

from incandescent.renderer import EmissionAbsorption, RenderSettings, render
from incandescent.renderer.integrators import SingleScattering
from incandescent.renderer.lights import EmissionLight
from incandescent.scenes import SCENES

FIRE = (EmissionLight(),)
#: today's default per-sample estimator (``SingleScattering.spp``)
DEFAULT_SPP = 4


def _variants(pairs: list[int], cells: list[int]) -> dict[str, SingleScattering]:
    """The per-sample estimators and the caches: ``cache_N`` (a centre per voxel) and
    ``cacheC_N`` (cells of C voxels a side), N samples a centre."""
    out = {f"per_sample_spp{n}": SingleScattering(lights=FIRE, spp=n) for n in (1, DEFAULT_SPP)}
    for c in cells:
        for n in pairs:
            out[_cache_name(n, c)] = SingleScattering(
                lights=FIRE, in_scatter="cache", cache_pairs=n, cache_voxels=c
            )
    return out


def _cache_name(pairs: int, cell: int) -> str:
    return f"cache_{pairs}" if cell == 1 else f"cache{cell}_{pairs}"


def _blocks(y: np.ndarray) -> np.ndarray:
    h, w = (n - n % 8 for n in y.shape)
    return y[:h, :w].reshape(h // 8, 8, w // 8, 8).mean(axis=(1, 3))


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def _quality(a: np.ndarray, b: np.ndarray, converged: np.ndarray) -> dict[str, float]:
    """Noise (two seeds a, b) and bias (their mean against ``converged``), relative."""
    mean = 0.5 * (a + b)
    return {
        "noise_pixel": _rms(a - b) / np.sqrt(2) / _rms(converged),
        "noise_block": _rms(_blocks(a) - _blocks(b)) / np.sqrt(2) / _rms(_blocks(converged)),
        "bias_mean": float(mean.mean() / converged.mean() - 1.0),
        "error_block": _rms(_blocks(mean) - _blocks(converged)) / _rms(_blocks(converged)),
    }


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--backend", default="cpu", help="cpu or cuda")
    parser.add_argument("--pairs", default="1,2,4,8,16", help="cache_pairs to try")
    parser.add_argument("--cells", default="1", help="cache_voxels to try (1, 2)")
    parser.add_argument("--converged-spp", type=int, default=64)
    parser.add_argument(
        "--jitter",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="jitter the camera rays (their noise then adds to the light's)",
    )
    args = parser.parse_args(argv)
    scene = SCENES["fire"]
    dark = scene.build(None)
    lit = dark.with_scattering(albedo=0.7, phase_g=0.3)
    camera = scene.camera() if scene.camera else None
    pairs = [int(n) for n in args.pairs.split(",")]
    cells = [int(c) for c in args.cells.split(",")]
    variants = _variants(pairs, cells)

    def run(volume, integrator, seed: int = 0):
        settings = RenderSettings(
            width=args.resolution, height=args.resolution, seed=seed, jitter=args.jitter
        )
        return render(volume, camera, settings, args.backend, integrator=integrator)

    timed = {"emission_absorption": (dark, EmissionAbsorption())}
    timed |= {name: (lit, integrator) for name, integrator in variants.items()}
    times: dict[str, list[float]] = {name: [] for name in timed}
    for volume, integrator in timed.values():  # compile
        run(volume, integrator)
    for _ in range(args.rounds):
        for name, (volume, integrator) in timed.items():
            times[name].append(run(volume, integrator).metadata["seconds"])
    medians = {name: statistics.median(t) for name, t in times.items()}
    base = medians["emission_absorption"]

    converged = run(lit, SingleScattering(lights=FIRE, spp=args.converged_spp), seed=99)
    reference = np.asarray(converged.luminance, dtype=np.float64)
    quality = {}
    for name, integrator in variants.items():
        a, b = (np.asarray(run(lit, integrator, seed).luminance, np.float64) for seed in (1, 2))
        quality[name] = _quality(a, b, reference)
    default = quality[f"per_sample_spp{DEFAULT_SPP}"]

    def cheapest(*kinds: str) -> str | None:
        """The cheapest cache whose noise of each kind is no worse than the default's."""
        names = [_cache_name(n, c) for c in cells for n in pairs]
        good = [name for name in names if all(
            quality[name][kind] <= default[kind] for kind in kinds)]  # fmt: skip
        return min(good, key=lambda name: medians[name]) if good else None

    verdicts = {"pixel_and_block": cheapest("noise_pixel", "noise_block"),
                "pixel": cheapest("noise_pixel")}  # fmt: skip
    report = {
        "scene": f"fire demo {dark.shape}, {args.resolution}² px, albedo 0.7, g 0.3, fire light",
        "backend": args.backend,
        "rounds": args.rounds,
        "median_ms": {k: v * 1e3 for k, v in medians.items()},
        "over_emission": {k: v / base for k, v in medians.items()},
        "quality": quality,
        "jitter": args.jitter,
        "converged": f"per-sample, {args.converged_spp} pairs a sample, seed 99",
        "cheapest_cache_at_default_noise": {
            kinds: None if name is None else {"cache": name, "over_emission": medians[name] / base}
            for kinds, name in verdicts.items()
        },
        "default_ratio": medians[f"per_sample_spp{DEFAULT_SPP}"] / base,
    }
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2))
    return report


if __name__ == "__main__":
    main()
