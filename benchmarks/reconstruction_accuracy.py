"""Accuracy of emission tomography (issue 30): a held-out fire — a frame of our fire simulator
(the ``fire`` scene: Nguyen et al. 2002's campfire, 32×48×32, with its soot κ grid), padded to
a cube and resampled to N³, scaled to a lab flame of 0.2 m (κ as simulated, so its optical
depth across is ~2) — seen by V views of P² on a ring around its axis (10° above the
horizon), reconstructed from a uniform start with its κ known (``inverse.reconstruct``).

Reported per case: the RMSE of T over the voxels above 1000 K, the re-rendered views' error
(relative L1 and L2 over all views, against the noise-free truth and against the inputs), the
time and the peak resident memory (VmHWM). Cases: V views, 4 views, and V views with 1 %
Gaussian noise per pixel (σ = 1 % of each pixel's value), or the ones named.

    python benchmarks/reconstruction_accuracy.py                 # 64³, 12 views of 128²
    python benchmarks/reconstruction_accuracy.py --size 32 --pixels 64 --out r.json
    python benchmarks/reconstruction_accuracy.py --backend cuda --cases all   # on a GPU

Each case runs in its own process (its own peak memory). On 2 shared cores the full case takes
long (each evaluation renders and differentiates every view once); say whether the machine was
shared when quoting a time.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from incandescent.inverse.reconstruct import Settings

#: The flame's box side, m.
SIDE_M = 0.2


def fire(n: int):
    """The simulated campfire padded to a cube, resampled to n³ voxels over SIDE_M."""
    from scipy.ndimage import zoom

    import incandescent as inc
    from incandescent.api import demo_volume

    frame = demo_volume("fire", 48)
    side = max(frame.shape)
    grids = []
    for grid, ambient in ((frame.temperature_K, 300.0), (frame.absorption_per_m, 0.0)):
        pad = [((side - s) // 2, side - s - (side - s) // 2) for s in grid.shape]
        cube = np.pad(np.asarray(grid, np.float64), pad, constant_values=ambient)
        grids.append(np.clip(zoom(cube, n / side, order=1), ambient, None))
    half = SIDE_M / 2
    return inc.Volume.from_arrays(grids[0], absorption=grids[1], voxel_size_m=SIDE_M / n,
                                  origin_m=(-half, -half, -half))  # fmt: skip


def ring(count: int, pixels: int):
    """``count`` cameras on a ring of radius 2.5·SIDE_M, 10° above the horizon."""
    import incandescent as inc

    settings = inc.RenderSettings(width=pixels, height=pixels, jitter=False)
    cameras = []
    for k in range(count):
        a, up = 2 * np.pi * k / count, np.radians(10.0)
        r = 2.5 * SIDE_M
        eye = (r * np.cos(up) * np.sin(a), r * np.sin(up), r * np.cos(up) * np.cos(a))
        cameras.append(inc.Camera(eye=eye, target=(0.0, 0.0, 0.0), fov_deg=30.0))
    return cameras, settings


def fit(views, truth, options: dict, backend: str, deadline_s: float | None):
    """(the reconstruction, finished?): stopped at ``deadline_s``, the last round that ended
    at the finest level (the checkpoint's), or None if none had."""
    import tempfile
    import time

    from incandescent.inverse import reconstruct as solver

    settings = solver.Settings(**options)
    if deadline_s is None:
        return solver.reconstruct(views, truth, settings, backend), True
    end = time.perf_counter() + deadline_s
    path = Path(tempfile.mkdtemp()) / "checkpoint.npz"

    def stop(level: int, evaluation: int, loss: float) -> None:
        if time.perf_counter() > end:
            raise TimeoutError

    try:
        return solver.reconstruct(views, truth, settings, backend, stop, path), True
    except TimeoutError:
        if not path.exists():
            return None, False
        state = solver.load_checkpoint(path, solver._fingerprint(views, truth, settings))
        if state.level != 0:
            return None, False
        table = solver.Luminance(settings.visible_K, settings.ceiling_K, settings.power)
        return solver._result(views, truth, settings, table, state, backend), False


def case(n: int, pixels: int, count: int, noise: float, options: dict,
         backend: str = "cpu", deadline_s: float | None = None) -> dict:  # fmt: skip
    """One reconstruction on ``backend`` (its views rendered there too) with ``Settings(**
    options)``: its accuracy, time and memory (stopped at ``deadline_s``: see :func:`fit`)."""
    import time

    import incandescent as inc
    from incandescent.inverse.reconstruct import View

    truth = fire(n)
    cameras, settings = ring(count, pixels)
    rng = np.random.default_rng(30)
    clean = [np.asarray(inc.render(truth, c, settings, backend).xyz, np.float64) for c in cameras]
    noisy = [np.maximum(x * (1 + noise * rng.standard_normal(x.shape)), 0) for x in clean]
    views = [
        View(x, c, settings, f"view {k}")
        for k, (x, c) in enumerate(zip(noisy, cameras, strict=True))
    ]
    start = time.perf_counter()
    result, finished = fit(views, truth, options, backend, deadline_s)
    seconds = time.perf_counter() - start
    if result is None:
        return {"stopped": f"not at the finest level after {seconds:.0f} s", "seconds": seconds}
    hot = truth.temperature_K > 1000
    error = (result.volume.temperature_K - truth.temperature_K)[hot]
    rendered = result.rendered
    peak = next(int(line.split()[1]) for line in open("/proc/self/status")
                if line.startswith("VmHWM"))  # fmt: skip
    return {
        "size": n, "pixels": pixels, "views": count, "noise": noise, "backend": backend,
        "settings": options, "finished": finished,
        "hot_voxels": int(hot.sum()),
        "rmse_hot_K": float(np.sqrt(np.mean(error**2))),
        "mean_error_hot_K": float(np.mean(error)),
        "views_l1_vs_truth": _relative(rendered, clean, 1),
        "views_l2_vs_truth": _relative(rendered, clean, 2),
        "views_l1_vs_inputs": _relative(rendered, noisy, 1),
        "evaluations": len(result.losses),
        "loss_first_last": [result.losses[0], result.losses[-1]],
        "seconds": seconds, "peak_rss_MiB": peak / 1024,
    }  # fmt: skip


def _relative(rendered, target, order: int) -> float:
    """Σ|rendered − target|^order / Σ|target|^order, to the 1/order, over all views."""
    num = sum(float(np.sum(np.abs(r - t) ** order)) for r, t in zip(rendered, target, strict=True))
    den = sum(float(np.sum(np.abs(t) ** order)) for t in target)
    return (num / den) ** (1.0 / order)


def run_case(n: int, pixels: int, count: int, noise: float, options: dict, backend: str,
             deadline_s: float | None = None) -> dict:  # fmt: skip
    """:func:`case` in a child process (its own peak memory); the fit stopped at
    ``deadline_s``."""
    spec = json.dumps({"n": n, "pixels": pixels, "count": count, "noise": noise,
                       "options": options, "backend": backend,
                       "deadline_s": deadline_s})  # fmt: skip
    cmd = [sys.executable, __file__, "--child", spec]
    timeout = None if deadline_s is None else deadline_s + 120.0  # the views, the re-render
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, timeout=timeout)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--pixels", type=int, default=128)
    parser.add_argument("--views", type=int, default=12)
    parser.add_argument("--iterations", type=int, default=100, help="per level")
    parser.add_argument("--levels", type=int, default=3)
    parser.add_argument("--tv", type=float, default=Settings.tv_weight, help="TV weight")
    parser.add_argument("--tv-eps", type=float, default=Settings.tv_eps_K, help="TV's ε, K")
    parser.add_argument("--power", type=float, default=Settings.power, help="the unknown's p")
    parser.add_argument("--dark", type=float, default=Settings.dark_fraction,
                        help="hold voxels with local κ ≤ this × the largest dark")  # fmt: skip
    parser.add_argument("--gauss-newton", type=int, default=Settings.gauss_newton,
                        help="Gauss–Newton steps after L-BFGS-B")  # fmt: skip
    parser.add_argument("--tv-continuation", default="",
                        help="TV weights to relax to at the finest level, e.g. 1e-3,3e-4,1e-4 "
                        "(each case is told its noise: the discrepancy stop)")  # fmt: skip
    parser.add_argument(
        "--continuation-iterations",
        type=int,
        default=0,
        help="iterations at each continuation weight (0: --iterations)",
    )
    parser.add_argument("--cases", default="all,few,noisy", help="all, few (4 views), noisy")
    parser.add_argument("--backend", default="cpu", choices=("cpu", "cuda", "reference"))
    parser.add_argument("--out", type=Path)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        spec = json.loads(args.child)
        print(json.dumps(case(spec["n"], spec["pixels"], spec["count"], spec["noise"],
                              spec["options"], spec["backend"],
                              spec.get("deadline_s"))))  # fmt: skip
        return
    plan = {"all": (args.views, 0.0), "few": (4, 0.0), "noisy": (args.views, 0.01)}
    options = {"iterations": args.iterations, "levels": args.levels, "tv_weight": args.tv,
               "tv_eps_K": args.tv_eps,
               "power": args.power, "dark_fraction": args.dark,
               "gauss_newton": args.gauss_newton,
               "continuation_iterations": args.continuation_iterations,
               "tv_continuation": [float(w) for w in args.tv_continuation.split(",")
                                   if w]}  # fmt: skip
    rows = []
    for name in args.cases.split(","):
        count, noise = plan[name]
        told = {**options, "noise": noise}
        row = run_case(args.size, args.pixels, count, noise, told, args.backend)
        rows.append({"case": name, **row})
        print(json.dumps(rows[-1]), flush=True)
    if args.out:
        args.out.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
