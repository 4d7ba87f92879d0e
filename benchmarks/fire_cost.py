"""What a simulated fire costs: ms per solver step and seconds per frame at 64³ and 128³.

The explosion preset (a 4 m cube, so the grid is n³), on the cpu backend: two untimed steps
(kernel compilation), then ``--steps`` timed steps of 1/96 s (pressure iterations and residual of
each), then ``--frames`` timed frames (CFL sub-steps as ``simulate`` takes them) — with the
preset's CFL 2 (at most 8 sub-steps a frame) and with Mantaflow's defaults in Blender, CFL 4 and
at most 4 sub-steps (``cfl4``).

Usage: ``python benchmarks/fire_cost.py OUT.json [--sizes 64,128] [--steps 5] [--frames 2]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from incandescent.simulation import FireSolver, preset
from incandescent.simulation.run import advance_frame


def measure(size: int, steps: int, frames: int, backend: str, **changes) -> dict:
    solver = FireSolver(preset("explosion", **changes), size, backend)
    state = solver.initial_state()
    for _ in range(2):
        state, _ = solver.step(state, 1 / 96)
    times, reports = [], []
    for _ in range(steps):
        began = time.perf_counter()
        state, report = solver.step(state, 1 / 96)
        times.append(time.perf_counter() - began)
        reports.append(report)
    frame_s, frame_steps = [], []
    for _ in range(frames):
        began = time.perf_counter()
        state, done = advance_frame(solver, state)
        frame_s.append(time.perf_counter() - began)
        frame_steps.append(len(done))
    per_frame = statistics.median(frame_s)
    stepped = (
        {
            "ms_per_step": statistics.median(times) * 1e3,
            "pressure_iterations": [r.pressure_iterations for r in reports],
            "pressure_residual": max(r.pressure_residual for r in reports),
            "max_divergence_per_s": max(r.max_divergence for r in reports),
        }
        if times
        else {}
    )
    return {
        "shape": solver.shape,
        **stepped,
        "s_per_frame": per_frame,
        "steps_per_frame": frame_steps,
        "frames_per_minute": 60.0 / per_frame,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--sizes", default="64,128")
    parser.add_argument("--steps", type=int, default=5)
    parser.add_argument("--frames", type=int, default=2)
    parser.add_argument("--backend", default="cpu")
    a = parser.parse_args()
    report = {}
    for n in map(int, a.sizes.split(",")):
        report[f"{n}"] = measure(n, a.steps, a.frames, a.backend)
        report[f"{n}_cfl4"] = measure(n, 0, a.frames, a.backend, cfl=4.0, max_steps_per_frame=4)
    a.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
