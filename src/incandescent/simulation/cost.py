"""``incandescent bench --fire``: what a simulated fire costs on this machine.

The explosion preset (a 4 m cube, so the grid is n³) at CFL 4 with at most 4 sub-steps a frame
(Blender Mantaflow's defaults, as ``benchmarks/fire_vs_mantaflow.py`` compares), on the cpu
backend (and cuda where present), once per pressure preconditioner: ``auto`` (the box's exact
inverse on the host, DESIGN §7) and ``multigrid`` (the V-cycle). Each solver runs one untimed
frame (Dr.Jit compiles its kernels), then the solvers' frames are timed in interleaved rounds so
that machine noise hits them alike; medians are reported.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Sequence

from incandescent.simulation.run import advance_frame
from incandescent.simulation.settings import preset
from incandescent.simulation.solver import FireSolver

#: The preconditioners timed side by side.
PRECONDITIONERS = ("auto", "multigrid")
#: The smallest grid the explosion preset takes (its nozzle needs cells) and the largest timed.
SIZES = (16, 512)


def parse_sizes(text: str) -> list[int]:
    """``"64,128"`` → [64, 128]; a one-line error naming the value otherwise."""
    try:
        sizes = [int(part) for part in text.split(",")]
    except ValueError:
        raise ValueError(f"--fire {text!r}: expected grid sizes like 64,128") from None
    for n in sizes:
        if not SIZES[0] <= n <= SIZES[1]:
            raise ValueError(f"--fire {n}: a grid size must be {SIZES[0]}..{SIZES[1]} cells")
    return sizes


def _solver(n: int, choice: str, backend: str) -> FireSolver:
    settings = preset("explosion", cfl=4.0, max_steps_per_frame=4, pressure_preconditioner=choice)
    return FireSolver(settings, n, backend)


def _case(n: int, choice: str, backend: str, frames: list) -> dict:
    """One solver's medians: s per frame, ms per step, steps and pressure iterations."""
    seconds = [s for s, _, _ in frames]
    steps = [k for _, k, _ in frames]
    per_frame = statistics.median(seconds)
    return {
        "cells": n, "backend": backend, "preconditioner": choice,
        "s_per_frame": per_frame,
        "ms_per_step": 1e3 * statistics.median(s / k for s, k, _ in frames),
        "steps_per_frame": steps,
        "pressure_iterations": sorted({i for _, _, its in frames for i in its}),
        "mcells_per_s": n**3 / per_frame / 1e6,
    }  # fmt: skip


def run(sizes: Sequence[int], repeat: int, backends: Sequence[str],
        progress: Callable[[str], None] | None = None) -> list[dict]:  # fmt: skip
    """Each size × backend × preconditioner: ``repeat`` timed frames, interleaved."""
    rows = []
    for n in sizes:
        for backend in backends:
            solvers = {c: _solver(n, c, backend) for c in PRECONDITIONERS}
            states = {c: advance_frame(s, s.initial_state())[0] for c, s in solvers.items()}
            frames: dict[str, list] = {c: [] for c in solvers}
            for _ in range(repeat):
                for c, solver in solvers.items():
                    began = time.perf_counter()
                    states[c], done = advance_frame(solver, states[c])
                    its = [r.pressure_iterations for r in done]
                    frames[c].append((time.perf_counter() - began, len(done), its))
            for c, solver in solvers.items():
                label = c if c != "auto" else ("auto: exact" if solver.exact else "auto: multigrid")
                rows.append(_case(n, label, backend, frames[c]))
                if progress is not None:
                    progress(f"fire {n}³ on {backend}, {label}: {rows[-1]['s_per_frame']:.3f} s")
    return rows


def print_table(rows: list[dict], console) -> None:
    from rich.table import Table

    table = Table(title="fire solver: the explosion preset at CFL 4, at most 4 sub-steps a frame")
    for col in ("cells", "backend", "pressure", "s/frame", "ms/step", "iterations", "Mcells/s"):
        table.add_column(col, justify="left" if col in ("backend", "pressure") else "right")
    for r in rows:
        its = r["pressure_iterations"]
        table.add_row(f"{r['cells']}³", r["backend"], r["preconditioner"],
                      f"{r['s_per_frame']:.3f}", f"{r['ms_per_step']:.1f}",
                      f"{its[0]}–{its[-1]}" if len(its) > 1 else str(its[0]),
                      f"{r['mcells_per_s']:.2f}")  # fmt: skip
    console.print(table)
