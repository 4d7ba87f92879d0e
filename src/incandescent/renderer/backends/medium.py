"""The medium on the device: each volume's grids laid out for the Dr.Jit kernel, made once per
volume and array module and freed with the volume (``DESIGN.md`` §6).

Dense grids: T alone where κ is made from T (:func:`threshold_K`), T with κ = 0 in its sign bit
for a two-valued κ (:func:`signed_medium`), else (κ, T) packed per voxel (:func:`packed_medium`);
the NumPy builds (:func:`host_signed`, :func:`host_packed`) are what CUDA uploads and what the
tests compare the Dr.Jit builds with. Sparse volumes: the 9³ bricks of ``bricks``.
"""

from __future__ import annotations

import weakref

import numpy as np

from incandescent._jit import drjit_module
from incandescent.renderer.backends.bricks import (
    device_bricks,
    velocity_bricks,
)
from incandescent.renderer.backends.bricks import plan as volume_plan
from incandescent.volume.sparse import SparseVolume


def table4(values: np.ndarray) -> np.ndarray:
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


def threshold_K(volume) -> np.float32 | None:
    """T (K) from which a two-valued κ is κ₀, when the volume knows it (κ made from T,
    ``Volume.absorbing_from_K``): the kernel then gathers T from the volume's own grid, which
    the CPU maps without a copy — no layout pass and no second grid (256³: 4.6 ms and 64 MB)."""
    if volume.two_valued_absorption_per_m is None:
        return None
    threshold = volume.absorbing_from_K
    return None if threshold is None else np.float32(threshold)


def host_signed(volume) -> np.ndarray:
    """:func:`signed_medium` built by NumPy (what CUDA uploads)."""
    temp = _flat32(volume.temperature_K).view("<u4")
    return temp | (_flat32(volume.absorption_per_m) <= 0).astype(np.uint32) << 31


def host_packed(volume) -> np.ndarray:
    """:func:`packed_medium` built by NumPy (what CUDA uploads)."""
    out = np.empty((volume.temperature_K.size, 2), dtype="<f4")
    out[:, 0], out[:, 1] = _flat32(volume.absorption_per_m), _flat32(volume.temperature_K)
    return out.view("<u8").reshape(-1)


def signed_medium(m, volume):
    """T's float32 bits with the sign bit set where κ = 0 (two-valued κ), voxels in C order: one
    32-bit gather per trilinear corner gives T and the occupancy, half the memory of the packed
    pair.

    On the CPU one Dr.Jit pass over the grids, which it maps without a copy: unpadded (the
    kernel clamps its corners) the layout is elementwise, ~5 ms at 256³ against 14–19 ms for
    the padded NumPy passes it replaces; its buffer comes from Dr.Jit's allocation cache, which
    hands a new volume the pages a freed one used. CUDA uploads the host build (no grid-sized
    temporaries on the device)."""
    if m.__name__ != "drjit.llvm":
        return m.UInt(host_signed(volume))
    dr = drjit_module()
    temp = dr.reinterpret_array(m.UInt, m.Float(_flat32(volume.temperature_K)))
    vacuum = m.Float(_flat32(volume.absorption_per_m)) <= 0.0
    return _evaluated(dr, temp | dr.select(vacuum, m.UInt(0x80000000), 0))


def packed_medium(m, volume):
    """(κ, T) per voxel packed into one uint64 (κ's float32 bits low, T's high), voxels in C
    order: a trilinear corner is then one 64-bit gather instead of two 32-bit ones (measured
    1.6× faster gathers on AVX2). Built as :func:`signed_medium` is."""
    if m.__name__ != "drjit.llvm":
        return m.UInt64(host_packed(volume))
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


def device_grid(m, volume, key: tuple, grid: np.ndarray):
    """One extra grid of ``volume`` on the device (float32, C order), once per volume and key;
    on the CPU a float32 C-ordered grid is mapped, not copied."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    full_key = (m.__name__,) + key
    if full_key not in per_volume:
        per_volume[full_key] = m.Float(_flat32(grid))
    return per_volume[full_key]


def device_bricks_of(m, volume: SparseVolume):
    """(pool, index, brick shape) of a sparse volume on the device, built once per volume."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    key = (m.__name__, "bricks")
    if key not in per_volume:
        plan = volume_plan(volume)
        packed = volume.two_valued_absorption_per_m is None
        per_volume[key] = device_bricks(m, volume, packed, plan) + (plan.brick_shape,)
        drjit_module().sync_thread()  # built before the march is timed, as the dense layout is
    return per_volume[key]


def device_velocity_bricks(m, volume: SparseVolume) -> list:
    """The velocity pools of a sparse volume, built once per volume."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    key = (m.__name__, "velocity bricks")
    if key not in per_volume:
        per_volume[key] = velocity_bricks(m, volume, volume_plan(volume))
        drjit_module().sync_thread()
    return per_volume[key]


def device_grids(m, volume):
    """(medium, emission scale) as device arrays (None where absent), made once per volume. The
    medium: T alone where κ is made from T (``threshold_K``), else T with κ = 0 in its sign bit
    for a two-valued κ (``signed_medium``), else (κ, T) interleaved (``packed_medium``)."""
    per_volume = _DEVICE_GRIDS.setdefault(volume, {})
    if m.__name__ not in per_volume:
        scale = volume.emission_scale
        two_valued = volume.two_valued_absorption_per_m is not None
        if threshold_K(volume) is not None:
            medium = m.Float(_flat32(volume.temperature_K))
        elif two_valued:
            medium = signed_medium(m, volume)
        else:
            medium = packed_medium(m, volume)
        emission_scale = None if scale is None else m.Float(_flat32(scale))
        per_volume[m.__name__] = (medium, emission_scale)
    return per_volume[m.__name__]
