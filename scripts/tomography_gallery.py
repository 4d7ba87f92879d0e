"""Render the worked examples of docs/inverse.md: a simulated fire (``benchmarks/
reconstruction_accuracy.py``'s, at N³) reconstructed from 12 views on a ring, from 4, and from
3 views with 1 % noise per pixel, and from the 12 again with Gauss–Newton steps after L-BFGS-B
and with the TV continuation (``CONTINUATION``): truth, reconstruction and error slices per
case, the loss curves, and each case's numbers (``tomography/cases.json``).

    python scripts/tomography_gallery.py --out docs            # docs/tomography/*.png
    python scripts/tomography_gallery.py --out /tmp/t --size 12 --pixels 24 --iterations 5
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from docpage import PageImages
from pyrometry_gallery import _figure_pixels, _maps

import incandescent as inc
from incandescent.inverse.reconstruct import Settings, View, reconstruct
from incandescent.io.output import write_json

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from reconstruction_accuracy import fire, ring  # noqa: E402

#: name → (views, noise per pixel, Gauss–Newton steps, TV continuation?)
CASES = {"ring12": (12, 0.0, 0, False), "ring4": (4, 0.0, 0, False),
         "noisy3": (3, 0.01, 0, False), "ring12gn": (12, 0.0, 10, False),
         "ring12tv": (12, 0.0, 0, True)}  # fmt: skip
#: the TV weights relaxed to at the finest level (as ``benchmarks/reconstruction_accuracy.py``)
CONTINUATION = (1e-3, 3e-4, 1e-4, 3e-5)


def solve(truth, count: int, noise: float, pixels: int, iterations: int, steps: int = 0,
          relax: bool = False):  # fmt: skip
    """The reconstruction from ``count`` views (noise: σ relative per pixel; ``steps`` of
    Gauss–Newton after L-BFGS-B; ``relax``: the TV continuation, told the noise) and its RMSE
    over the voxels above 1000 K."""
    cameras, settings = ring(count, pixels)
    rng = np.random.default_rng(30)
    views = []
    for k, camera in enumerate(cameras):
        xyz = np.asarray(inc.render(truth, camera, settings, "cpu").xyz, np.float64)
        noisy = np.maximum(xyz * (1 + noise * rng.standard_normal(xyz.shape)), 0.0)
        views.append(View(noisy, camera, settings, f"view {k + 1}"))
    settings = Settings(iterations=iterations, levels=3, gauss_newton=steps, noise=noise,
                        tv_continuation=CONTINUATION if relax else ())  # fmt: skip
    result = reconstruct(views, truth, settings)
    hot = truth.temperature_K > 1000
    rmse = float(np.sqrt(np.mean((result.volume.temperature_K - truth.temperature_K)[hot] ** 2)))
    return result, rmse


def _slices(truth, result, label: str, rmse: float):
    """The x–y slice through the box's centre (z), y up: truth, reconstruction, error."""

    def cut(grid):
        return np.asarray(grid)[:, :, grid.shape[2] // 2].T[::-1]

    t, r = cut(truth.temperature_K), cut(result.volume.temperature_K)
    return _maps([
        (t, "truth T (K)", "inferno", 300, 2000),
        (r, "reconstructed T (K)", "inferno", 300, 2000),
        (r - t, "error (K)", "coolwarm", -300, 300),
    ], f"{label}: RMSE {rmse:.0f} K over voxels > 1000 K")  # fmt: skip


def _losses(curves: dict[str, list[float]]):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 3.2))
    for name, losses in curves.items():
        ax.semilogy(np.arange(1, len(losses) + 1), losses, label=name)
    ax.set_xlabel("evaluation (coarse 1/4, 1/2, then full grid)")
    ax.set_ylabel("loss")
    ax.legend(fontsize=8)
    return _figure_pixels(fig)


def main(argv: Sequence[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs")
    parser.add_argument("--size", type=int, default=24)
    parser.add_argument("--pixels", type=int, default=48)
    parser.add_argument("--iterations", type=int, default=60)
    args = parser.parse_args(argv)
    page = PageImages(args.out, "tomography", "scripts/tomography_gallery.py")
    truth = fire(args.size)
    curves, numbers = {}, {}
    for name, (count, noise, steps, relax) in CASES.items():
        result, rmse = solve(truth, count, noise, args.pixels, args.iterations, steps, relax)
        label = f"{count} views" + (f", {noise:.0%} noise" if noise else "")
        label += f", {steps} Gauss–Newton steps" if steps else ""
        label += ", TV continuation" if relax else ""
        page.add(name, _slices(truth, result, label, rmse), label)
        curves[label] = result.losses
        numbers[name] = {"views": count, "noise": noise, "gauss_newton": steps, "rmse_hot_K": rmse,
                         "tv_continuation": list(CONTINUATION) if relax else [],
                         "evaluations": len(result.losses)}  # fmt: skip
    page.add("losses", _losses(curves), "loss per evaluation")
    page.written.append(write_json(args.out / "tomography" / "cases.json", numbers, True))
    return page.written


if __name__ == "__main__":
    main()
