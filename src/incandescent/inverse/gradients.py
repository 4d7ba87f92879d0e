"""Gradients of a render with respect to its volume: the exact adjoint of emission–absorption,
in float64 on the reference march (the ground truth the Dr.Jit adjoint is checked against).

Along a ray the march adds, per segment k of length Δs_k at a sample of absorption κ_k,
temperature T_k and species fractions f_k (trilinear in the grids),

    L = Σ_k Tr_k w(κ_k) η_k,   η = κ·S(T) + Σ_s f_s Φ_s(T),   w(κ) = (1 − e^{−κΔs})/κ,

Tr_k = Π_{j<k} e^{−κ_j Δs_j} (without lines, w·η = (1 − e^{−κΔs}) S). So for a loss with upstream
gradient g = ∂loss/∂L (one XYZ vector per ray)

    ∂loss/∂f_s = Tr w g·Φ_s,   ∂loss/∂T = Tr w g·∂η/∂T,
    ∂loss/∂κ = Tr (w′ g·η + w g·S) − Δs g·R_k,

R_k being the light from behind segment k that it attenuates. The forward march records only
where each ray's segments lie and their transmittance on arrival; the backward pass replays
them from the last to the first, recomputing κ, T, f, S and Φ (the replay of radiative
backpropagation, Nimier-David et al. 2020, ACM TOG 39:4), and scatters each segment's
gradients to its eight voxels with the trilinear weights. ∂η/∂T is a central difference of the
exact Planck × CMF and line terms (h = 10 mK; float64). Grey band; an emission scale is refused
in one line.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from incandescent.renderer import render
from incandescent.renderer.backends.common import Segment, trilinear, trilinear_setup
from incandescent.renderer.integrators import emission_absorption as ea

#: The central difference step of S′(T), K.
DT_K = 1e-2


@dataclass(frozen=True, eq=False)
class Gradients:
    """A loss and its gradients: ``loss``, the per-ray XYZ (n, 3, float64) and each row's camera
    ray (``ray``: x·H + y is pixel (y, x)), and ∂loss/∂T (K⁻¹) and ∂loss/∂κ (m) per voxel, shaped
    as the volume."""

    loss: float
    xyz: NDArray[np.float64]
    ray: NDArray[np.int64]
    temperature_K: NDArray[np.float64]
    absorption_per_m: NDArray[np.float64]
    #: ∂loss/∂(fraction) per voxel of each species grid
    species: dict[str, NDArray[np.float64]] = field(default_factory=dict)


class _Taping(ea._Reference):
    """The exact grey reference step, recording each segment (rays, midpoints, lengths and the
    transmittance on arrival) and keeping the per-ray XYZ it accumulates."""

    def __init__(self, inputs) -> None:
        super().__init__(inputs)
        self.tape: list[tuple[NDArray, NDArray, NDArray, NDArray]] = []
        self.xyz: NDArray | None = None

    def step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        self.xyz = xyz
        self.tape.append((segment.r, segment.p, segment.ds_m, tr[segment.r].copy()))
        return super().step(segment, xyz, tr)


@dataclass(frozen=True)
class _Taped(ea.EmissionAbsorption):
    """Grey emission–absorption whose reference program tapes (kept in ``programs``)."""

    programs: list = field(default_factory=list, compare=False, repr=False)

    def reference(self, inputs):
        program = _Taping(inputs)
        self.programs.append(program)
        return program


def _check(volume, settings) -> None:
    """One line for what the adjoint does not cover yet."""
    if volume.emission_scale is not None:
        raise ValueError("gradients cover emission–absorption without an emission scale")
    if settings.supersample != 1:
        raise ValueError(
            f"gradients need one ray per pixel; got supersample {settings.supersample}"
        )


def forward(volume, camera, settings) -> tuple[_Taping, NDArray, NDArray]:
    """The float64 reference render, taped: (program, per-ray XYZ (n, 3), their camera rays)."""
    _check(volume, settings)
    integrator = _Taped()
    render(volume, camera, settings, "reference", integrator=integrator)
    program = integrator.programs[-1]
    rays = program.inputs.rays
    xyz = np.zeros((rays.size, 3)) if program.xyz is None else program.xyz
    return program, xyz, np.asarray(rays.ray_index, dtype=np.int64)


def gradients(volume, camera, settings, weights: NDArray) -> Gradients:
    """The linear loss Σ_pixels weights·XYZ (``weights`` (H, W, 3): ∂loss/∂XYZ of the image, e.g.
    2·(XYZ − target) of a least-squares loss) and its exact gradients with respect to the
    volume's temperature and absorption grids."""
    program, xyz, ray = forward(volume, camera, settings)
    g = ray_ordered(weights)[ray]  # ∂loss/∂L per ray
    loss = float(np.sum(g * xyz))
    grad_t, grad_k, grad_f = _backward(program, g)
    return Gradients(loss, xyz, ray, grad_t, grad_k, grad_f)


def ray_ordered(image: NDArray) -> NDArray[np.float64]:
    """An (H, W, 3) image as per-camera-ray rows (H·W, 3): camera rays run column-major
    (``film.resolve_pixels``), ray x·H + y being pixel (y, x)."""
    return np.ascontiguousarray(np.swapaxes(np.asarray(image, dtype=np.float64), 0, 1)).reshape(
        -1, 3
    )


def _terms(program: _Taping, temp: NDArray, sampled) -> tuple[NDArray, list[NDArray]]:
    """(S: the source models' XYZ per unit κ, [Φ_s: each species' XYZ per metre per unit
    fraction]) at the samples, zero below the table's T_min as the forward's are."""
    inputs = program.inputs
    source, lines = program.emission_xyz(temp, sampled), []
    hot = temp >= inputs.lut.t_min_K
    for model, values in zip(inputs.models, sampled, strict=True):
        if model.kind != "coefficient":
            continue
        for s in range(len(values)):
            unit = [np.full(temp.shape, 1.0 if j == s else 0.0) for j in range(len(values))]
            phi = model.reference_add(np.zeros(temp.shape + (3,)), temp, unit, inputs)
            lines.append(np.where(hot[:, None], phi, 0.0))
    return source, lines


def _eta(kappa, source, lines, fractions) -> NDArray:
    """η = κ·S + Σ f_s Φ_s, XYZ per metre."""
    eta = kappa[:, None] * source
    for phi, f in zip(lines, fractions, strict=True):
        eta = eta + f[:, None] * phi
    return eta


def _weights(kappa: NDArray, ds_m: NDArray) -> tuple[NDArray, NDArray]:
    """w = (1 − e^{−κΔs})/κ (the segment's exact weight of η) and dw/dκ; their series where
    κΔs < 1e-4."""
    x = kappa * ds_m
    small = x < 1e-4
    safe = np.where(small, 1.0, kappa)
    w = np.where(small, ds_m * (1 - x / 2 + x * x / 6), -np.expm1(-x) / safe)
    dw = np.where(small, ds_m * ds_m * (-0.5 + x / 3 - x * x / 8),
                  (ds_m * np.exp(-x) * safe + np.expm1(-x)) / safe**2)  # fmt: skip
    return w, dw


def _backward(program: _Taping, g: NDArray):
    """Replay the tape from its last segment to its first, accumulating ∂loss/∂T, ∂loss/∂κ and
    ∂loss/∂f (each species) per sample and scattering them to the voxels. Per segment the
    forward adds Tr·w(κ)·η(κ, T, f) (``_weights``, ``_eta``)."""
    vol = program.inputs.volume
    behind = np.zeros_like(g)  # the light from behind, per ray: Σ over later segments
    grad_t, grad_k = np.zeros(vol.shape), np.zeros(vol.shape)
    grad_f = {name: np.zeros(vol.shape) for name in vol.species}
    dot = _dot
    for r, p, ds_m, tr in reversed(program.tape):
        kappa, temp = trilinear(vol.absorption_per_m, p), trilinear(vol.temperature_K, p)
        sampled = ea._sampled(program.inputs, p)
        fractions = [trilinear(vol.species[name], p) for name in vol.species]
        source, lines = _terms(program, temp, sampled)
        up, down = (_terms(program, temp + d, sampled) for d in (DT_K, -DT_K))
        eta = _eta(kappa, source, lines, fractions)
        slope = (_eta(kappa, *up, fractions) - _eta(kappa, *down, fractions)) / (2 * DT_K)
        w, dw = _weights(kappa, ds_m)
        gr = g[r]
        _scatter(grad_t, p, tr * w * dot(gr, slope))
        _scatter(grad_k, p, tr * (dw * dot(gr, eta) + w * dot(gr, source))
                 - ds_m * dot(gr, behind[r]))  # fmt: skip
        for name, phi in zip(vol.species, lines, strict=True):
            _scatter(grad_f[name], p, tr * w * dot(gr, phi))
        behind[r] += (tr * w)[:, None] * eta
    return grad_t, grad_k, grad_f


def _dot(a: NDArray, b: NDArray) -> NDArray:
    return np.einsum("ij,ij->i", a, b)


def _scatter(grid: NDArray, p: NDArray, values: NDArray) -> None:
    """Add ``values`` at positions p (voxel coordinates) to ``grid`` with the trilinear
    weights of ``common.trilinear`` (its transpose), in place."""
    axes = [trilinear_setup(p[:, a], grid.shape[a]) for a in range(3)]
    for corner in range(8):
        index, weight = [], np.ones(len(p))
        for a, (i0, i1, f) in enumerate(axes):
            upper = (corner >> a) & 1
            index.append(i1 if upper else i0)
            weight = weight * (f if upper else 1.0 - f)
        np.add.at(grid, tuple(index), weight * values)
