"""A pool fire in a wind: the flame's tilt against the AGA correlation (issue 28's optional wind).

``pool_fire(D, Q, combustion=…)`` (methane; ``--combustion front``, the premixed equivalent,
by default, or ``mixing``, the diffusion flame) with ``wind_m_s``
u_w along +x, each wind of ``--winds`` run for ``--seconds`` at 24 samples per second on
``--backend``; the first ``--warmup`` seconds dropped.
Measured over the rest: the tilt from the vertical of the luminous gas (T > 1000 K) below
``--flame-heights`` × Heskestad's flame height, atan(x̄ − x_pool, ȳ − y_pool) of its centroid (so
the plume above the flame does not count), against the American Gas Association's cos θ = u*^(−½)
(``pool.wind_tilt_deg``). Writes OUT.json and OUT.md.

Usage: ``python benchmarks/fire_wind.py OUT [--resolution 64] [--winds 0,0.5,1,2,4]
[--seconds 6] [--warmup 2] [--pool 0.5:50] [--backend cpu] [--combustion front]``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from incandescent.simulation import FireSolver
from incandescent.simulation.diagnostics import HOT_K
from incandescent.simulation.pool import FUELS, heskestad_height_m, pool_fire, wind_tilt_deg
from incandescent.simulation.run import advance_frame

RATE_HZ = 24.0


def tilt_deg(solver: FireSolver, state, below_m: float) -> float | None:
    """The luminous gas's tilt (degrees from vertical, + downwind) below ``below_m`` above the
    pool: its centroid against the pool's centre; None where there is none."""
    t = solver.ops.numpy(state.temperature.values).reshape(solver.shape)
    (source,) = solver.settings.sources
    pool = np.asarray(source.centre) * np.asarray(solver.shape) * solver.h
    i, j, _ = np.nonzero(t > HOT_K)
    x, y = (i + 0.5) * solver.h - pool[0], (j + 0.5) * solver.h - pool[1]
    keep = (y > 0) & (y < below_m)
    if not keep.any():
        return None
    return math.degrees(math.atan2(x[keep].mean(), y[keep].mean()))


def measure(d: float, q: float, wind: float, args: argparse.Namespace) -> dict:
    changes = {"fps": RATE_HZ, "wind_m_s": wind}
    settings = pool_fire(d, q, changes=changes, combustion=args.combustion)
    solver = FireSolver(settings, args.resolution, args.backend)
    below = args.flame_heights * max(heskestad_height_m(q, d), d)
    state, tilts, began = solver.initial_state(), [], time.perf_counter()
    for frame in range(round(args.seconds * RATE_HZ)):
        state, _ = advance_frame(solver, state)
        if frame >= args.warmup * RATE_HZ:
            tilts.append(tilt_deg(solver, state, below))
    seen = [t for t in tilts if t is not None]
    return {
        "D_m": d, "Q_kW": q, "wind_m_s": wind, "resolution": args.resolution,
        "shape": list(solver.shape), "backend": args.backend, "combustion": args.combustion,
        "tilt_deg": float(np.mean(seen)) if seen else None,
        "tilt_sd_deg": float(np.std(seen)) if seen else None,
        "aga_deg": wind_tilt_deg(wind, d, q, FUELS["methane"]),
        "wall_s": time.perf_counter() - began,
    }  # fmt: skip


def table(rows: list[dict]) -> str:
    lines = ["| wind m/s | tilt ° (± sd) | AGA ° | cells | wall s |", "|---|---|---|---|---|"]
    for r in rows:
        tilt = "—" if r["tilt_deg"] is None else f"{r['tilt_deg']:.1f} ± {r['tilt_sd_deg']:.1f}"
        cells = "×".join(map(str, r["shape"]))
        lines.append(
            f"| {r['wind_m_s']:g} | {tilt} | {r['aga_deg']:.1f} | {cells} | "
            f"{r['wall_s']:.0f} ({r['backend']}) |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--winds", default="0,0.5,1,2,4")
    parser.add_argument("--seconds", type=float, default=6.0)
    parser.add_argument("--warmup", type=float, default=2.0)
    parser.add_argument("--pool", default="0.5:50", help="D:Q, m and kW")
    parser.add_argument("--flame-heights", type=float, default=1.0)
    parser.add_argument("--backend", default="cpu")
    parser.add_argument(
        "--combustion",
        default="front",
        choices=("front", "mixing"),
        help="pool_fire's model (mixing: warm up past the pool's fill time)",
    )
    args = parser.parse_args()
    d, q = (float(v) for v in args.pool.split(":"))
    rows = []
    for wind in (float(v) for v in args.winds.split(",")):
        rows.append(measure(d, q, wind, args))
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1) + "\n")
    args.out.with_suffix(".md").write_text(table(rows))


if __name__ == "__main__":
    main()
