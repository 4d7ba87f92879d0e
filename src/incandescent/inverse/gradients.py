"""Gradients of a render with respect to its volume: the exact adjoint of emission–absorption,
in float64 on the reference march (the ground truth the Dr.Jit adjoint will be checked
against).

Along a ray the march sums, per segment k of length Δs_k at a sample of absorption κ_k and
temperature T_k (trilinear in the grids),

    L = Σ_k Tr_k α_k S(T_k),   α_k = 1 − e^{−κ_k Δs_k},   Tr_k = Π_{j<k} e^{−κ_j Δs_j},

so for a loss with upstream gradient g = ∂loss/∂L (one XYZ vector per ray)

    ∂loss/∂T_k = Tr_k α_k g·S′(T_k),
    ∂loss/∂κ_k = Δs_k (Tr_k e^{−κ_kΔs_k} g·S(T_k) − g·R_k),   R_k = Σ_{j>k} Tr_j α_j S(T_j),

R_k being the light from behind segment k that it attenuates. The forward march records only
where each ray's segments lie and their transmittance on arrival; the backward pass replays
them from the last to the first, recomputing κ, T and S (the replay of radiative
backpropagation, Nimier-David et al. 2020, ACM TOG 39:4), and scatters each segment's
gradients to its eight voxels with the trilinear weights. S′ is a central difference of the
exact Planck × CMF source (h = 10 mK; float64). Grey blackbody emission only: species lines, an
emission scale and spectral bins are refused in one line.
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
    if volume.species or volume.emission_scale is not None:
        raise ValueError("gradients cover blackbody emission–absorption: no species lines or "
                         "emission scale yet")  # fmt: skip
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
    grad_t, grad_k = _backward(program, g)
    return Gradients(loss, xyz, ray, grad_t, grad_k)


def ray_ordered(image: NDArray) -> NDArray[np.float64]:
    """An (H, W, 3) image as per-camera-ray rows (H·W, 3): camera rays run column-major
    (``film.resolve_pixels``), ray x·H + y being pixel (y, x)."""
    return np.ascontiguousarray(np.swapaxes(np.asarray(image, dtype=np.float64), 0, 1)).reshape(
        -1, 3
    )


def _backward(program: _Taping, g: NDArray) -> tuple[NDArray, NDArray]:
    """Replay the tape from its last segment to its first, accumulating ∂loss/∂T and ∂loss/∂κ
    per sample and scattering them to the voxels."""
    vol = program.inputs.volume
    behind = np.zeros_like(g)  # g·R per ray is g·behind[r]
    grad_t, grad_k = np.zeros(vol.shape), np.zeros(vol.shape)
    for r, p, ds_m, tr in reversed(program.tape):
        kappa, temp = trilinear(vol.absorption_per_m, p), trilinear(vol.temperature_K, p)
        sampled = ea._sampled(program.inputs, p)
        source = program.emission_xyz(temp, sampled)
        slope = (program.emission_xyz(temp + DT_K, sampled)
                 - program.emission_xyz(temp - DT_K, sampled)) / (2 * DT_K)  # fmt: skip
        through = np.exp(-kappa * ds_m)
        gr = g[r]
        d_temp = tr * (1.0 - through) * np.einsum("ij,ij->i", gr, slope)
        d_kappa = ds_m * (tr * through * np.einsum("ij,ij->i", gr, source)
                          - np.einsum("ij,ij->i", gr, behind[r]))  # fmt: skip
        behind[r] += (tr * (1.0 - through))[:, None] * source
        _scatter(grad_t, p, d_temp)
        _scatter(grad_k, p, d_kappa)
    return grad_t, grad_k


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
