"""Our fire solver against Blender's Mantaflow, side by side in one run (issue 28's must-show).

Both simulate a fire in a cube of n³ cells at CFL 4 with at most 4 sub-steps a frame (Mantaflow's
defaults; ``cfl``, ``max_steps_per_frame`` in our settings), on the same cores, in interleaved
rounds, each in a fresh process:

- **Mantaflow**: Debian's ``blender`` (3.4), headless (``blender -b --factory-startup -t
  THREADS``) running ``scripts/make_blender_fire_cache.py --cube --cfl 4 --timesteps-max 4``: a
  1 m gas domain at ``resolution_max`` n, a 0.25 m FIRE emitter near its floor, baked with
  ``fluid.bake_all`` (its cache written as OpenVDB, as an artist bakes) for F frames and,
  separately, for 1 frame. Its cost per frame is (t_F − t_1)/(F − 1): what a frame adds,
  without Blender's start, the domain's set-up and the first frame.
- **incandescent**: ``FireSolver`` on the explosion preset (a 4 m cube, so the grid is n³) on the
  cpu backend; one untimed frame (Dr.Jit compiles its kernels), then F − 1 frames timed with
  ``run.advance_frame`` (the sub-steps ``simulate`` takes), the median reported — once per
  pressure preconditioner (``--preconditioners``: the exact inverse ``auto`` picks for this box,
  and the V-cycle), in the same rounds. BLAS (the exact inverse's matrix products) is held to the
  same thread count (``OPENBLAS_NUM_THREADS``).

Reported per resolution: seconds per frame for both (medians over rounds), our sub-steps per
frame, and cells per second per thread — n³ cells per frame / (s per frame · threads) — and the
ratio (issue 28's target: ours ≥ 4× Mantaflow's). Time a quiet machine only.

Usage: ``python benchmarks/fire_vs_mantaflow.py OUT.json [--sizes 64,128] [--frames 6]
[--rounds 2] [--threads 2] [--preconditioners exact,multigrid]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The Blender scene and its bake: the script that made tests/data's Mantaflow caches.
BAKE_SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "make_blender_fire_cache.py"

#: Run in a fresh Python: our solver at n³ for F frames; prints each frame's seconds and steps.
OURS = r"""
import json, sys, time, drjit as dr
from incandescent.simulation import FireSolver, preset
from incandescent.simulation.run import advance_frame
n, frames, threads, choice = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
dr.set_thread_count(threads)
settings = preset("explosion", cfl=4.0, max_steps_per_frame=4, pressure_preconditioner=choice)
solver = FireSolver(settings, n, "cpu")
state, rows = solver.initial_state(), []
for _ in range(frames):
    began = time.perf_counter()
    state, done = advance_frame(solver, state)
    rows.append((time.perf_counter() - began, len(done), done[-1].pressure_iterations))
print("OURS", json.dumps({"shape": solver.shape, "frames": rows}))
"""


def mantaflow_seconds(n: int, frames: int, threads: int) -> float:
    """Seconds of one ``bake_all`` of ``frames`` frames of a 1 m cube at resolution ``n`` (n³
    cells: its ``shadow`` grid is n³), CFL 4, at most 4 sub-steps a frame."""
    with tempfile.TemporaryDirectory(prefix="manta-") as cache:
        command = ["blender", "-b", "--factory-startup", "-t", str(threads), "--python",
                   str(BAKE_SCRIPT), "--", cache, "--frames", str(frames), "--resolution", str(n),
                   "--cube", "--cfl", "4", "--timesteps-max", "4"]  # fmt: skip
        out = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    return float(next(r for r in out.splitlines() if r.startswith("BAKE_SECONDS")).split()[1])


def ours(n: int, frames: int, threads: int, choice: str) -> dict:
    """Our solver's frames at n³ in a fresh process with the pressure preconditioner ``choice``:
    shape, per-frame (seconds, steps, the last step's pressure iterations)."""
    command = [sys.executable, "-c", OURS, str(n), str(frames), str(threads), choice]
    env = os.environ | {"OPENBLAS_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads)}
    out = subprocess.run(command, check=True, capture_output=True, text=True, env=env).stdout
    return json.loads(next(r for r in out.splitlines() if r.startswith("OURS")).split(" ", 1)[1])


def measure(n: int, frames: int, rounds: int, threads: int, choices: list[str]) -> dict:
    """Both solvers at ``n`` (ours with each preconditioner of ``choices``), ``rounds``
    interleaved rounds; medians and the ratios."""
    manta: list[float] = []
    runs: dict[str, dict[str, list]] = {
        c: {"s": [], "steps": [], "iterations": []} for c in choices
    }
    for _ in range(rounds):
        full = mantaflow_seconds(n, frames, threads)
        first = mantaflow_seconds(n, 1, threads)
        manta.append((full - first) / (frames - 1))
        for choice in choices:
            run = ours(n, frames, threads, choice)
            runs[choice]["s"].append(statistics.median(row[0] for row in run["frames"][1:]))
            runs[choice]["steps"] += [row[1] for row in run["frames"][1:]]
            runs[choice]["iterations"] += [row[2] for row in run["frames"][1:]]
    manta_rate = n**3 / statistics.median(manta) / threads
    ours_report = {
        choice: {
            "s_per_frame": r["s"], "steps_per_frame": r["steps"],
            "pressure_iterations_last_step": r["iterations"],
            "cells_per_s_per_thread": n**3 / statistics.median(r["s"]) / threads,
            "over_mantaflow": n**3 / statistics.median(r["s"]) / threads / manta_rate,
        }
        for choice, r in runs.items()
    }  # fmt: skip
    return {
        "n": n, "ours_shape": run["shape"], "threads": threads,
        "frames": frames, "rounds": rounds,
        "mantaflow_s_per_frame": manta, "mantaflow_cells_per_s_per_thread": manta_rate,
        "ours": ours_report,
    }  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--sizes", default="64,128")
    parser.add_argument("--frames", type=int, default=6, help="frames per bake (≥ 2)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--preconditioners", default="exact,multigrid")
    args = parser.parse_args(argv)
    if shutil.which("blender") is None:
        raise SystemExit("fire_vs_mantaflow: no `blender` on PATH (scripts/setup.sh installs it)")
    if args.frames < 2:
        raise SystemExit(f"fire_vs_mantaflow: --frames must be ≥ 2; got {args.frames}")
    report = {"when": time.strftime("%Y-%m-%d %H:%M"), "sizes": {}}
    for n in (int(v) for v in args.sizes.split(",")):
        report["sizes"][n] = measure(
            n, args.frames, args.rounds, args.threads, args.preconditioners.split(",")
        )
        print(json.dumps(report["sizes"][n]), flush=True)
    args.out.write_text(json.dumps(report, indent=1) + "\n")


if __name__ == "__main__":
    main()
