"""Gauss–Newton refinement of a reconstruction at its finest level (``Settings.gauss_newton``).

L-BFGS-B stalls on the emission tomography objective f(T) = |r(T)|²/N + λ·TV(T) long before
its minimum: on the held-out fire at 32³ it stops at f = 1.0·10⁻³ with 82–85 K RMSE, while the
truth itself, polished by the same optimiser from there, sits at f = 3.9·10⁻⁴ and 4.7 K — the
objective is not what limits the accuracy, the optimiser is. Its curvature estimate from a
few dozen gradient pairs cannot resolve the ill-conditioned directions (voxels whose light
the flame in front of them nearly hides, the rim's steep fall from 1 300 to 700 K).

Each step here solves the Levenberg–Marquardt system (Marquardt 1963)

    (2·JᵀJ/N + λ·H_TV + μ) p = −∇f

by conjugate gradients (``gauss_newton_cg`` iterations; a truncated Newton method, Nocedal &
Wright 2006 §7.1) with J the views' Jacobian in T: J·d by central differences of two renders
(a 10 K step on the direction's largest voxel; the renders are float32, so the difference
keeps ~5 digits), Jᵀ·w by the replay adjoint the gradient uses, H_TV·d by central differences
of the TV's gradient. μ is 10⁻⁵ of the Rayleigh quotient of the undamped matrix along ∇f.
Bounds (``visible_K`` ≤ T ≤ ``ceiling_K``) are kept by projection: a voxel at a bound whose
gradient pushes outward is held for the step (an active set, Bertsekas 1982), the step is
clipped and halved until f falls (at most :data:`HALVINGS` times; a step that never lowers f
is not taken). Dark voxels stay at the floor.

Measured on the held-out fire at 32³ (12 views of 64², ``benchmarks/reconstruction_accuracy``):
from L-BFGS-B's 84.7 K, 15 steps of 60 CG iterations at μ = 10⁻⁵ reach 63.4 K (f 1.01·10⁻³ →
6.65·10⁻⁴); at μ = 10⁻³, 40 steps of 30 iterations only 63.5 K (a larger μ damps the soft
directions that carry the error, so the steps shrink).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from incandescent.renderer import render

#: The central difference's step on the direction's largest voxel, K.
JVP_STEP_K = 10.0
#: μ relative to the undamped matrix's Rayleigh quotient along the gradient.
DAMPING = 1e-5
#: Halvings of a step that does not lower the objective before it is given up.
HALVINGS = 6


class Model:
    """The objective of one reconstruction at its finest level, in T (K): the views' squared
    residuals over N = Σ|XYZ*|², plus ``tv_weight``·TV(T)/(voxels·1000 K) as the L-BFGS-B
    stage has it. ``films``: (camera or rig, render settings, the input XYZ side by side) per
    group of views rendered together; ``free`` marks the unknowns (not dark); ``tv(T, ε)`` is
    (TV, its gradient) and ``adjoint(backend, volume, camera, settings, w, image)`` ∂(Σ w·XYZ)/∂
    (T, κ), as ``inverse.reconstruct`` has them."""

    def __init__(self, films: Sequence[tuple], grid, settings, backend: str, free: NDArray,
                 tv: Callable, adjoint: Callable) -> None:  # fmt: skip
        self.films, self.grid, self.settings, self.backend = films, grid, settings, backend
        self.tv, self.adjoint = tv, adjoint
        self.norm = max(sum(float(np.sum(f[2] ** 2)) for f in films), 1e-300)
        self.weight = settings.tv_weight / (grid.temperature_K.size * 1000.0)
        self.free = free.astype(np.float64)

    def volume(self, temp: NDArray):
        return self.grid.replace(temperature_K=temp.astype(np.float32))

    def residuals(self, temp: NDArray) -> list[tuple]:
        """(rendered − input XYZ, the image, its camera, its settings) per film group."""
        out = []
        for camera, settings, target in self.films:
            image = render(self.volume(temp), camera, settings, self.backend)
            out.append((np.asarray(image.xyz, np.float64) - target, image, camera, settings))
        return out

    def loss(self, temp: NDArray, parts: list[tuple]) -> float:
        tv, _ = self.tv(temp, self.settings.tv_eps_K)
        return sum(float(np.sum(p[0] ** 2)) for p in parts) / self.norm + self.weight * tv

    def transposed(self, temp: NDArray, parts: list[tuple], weights: list[NDArray]) -> NDArray:
        """Jᵀ·w: ∂(Σ w·XYZ)/∂T by the adjoint, over the free voxels."""
        out = np.zeros(temp.shape)
        for (_, image, camera, settings), w in zip(parts, weights, strict=True):
            out += self.adjoint(self.backend, self.volume(temp), camera, settings, w, image)[0]
        return out * self.free

    def tv_gradient(self, temp: NDArray) -> NDArray:
        return self.weight * self.tv(temp, self.settings.tv_eps_K)[1]

    def gradient(self, temp: NDArray, parts: list[tuple]) -> NDArray:
        data = self.transposed(temp, parts, [2.0 * p[0] / self.norm for p in parts])
        return data + self.tv_gradient(temp) * self.free

    def curvature(self, temp: NDArray, parts: list[tuple], d: NDArray) -> NDArray:
        """(2·JᵀJ/N + λ·H_TV)·d, J·d and H_TV·d by central differences."""
        scale = max(float(np.abs(d).max()), 1e-300)
        unit, h = d / scale, JVP_STEP_K
        ahead, behind = self.residuals(temp + h * unit), self.residuals(temp - h * unit)
        jd = [(a[0] - b[0]) / (2.0 * h) for a, b in zip(ahead, behind, strict=True)]
        data = self.transposed(temp, parts, [2.0 * x / self.norm for x in jd])
        tv = (self.tv_gradient(temp + h * unit) - self.tv_gradient(temp - h * unit)) / (2.0 * h)
        return (data + tv * self.free) * scale


def _conjugate_gradients(product: Callable[[NDArray], NDArray], g: NDArray, its: int) -> NDArray:
    """p with product(p) ≈ −g after ``its`` CG iterations from 0 (stops at non-positive
    curvature)."""
    p, r = np.zeros_like(g), -g
    z, rz = r.copy(), float(np.sum(r * r))
    for _ in range(its):
        hz = product(z)
        curvature = float(np.sum(z * hz))
        if curvature <= 0.0 or rz == 0.0:
            break
        alpha = rz / curvature
        p, r = p + alpha * z, r - alpha * hz
        rz_next = float(np.sum(r * r))
        z, rz = r + (rz_next / rz) * z, rz_next
    return p


def step(model: Model, temp: NDArray, parts: list[tuple], loss: float) -> tuple:
    """One projected Levenberg–Marquardt step: (T, its parts, its loss), unchanged if no
    halving of the step lowered the loss."""
    s = model.settings
    lo, hi = s.visible_K, s.ceiling_K
    g = model.gradient(temp, parts)
    held = ((temp <= lo + 1e-6) & (g > 0)) | ((temp >= hi - 1e-6) & (g < 0))
    mask = model.free * ~held
    g = g * mask
    if not np.any(g):
        return temp, parts, loss
    mu = DAMPING * float(np.sum(g * model.curvature(temp, parts, g)) / np.sum(g * g))

    def product(d: NDArray) -> NDArray:
        return (model.curvature(temp, parts, d) + mu * d) * mask

    p = _conjugate_gradients(product, g, s.gauss_newton_cg)
    fixed = model.free == 0
    for _ in range(HALVINGS + 1):
        trial = np.where(fixed, temp, np.clip(temp + p, lo, hi))
        trial_parts = model.residuals(trial)
        trial_loss = model.loss(trial, trial_parts)
        if trial_loss < loss:
            return trial, trial_parts, trial_loss
        p = 0.5 * p
    return temp, parts, loss
