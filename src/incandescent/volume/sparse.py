"""Sparse volumes: only the occupied 8³ leaves of a large, mostly empty grid (OpenVDB's leaf nodes).

A production fire cache spans 1000³ voxels or more with a few percent active; a dense (κ, T) copy
of 1024³ is 8 GB. :class:`SparseVolume` keeps the leaves that hold any non-zero temperature or
absorption — the rest of the grid is vacuum (T = 0, κ = 0) — and answers what the renderer asks of a
:class:`~incandescent.volume.Volume` (placement, hottest voxel, content bounds, two-valued κ,
macrocells) from the leaves alone, so a big cache is never densified on the host.

Leaf ``c`` (integer leaf coordinates) holds voxels ``8c … 8c + 7`` on each axis, ``[x][y][z]`` like
the dense grids; voxels of a leaf beyond the grid's shape are 0 and never read.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from incandescent.volume.grid import T_CEILING_K, Placed, Volume
from incandescent.volume.macrocells import MacrocellGrid, dilate_cells, empty_radius

#: Voxels along each side of a leaf (OpenVDB's LeafNode log2 dimension 3).
LEAF = 8

#: Below this fraction of occupied leaves ``auto`` marches a dense volume sparse (and reads an
#: OpenVDB file as leaves). Measured at 256³, 512² (``benchmarks/layout_cost.py``): the plume
#: (39 % of leaves) marches faster sparse (70 vs 80 ms) but its first frame costs more (219 vs
#: 164 ms: the leaves are gathered from the dense grid first); the sparse flame (0.6 %) is faster
#: sparse both ways (72 vs 106 ms cold).
AUTO_SPARSE_FRACTION = 0.25


@dataclass(frozen=True, eq=False)
class SparseVolume(Placed):
    """The occupied leaves of a grid of ``shape`` voxels, placed like a :class:`Volume`.

    Attributes
    ----------
    shape: (nx, ny, nz) voxels of the whole grid.
    leaf_coords: (n, 3) int32 leaf coordinates (voxel = 8·leaf + i), unique.
    leaf_temperature_K, leaf_absorption_per_m: (n, 8, 8, 8) float32, kelvin and 1/m.
    origin_m, voxel_size_m, absorption_source, temperature_source: as in :class:`Volume`.
    """

    shape: tuple[int, int, int]
    leaf_coords: NDArray[np.int32]
    leaf_temperature_K: NDArray[np.float32]
    leaf_absorption_per_m: NDArray[np.float32]
    origin_m: tuple[float, float, float]
    voxel_size_m: float
    absorption_source: str = "grid"
    temperature_source: str = "given in K"
    #: (n, 8, 8, 8, 3) float32 gas velocity in m/s (motion blur), or None
    leaf_velocity_m_s: NDArray[np.float32] | None = None
    #: the absorption's spectral law κ_λ = κ·(550 nm/λ)^α (``Volume.soot_alpha``)
    soot_alpha: float = 1.0
    _cache: dict = field(default_factory=dict, repr=False)

    # What a dense Volume has that a sparse one does not carry (the sparse layout marches
    # blackbody emission from κ and T; species and emission-scale grids stay dense).
    emission_scale = None
    scattering_per_m = None
    phase_g = 0.0
    species: ClassVar[Mapping[str, NDArray[np.float32]]] = MappingProxyType({})

    @classmethod
    def from_leaves(
        cls,
        shape,
        leaf_coords,
        temperature_K,
        absorption_per_m,
        voxel_size_m: float | None = None,
        origin_m=None,
        source: str = "leaves",
        velocity_m_s=None,
    ) -> SparseVolume:
        """Validate leaves (coordinates inside the grid, unique; values finite, ≥ 0, T below the
        tables' ceiling; κ = 0 wherever T = 0 is not required) and place them like
        :meth:`Volume.from_arrays` (default: centred, largest side 1 m)."""
        shape = _shape(shape, source)
        coords = np.ascontiguousarray(leaf_coords, dtype=np.int32).reshape(-1, 3)
        _check_coords(coords, shape, source)
        temp = _leaf_values(temperature_K, len(coords), "temperature_K", source)
        kappa = _leaf_values(absorption_per_m, len(coords), "absorption_per_m", source)
        if temp.size and temp.max() > T_CEILING_K:
            raise ValueError(f"{source}: temperature above the {T_CEILING_K:g} K ceiling")
        voxel = 1.0 / max(shape) if voxel_size_m is None else float(voxel_size_m)
        if not np.isfinite(voxel) or voxel <= 0:
            raise ValueError(f"{source}: voxel_size_m must be > 0; got {voxel_size_m!r}")
        origin = tuple(-0.5 * n * voxel for n in shape) if origin_m is None else origin_m
        x, y, z = (float(o) for o in origin)
        velocity = None
        if velocity_m_s is not None:
            velocity = np.ascontiguousarray(velocity_m_s, dtype=np.float32)
            if (
                velocity.shape != (len(coords), LEAF, LEAF, LEAF, 3)
                or not np.isfinite(velocity).all()
            ):
                raise ValueError(
                    f"{source}: velocity must be finite ({len(coords)}, 8, 8, 8, 3) leaves"
                )
        return cls(shape, coords, temp, kappa, (x, y, z), voxel, leaf_velocity_m_s=velocity)

    @classmethod
    def from_volume(cls, volume: Volume, blur_rings: int = 0) -> SparseVolume:
        """The leaves of a dense Volume that absorb, and their neighbours' non-zero T.

        A sample whose trilinear κ is > 0 reads T only from the leaves around an absorbing voxel,
        so with blackbody emission (which needs κ > 0) the image equals the dense volume's; T in
        leaves farther from any absorption is never read and is dropped. ``blur_rings``: motion
        blur reads the velocity in every macrocell that many leaves from an absorbing one, so
        those leaves (and one more ring, for the trilinear stencil) keep their velocity."""
        grids = ("emission_scale", "scattering_per_m")
        extra = [n for n in grids if getattr(volume, n) is not None]
        if extra or volume.species:
            names = ", ".join(extra + [f"species {s}" for s in volume.species])
            raise ValueError(f"the sparse layout carries T and κ only; this volume has {names}")
        cells = volume.macrocells(LEAF)  # κ over each leaf and its border, cached on the volume
        reach = cells.max_absorption > 0
        with_velocity = volume.velocity_m_s is not None and blur_rings > 0
        for _ in range(1 + (blur_rings if with_velocity else 0)):
            reach = dilate_cells(reach)
        coords = np.argwhere(reach).astype(np.int32)
        leaves_t = _blocks(volume.temperature_K)[tuple(coords.T)]  # copies of these leaves only
        leaves_k = _blocks(volume.absorption_per_m)[tuple(coords.T)]
        keep = np.any((leaves_t != 0) | (leaves_k != 0), axis=(1, 2, 3))
        velocity = None
        if with_velocity and volume.velocity_m_s is not None:
            velocity = _blocks(volume.velocity_m_s)[tuple(coords.T)]
            keep |= np.any(velocity != 0, axis=(1, 2, 3, 4))
            velocity = np.ascontiguousarray(velocity[keep])
        out = cls(
            volume.shape,
            coords[keep],
            leaves_t[keep],
            leaves_k[keep],
            volume.origin_m,
            volume.voxel_size_m,
            volume.absorption_source,
            volume.temperature_source,
            velocity,
            volume.soot_alpha,
        )
        out._cache[("macrocells", LEAF, "absorption")] = cells  # the same cells, exactly
        out._cache["two_valued_kappa"] = volume.two_valued_absorption_per_m
        out._cache["max_temperature_K"] = volume.max_temperature_K
        return out

    # --- what the renderer asks of a volume ---------------------------------------------------
    @property
    def leaf_shape(self) -> tuple[int, int, int]:
        """Leaves along each axis (the last may be partial)."""
        return tuple(-(-n // LEAF) for n in self.shape)  # type: ignore[return-value]

    @property
    def leaf_fraction(self) -> float:
        """Occupied leaves over all leaves of the grid."""
        return len(self.leaf_coords) / float(np.prod(self.leaf_shape))

    @property
    def content_bounds_m(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World box around the voxels that absorb; the whole box if none do (computed once)."""
        if "content_bounds_m" not in self._cache:
            self._cache["content_bounds_m"] = self._content_bounds()
        return self._cache["content_bounds_m"]

    def _content_bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        occupied = self.leaf_absorption_per_m > 0
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for axis in range(3):
            others = tuple(a + 1 for a in range(3) if a != axis)
            along = np.any(occupied, axis=others)  # (n, 8): which layers of each leaf absorb
            rows = np.flatnonzero(along.any(axis=1))
            if rows.size == 0:
                return self.bounds_m
            first = self.leaf_coords[rows, axis] * LEAF + along[rows].argmax(axis=1)
            last = self.leaf_coords[rows, axis] * LEAF + LEAF - 1 - along[rows, ::-1].argmax(axis=1)
            lo[axis], hi[axis] = first.min(), last.max() + 1
        origin = np.asarray(self.origin_m)
        return origin + lo * self.voxel_size_m, origin + hi * self.voxel_size_m

    @property
    def velocity_m_s(self) -> NDArray[np.float32] | None:
        """The leaves' velocity (what tells a blurring render it has one), or None."""
        return self.leaf_velocity_m_s

    @property
    def max_speed_m_s(self) -> float:
        """Largest |v| component over the leaves, m/s (0 without velocity)."""
        v = self.leaf_velocity_m_s
        return 0.0 if v is None or v.size == 0 else float(np.abs(v).max())

    @property
    def max_temperature_K(self) -> float:
        if "max_temperature_K" not in self._cache:
            temp = self.leaf_temperature_K
            self._cache["max_temperature_K"] = float(temp.max()) if temp.size else 0.0
        return self._cache["max_temperature_K"]

    @property
    def two_valued_absorption_per_m(self) -> float | None:
        """κ₀ when every voxel's κ is 0 or κ₀ > 0 (see :class:`Volume`), else None."""
        if "two_valued_kappa" not in self._cache:
            kappa = self.leaf_absorption_per_m
            peak = np.float32(kappa.max()) if kappa.size else np.float32(0)
            two = peak > 0 and not np.any((kappa != 0) & (kappa != peak))
            self._cache["two_valued_kappa"] = float(peak) if two else None
        return self._cache["two_valued_kappa"]

    def macrocells(self, cell_voxels: int = 8, rule: str = "absorption", occupancy=None):
        """Macrocells of one leaf each, exactly those of the dense grid (``build_macrocells``):
        per-cell maximum κ over the cell plus a one-voxel border, from the leaves alone."""
        if cell_voxels != LEAF or occupancy is not None:
            raise ValueError(
                f"a sparse volume's macrocells are its {LEAF}³ leaves over κ; got cells of "
                f"{cell_voxels} voxels{' and another occupancy rule' if occupancy else ''}"
            )
        key = ("macrocells", cell_voxels, rule)
        if key not in self._cache:
            cells = leaf_macrocells(self.leaf_coords, self.leaf_absorption_per_m, self.leaf_shape)
            self._cache[key] = MacrocellGrid(cells, LEAF, empty_radius(cells > 0))
        return self._cache[key]

    def replace(self, **changes) -> SparseVolume:
        return replace(self, _cache={}, **changes)

    def to_dense(self) -> Volume:
        """The dense Volume of the same grids (for the float64 reference and small grids)."""
        temp = np.zeros(self.shape, dtype=np.float32)
        kappa = np.zeros(self.shape, dtype=np.float32)
        for dense, leaves in ((temp, self.leaf_temperature_K), (kappa, self.leaf_absorption_per_m)):
            _scatter_leaves(dense, self.leaf_coords, leaves)
        velocity = None
        if self.leaf_velocity_m_s is not None:
            velocity = np.zeros(self.shape + (3,), dtype=np.float32)
            _scatter_leaves(velocity, self.leaf_coords, self.leaf_velocity_m_s)
        for a in (temp, kappa, velocity):
            if a is not None:
                a.setflags(write=False)
        return Volume(
            temp,
            kappa,
            None,
            self.origin_m,
            self.voxel_size_m,
            self.absorption_source,
            temperature_source=self.temperature_source,
            velocity_m_s=velocity,
            soot_alpha=self.soot_alpha,
        )


def _shape(shape, source: str) -> tuple[int, int, int]:
    out = tuple(int(n) for n in shape)
    if len(out) != 3 or min(out) < 1:
        raise ValueError(f"{source}: shape must be 3 positive voxel counts; got {shape!r}")
    return out  # type: ignore[return-value]


def _check_coords(coords: NDArray, shape: tuple[int, int, int], source: str) -> None:
    limit = np.array([-(-n // LEAF) for n in shape])
    bad = np.any((coords < 0) | (coords >= limit), axis=1)
    if bad.any():
        leaf = tuple(int(c) for c in coords[bad][0])
        raise ValueError(f"{source}: leaf {leaf} lies outside a grid of {limit.tolist()} leaves")
    flat = np.ravel_multi_index(coords.T, tuple(limit)) if len(coords) else coords[:, 0]
    if len(np.unique(flat)) != len(flat):
        raise ValueError(f"{source}: leaf coordinates must be unique")


def _leaf_values(values, n: int, name: str, source: str) -> NDArray[np.float32]:
    arr = np.ascontiguousarray(values, dtype=np.float32)
    if arr.shape != (n, LEAF, LEAF, LEAF):
        raise ValueError(f"{source}: {name} must be ({n}, 8, 8, 8) leaves; got {arr.shape}")
    if not np.isfinite(arr).all() or (arr < 0).any():
        raise ValueError(f"{source}: {name} must be finite and >= 0")
    return arr


def _blocks(grid: NDArray) -> NDArray:
    """(lx, ly, lz, 8, 8, 8[, c]) leaves of a dense grid (of scalars or c-vectors), zero-padded
    to whole leaves."""
    rest = grid.shape[3:]
    padded_shape = tuple(-(-n // LEAF) * LEAF for n in grid.shape[:3])
    if padded_shape != grid.shape[:3]:
        out = np.zeros(padded_shape + rest, dtype=grid.dtype)
        out[: grid.shape[0], : grid.shape[1], : grid.shape[2]] = grid
        grid = out
    lx, ly, lz = (n // LEAF for n in padded_shape)
    view = grid.reshape((lx, LEAF, ly, LEAF, lz, LEAF) + rest)
    return view.transpose((0, 2, 4, 1, 3, 5) + tuple(range(6, 6 + len(rest))))


def _scatter_leaves(dense: NDArray, coords: NDArray, leaves: NDArray) -> None:
    """Write leaves into a dense grid (voxels beyond the grid's shape are dropped)."""
    whole = _padded(dense.shape[:3]) == dense.shape[:3]
    full = dense if whole else np.zeros(_padded(dense.shape[:3]) + dense.shape[3:], dense.dtype)
    _blocks(full)[tuple(coords.T)] = leaves  # _blocks of whole leaves is a view of ``full``
    if not whole:
        nx, ny, nz = dense.shape[:3]  # a vector grid has a fourth axis
        dense[...] = full[:nx, :ny, :nz]


def _padded(shape) -> tuple[int, ...]:
    return tuple(-(-n // LEAF) * LEAF for n in shape)


#: For a neighbour leaf at offset d (−1, 0, +1) along an axis, the layers of it that lie in a
#: cell's one-voxel border: its last layer, all of it, its first layer.
_LAYERS = {-1: slice(LEAF - 1, LEAF), 0: slice(0, LEAF), 1: slice(0, 1)}


def leaf_macrocells(coords: NDArray, kappa: NDArray, leaf_shape) -> NDArray[np.float32]:
    """Per leaf-sized cell, the maximum κ over the cell's voxels plus a one-voxel border: cell c
    takes all of leaf c and the touching layer of each of its 26 neighbours (exact, as
    ``macrocells._extended_block_max`` on the dense grid; voxels past the grid's edge are 0)."""
    cells = np.zeros(tuple(leaf_shape), dtype=np.float32)
    for dx, dy, dz in np.ndindex(3, 3, 3):
        d = np.array([dx, dy, dz]) - 1
        part = kappa[:, _LAYERS[int(d[0])], _LAYERS[int(d[1])], _LAYERS[int(d[2])]]
        target = coords - d  # the cell whose border this layer is
        inside = np.all((target >= 0) & (target < np.asarray(leaf_shape)), axis=1)
        np.maximum.at(cells, tuple(target[inside].T), part[inside].max(axis=(1, 2, 3)))
    return cells
