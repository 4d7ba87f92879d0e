"""Emission tomography: the temperature grid that explains a set of calibrated views.

Each view is an absolute XYZ image with its camera. The loss is the views' relative squared
error, Σ_v |XYZ_v(T) − XYZ_v*|² / |XYZ_v*|², plus a total-variation prior λ·Σ|∇T| (smoothed,
√(|∇T|² + ε²)); its gradient comes from the replay adjoint (``adjoint``), one forward and one
adjoint march per view and iteration. Adam (Kingma & Ba 2015) takes the steps, in kelvin,
their size decaying as a cosine to 0 over the iterations (Loshchilov & Hutter 2017), and T is
kept within [T_floor, T_ceiling] (positivity). The absorption grid is given (known
soot, e.g. from a separate extinction measurement): T alone is solved.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.camera import Camera
from incandescent.inverse.adjoint import gradients_on
from incandescent.renderer import RenderSettings, render


@dataclass(frozen=True, eq=False)
class View:
    """One calibrated view: its XYZ image (H, W, 3; Y in cd/m²), camera and film settings."""

    xyz: NDArray
    camera: Camera
    settings: RenderSettings

    def __post_init__(self) -> None:
        xyz = np.asarray(self.xyz, dtype=np.float64)
        want = (self.settings.height, self.settings.width, 3)
        if xyz.shape != want:
            raise ValueError(f"a view's image is {xyz.shape}; its settings say {want}")
        if not np.isfinite(xyz).all():
            raise ValueError("a view's image has NaN or infinite pixels")
        if (xyz[..., 1] < 0).any():
            raise ValueError("a view's image has negative luminance")
        object.__setattr__(self, "xyz", xyz)


@dataclass(frozen=True)
class Settings:
    """The optimisation: Adam's step in kelvin and its decay rates, the TV weight (per voxel,
    relative to the data term), the iterations, and T's bounds."""

    iterations: int = 100
    step_K: float = 20.0
    beta1: float = 0.9
    beta2: float = 0.99
    tv_weight: float = 1e-4
    floor_K: float = 300.0
    ceiling_K: float = 4000.0


def total_variation(temp: NDArray, eps: float = 1.0) -> tuple[float, NDArray]:
    """(Σ √(|∇T|² + ε²), its gradient) with forward differences (K; ε in K)."""
    grads = [np.diff(temp, axis=a, append=np.take(temp, [-1], axis=a)) for a in range(3)]
    norm = np.sqrt(sum(g * g for g in grads) + eps * eps)
    out = np.zeros_like(temp)
    for a, g in enumerate(grads):
        unit = g / norm
        out -= unit
        out += np.roll(unit, 1, axis=a) * (np.arange(temp.shape[a]) > 0).reshape(
            [-1 if b == a else 1 for b in range(3)])  # fmt: skip
    return float(norm.sum()), out


def data_term(volume, views: Sequence[View], backend: str) -> tuple[float, NDArray, list]:
    """(Σ_v relative squared error, its T gradient, the rendered images)."""
    loss, grad, images = 0.0, np.zeros(volume.shape), []
    for view in views:
        image = render(volume, view.camera, view.settings, backend)
        scale = 1.0 / max(float(np.sum(view.xyz**2)), 1e-300)
        residual = np.asarray(image.xyz, dtype=np.float64) - view.xyz
        loss += scale * float(np.sum(residual**2))
        weights = 2.0 * scale * residual
        grad += gradients_on(backend, volume, view.camera, view.settings, weights,
                             image).temperature_K  # fmt: skip
        images.append(image)
    return loss, grad, images


def reconstruct(
    views: Sequence[View],
    start,
    settings: Settings = Settings(),
    backend: str = "cpu",
    progress: Callable | None = None,
):
    """T on ``start``'s grid (its absorption and placement kept) that fits ``views``; returns
    (the volume, the loss per iteration)."""
    temp = np.asarray(start.temperature_K, dtype=np.float64)
    m, v, losses = np.zeros_like(temp), np.zeros_like(temp), []
    volume = start
    for it in range(1, settings.iterations + 1):
        volume = start.replace(temperature_K=temp.astype(np.float32))
        loss, grad, _ = data_term(volume, views, backend)
        tv, tv_grad = total_variation(temp)
        loss, grad = loss + settings.tv_weight * tv, grad + settings.tv_weight * tv_grad
        m = settings.beta1 * m + (1 - settings.beta1) * grad
        v = settings.beta2 * v + (1 - settings.beta2) * grad * grad
        m_hat, v_hat = m / (1 - settings.beta1**it), v / (1 - settings.beta2**it)
        rate = settings.step_K * 0.5 * (1.0 + np.cos(np.pi * (it - 1) / settings.iterations))
        step = rate * m_hat / (np.sqrt(v_hat) + 1e-30)
        temp = np.clip(temp - np.where(v_hat > 0, step, 0.0), settings.floor_K, settings.ceiling_K)
        losses.append(loss)
        if progress is not None:
            progress(it, loss)
    return start.replace(temperature_K=temp.astype(np.float32)), losses
