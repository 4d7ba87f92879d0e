"""Render the picture of docs/inverse.md: a loss's gradients with respect to a flame's
temperature and absorption grids (central slices), from the float64 adjoint and from Dr.Jit's
replay adjoint, side by side.

    python scripts/inverse_gallery.py --out docs          # docs/inverse/*.png
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from docpage import PageImages
from pyrometry_gallery import _maps

import incandescent as inc
from incandescent.inverse import gradients, gradients_on


def flame(n: int = 24) -> inc.Volume:
    """Two hot lobes in a sooty ball."""
    x = (np.indices((n, n, n)).transpose(1, 2, 3, 0) + 0.5) / n - 0.5
    r1 = np.linalg.norm(x - [0.1, -0.1, 0.0], axis=-1)
    r2 = np.linalg.norm(x - [-0.12, 0.1, 0.0], axis=-1)
    temp = 300 + 1500 * np.exp(-((r1 / 0.2) ** 2)) + 900 * np.exp(-((r2 / 0.15) ** 2))
    kappa = 30.0 * np.exp(-((np.linalg.norm(x, axis=-1) / 0.4) ** 2))
    return inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.1 / n)


def main(argv: Sequence[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs")
    args = parser.parse_args(argv)
    page = PageImages(args.out, "inverse", "scripts/inverse_gallery.py")
    volume = flame()
    camera = inc.Camera(eye=(0.0, 0.0, 0.3), target=(0.0, 0.0, 0.0), fov_deg=25.0)
    settings = inc.RenderSettings(width=32, height=32, jitter=False)
    weights = np.ones((32, 32, 3))  # the loss: the image's summed X + Y + Z
    exact = gradients(volume, camera, settings, weights)
    device = gradients_on("cpu", volume, camera, settings, weights)
    y = volume.shape[1] // 2 - 2

    def cut(grid, compress=True):
        """The x–z slice through the hot lobe, the camera (+z) at the top; signed ⁴√."""
        plane = grid[:, y, :].T[::-1].astype(np.float64)
        if not compress:
            return plane
        plane = np.sign(plane) * np.abs(plane) ** 0.25
        return plane / np.abs(plane).max()

    page.add("gradients", _maps([
        (cut(volume.temperature_K, False), "T (K); camera at top", "inferno", 300, 2100),
        (cut(exact.temperature_K), "∂loss/∂T float64", "coolwarm", -1, 1),
        (cut(device.temperature_K), "∂loss/∂T Dr.Jit", "coolwarm", -1, 1),
        (cut(exact.absorption_per_m), "∂loss/∂κ float64", "coolwarm", -1, 1),
        (cut(device.absorption_per_m), "∂loss/∂κ Dr.Jit", "coolwarm", -1, 1),
    ], "a view's brightness differentiated by the volume (signed fourth roots)"),
        "gradients")  # fmt: skip
    return page.written


if __name__ == "__main__":
    main()
