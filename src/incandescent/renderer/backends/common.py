"""What every backend shares: the march inputs and outputs and the per-step physics in float64.

The step lattice (DESIGN.md §4): along a ray clipped to [t_enter, t_exit] (voxel units),
segment k (k = 0, 1, ...) spans [t_enter + (k − 1 + j)·Δt, t_enter + (k + j)·Δt] clipped to the box,
where j is the ray's jitter. Each segment is sampled at its midpoint and integrated exactly for
constant κ, T (emission–absorption, Kirchhoff):

    L += Tr · (1 − e^{−κΔs}) · s_e · B(T),   Tr ← Tr · e^{−κΔs}

with Δs the segment length in m and s_e the emission scale. The segments tile the clipped ray
exactly, so a uniform medium is integrated exactly for any step size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from incandescent.emission import Bands, EmissionModel
from incandescent.renderer.rays import RayBatch, RaySpec
from incandescent.renderer.settings import RenderSettings
from incandescent.spectra.lut import EmissionLUT
from incandescent.volume import MacrocellGrid, Volume

#: Below this optical depth per step, 1 − e^{−x} is evaluated by its series (float32 accuracy).
THIN_STEP = 1e-3


@dataclass(frozen=True)
class MarchInputs:
    """Everything a backend needs; built once per render on the host."""

    #: how light is transported: a ``renderer.integrators.Integrator`` (not imported here: the
    #: integrators import this module)
    integrator: Any
    rays: RayBatch | None  # host-generated rays that hit the box (reference backend); else None
    volume: Volume
    models: tuple[EmissionModel, ...]  # what emits (``integrator.models(volume)``)
    macrocells: MacrocellGrid | None
    settings: RenderSettings
    ray_spec: RaySpec | None = None  # what the Dr.Jit kernels generate their rays from

    @property
    def bands(self) -> Bands:
        """The wavelength bands of transport (grey, or spectral bins)."""
        return self.integrator.bands(self.models)

    @property
    def lut(self) -> EmissionLUT:
        """The table whose 1/T spacing and T_min every table of the render shares."""
        return self.integrator.first_table(self.models)


class Segment(NamedTuple):
    """One segment of the rays ``r`` (float64, the reference): its ends ``a``, ``b`` in voxels
    along the ray, its midpoint ``p`` (voxel coordinates, (m, 3)) and length ``ds_m`` in m."""

    r: NDArray[np.int64]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    p: NDArray[np.float64]
    ds_m: NDArray[np.float64]
    k: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class MarchResult:
    """Per-ray results for the rays in the batch, plus counters.

    xyz: (n, 3) emitted XYZ (paper mode: the paper's uncapped RGB sums); transmittance: (n,);
    samples: trilinear lookups taken; seconds: march wall time (no start-up, no kernel
    compilation); device: what ran it.
    """

    xyz: NDArray
    transmittance: NDArray
    samples: int
    seconds: float
    device: str
    depth_m: NDArray  # distance from the ray origin to the first emitting sample; inf if none
    #: which camera rays the rows are (None: every camera ray, in order)
    ray_index: NDArray | None = None


def upper_samples_per_ray(shape: tuple[int, ...], step_voxels: float) -> float:
    """Most segments a ray can take: the box diagonal in steps, plus the partial ones at its ends
    (the bound of the sample budget and of the kernels' chunk sizes; no skipping, no early
    termination)."""
    return float(np.ceil(np.linalg.norm(shape) / step_voxels) + 1.0)


def trilinear_setup(p: NDArray, n: int) -> tuple[NDArray, NDArray, NDArray]:
    """Voxel indices i0, i1 and weight f along one axis for positions p (voxel units), NumPy.

    Voxel centres are at i + 0.5; positions in the outer half voxel clamp to the edge voxel.
    """
    u = np.clip(p - 0.5, 0.0, n - 1)
    i0 = np.minimum(np.floor(u).astype(np.int64), max(n - 2, 0))
    return i0, np.minimum(i0 + 1, n - 1), u - i0


def trilinear(grid: NDArray, p: NDArray) -> NDArray[np.float64]:
    """Trilinear sample of ``grid`` at positions p (m, 3) in voxel coordinates, float64."""
    (x0, x1, fx), (y0, y1, fy), (z0, z1, fz) = (
        trilinear_setup(p[:, a], grid.shape[a]) for a in range(3)
    )

    def g(x, y, z):
        return grid[x, y, z].astype(np.float64)  # float32 voxels widen exactly

    c00 = g(x0, y0, z0) * (1 - fx) + g(x1, y0, z0) * fx
    c10 = g(x0, y1, z0) * (1 - fx) + g(x1, y1, z0) * fx
    c01 = g(x0, y0, z1) * (1 - fx) + g(x1, y0, z1) * fx
    c11 = g(x0, y1, z1) * (1 - fx) + g(x1, y1, z1) * fx
    return (c00 * (1 - fy) + c10 * fy) * (1 - fz) + (c01 * (1 - fy) + c11 * fy) * fz
