"""Cost of species line emission in the march: 0, 1, 2, 4 species on one scene.

Usage::

    python benchmarks/species_cost.py OUT.json [--size 128] [--resolution 256] [--rounds 7]
        [--backend cpu]

Scene: the plume of :func:`incandescent.scenes.plume_temperature` (n³, peak 2000 K) with the
default absorption (κ where T ≥ 500 K) and k species (Na, Li, Sr, Cu, in that order), each a grid
following the hot gas (:func:`incandescent.scenes.species.hot_gas_weight`, 0 below 500 K). Species
therefore occupy exactly the voxels that absorb, so empty-space skipping visits the same cells in
every variant and the difference is the per-sample cost of the species lookups.

Timing: ``image.metadata["seconds"]`` (march only, no start-up or kernel compilation). Every
variant is rendered once untimed (compilation, tables), then the variants are interleaved for
``--rounds`` rounds and the median per variant is reported, with the cost per added species
(ms and % of the 0-species march): (t_k − t_0)/k for each k, and a least-squares slope over all k.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from incandescent import __version__
from incandescent.benchmark import git_commit
from incandescent.renderer import RenderSettings, render
from incandescent.scenes import plume_temperature
from incandescent.scenes.species import hot_gas_weight
from incandescent.volume import Volume

SPECIES = ("Na", "Li", "Sr", "Cu")
COUNTS = (0, 1, 2, 4)


def volumes(n: int) -> dict[int, Volume]:
    """The plume with 0, 1, 2, 4 species (fraction = the hot-gas weight × 0.5)."""
    temperature = plume_temperature(n)
    fraction = hot_gas_weight(temperature) * np.float32(0.5)
    return {
        k: Volume.from_arrays(temperature, species={s: fraction for s in SPECIES[:k]})
        for k in COUNTS
    }


def main(argv: Sequence[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="JSON file to write")
    parser.add_argument("--size", type=int, default=128, help="grid n³ (128)")
    parser.add_argument("--resolution", type=int, default=256, help="image side in px (256)")
    parser.add_argument("--rounds", type=int, default=7, help="timed rounds, >= 5 (7)")
    parser.add_argument("--backend", default="cpu", help="render backend (cpu)")
    args = parser.parse_args(argv)
    if args.rounds < 5:
        parser.error("--rounds must be >= 5")
    settings = RenderSettings(width=args.resolution, height=args.resolution)
    vols = volumes(args.size)
    times: dict[int, list[float]] = {k: [] for k in COUNTS}
    samples: dict[int, int] = {}
    device = ""
    for k in COUNTS:  # warm-up: compile kernels, build tables
        render(vols[k], settings=settings, backend=args.backend)
    start = time.perf_counter()
    for r in range(args.rounds):
        order = COUNTS if r % 2 == 0 else COUNTS[::-1]  # interleave, alternating direction
        for k in order:
            image = render(vols[k], settings=settings, backend=args.backend)
            times[k].append(float(image.metadata["seconds"]))
            samples[k] = int(image.metadata.get("samples", 0))
            device = str(image.metadata.get("device", ""))
    wall = time.perf_counter() - start

    median_ms = {k: 1e3 * statistics.median(v) for k, v in times.items()}
    base = median_ms[0]
    per_species = {
        k: {"ms": (median_ms[k] - base) / k, "percent": 100.0 * (median_ms[k] - base) / k / base}
        for k in COUNTS
        if k
    }
    slope = float(np.polyfit(COUNTS, [median_ms[k] for k in COUNTS], 1)[0])
    result = {
        "benchmark": "species_cost",
        "scene": f"plume({args.size}) default absorption, species fraction 0.5·w(T)",
        "resolution": [args.resolution, args.resolution],
        "backend": args.backend,
        "device": device,
        "rounds": args.rounds,
        "species_order": list(SPECIES),
        "median_ms": {str(k): median_ms[k] for k in COUNTS},
        "all_ms": {str(k): [1e3 * t for t in times[k]] for k in COUNTS},
        "samples": {str(k): samples[k] for k in COUNTS},
        "per_added_species": {str(k): v for k, v in per_species.items()},
        "slope_ms_per_species": slope,
        "slope_percent_per_species": 100.0 * slope / base,
        "timed_wall_s": wall,
        "incandescent": __version__,
        "commit": git_commit(),
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    print(
        f"plume {args.size}³ at {args.resolution}², backend {args.backend} ({device}), "
        f"{args.rounds} rounds, median march ms"
    )
    head = ("species", "median ms", "min ms", "max ms", "Δ/species ms", "Δ %")
    print("{:>8} {:>10} {:>8} {:>8} {:>13} {:>7}".format(*head))
    for k in COUNTS:
        lo, hi = 1e3 * min(times[k]), 1e3 * max(times[k])
        cost = per_species.get(k)
        extra = f"{cost['ms']:>13.2f} {cost['percent']:>6.1f}%" if cost else f"{'—':>13} {'—':>7}"
        print(f"{k:>8} {median_ms[k]:>10.2f} {lo:>8.2f} {hi:>8.2f} {extra}")
    pct = 100.0 * slope / base
    print(f"least-squares slope: {slope:.2f} ms per species ({pct:.1f} % of 0 species)")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")
    return result


if __name__ == "__main__":
    main()
