"""The Dr.Jit megakernel: one source for the CPU (LLVM) and CUDA backends.

The whole march is one symbolic ``dr.while_loop`` with one ray per lane (DESIGN.md §6). Each
iteration handles one segment of the step lattice (see ``common``): either

* the segment's midpoint lies in an *empty* macrocell → jump, with one 3-D DDA step, to the first
  segment that reaches the cell's exit (no sample is taken; the image is unchanged because an empty
  cell, border included, guarantees that no sample in it interacts); or
* sample κ and T trilinearly (and the emission models' grids), and only where the render's
  integrator says the sample interacts (``dr.if_stmt``: the CPU backend branches around the
  block when no lane of a packet needs it) let the integrator's traced program update the ray's
  transmittance and radiance (``renderer.integrators``: emission–absorption sums the emission
  models' table lookups and integrates the segment exactly).

Outputs are the loop's own state variables (XYZ, transmittance, sample count): no scatters.
"""

from __future__ import annotations

import numpy as np

from incandescent._jit import drjit_module
from incandescent.renderer.backends.camera_rays import ray_arrays
from incandescent.renderer.backends.common import MarchInputs
from incandescent.renderer.backends.kernel import Kernel
from incandescent.renderer.backends.sampling import shutter_time


def trace(inputs: MarchInputs, m, order, K: Kernel | None = None):
    """Trace the megakernel for the rays in ``order``; returns lazy (XYZ, transmittance,
    samples, depth). ``K``: the kernel's bound tables and grids (built once per render)."""
    dr = drjit_module()
    K = K or Kernel(m, inputs)
    spec = inputs.ray_spec
    assert spec is not None, "the Dr.Jit kernels generate their rays from a RaySpec"
    o, d, t0, t1, j = ray_arrays(m, spec, order)
    K.ray_direction = d  # unit, voxel space = world axes (for integrators that scatter)
    K.ray_index = m.UInt(order[2])  # the camera ray's index (what seeds Monte Carlo estimates)
    if K.velocity is not None:
        x, y, index = (m.UInt(a) for a in order)
        voxel = dr.opaque(m.Float, float(spec.voxel_size_m))
        K.time_voxels = shutter_time(m, spec, x, y, index) / voxel
    dt, skipping = K.dt, K.cells is not None

    def segment(k):
        a = dr.maximum(dr.fma(k - 1.0 + j, dt, t0), t0)
        b = dr.minimum(dr.fma(k + j, dt, t0), t1)
        return a, b

    def alive(tr):
        return K.program.alive(tr) >= K.min_tr

    def cond(k, tr, L, n, depth):
        a, _ = segment(k)
        return (a < t1) & alive(tr)

    inv_d = dr.rcp(d)  # ±inf along an axis the ray is parallel to

    def skip(k, tr, L, n, depth, p, t_mid, ds_m, radius):
        return K.skip(k, p, radius, (o, inv_d, t0, j)), tr, L, n, depth

    def sample(k, tr, L, n, depth, p, t_mid, ds_m, radius):
        return K.sample(k, tr, L, n, depth, p, t_mid, ds_m)

    def body(k, tr, L, n, depth):
        a, b = segment(k)
        t_mid = 0.5 * (a + b)
        args = (k, tr, L, n, depth, dr.fma(d, t_mid, o), t_mid, (b - a) * K.ds_per_voxel)
        if not skipping:
            return K.sample(*args)
        radius = K.empty_radius(args[5])
        return dr.if_stmt(args + (radius,), radius > 0.0, skip, sample)

    state = (m.Float(0.0), K.program.transmittance0(), m.Array3f(0.0), m.UInt(0), m.Float(np.inf))
    _, tr, L, n, depth = dr.while_loop(state, cond, body, labels=("k", "tr", "L", "n", "depth"))
    return L, K.program.transmittance_out(tr), n, depth
