"""Does anything dilute a simulated pool fire's core? The centreline with radiative cooling off.

With ``cooling_K_s = 0`` the products keep T_ad unless air mixes into them, so the time-mean
centreline excess temperature (2×2 central columns, 5 s at 24 samples per second, the first 2 s
dropped) of a 0.5 m, 50 kW methane pool measures dilution alone. Each variant changes one
setting (or the resolution) from the pool preset; McCaffrey's plume would have the excess fall
as z^(−5/3) above the flame. Writes OUT.json and prints a row per variant.

Usage: ``python benchmarks/fire_dilution.py OUT.json [--variants base,noise,...]``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from incandescent.simulation import FireSolver
from incandescent.simulation.pool import centreline_K, pool_fire
from incandescent.simulation.run import advance_frame

#: name → (resolution, settings over the pool's with cooling off).
VARIANTS = {
    "base": (48, {}),
    "radiative cooling on": (48, {"cooling_K_s": 3000.0}),
    "source noise 1": (48, {"noise": 1.0}),
    "smagorinsky 0.5": (48, {"smagorinsky": 0.5}),
    "vorticity 0": (48, {"vorticity": 0.0}),
    "vorticity 20": (48, {"vorticity": 20.0}),
    "96 cells": (96, {}),
}
HEIGHTS_M = (0.25, 0.5, 1.0, 1.5, 1.9)


def centreline(resolution: int, changes: dict) -> dict:
    settings = pool_fire(
        0.5, 50.0, changes={"fps": 24.0, "cooling_K_s": 0.0, **changes}, combustion="front"
    )
    solver = FireSolver(settings, resolution, "cpu")
    state, rows, began = solver.initial_state(), [], time.perf_counter()
    ny = solver.shape[1]
    for frame in range(5 * 24):
        state, _ = advance_frame(solver, state)
        if frame >= 2 * 24:
            t = solver.ops.numpy(state.temperature.values).reshape(solver.shape)
            rows.append(centreline_K(t))
    excess = np.mean(rows, axis=0) - settings.t_air_K
    z = (np.arange(ny) + 0.5) * solver.h
    picks = {f"{h:g}": float(excess[np.argmin(abs(z - h))]) for h in HEIGHTS_M if h < z[-1]}
    return {"shape": list(solver.shape), "excess_K_at_m": picks,
            "wall_s": time.perf_counter() - began}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    args = parser.parse_args()
    report = {}
    for name in args.variants.split(","):
        report[name] = centreline(*VARIANTS[name])
        cells = " ".join(f"{h} m: {v:.0f} K" for h, v in report[name]["excess_K_at_m"].items())
        print(f"{name:>22} {report[name]['shape']}  {cells}", flush=True)
    args.out.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()
