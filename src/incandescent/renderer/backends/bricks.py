"""The sparse device layout: a pool of 9³ bricks of the occupied part of a grid, and a brick index.

The dense layout pads every grid by one edge-replicated voxel and samples it at padded coordinates
u = clip(p, 0, n) + 0.5 (``kernel.Kernel.corners``): the lower trilinear corner is
i0 = ⌊u⌋ ∈ [0, n] and the upper one i0 + 1. Here the padded grid is cut into bricks of 8 lower
corners per axis: brick b serves i0 ∈ [8b, 8b + 7] and stores the padded voxels 8b … 8b + 8 (9 per
axis: the corners plus the one-voxel apron trilinear sampling needs), so a sample reads one brick
only. A brick whose padded voxels all lie in absent leaves of the :class:`SparseVolume` (vacuum:
T = κ = 0) is not stored; its index entry points at slot 0, a brick of zeros. Every value read
is therefore the value the dense layout reads, and the image is the same.

Padded voxel j is voxel clip(j − 1, 0, n − 1) of the grid (the edge rule, DESIGN §4), so brick b
reads leaves b − 1 and b along each axis (clipped to the grid).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent._jit import drjit_module
from incandescent.volume.sparse import LEAF, SparseVolume

#: Padded voxels along each side of a device brick: 8 lower corners and the apron.
BRICK = LEAF + 1
BRICK_VOXELS = BRICK**3


@dataclass(frozen=True)
class BrickPlan:
    """Which device bricks a sparse volume needs (host side, cheap: one entry per brick).

    brick_shape: bricks along each axis (n // 8 + 1: lower corners 0 … n).
    slots: brick_shape uint32, the pool slot of each brick (0: the brick of zeros).
    coords: (m + 1, 3) int32 brick coordinates of slots 0 … m (slot 0's unused).
    leaf_slots: leaf-grid uint32, 1 + the volume's row of each leaf (0: absent).
    """

    brick_shape: tuple[int, int, int]
    slots: NDArray[np.uint32]
    coords: NDArray[np.int32]
    leaf_slots: NDArray[np.uint32]

    @property
    def bricks(self) -> int:
        """Stored bricks, the brick of zeros included."""
        return len(self.coords)


def plan(volume: SparseVolume) -> BrickPlan:
    """The bricks ``volume`` needs: those reading any present leaf (computed once per volume)."""
    if "brick_plan" not in volume._cache:
        volume._cache["brick_plan"] = _plan(volume)
    return volume._cache["brick_plan"]


def _plan(volume: SparseVolume) -> BrickPlan:
    leaf_shape = volume.leaf_shape
    present = np.zeros(leaf_shape, dtype=bool)
    present[tuple(volume.leaf_coords.T)] = True
    leaf_slots = np.zeros(leaf_shape, dtype=np.uint32)
    leaf_slots[tuple(volume.leaf_coords.T)] = np.arange(1, len(volume.leaf_coords) + 1)
    brick_shape = tuple(n // LEAF + 1 for n in volume.shape)
    reads = [  # per axis, the two leaves brick b reads: b − 1 and b, clipped to the leaf grid
        (np.clip(np.arange(nb) - 1, 0, nl - 1), np.minimum(np.arange(nb), nl - 1))
        for nb, nl in zip(brick_shape, leaf_shape, strict=True)
    ]
    need = np.zeros(brick_shape, dtype=bool)
    for ix in reads[0]:
        for iy in reads[1]:
            for iz in reads[2]:
                need |= present[np.ix_(ix, iy, iz)]
    coords = np.concatenate([np.zeros((1, 3), np.int32), np.argwhere(need).astype(np.int32)])
    slots = np.zeros(brick_shape, dtype=np.uint32)
    slots[need] = np.arange(1, len(coords), dtype=np.uint32)
    return BrickPlan(brick_shape, slots, coords, leaf_slots)  # type: ignore[arg-type]


def brick_bytes(volume: SparseVolume, packed: bool) -> float:
    """Device bytes of the brick pool and index (packed (κ, T): 8 B per voxel; signed T: 4 B)."""
    p = plan(volume)
    return p.bricks * BRICK_VOXELS * (8.0 if packed else 4.0) + 4.0 * p.slots.size


def _reader(m, volume: SparseVolume, p: BrickPlan):
    """``read(leaves, components, component)``: a leaf field's values in the pool — for every
    voxel of every brick, the leaf voxel it holds (edge rule); 0 where the leaf is absent."""
    dr = drjit_module()
    lane = dr.arange(m.UInt, p.bricks * BRICK_VOXELS)
    brick, k = lane // BRICK_VOXELS, lane % BRICK_VOXELS
    local = (k // (BRICK * BRICK), (k // BRICK) % BRICK, k % BRICK)
    coords = m.UInt(p.coords.astype(np.uint32).ravel())
    voxel = []
    for axis, n in enumerate(volume.shape):  # padded voxel 8b + k is voxel clip(8b + k − 1)
        corner = m.Int(dr.gather(m.UInt, coords, brick * 3 + axis) * LEAF + local[axis]) - 1
        voxel.append(m.UInt(dr.clip(corner, 0, n - 1)))
    _, ly, lz = volume.leaf_shape
    leaf = ((voxel[0] >> 3) * ly + (voxel[1] >> 3)) * lz + (voxel[2] >> 3)
    slot = dr.gather(m.UInt, m.UInt(p.leaf_slots.ravel()), leaf)
    within = ((voxel[0] & 7) * LEAF + (voxel[1] & 7)) * LEAF + (voxel[2] & 7)
    present = (slot > 0) & (brick > 0)

    def read(leaves: np.ndarray, components: int = 1, component: int = 0):
        if leaves.size == 0:  # no leaf: every brick is the brick of zeros
            return dr.zeros(m.UInt, p.bricks * BRICK_VOXELS)
        bits = dr.reinterpret_array(m.UInt, m.Float(np.ascontiguousarray(leaves).ravel()))
        at = ((slot - 1) * (LEAF**3) + within) * components + component
        return dr.gather(m.UInt, bits, at, present)  # 0 (T = κ = 0) where absent

    return read


def device_bricks(m, volume: SparseVolume, packed: bool, brick_plan: BrickPlan | None = None):
    """(pool, index) on the device: the pool holds (κ, T) packed in UInt64 (``packed``) or T's
    bits with the sign set where κ = 0, brick after brick (x, y, z order inside, z fastest); the
    index holds each brick's slot. Built by one Dr.Jit kernel over the pool's voxels."""
    dr = drjit_module()
    p = brick_plan or plan(volume)
    read = _reader(m, volume, p)
    kappa, temp = read(volume.leaf_absorption_per_m), read(volume.leaf_temperature_K)
    if packed:
        pool = m.UInt64(kappa) | (m.UInt64(temp) << 32)
    else:
        vacuum = dr.reinterpret_array(m.Float, kappa) <= 0.0
        pool = temp | dr.select(vacuum, m.UInt(0x80000000), m.UInt(0))
    index = m.UInt(p.slots.ravel())
    dr.eval(pool, index)
    return pool, index


def velocity_bricks(m, volume: SparseVolume, brick_plan: BrickPlan | None = None) -> list:
    """The leaves' velocity (m/s) as three Float pools in the bricks' layout (motion blur)."""
    dr = drjit_module()
    p = brick_plan or plan(volume)
    read = _reader(m, volume, p)
    velocity = volume.leaf_velocity_m_s
    assert velocity is not None
    pools = [dr.reinterpret_array(m.Float, read(velocity, 3, a)) for a in range(3)]
    dr.eval(*pools)
    return pools
