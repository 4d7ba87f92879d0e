"""A sweep of the reconstruction's settings on the held-out fire (issue 30): one case of
``reconstruction_accuracy`` (64³, 12 views of 128², noise free) per setting, each in its own
process, ``--jobs`` at once (the kernels are traced on the CPU, so cases run side by side on a
GPU machine's cores), the rows written to one JSON as they finish. A fit still running after
``--budget-s`` is stopped and measured at its last finished round at the finest level
(``"finished": false``; none yet: ``"stopped"``), so the sweep fits a fixed slot:

    python benchmarks/reconstruction_sweep.py --backend cuda --jobs 8 --budget-s 280 \\
        --out sweep.json
    python benchmarks/reconstruction_sweep.py --size 32 --pixels 64 --backend cpu --jobs 1

The settings (``Settings`` fields; unnamed ones are the defaults; ``views`` and ``noise``, the
case's) are ``SWEEP``, or a JSON list of dicts given with ``--settings``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from reconstruction_accuracy import run_case  # noqa: E402

#: The settings tried: the defaults; thin voxels held dark; then, with them, L-BFGS-B with
#: memory 50 restarted every 100 iterations (a checkpoint each: a case stopped by the budget
#: reports its last), 200 and 400 iterations a level, and around the first the TV weight and
#: the unknown's power (at 32³ each helped: 97 → 93 → 85 K at 150, 73 K at 400).
LONG = {"round": 100, "memory": 50, "dark_fraction": 0.05}
SWEEP: list[dict] = [
    {},
    {"dark_fraction": 0.05},
    {**LONG, "iterations": 200},
    {**LONG, "iterations": 400},
    {**LONG, "iterations": 200, "tv_weight": 3e-4},
    {**LONG, "iterations": 200, "tv_weight": 3e-3},
    {**LONG, "iterations": 200, "power": 0.33},
    {"round": 100, "memory": 50, "iterations": 200},
]


def one(args, options: dict) -> dict:
    """One case's row, or what stopped it (``views`` and ``noise`` in ``options`` override the
    case's 12 noise-free views; the rest are ``Settings`` fields)."""
    began = time.perf_counter()
    settings = {k: v for k, v in options.items() if k not in ("views", "noise")}
    views, noise = options.get("views", args.views), options.get("noise", 0.0)
    try:
        row = run_case(args.size, args.pixels, views, noise, settings, args.backend,
                       args.budget_s)  # fmt: skip
    except subprocess.TimeoutExpired:
        row = {"stopped": f"not done after {args.budget_s:g} s"}
    except subprocess.CalledProcessError as error:
        row = {"failed": (error.stderr or "").strip().splitlines()[-1:]}
    return {"changed": options, "wall_s": time.perf_counter() - began, **row}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--pixels", type=int, default=128)
    parser.add_argument("--views", type=int, default=12)
    parser.add_argument("--backend", default="cuda", choices=("cpu", "cuda", "reference"))
    parser.add_argument("--jobs", type=int, default=8, help="cases at once")
    parser.add_argument("--budget-s", type=float, default=280.0, help="per case, wall clock")
    parser.add_argument("--settings", type=json.loads, default=SWEEP, help="a JSON list")
    parser.add_argument("--out", type=Path, default=Path("reconstruction_sweep.json"))
    args = parser.parse_args()
    rows: list[dict] = []
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for future in as_completed([pool.submit(one, args, o) for o in args.settings]):
            rows.append(future.result())
            keys = (
                "changed",
                "rmse_hot_K",
                "views_l1_vs_truth",
                "finished",
                "seconds",
                "stopped",
                "failed",
            )
            print(json.dumps({k: rows[-1][k] for k in keys if k in rows[-1]}), flush=True)
            args.out.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
