"""The traced helpers of one render (``Kernel``): trilinear sampling of dense grids and bricks,
the medium, the 1/T tables, and the DDA over empty macrocells; the emission models and the
integrator's traced program (``renderer.integrators``) build on them."""

from __future__ import annotations

import numpy as np

from incandescent._jit import drjit_module
from incandescent.renderer.backends.bricks import (
    BRICK,
    BRICK_VOXELS,
)
from incandescent.renderer.backends.common import MarchInputs
from incandescent.renderer.backends.medium import (
    device_bricks_of,
    device_grid,
    device_grids,
    device_velocity_bricks,
    table4,
    threshold_K,
)
from incandescent.renderer.backends.sampling import blurs
from incandescent.volume.sparse import SparseVolume


class Kernel:
    """Traced helpers bound to one Dr.Jit array module (``drjit.llvm`` or ``drjit.cuda``) and one
    render: the medium, the emission models' device data, the step lattice and the macrocells.
    The models (``incandescent.emission``) and the integrator's traced program
    (``renderer.integrators``, :attr:`program`) add their terms through :meth:`lookup`,
    :meth:`trilinear`, :meth:`table` and :meth:`grid`."""

    def __init__(self, m, inputs: MarchInputs) -> None:
        self.dr, self.m = drjit_module(), m
        self.volume = vol = inputs.volume
        self.shape = vol.shape
        self._bind_medium(vol)
        self._bind_lattice(inputs)
        self.bands = inputs.bands
        self.ray_spec = inputs.ray_spec  # the camera (what a per-camera cache is built for)
        self.terms = [(model, model.bind(self)) for model in inputs.models]
        #: motion blur: the velocity grid's x, y, z components (m/s), and each ray's time in s
        #: divided by the voxel side (set by ``trace``); None without blur
        self.velocity = self.time_voxels = None
        #: the current sample's position and trilinear corners (set by ``sample``) and each ray's
        #: unit direction (set by ``trace``): what an integrator may read beyond κ and T
        self.position = self.at = self.ray_direction = None
        #: each ray's camera-ray index (set by ``trace``) and the current segment's step k (set
        #: by ``sample``): what seeds an integrator's Monte Carlo estimates, with ``seed``
        self.ray_index = self.step_k = None
        if inputs.ray_spec is not None and blurs(inputs.ray_spec, vol):
            self.velocity = self._velocity(vol)
        self.program = inputs.integrator.traced(self)

    def _bind_medium(self, vol) -> None:
        """The medium on the device: bricks or a dense layout (``medium``), its strides, and
        the two-valued κ₀ and threshold the layout relies on."""
        self.brick_index = None
        self.strides: tuple[int, int, int]
        self.medium: object
        self.scale: object | None
        if isinstance(vol, SparseVolume):  # 9³ bricks of the occupied leaves (``bricks``)
            self.strides = (BRICK * BRICK, BRICK, 1)
            self.medium, self.brick_index, self.brick_shape = device_bricks_of(self.m, vol)
            self.scale = None
        else:
            self.strides = dense_strides(vol.shape)
            self.medium, self.scale = device_grids(self.m, vol)
        kappa0 = vol.two_valued_absorption_per_m
        self.kappa0 = None if kappa0 is None else np.float32(kappa0)
        #: κ = κ₀ where T ≥ this (K), 0 below: the medium is T alone (``threshold_K``)
        self.kappa_from_K = None if self.brick_index is not None else threshold_K(vol)

    def _bind_lattice(self, inputs: MarchInputs) -> None:
        """The tables' 1/T spacing, the step lattice, early termination and the macrocells."""
        lut, s, m = inputs.lut, inputs.settings, self.m
        self.first_table = lut  # every table shares its spacing (checked in table())
        self.lut_size, self.lut_t_min = lut.size, np.float32(lut.t_min_K)
        self.lut_w_min, self.lut_inv_dw = np.float32(lut.w_min), np.float32(lut.inv_dw)
        self.ds_per_voxel = np.float32(inputs.volume.voxel_size_m)
        self.dt = np.float32(s.step_voxels)
        self.min_tr = np.float32(s.min_transmittance)
        self.seed = s.seed
        cells = inputs.macrocells
        self.cells = None if cells is None else m.Float(cells.empty_radius.ravel())
        self.cell_shape = None if cells is None else cells.shape
        self.cell_voxels = None if cells is None else np.float32(cells.cell_voxels)

    def _velocity(self, vol) -> list:
        """The velocity's x, y, z components on the device (bricks or dense grids), m/s."""
        if isinstance(vol, SparseVolume):
            return device_velocity_bricks(self.m, vol)
        v = vol.velocity_m_s
        return [self.grid(("velocity", a), v[..., a]) for a in range(3)]  # type: ignore[index]

    # --- what the emission models use -----------------------------------------------------
    def table(self, lut) -> object:
        """A T ↦ XYZ table on the device, 16-byte rows (:func:`table4`)."""
        first = self.first_table
        if (lut.size, lut.t_min_K, lut.t_max_K) != (first.size, first.t_min_K, first.t_max_K):
            raise ValueError("every emission table must share the 1/T spacing of the first")
        return self.m.Float(table4(lut.values))

    def grid(self, key: tuple, grid: np.ndarray):
        """A volume grid on the device, uploaded once per volume and ``key``."""
        if self.brick_index is not None:
            raise ValueError("the sparse layout carries T and κ only; use layout 'dense'")
        return device_grid(self.m, self.volume, key, grid)

    # --- sampling -------------------------------------------------------------------------
    def corners(self, p, lattice=None):
        """Flat index of the lower trilinear neighbour of p and the weights along x, y, z.

        Voxel centres sit at i + 0.5. Dense grids are unpadded: p is clamped to the centres of
        the outermost voxels (the upper neighbour of the last two along an axis, weight 1), so a
        position in the outer half voxel takes the edge voxel's value (the edge rule, DESIGN §4)
        with the neighbours at fixed offsets and never outside the grid; an axis one voxel thick
        has both neighbours at that voxel. Bricks carry a one-voxel border (``bricks``).
        ``lattice``: (shape, strides) of another dense grid, p in its cells (``dense_strides``).
        """
        if lattice is None and self.brick_index is not None:
            return self.brick_corners(p)
        shape, strides = lattice or (self.shape, self.strides)
        dr, m = self.dr, self.m
        base, weights = m.UInt(0), []
        for a, n in enumerate(shape):  # n = 1: stride 0, both neighbours are the one voxel
            u = dr.clip(p[a] + 0.5, 1.0, float(n))  # 1 + the coordinate from the first centre
            i0 = dr.minimum(m.UInt(u), max(n - 1, 1))  # the upper neighbour, 1..n − 1
            weights.append(u - m.Float(i0))
            base += i0 * strides[a]
        return base - sum(strides), weights

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

    def trilinear(self, grid, c, kind=None, strides=None):
        """Trilinear sample of a grid at corners ``c`` (:meth:`corners`; ``strides``: of the
        lattice they were taken on): Float values, or (κ, T) pairs packed in UInt64."""
        dr = self.dr
        kind = kind or self.m.Float
        base, (fx, fy, fz) = c
        sx, sy, sz = strides or self.strides

        def fetch(index):
            if kind == "threshold":  # T; the occupancy from T itself (``threshold_K``)
                temp = dr.gather(self.m.Float, grid, index)
                return self.m.Array2f(dr.select(temp >= self.kappa_from_K, 1.0, 0.0), temp)
            if kind is self.m.UInt:  # T with the sign bit set where κ = 0 (signed_medium)
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
            p = dr.fma(v, -self.time_voxels, p)
            c = self.corners(p)
        kappa, temp = self.medium_at(c)
        self.position, self.at, self.step_k = p, c, k  # for integrators that need more than κ, T
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


def dense_strides(shape: tuple[int, ...]) -> tuple[int, int, int]:
    """C-order strides of a dense grid; an axis one voxel thick steps 0 (both trilinear
    neighbours are its voxel)."""
    _, ny, nz = shape
    return tuple(0 if n == 1 else s for n, s in zip(shape, (ny * nz, nz, 1), strict=True))  # type: ignore[return-value]
