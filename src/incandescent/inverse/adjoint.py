"""The Dr.Jit adjoint of grey emission–absorption: a second march that replays each ray front
to back and scatter-adds ∂loss/∂κ and ∂loss/∂T into two grids, on the CPU (LLVM) or CUDA.

It needs no tape: with the ray's total radiance L from the forward render, the light from
behind segment k is L − L_{≤k} (what the march has summed up to and including k), so

    ∂loss/∂κ_k = Δs_k (Tr_k e^{−κ_kΔs_k} g·S(T_k) − g·(L − L_{≤k})),
    ∂loss/∂T_k = Tr_k α_k g·S′(T_k)

are known at segment k as the march reaches it (the replay of radiative backpropagation,
Nimier-David et al. 2020). Memory is the forward render's plus the two gradient grids and the
rays' g and L. S′ is the central difference of the emission table at T ± 1 K (the table is
linear between its entries). Every hot voxel counts as occupied, so empty-space skipping never
jumps a sample whose κ gradient is not zero; a κ = 0 sample is processed where T ≥ the table's
T_min. Dense layout, grey band, one ray per pixel, a κ grid of its own (not made from T).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.inverse.gradients import ray_ordered
from incandescent.renderer import render
from incandescent.renderer.backends.common import THIN_STEP
from incandescent.renderer.integrators import emission_absorption as ea

#: The central difference of S′(T), K.
DT_K = 1.0


@dataclass(frozen=True)
class AdjointEmissionAbsorption(ea.EmissionAbsorption):
    """Grey emission–absorption whose traced step also scatter-adds the loss's gradients
    (``upstream``: g per ray (n, 3); ``totals``: the forward render's L per ray (n, 3); the
    gradient grids land in ``sink``)."""

    upstream: Any = field(default=None, compare=False, repr=False)
    totals: Any = field(default=None, compare=False, repr=False)
    sink: list = field(default_factory=list, compare=False, repr=False)

    name = "emission_absorption_adjoint"

    def occupancy(self, models) -> tuple[str, Callable | None]:
        """κ > 0, or hot enough to emit once κ > 0 (T ≥ the table's T_min)."""
        t_min = self.first_table(models).t_min_K

        def grid(volume) -> NDArray:
            hot = (volume.temperature_K >= t_min).astype(np.float32)
            return np.maximum(volume.absorption_per_m, hot)

        return f"absorption or T >= {t_min:g}", grid

    def sparse_problem(self, models) -> str | None:
        return "the adjoint scatters into dense gradient grids"

    def traced(self, kernel):
        program = _Traced(kernel, self)
        self.sink.append(program)
        return program

    def reference(self, inputs):
        raise ValueError("the float64 adjoint is inverse.gradients; this one is Dr.Jit's")


class _Traced(ea._Traced):
    """The forward step plus its gradients, scatter-added at the sample's eight voxels."""

    def __init__(self, kernel, integrator: AdjointEmissionAbsorption) -> None:
        super().__init__(kernel)
        m, dr = kernel.m, kernel.dr
        upstream = np.asarray(integrator.upstream, dtype=np.float32)
        totals = np.asarray(integrator.totals, dtype=np.float32)
        self.g = [m.Float(np.ascontiguousarray(upstream[:, a])) for a in range(3)]
        self.total = [m.Float(np.ascontiguousarray(totals[:, a])) for a in range(3)]
        size = int(np.prod(kernel.shape))
        self.grad_kappa, self.grad_temp = dr.zeros(m.Float, size), dr.zeros(m.Float, size)

    def interacts(self, kappa, temp, sampled):
        present, emits = super().interacts(kappa, temp, sampled)
        return present | (temp >= self.kernel.lut_t_min), emits

    def _per_ray(self, arrays):
        K = self.kernel
        return K.m.Array3f(*(K.dr.gather(K.m.Float, a, K.ray_index) for a in arrays))

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        K = self.kernel
        dr = K.dr
        x = kappa * ds_m
        through = dr.exp(-x)
        alpha = dr.select(x < THIN_STEP, x * (1.0 - x * (0.5 - x * (1.0 / 6.0))), 1.0 - through)
        hot = temp >= K.lut_t_min
        source = dr.select(hot, self.source_function(0, K.lut_position(temp), sampled), 0.0)
        L_new = dr.fma(source, tr * alpha, L)
        g = self._per_ray(self.g)
        behind = self._per_ray(self.total) - L_new
        d_kappa = ds_m * (tr * through * dr.dot(g, source) - dr.dot(g, behind))
        up = self.source_function(0, K.lut_position(temp + DT_K), sampled)
        down = self.source_function(0, K.lut_position(dr.maximum(temp - DT_K, 1.0)), sampled)
        slope = (up - down) * (0.5 / DT_K)
        d_temp = dr.select(hot, tr * alpha * dr.dot(g, slope), 0.0)
        self._scatter(self.grad_kappa, c, d_kappa)
        self._scatter(self.grad_temp, c, d_temp)
        return tr * through, L_new

    def _scatter(self, grid, c, values) -> None:
        """Add ``values`` at the trilinear corners c (``Kernel.corners``) with their weights."""
        K = self.kernel
        dr = K.dr
        base, (fx, fy, fz) = c
        sx, sy, sz = K.strides
        for corner in range(8):
            ux, uy, uz = corner & 1, (corner >> 1) & 1, (corner >> 2) & 1
            w = (fx if ux else 1.0 - fx) * (fy if uy else 1.0 - fy) * (fz if uz else 1.0 - fz)
            dr.scatter_reduce(
                dr.ReduceOp.Add, grid, values * w, base + (ux * sx + uy * sy + uz * sz)
            )


@dataclass(frozen=True, eq=False)
class DeviceGradients:
    """∂loss/∂T and ∂loss/∂κ per voxel from a Dr.Jit backend, float32, shaped as the volume."""

    temperature_K: NDArray[np.float32]
    absorption_per_m: NDArray[np.float32]


def gradients_on(
    backend: str, volume, camera, settings, weights: NDArray, image=None
) -> DeviceGradients:
    """The gradients of the loss Σ_pixels weights·XYZ on ``backend`` (cpu, cuda): the forward
    render (or ``image``, that render already made), then the replay adjoint with each ray's
    L and g."""
    if settings.supersample != 1 or volume.absorption_source != "grid":
        raise ValueError("the adjoint needs one ray per pixel and a κ grid of its own")
    if volume.species or volume.emission_scale is not None:
        raise ValueError("gradients cover blackbody emission–absorption: no species lines or "
                         "emission scale yet")  # fmt: skip
    if image is None:
        image = render(volume, camera, settings, backend)
    assert image.xyz is not None, "emission–absorption renders radiance"
    totals, upstream = ray_ordered(image.xyz), ray_ordered(weights)  # indexed by camera ray
    adjoint = AdjointEmissionAbsorption(upstream=upstream, totals=totals)
    render(volume, camera, settings, backend, integrator=adjoint)
    program = adjoint.sink[-1]
    grad_t, grad_k = (np.asarray(g, dtype=np.float32).reshape(volume.shape)
                      for g in (program.grad_temp, program.grad_kappa))  # fmt: skip
    return DeviceGradients(grad_t, grad_k)
