"""Emission tomography (``inverse.reconstruct``): six views of a small two-lobed flame with its
absorption known; the fit and what a view that cannot be used says."""

from __future__ import annotations

import numpy as np
import pytest

import incandescent as inc
from incandescent.inverse.reconstruct import Settings, View, reconstruct


def _flame(n: int = 10) -> inc.Volume:
    x = (np.indices((n, n, n)).transpose(1, 2, 3, 0) + 0.5) / n - 0.5
    r1 = np.linalg.norm(x - [0.1, -0.1, 0.05], axis=-1)
    r2 = np.linalg.norm(x - [-0.12, 0.1, -0.05], axis=-1)
    temp = 300 + 1500 * np.exp(-((r1 / 0.2) ** 2)) + 900 * np.exp(-((r2 / 0.15) ** 2))
    kappa = 8.0 * np.exp(-((np.linalg.norm(x, axis=-1) / 0.4) ** 2))
    return inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.1 / n)


def _views(truth, count=6, pixels=16):
    settings = inc.RenderSettings(width=pixels, height=pixels, jitter=False)
    out = []
    for k in range(count):
        a = 2 * np.pi * k / count
        camera = inc.Camera(eye=(0.25 * np.sin(a), 0.05 * (k % 2), 0.25 * np.cos(a)),
                            target=(0.0, 0.0, 0.0), fov_deg=30.0)  # fmt: skip
        out.append(View(inc.render(truth, camera, settings, "cpu").xyz, camera, settings))
    return out


def test_six_views_pull_a_flat_start_toward_the_flame():
    """From 1200 K everywhere, 80 Adam steps with a small TV prior: the loss falls over 50×
    (measured 5.48 → 0.065) and the re-rendered views come within 10 % (L1; measured 4.6 %),
    but the field itself only begins to follow: the RMSE over voxels above 1000 K falls from
    199 K to 165 K (six views of 16² for 10³ voxels leave T under-determined). Far from what
    issue 30 asks of a 64³ fire from 12 views (RMSE ≤ 50 K, views within 1 %)."""
    truth = _flame()
    views = _views(truth)
    start = truth.replace(temperature_K=np.full(truth.shape, 1200.0, dtype=np.float32))
    result, losses = reconstruct(views, start, Settings(iterations=80, step_K=40.0,
                                                         tv_weight=1e-6))  # fmt: skip
    assert losses[-1] < losses[0] / 50
    hot = truth.temperature_K > 1000

    def rmse(volume):
        return float(np.sqrt(np.mean((volume.temperature_K - truth.temperature_K)[hot] ** 2)))

    assert rmse(result) < rmse(start)
    for view in views:
        again = inc.render(result, view.camera, view.settings, "cpu").xyz
        assert np.abs(again - view.xyz).sum() < 0.1 * view.xyz.sum()


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((8, 16, 3)), r"is \(8, 16, 3\); its settings say \(16, 16, 3\)"),
        (np.full((16, 16, 3), np.nan), "NaN or infinite"),
        (np.full((16, 16, 3), -1.0), "negative luminance"),
    ],
)
def test_a_view_that_cannot_be_used_is_one_line(image, message):
    settings = inc.RenderSettings(width=16, height=16)
    with pytest.raises(ValueError, match=message):
        View(image, inc.Camera(eye=(0.0, 0.0, 1.0)), settings)
