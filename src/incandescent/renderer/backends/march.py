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

import time
import weakref

import numpy as np

from incandescent._jit import array_module, device_name, drjit_module
from incandescent.renderer.backends.bricks import (
    BRICK,
    BRICK_VOXELS,
    device_bricks,
    velocity_bricks,
)
from incandescent.renderer.backends.bricks import plan as volume_plan
from incandescent.renderer.backends.common import (
    MarchInputs,
    MarchResult,
    upper_samples_per_ray,
)
from incandescent.renderer.rays import lane_order
from incandescent.volume.sparse import SparseVolume


class _Kernel:
    """Traced helpers bound to one Dr.Jit array module (``drjit.llvm`` or ``drjit.cuda``) and one
    render: the medium, the emission models' device data, the step lattice and the macrocells.
    The models (``incandescent.emission``) and the integrator's traced program
    (``renderer.integrators``, :attr:`program`) add their terms through :meth:`lookup`,
    :meth:`trilinear`, :meth:`table` and :meth:`grid`."""

    def __init__(self, m, inputs: MarchInputs) -> None:
        self.dr, self.m = drjit_module(), m
        vol, lut, s = inputs.volume, inputs.lut, inputs.settings
        self.volume = vol
        self.shape = vol.shape
        self.brick_index = None
        self.strides: tuple[int, int, int]
        self.medium: object
        self.scale: object | None
        if isinstance(vol, SparseVolume):  # 9³ bricks of the occupied leaves (``bricks``)
            self.strides = (BRICK * BRICK, BRICK, 1)
            self.medium, self.brick_index, self.brick_shape = _device_bricks(m, vol)
            self.scale = None
        else:
            _, ny, nz = vol.shape
            # C order; an axis one voxel thick steps 0 (both neighbours are its voxel)
            self.strides = tuple(  # type: ignore[assignment]
                0 if n == 1 else s for n, s in zip(vol.shape, (ny * nz, nz, 1), strict=True)
            )
            self.medium, self.scale = _device_grids(m, vol)
        kappa0 = vol.two_valued_absorption_per_m
        self.kappa0 = None if kappa0 is None else np.float32(kappa0)
        #: κ = κ₀ where T ≥ this (K), 0 below: the medium is T alone (``_threshold_K``)
        self.kappa_from_K = None if self.brick_index is not None else _threshold_K(vol)
        self.first_table = lut  # every table shares its spacing (checked in table())
        self.lut_size, self.lut_t_min = lut.size, np.float32(lut.t_min_K)
        self.lut_w_min, self.lut_inv_dw = np.float32(lut.w_min), np.float32(lut.inv_dw)
        self.ds_per_voxel = np.float32(vol.voxel_size_m)
        self.dt = np.float32(s.step_voxels)
        self.min_tr = np.float32(s.min_transmittance)
        cells = inputs.macrocells
        self.cells = None if cells is None else m.Float(cells.empty_radius.ravel())
        self.cell_shape = None if cells is None else cells.shape
        self.cell_voxels = None if cells is None else np.float32(cells.cell_voxels)
        self.bands = inputs.bands
        self.terms = [(model, model.bind(self)) for model in inputs.models]
        #: motion blur: the velocity grid's x, y, z components (m/s), and each ray's time in s
        #: divided by the voxel side (set by ``trace``); None without blur
        self.velocity = self.time_voxels = None
        if inputs.ray_spec is not None and _blurs(inputs.ray_spec, vol):
            if isinstance(vol, SparseVolume):
                self.velocity = _device_velocity_bricks(m, vol)
            else:
                v = vol.velocity_m_s
                self.velocity = [self.grid(("velocity", a), v[..., a]) for a in range(3)]  # type: ignore[index]
        self.program = inputs.integrator.traced(self)

    # --- what the emission models use -----------------------------------------------------
    def table(self, lut) -> object:
        """A T ↦ XYZ table on the device, 16-byte rows (:func:`_table4`)."""
        first = self.first_table
        if (lut.size, lut.t_min_K, lut.t_max_K) != (first.size, first.t_min_K, first.t_max_K):
            raise ValueError("every emission table must share the 1/T spacing of the first")
        return self.m.Float(_table4(lut.values))

    def grid(self, key: tuple, grid: np.ndarray):
        """A volume grid on the device, uploaded once per volume and ``key``."""
        if self.brick_index is not None:
            raise ValueError("the sparse layout carries T and κ only; use layout 'dense'")
        return _device_grid(self.m, self.volume, key, grid)

    # --- sampling -------------------------------------------------------------------------
    def corners(self, p):
        """Flat index of the lower trilinear neighbour of p and the weights along x, y, z.

        Voxel centres sit at i + 0.5. Dense grids are unpadded: p is clamped to the centres of
        the outermost voxels (the upper neighbour of the last two along an axis, weight 1), so a
        position in the outer half voxel takes the edge voxel's value (the edge rule, DESIGN §4)
        with the neighbours at fixed offsets and never outside the grid; an axis one voxel thick
        has both neighbours at that voxel. Bricks carry a one-voxel border (``bricks``).
        """
        if self.brick_index is not None:
            return self.brick_corners(p)
        dr, m = self.dr, self.m
        base, weights = m.UInt(0), []
        for a, n in enumerate(self.shape):  # n = 1: stride 0, both neighbours are the one voxel
            u = dr.clip(p[a] + 0.5, 1.0, float(n))  # 1 + the coordinate from the first centre
            i0 = dr.minimum(m.UInt(u), max(n - 1, 1))  # the upper neighbour, 1..n − 1
            weights.append(u - m.Float(i0))
            base += i0 * self.strides[a]
        return base - sum(self.strides), weights

    def brick_corners(self, p):
        """:meth:`corners` in the bricks (grid coordinates padded by one voxel)."""
        dr, m = self.dr, self.m
        lower, weights = [], []
        for a, n in enumerate(self.shape):
            u = dr.clip(p[a], 0.0, float(n)) + 0.5  # padded voxel-centre coordinate
            i0 = dr.minimum(m.UInt(u), n)
            lower.append(i0)
            weights.append(u - m.Float(i0))
        return self.brick_corner(lower), weights

    def brick_corner(self, lower):
        """Pool index of the lower corner (``lower``: each axis's index in the grid padded by one
        voxel, as the bricks are): brick ⌊i0 / 8⌋'s slot, then i0 mod 8 inside it."""
        _, ny, nz = self.brick_shape
        bx, by, bz = (i0 >> 3 for i0 in lower)
        slot = self.dr.gather(self.m.UInt, self.brick_index, (bx * ny + by) * nz + bz)
        lx, ly, lz = (i0 & 7 for i0 in lower)
        return slot * BRICK_VOXELS + (lx * BRICK + ly) * BRICK + lz

    def trilinear(self, grid, c, kind=None):
        """Trilinear sample of a grid at corners ``c`` (:meth:`corners`): Float values, or (κ, T)
        pairs packed in UInt64."""
        dr = self.dr
        kind = kind or self.m.Float
        base, (fx, fy, fz) = c
        sx, sy, sz = self.strides

        def fetch(index):
            if kind == "threshold":  # T; the occupancy from T itself (``_threshold_K``)
                temp = dr.gather(self.m.Float, grid, index)
                return self.m.Array2f(dr.select(temp >= self.kappa_from_K, 1.0, 0.0), temp)
            if kind is self.m.UInt:  # T with the sign bit set where κ = 0 (_signed_medium)
                bits = dr.gather(self.m.UInt, grid, index)
                temp = dr.reinterpret_array(self.m.Float, bits & 0x7FFFFFFF)
                return self.m.Array2f(self.m.Float(1 - (bits >> 31)), temp)
            if kind is not self.m.UInt64:
                return dr.gather(kind, grid, index)
            packed = dr.gather(self.m.UInt64, grid, index)  # one 64-bit gather for κ and T
            low = dr.reinterpret_array(self.m.Float, self.m.UInt(packed & 0xFFFFFFFF))
            high = dr.reinterpret_array(self.m.Float, self.m.UInt(packed >> 32))
            return self.m.Array2f(low, high)

        def lerp_x(offset):
            a = fetch(base + offset)
            return dr.fma(fetch(base + (offset + sx)) - a, fx, a)

        c0 = dr.lerp(lerp_x(0), lerp_x(sy), fy)
        c1 = dr.lerp(lerp_x(sz), lerp_x(sy + sz), fy)
        return dr.lerp(c0, c1, fz)

    def medium_at(self, c):
        """(κ in 1/m, T in K) at the trilinear corners c."""
        if self.kappa0 is None:
            return self.trilinear(self.medium, c, self.m.UInt64)
        kind = self.m.UInt if self.kappa_from_K is None else "threshold"
        occupancy, temp = self.trilinear(self.medium, c, kind)
        return occupancy * self.kappa0, temp

    def lut_position(self, temp):
        """Entry i0 and weight of T in the 1/T-uniform tables (all tables share the spacing)."""
        dr, m = self.dr, self.m
        f = (dr.rcp(dr.maximum(temp, 1e-30)) - self.lut_w_min) * self.lut_inv_dw
        f = dr.clip(f, 0.0, float(self.lut_size - 1))
        i0 = dr.minimum(m.UInt(f), self.lut_size - 2)
        return i0, f - m.Float(i0)

    def lookup(self, table, position):
        """Linear interpolation in a 4-float-per-entry table (one 16-byte load per entry)."""
        dr, Array3f, Array4f = self.dr, self.m.Array3f, self.m.Array4f
        i0, frac = position
        lo, hi = dr.gather(Array4f, table, i0), dr.gather(Array4f, table, i0 + 1)
        return dr.lerp(Array3f(lo[0], lo[1], lo[2]), Array3f(hi[0], hi[1], hi[2]), frac)

    # --- one segment ----------------------------------------------------------------------
    def sample(self, k, tr, L, n, depth, p, t_mid, ds_m):
        """One segment: sample (κ, T) at its midpoint; the integrator's program updates the ray
        where the sample interacts."""
        dr = self.dr
        c = self.corners(p)
        if self.velocity is not None:  # backward advection: the gas at p now was at p − v·t
            v = self.m.Array3f(*(self.trilinear(grid, c) for grid in self.velocity))
            c = self.corners(dr.fma(v, -self.time_voxels, p))
        kappa, temp = self.medium_at(c)
        sampled = [model.sample(self, bound, c) for model, bound in self.terms]
        interacts, emits = self.program.interacts(kappa, temp, sampled)
        tr, L = dr.if_stmt(
            (tr, L, kappa, temp, c, ds_m, sampled),
            interacts,
            self.program.step,
            lambda tr, L, kappa, temp, c, ds_m, sampled: (tr, L),
        )
        first = emits & (depth == np.inf)
        depth = dr.select(first, t_mid * self.ds_per_voxel, depth)
        return k + 1.0, tr, L, n + 1, depth

    # --- empty space --------------------------------------------------------------------------
    def cell_index(self, p):
        dr, m = self.dr, self.m
        cx, cy, cz = (
            dr.minimum(m.UInt(dr.maximum(p[a] / self.cell_voxels, 0.0)), self.cell_shape[a] - 1)
            for a in range(3)
        )
        return cx, cy, cz

    def empty_radius(self, p):
        """The empty radius r of p's macrocell (0: not empty; see ``volume.macrocells``)."""
        cx, cy, cz = self.cell_index(p)
        _, ny, nz = self.cell_shape
        flat = (cx * ny + cy) * nz + cz
        return self.dr.gather(self.m.Float, self.cells, flat)

    def skip(self, k, p, radius, ray):
        """k of the first segment reaching the exit of the block of empty macrocells within
        radius − 1 cells of p's cell (one DDA step; that block is empty by the radius's
        definition, so every segment before it has κ = 0)."""
        dr, m = self.dr, self.m
        o, inv_d, t0, j = ray
        cell = self.cell_index(p)
        reach = radius - 1.0
        t_exit = m.Float(np.inf)
        for a in range(3):
            forward = inv_d[a] > 0
            bound = (m.Float(cell[a]) + dr.select(forward, 1.0 + reach, -reach)) * self.cell_voxels
            t_axis = (bound - o[a]) * inv_d[a]
            t_exit = dr.minimum(t_exit, dr.select(dr.isinf(inv_d[a]), np.inf, t_axis))
        k_exit = dr.floor((t_exit - t0) / self.dt - j) + 1.0
        return dr.maximum(k_exit, k + 1.0)


def _table4(values: np.ndarray) -> np.ndarray:
    """An (N, 3) table as float32 rows of 4 (the 4th unused): aligned 16-byte entries gather as
    one packet load each on the CPU (measured ~8 % faster than 3-float rows on the plume)."""
    out = np.zeros((values.shape[0], 4), dtype=np.float32)
    out[:, :3] = values
    return out.ravel()


def _flat32(grid: np.ndarray) -> np.ndarray:
    """``grid`` as one C-ordered float32 run: the grid itself when it is one, else a copy."""
    return np.ascontiguousarray(grid, dtype=np.float32).reshape(-1)


#: Device copies of each live volume's grids, per array module (freed with the volume).
_DEVICE_GRIDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _threshold_K(volume) -> np.float32 | None:
    """T (K) from which a two-valued κ is κ₀, when the volume knows it (κ made from T,
    ``Volume.absorbing_from_K``): the kernel then gathers T from the volume's own grid, which
    the CPU maps without a copy — no layout pass and no second grid (256³: 4.6 ms and 64 MB)."""
    if volume.two_valued_absorption_per_m is None:
        return None
    threshold = volume.absorbing_from_K
    return None if threshold is None else np.float32(threshold)


def _host_signed(volume) -> np.ndarray:
    """:func:`_signed_medium` built by NumPy (what CUDA uploads)."""
    temp = _flat32(volume.temperature_K).view("<u4")
    return temp | (_flat32(volume.absorption_per_m) <= 0).astype(np.uint32) << 31


def _host_packed(volume) -> np.ndarray:
    """:func:`_packed_medium` built by NumPy (what CUDA uploads)."""
    out = np.empty((volume.temperature_K.size, 2), dtype="<f4")
    out[:, 0], out[:, 1] = _flat32(volume.absorption_per_m), _flat32(volume.temperature_K)
    return out.view("<u8").reshape(-1)


def _signed_medium(m, volume):
    """T's float32 bits with the sign bit set where κ = 0 (two-valued κ), voxels in C order: one
    32-bit gather per trilinear corner gives T and the occupancy, half the memory of the packed
    pair.

    On the CPU one Dr.Jit pass over the grids, which it maps without a copy: unpadded (the
    kernel clamps its corners) the layout is elementwise, ~5 ms at 256³ against 14–19 ms for
    the padded NumPy passes it replaces; its buffer comes from Dr.Jit's allocation cache, which
    hands a new volume the pages a freed one used. CUDA uploads the host build (no grid-sized
    temporaries on the device)."""
    if m.__name__ != "drjit.llvm":
        return m.UInt(_host_signed(volume))
    dr = drjit_module()
    temp = dr.reinterpret_array(m.UInt, m.Float(_flat32(volume.temperature_K)))
    vacuum = m.Float(_flat32(volume.absorption_per_m)) <= 0.0
    return _evaluated(dr, temp | dr.select(vacuum, m.UInt(0x80000000), 0))


def _packed_medium(m, volume):
    """(κ, T) per voxel packed into one uint64 (κ's float32 bits low, T's high), voxels in C
    order: a trilinear corner is then one 64-bit gather instead of two 32-bit ones (measured
    1.6× faster gathers on AVX2). Built as :func:`_signed_medium` is."""
    if m.__name__ != "drjit.llvm":
        return m.UInt64(_host_packed(volume))
    dr = drjit_module()
    temp, kappa = (
        m.UInt64(dr.reinterpret_array(m.UInt, m.Float(_flat32(g))))
        for g in (volume.temperature_K, volume.absorption_per_m)
    )
    return _evaluated(dr, (temp << 32) | kappa)


def _evaluated(dr, array):
    """``array`` computed now (before the march is timed)."""
    dr.eval(array)
    dr.sync_thread()
    return array


def _device_grid(m, volume, key: tuple, grid: np.ndarray):
    """One extra grid of ``volume`` on the device (float32, C order), once per volume and key;
    on the CPU a float32 C-ordered grid is mapped, not copied."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    full_key = (m.__name__,) + key
    if full_key not in per_volume:
        per_volume[full_key] = m.Float(_flat32(grid))
    return per_volume[full_key]


def _device_bricks(m, volume: SparseVolume):
    """(pool, index, brick shape) of a sparse volume on the device, built once per volume."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    key = (m.__name__, "bricks")
    if key not in per_volume:
        plan = volume_plan(volume)
        packed = volume.two_valued_absorption_per_m is None
        per_volume[key] = device_bricks(m, volume, packed, plan) + (plan.brick_shape,)
        drjit_module().sync_thread()  # built before the march is timed, as the dense layout is
    return per_volume[key]


def _device_velocity_bricks(m, volume: SparseVolume) -> list:
    """The velocity pools of a sparse volume, built once per volume."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    key = (m.__name__, "velocity bricks")
    if key not in per_volume:
        per_volume[key] = velocity_bricks(m, volume, volume_plan(volume))
        drjit_module().sync_thread()
    return per_volume[key]


def _device_grids(m, volume):
    """(medium, emission scale) as device arrays (None where absent), made once per volume. The
    medium: T alone where κ is made from T (``_threshold_K``), else T with κ = 0 in its sign bit
    for a two-valued κ (``_signed_medium``), else (κ, T) interleaved (``_packed_medium``)."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    if m.__name__ not in per_volume:
        scale = volume.emission_scale
        two_valued = volume.two_valued_absorption_per_m is not None
        if _threshold_K(volume) is not None:
            medium = m.Float(_flat32(volume.temperature_K))
        elif two_valued:
            medium = _signed_medium(m, volume)
        else:
            medium = _packed_medium(m, volume)
        emission_scale = None if scale is None else m.Float(_flat32(scale))
        per_volume[m.__name__] = (medium, emission_scale)
    return per_volume[m.__name__]


def _blurs(spec, volume) -> bool:
    """Does this render blur motion (a shutter is set and the volume has a velocity grid)?"""
    return spec.shutter_s is not None and getattr(volume, "velocity_m_s", None) is not None


#: Salts XORed into the seed's key for the hashes of the shutter time (independent of the jitter).
_TIME_SALT, _STRATUM_SALT = 0x68E31DA4, 0xB5297A4D


def _shutter_time(m, spec, x, y, index):
    """Each ray's time in s within the shutter: the N×N rays of a pixel take the N² strata of the
    interval in a pseudo-random order of their own (:func:`_permute`: a time never follows the
    ray's place in the pixel, which would bias a moving edge), each at a hashed point in its
    stratum."""
    dr = drjit_module()
    s = spec.supersample
    strata = s * s
    sub = (x % s) * s + (y % s)
    pixel = (x // s) * spec.height + (y // s)
    seed = _lowbias32(pixel ^ dr.opaque(m.UInt, spec.key ^ _STRATUM_SALT))
    stratum = _permute(m, sub, strata, seed)
    xi = m.Float(_lowbias32(index ^ dr.opaque(m.UInt, spec.key ^ _TIME_SALT)) >> 8) * 2.0**-24
    u = (m.Float(stratum) + xi) * (1.0 / strata)
    low, high = (dr.opaque(m.Float, float(t)) for t in spec.shutter_s)
    return dr.fma(high - low, u, low)


def _permute(m, i, count: int, seed):
    """Element i of a pseudo-random permutation of 0 … count − 1 chosen by ``seed`` (per lane):
    Kensler's hash with cycle walking ("Correlated Multi-Jittered Sampling", Pixar 2013, §3)."""
    dr = drjit_module()
    if count == 1:
        return m.UInt(0)
    w = (1 << (count - 1).bit_length()) - 1  # the smallest all-ones mask covering count − 1

    def scramble(i):
        i = i ^ seed
        i = i * 0xE170893D
        i = i ^ (seed >> 16)
        i = i ^ ((i & w) >> 4)
        i = i ^ (seed >> 8)
        i = i * 0x0929EB3F
        i = i ^ (seed >> 23)
        i = i ^ ((i & w) >> 1)
        i = i * (1 | (seed >> 27))
        i = i * 0x6935FA69
        i = i ^ ((i & w) >> 11)
        i = i * 0x74DCB303
        i = i ^ ((i & w) >> 2)
        i = i * 0x9E501CC3
        i = i ^ ((i & w) >> 2)
        i = i * 0xC860A3DF
        i = i & w
        return (i ^ (i >> 5),)

    (i,) = scramble(i)  # do … while (i >= count): walk the cycle back into range
    (i,) = dr.while_loop((i,), lambda i: i >= count, scramble, labels=("i",))
    return (i + seed) % count


def _lowbias32(x):
    """The integer hash of ``rays.lowbias32`` on UInt32 lanes (multiplication wraps mod 2³²)."""
    x = x ^ (x >> 16)
    x = x * 0x7FEB352D
    x = x ^ (x >> 15)
    x = x * 0x846CA68B
    return x ^ (x >> 16)


def _ray_arrays(m, spec, order):
    """Camera rays generated in the kernel, one lane per ray in ``order`` (sub-pixel X, Y and the
    ray's index, from :func:`~incandescent.renderer.rays.lane_order`), in voxel space, clipped to
    the grid box [0, shape] (t_exit ≤ t_enter: the ray misses)."""
    dr = drjit_module()
    s = spec.supersample
    x, y, index = (m.UInt(a) for a in order)
    px = 2.0 * (m.Float(x) + 0.5) / (spec.width * s) - 1.0
    py = 1.0 - 2.0 * (m.Float(y) + 0.5) / (spec.height * s)

    def given(v):  # a kernel input, not a constant: a new camera reuses the compiled kernel
        return m.Array3f(*(dr.opaque(m.Float, float(c)) for c in v))

    right, up, forward, eye = (given(v) for v in (spec.right, spec.up, spec.forward, spec.eye))
    half_w, half_h, voxel = (
        dr.opaque(m.Float, float(v)) for v in (spec.half_width, spec.half_height, spec.voxel_size_m)
    )
    film = right * (px * half_w) + up * (py * half_h)
    if spec.perspective:
        o, d = eye, dr.normalize(forward + film)
    else:
        o, d = eye + film, forward + 0.0 * px
    o = (o - given(spec.origin_m)) / voxel
    t0, t1 = _clip(dr, m, o, d, spec.shape)
    if spec.jitter:
        h = _lowbias32(index ^ dr.opaque(m.UInt, spec.key))
        j = m.Float(h >> 8) * 2.0**-24
    else:
        j = m.Float(0.5)
    return o, d, t0, t1, j


def _clip(dr, m, o, d, shape):
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


def trace(inputs: MarchInputs, m, order, K: _Kernel | None = None):
    """Trace the megakernel for the rays in ``order``; returns lazy (XYZ, transmittance,
    samples, depth). ``K``: the kernel's bound tables and grids (built once per render)."""
    dr = drjit_module()
    K = K or _Kernel(m, inputs)
    spec = inputs.ray_spec
    assert spec is not None, "the Dr.Jit kernels generate their rays from a RaySpec"
    o, d, t0, t1, j = _ray_arrays(m, spec, order)
    if K.velocity is not None:
        x, y, index = (m.UInt(a) for a in order)
        voxel = dr.opaque(m.Float, float(spec.voxel_size_m))
        K.time_voxels = _shutter_time(m, spec, x, y, index) / voxel
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


#: Chunks of rays. The first holds FIRST_CHUNK_SAMPLES upper-bound samples (rays × steps across
#: the box diagonal): a 512² image of a 256³ volume at step 0.5 is one chunk. Later chunks take
#: about CHUNK_SECONDS at the last chunk's ray rate, grow at most 2× per chunk (rays elsewhere in
#: the image can cost far more) and hold at most MAX_CHUNK_SAMPLES upper-bound samples. Below
#: MIN_CHUNK_RAYS the CPU backend loses its threads (Dr.Jit hands threads blocks of 16 384
#: lanes). A Ctrl-C raises KeyboardInterrupt between chunks.
FIRST_CHUNK_SAMPLES, MAX_CHUNK_SAMPLES = 2.5e8, 1e9
CHUNK_SECONDS = 0.25
MIN_CHUNK_RAYS, MAX_CHUNK_RAYS = 1 << 15, 1 << 22


def _first_chunk(spec, settings) -> int:
    per_ray = upper_samples_per_ray(spec.shape, settings.step_voxels)
    rays = int(np.clip(FIRST_CHUNK_SAMPLES / per_ray, MIN_CHUNK_RAYS, MAX_CHUNK_RAYS))
    return rays // ALIGN_LANES * ALIGN_LANES


def _next_chunk(rays: int, seconds: float, upper_per_ray: float) -> int:
    """Rays in the next chunk after ``rays`` took ``seconds`` (see CHUNK_SECONDS), a multiple of
    ALIGN_LANES."""
    size = min(2 * rays, rays / max(seconds, 1e-3) * CHUNK_SECONDS)
    size = min(size, MAX_CHUNK_SAMPLES / upper_per_ray)
    return int(np.clip(size, MIN_CHUNK_RAYS, MAX_CHUNK_RAYS)) // ALIGN_LANES * ALIGN_LANES


#: Lanes per 64 bytes of a 32-bit input. Dr.Jit maps NumPy inputs without a copy and writes each
#: one's alignment into the kernel it traces: arrays that start on a 64-byte boundary in every
#: process keep one kernel (a disk-cache hit) instead of one per alignment found (a 30 ms compile).
ALIGN_LANES = 16


def _aligned(a: np.ndarray, alignment: int = 64) -> np.ndarray:
    """A copy of ``a`` whose data starts on an ``alignment``-byte boundary."""
    buffer = np.empty(a.nbytes + alignment, dtype=np.uint8)
    offset = -buffer.ctypes.data % alignment
    out = buffer[offset : offset + a.nbytes].view(a.dtype)
    out[:] = a
    return out


def _march_chunk(inputs: MarchInputs, m, K: _Kernel, order) -> tuple[list[np.ndarray], int, float]:
    """March the rays of one chunk: ([X, Y, Z, Tr, depth] per lane, samples, compile seconds)."""
    dr = drjit_module()
    dr.kernel_history()  # clear
    L, tr, n, depth = trace(inputs, m, order, K)
    dr.eval(L, tr, n, depth)
    dr.sync_thread()
    compile_s = sum(_compile_seconds(h) for h in dr.kernel_history())
    lanes = len(order[0])

    def per_lane(values) -> np.ndarray:  # a loop variable no lane changed comes back as 1 value
        return np.broadcast_to(np.asarray(values, dtype=np.float64), (lanes,))

    columns = [per_lane(L[a]) for a in range(3)] + [per_lane(tr), per_lane(depth)]
    return columns, int(np.asarray(n, dtype=np.uint64).sum()), compile_s


def march(inputs: MarchInputs, kind: str, progress=None) -> MarchResult:
    """Run the megakernel on backend ``kind`` ("cpu" or "cuda"), in chunks of rays (a Ctrl-C
    raises KeyboardInterrupt between chunks); ``progress(fraction of rays done)`` after each."""
    m = array_module(kind)
    dr = drjit_module()
    spec = inputs.ray_spec
    assert spec is not None, "the Dr.Jit kernels generate their rays from a RaySpec"
    lanes = lane_order(spec.width, spec.height, spec.supersample)
    order = tuple(_aligned(a) for a in lanes)
    parts, samples, march_s = [], 0, 0.0
    start, size = 0, _first_chunk(spec, inputs.settings)
    upper_per_ray = upper_samples_per_ray(spec.shape, inputs.settings.step_voxels)
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        K = _Kernel(m, inputs)
        while start < spec.n_total:
            chunk = [a[start : start + size] for a in order]
            began = time.perf_counter()
            columns, n, compile_s = _march_chunk(inputs, m, K, chunk)
            seconds = max(time.perf_counter() - began - compile_s, 0.0)
            parts.append(columns)
            samples, march_s = samples + n, march_s + seconds
            rays = len(chunk[0])
            start, size = start + rays, _next_chunk(rays, seconds, upper_per_ray)
            if progress is not None:
                progress(start / spec.n_total)
    columns = parts[0] if len(parts) == 1 else [np.concatenate(c) for c in zip(*parts, strict=True)]
    xyz = np.stack(columns[:3], axis=1)
    # the cached lane order itself as the ray index: the image is then gathered in one pass
    return MarchResult(xyz, columns[3], samples, march_s, device_name(kind), columns[4], lanes[2])


def _compile_seconds(entry: dict) -> float:
    """Code generation and backend compilation time of one kernel-history entry, in s."""
    ms = float(entry.get("codegen_time", 0.0)) + float(entry.get("backend_time", 0.0))
    return ms / 1000.0
