"""Camera rays generated in the Dr.Jit kernel (one lane per ray), in voxel space, clipped to the
grid box; the same rays as ``renderer.rays`` builds on the host for the reference."""

from __future__ import annotations

import numpy as np

from incandescent._jit import drjit_module
from incandescent.renderer.backends.sampling import lowbias32


def ray_arrays(m, spec, order):
    """Camera rays generated in the kernel, one lane per ray in ``order`` (sub-pixel X, Y and the
    ray's index, from :func:`~incandescent.renderer.rays.lane_order`), in voxel space, clipped to
    the grid box [0, shape] (t_exit ≤ t_enter: the ray misses)."""
    dr = drjit_module()
    s = spec.supersample
    x, y, index = (m.UInt(a) for a in order)
    columns = spec.width * s // max(len(spec.views), 1)  # one camera's sub-pixel columns
    eye, right, up, forward, half_w, half_h, x = _camera(m, spec, x, columns)
    px = 2.0 * (m.Float(x) + 0.5) / columns - 1.0
    py = 1.0 - 2.0 * (m.Float(y) + 0.5) / (spec.height * s)
    voxel = dr.opaque(m.Float, float(spec.voxel_size_m))
    film = right * (px * half_w) + up * (py * half_h)
    if spec.perspective:
        o, d = eye, dr.normalize(forward + film)
    else:
        o, d = eye + film, forward + 0.0 * px
    o = (o - _given(m, spec.origin_m)) / voxel
    t0, t1 = clip_to_box(dr, m, o, d, spec.shape)
    if spec.jitter:
        h = lowbias32(index ^ dr.opaque(m.UInt, spec.key))
        j = m.Float(h >> 8) * 2.0**-24
    else:
        j = m.Float(0.5)
    return o, d, t0, t1, j


def _given(m, v):
    """A 3-vector as a kernel input, not a constant: a new camera reuses the compiled kernel."""
    dr = drjit_module()
    return m.Array3f(*(dr.opaque(m.Float, float(c)) for c in v))


def _camera(m, spec, x, columns: int):
    """(eye, right, up, forward, film half-width, half-height, the sub-pixel column within its
    camera's image) per lane: the spec's one camera, or a rig's (``spec.views``) gathered by the
    lane's camera x // ``columns``."""
    dr = drjit_module()
    if not spec.views:
        vectors = (spec.eye, spec.right, spec.up, spec.forward)
        halves = (dr.opaque(m.Float, float(v)) for v in (spec.half_width, spec.half_height))
        return (*(_given(m, v) for v in vectors), *halves, x)
    view = x // columns
    table = np.asarray([np.concatenate([np.ravel(a) for a in v]) for v in spec.views])
    column = [m.Float(np.ascontiguousarray(table[:, k], dtype=np.float32)) for k in range(14)]

    def gathered(k: int):
        return dr.gather(m.Float, column[k], view)

    rows = [m.Array3f(*(gathered(3 * a + c) for c in range(3))) for a in range(4)]
    return (*rows, gathered(12), gathered(13), x - view * columns)


def clip_to_box(dr, m, o, d, shape):
    """Slab-method entry and exit distances of rays (o, d) with the box [0, shape]."""
    t0, t1 = m.Float(0.0), m.Float(np.inf)
    for a, n in enumerate(shape):
        inv = dr.rcp(d[a])
        lo, hi = (0.0 - o[a]) * inv, (float(n) - o[a]) * inv
        parallel = d[a] == 0.0
        inside = (o[a] >= 0.0) & (o[a] <= float(n))
        near = dr.select(parallel, dr.select(inside, -np.inf, np.inf), dr.minimum(lo, hi))
        far = dr.select(parallel, dr.select(inside, np.inf, -np.inf), dr.maximum(lo, hi))
        t0, t1 = dr.maximum(t0, near), dr.minimum(t1, far)
    return t0, t1
