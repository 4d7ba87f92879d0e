"""The reference backend: a readable float64 NumPy marcher, the ground truth for the others.

All rays advance in lockstep, one segment per iteration (see ``common`` for the step lattice).
Each segment goes to the render's integrator (``renderer.integrators``), whose float64 program
adds its light *exactly* — for emission–absorption the Planck × CMF integral at each sample's
temperature and the species' line sums, not the tables the fast backends use, so parity tests
also check the tables; spectral bins are marched in their limit, every 1 nm CMF sample. No
empty-space skipping.
"""

from __future__ import annotations

import time

import numpy as np

from incandescent.renderer.backends.common import MarchInputs, MarchResult, Segment


def _segment(rays, r, k, step_voxels: float):
    """Segment k of rays ``r`` (see ``common``): its ends a, b (voxels) and midpoint position."""
    a = np.maximum(rays.t_enter[r] + (k - 1 + rays.jitter[r]) * step_voxels, rays.t_enter[r])
    b = np.minimum(rays.t_enter[r] + (k + rays.jitter[r]) * step_voxels, rays.t_exit[r])
    return a, b, rays.origin[r] + rays.direction[r] * (0.5 * (a + b))[:, None]


def march(inputs: MarchInputs) -> MarchResult:
    """March every ray of ``inputs.rays`` front to back; float64 throughout."""
    start = time.perf_counter()
    rays, vol, s = inputs.rays, inputs.volume, inputs.settings
    assert rays is not None, "the reference backend marches host-generated rays"
    program = inputs.integrator.reference(inputs)
    n = rays.size
    xyz, transmittance, depth = np.zeros((n, 3)), program.transmittance0(n), np.full(n, np.inf)
    k, samples, active = np.zeros(n), 0, np.arange(n)
    while active.size:
        r = active
        a, b, p = _segment(rays, r, k[r], s.step_voxels)
        samples += r.size
        ds_m = (b - a) * vol.voxel_size_m
        emits = program.step(Segment(r, a, b, p, ds_m, k[r]), xyz, transmittance)
        first = emits & np.isinf(depth[r])
        depth[r[first]] = 0.5 * (a + b)[first] * vol.voxel_size_m
        k[r] += 1
        more = (b < rays.t_exit[r]) & (program.alive(transmittance[r]) >= s.min_transmittance)
        active = r[more]
    seconds = time.perf_counter() - start
    tr = program.transmittance_out(transmittance)
    return MarchResult(xyz, tr, samples, seconds, "numpy float64", depth, rays.ray_index)
