"""The Dr.Jit adjoint of grey emission–absorption: a second march that replays each ray front
to back and scatter-adds ∂loss/∂κ, ∂loss/∂T and ∂loss/∂(species fraction) into grids, on the
CPU (LLVM) or CUDA.

It needs no tape: with the ray's total radiance L from the forward render, the light from
behind segment k is L − L_{≤k} (what the march has summed up to and including k), so

    ∂loss/∂κ_k = Δs_k (Tr_k e^{−κ_kΔs_k} g·S(T_k) − g·(L − L_{≤k})),
    ∂loss/∂T_k = Tr_k α_k g·S′(T_k)

are known at segment k as the march reaches it (the replay of radiative backpropagation,
Nimier-David et al. 2020). With species lines the segment adds Tr_k w(κ_k) η_k, η = κS + Σ f_sΦ_s
(w = (1 − e^{−κΔs})/κ), and the gradients are ``gradients``' weight form, ∂loss/∂f_s = Tr w g·Φ_s
among them. Memory is the forward render's plus the gradient grids and the rays' g and L. S′
(and η′) is the central difference of the emission tables at T ± 1 K (they are linear between
their entries). Every hot voxel counts as occupied, so empty-space skipping never
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
        #: ∂loss/∂(fraction) of each coefficient model's grids, in order (``fraction_names``)
        self.fraction_names = [name for model, _, _ in self.coefficients
                               for name in _grid_names(model)]  # fmt: skip
        self.grad_fractions = [dr.zeros(m.Float, size) for _ in self.fraction_names]

    def interacts(self, kappa, temp, sampled):
        present, emits = super().interacts(kappa, temp, sampled)
        return present | (temp >= self.kernel.lut_t_min), emits

    def _per_ray(self, arrays):
        K = self.kernel
        return K.m.Array3f(*(K.dr.gather(K.m.Float, a, K.ray_index) for a in arrays))

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        """The forward segment update, and its gradients scatter-added (grey blackbody: the
        ``alpha`` form; with lines: the weight form of ``gradients``)."""
        if self.coefficients:
            return self._step_lines(tr, L, kappa, temp, c, ds_m, sampled)
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

    def _step_lines(self, tr, L, kappa, temp, c, ds_m, sampled):
        """With coefficient models (species lines): the segment adds Tr·w(κ)·η, η = κ·S(T) +
        Σ f_s Φ_s(T), w = (1 − e^{−κΔs})/κ, so ∂/∂f_s = Tr·w·g·Φ_s, ∂/∂T = Tr·w·g·∂η/∂T and
        ∂/∂κ = Tr·(w′·g·η + w·g·S) − Δs·g·R (``gradients``' derivation)."""
        K = self.kernel
        dr = K.dr
        x = kappa * ds_m
        through = dr.exp(-x)
        w, dw = _weights(dr, kappa, ds_m, x, through)
        hot = temp >= K.lut_t_min
        position = K.lut_position(temp)
        eta = self.emission_coefficient(0, kappa, temp, sampled)
        L_new = dr.fma(eta, tr * w, L)
        g = self._per_ray(self.g)
        behind = self._per_ray(self.total) - L_new
        source = dr.select(hot, self.source_function(0, position, sampled), 0.0)
        d_kappa = tr * (dw * dr.dot(g, eta) + w * dr.dot(g, source)) - ds_m * dr.dot(g, behind)
        up = self.emission_coefficient(0, kappa, temp + DT_K, sampled)
        down = self.emission_coefficient(0, kappa, dr.maximum(temp - DT_K, 1.0), sampled)
        d_temp = dr.select(hot, tr * w * dr.dot(g, up - down) * (0.5 / DT_K), 0.0)
        self._scatter(self.grad_kappa, c, d_kappa)
        self._scatter(self.grad_temp, c, d_temp)
        for grid, phi in zip(self.grad_fractions, self._line_terms(position, sampled),
                             strict=True):  # fmt: skip
            self._scatter(grid, c, dr.select(hot, tr * w * dr.dot(g, phi), 0.0))
        return tr * through, L_new

    def _line_terms(self, position, sampled) -> list:
        """Φ_s: each coefficient model's term per unit of each of its fractions (XYZ per metre;
        the models are linear in their fractions, as ``gradients._terms`` assumes)."""
        K = self.kernel
        out = []
        for model, bound, i in self.coefficients:
            n = len(sampled[i])
            for s in range(n):
                unit = [K.m.Float(1.0 if j == s else 0.0) for j in range(n)]
                out.append(model.add(K, bound, K.m.Array3f(0.0), 0, position, unit))
        return out

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


def _grid_names(model) -> tuple[str, ...]:
    """The names of a coefficient model's fraction grids (a species' name)."""
    return tuple(getattr(model, "species", ()))


def _weights(dr, kappa, ds_m, x, through):
    """w = (1 − e^{−κΔs})/κ as the forward march has it (its series below ``THIN_STEP``) and
    dw/dκ (its series Δs²(−½ + x/3 − x²/8 + x³/30) below x = 10⁻², where the closed form
    cancels in float32)."""
    w = dr.select(x < THIN_STEP, ds_m * (1.0 - x * (0.5 - x * (1.0 / 6.0))),
                  (1.0 - through) / kappa)  # fmt: skip
    series = ds_m * ds_m * (-0.5 + x * (1.0 / 3.0 - x * (0.125 - x * (1.0 / 30.0))))
    dw = dr.select(x < 1e-2, series, (ds_m * through * kappa - (1.0 - through)) / (kappa * kappa))
    return w, dw


@dataclass(frozen=True, eq=False)
class DeviceGradients:
    """The loss Σ weights·XYZ (float64, from the forward image) and ∂loss/∂T, ∂loss/∂κ and
    ∂loss/∂(species fraction) per voxel from a Dr.Jit backend, float32, shaped as the volume
    (the fields of the float64 :class:`~incandescent.inverse.gradients.Gradients`)."""

    loss: float
    temperature_K: NDArray[np.float32]
    absorption_per_m: NDArray[np.float32]
    #: ∂loss/∂(fraction) per voxel of each species grid
    species: dict[str, NDArray[np.float32]] = field(default_factory=dict)


def gradients_on(
    backend: str, volume, camera, settings, weights: NDArray, image=None
) -> DeviceGradients:
    """The gradients of the loss Σ_pixels weights·XYZ on ``backend`` (cpu, cuda): the forward
    render (or ``image``, that render already made), then the replay adjoint with each ray's
    L and g."""
    if settings.supersample != 1 or volume.absorption_source != "grid":
        raise ValueError("the adjoint needs one ray per pixel and a κ grid of its own")
    if volume.emission_scale is not None:
        raise ValueError("gradients cover emission–absorption without an emission scale")
    if image is None:
        image = render(volume, camera, settings, backend)
    assert image.xyz is not None, "emission–absorption renders radiance"
    totals, upstream = ray_ordered(image.xyz), ray_ordered(weights)  # indexed by camera ray
    adjoint = AdjointEmissionAbsorption(upstream=upstream, totals=totals)
    render(volume, camera, settings, backend, integrator=adjoint)
    program = adjoint.sink[-1]

    def grid(values) -> NDArray[np.float32]:
        return np.asarray(values, dtype=np.float32).reshape(volume.shape)

    species = {name: grid(g) for name, g in zip(program.fraction_names, program.grad_fractions,
                                                 strict=True)}  # fmt: skip
    loss = float(np.sum(np.asarray(weights, np.float64) * np.asarray(image.xyz, np.float64)))
    return DeviceGradients(loss, grid(program.grad_temp), grid(program.grad_kappa), species)
