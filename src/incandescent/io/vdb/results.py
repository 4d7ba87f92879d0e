"""What the VDB readers return: :class:`GridInfo` (one grid as its file describes it, built by
the one constructor :meth:`GridInfo.of` that all three readers use), :class:`DenseGrid` and
:class:`LeafGrids`; and the small conversions they share."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

Index = tuple[int, int, int]
Matrix = tuple[tuple[float, ...], ...]
#: (index→world 4×4 matrix or None when not linear, voxel size m, translation m).
Transform = tuple[Matrix | None, tuple[float, float, float], tuple[float, float, float]]


def ints(values: Any) -> Index:
    """Three integers (an index) from any iterable of three numbers."""
    a, b, c = (int(v) for v in values)
    return a, b, c


def floats(values: Any) -> tuple[float, float, float]:
    """Three floats (a position or size, m) from any iterable of three numbers."""
    a, b, c = (float(v) for v in values)
    return a, b, c


def matrix(array: NDArray) -> Matrix:
    """A matrix as nested tuples of floats (hashable, comparable)."""
    return tuple(tuple(float(v) for v in row) for row in array)


def optional_bool(value: object) -> bool | None:
    return value if isinstance(value, bool) else None


def optional_str(value: object) -> str | None:
    return value if isinstance(value, str) else None


def _optional_count(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


@dataclass(frozen=True)
class GridInfo:
    """What a file says about one grid (no voxel data beyond value statistics).

    Attributes
    ----------
    name: grid name as stored.
    value_type: "float", "double", "int32", "bool", "vec3s", … (OpenVDB) or NanoVDB's type name.
    type_name: the library's raw type string (``Tree_float_5_4_3``, ``Float``).
    active_voxels: number of active voxels (None when the library cannot count them).
    index_min, index_max: inclusive index box of the active voxels (None when empty or unknown).
    index_to_world: 4×4 matrix, world = M @ (i, j, k, 1) (column vectors; None if not linear).
    voxel_size_m: voxel size along x, y, z (world units, taken as m).
    translation_m: world position of the centre of voxel (0, 0, 0).
    value_min, value_max: range of the active values (None for non-float grids).
    background: value outside the active voxels (None for non-float grids).
    half_float: stored as 16-bit floats (None when the file does not say).
    compression: the file's compression as recorded in the grid metadata (None when not recorded).
    grid_class: "fog volume", "level set", … (None when not recorded).
    unreadable: why :func:`read_grid` would refuse this grid (None when it can be read); counts
        and boxes then come from OpenVDB's ``file_*`` metadata where the file has it.
    """

    name: str
    value_type: str
    type_name: str
    active_voxels: int | None
    index_min: Index | None
    index_max: Index | None
    index_to_world: Matrix | None
    voxel_size_m: tuple[float, float, float]
    translation_m: tuple[float, float, float]
    value_min: float | None
    value_max: float | None
    background: float | None
    half_float: bool | None
    compression: str | None
    grid_class: str | None
    unreadable: str | None = None

    @classmethod
    def of(
        cls,
        name: str,
        type_name: str,
        transform: Transform,
        *,
        value_type: str | None = None,
        metadata: Mapping[str, object] | None = None,
        grid_class: str | None = None,
        active_voxels: int | None = None,
        box: tuple[Index | None, Index | None] = (None, None),
        value_range: tuple[float | None, float | None] = (None, None),
        background: float | None = None,
        unreadable: str | None = None,
    ) -> GridInfo:
        """A grid's description. ``transform``: (index→world matrix, voxel size m, translation
        m); ``value_type`` defaults to ``type_name``; half float, compression and (unless given)
        class are read from OpenVDB's grid ``metadata``; ``box``: the inclusive index box."""
        meta = metadata or {}
        return cls(
            name=name,
            value_type=type_name if value_type is None else value_type,
            type_name=type_name,
            active_voxels=active_voxels,
            index_min=box[0],
            index_max=box[1],
            index_to_world=transform[0],
            voxel_size_m=transform[1],
            translation_m=transform[2],
            value_min=value_range[0],
            value_max=value_range[1],
            background=background,
            half_float=optional_bool(meta.get("is_saved_as_half_float")),
            compression=optional_str(meta.get("file_compression")),
            grid_class=optional_str(meta.get("class")) if grid_class is None else grid_class,
            unreadable=unreadable,
        )

    @classmethod
    def unread(
        cls,
        problem: str,
        name: str,
        type_name: str,
        transform: Transform,
        metadata: Mapping[str, object],
        value_type: str | None = None,
    ) -> GridInfo:
        """A grid whose voxels cannot be read (``problem`` says why): its voxel count and box
        from OpenVDB's own ``file_*`` metadata where the file has them."""
        lo, hi = metadata.get("file_bbox_min"), metadata.get("file_bbox_max")
        box_ok = isinstance(lo, tuple) and isinstance(hi, tuple) and len(lo) == len(hi) == 3
        return cls.of(
            name,
            type_name,
            transform,
            value_type=value_type,
            metadata=metadata,
            active_voxels=_optional_count(metadata.get("file_voxel_count")),
            box=(ints(lo), ints(hi)) if box_ok else (None, None),
            unreadable=problem,
        )

    @property
    def is_float(self) -> bool:
        return self.value_type == "float"

    @property
    def shape(self) -> Index | None:
        """Dense shape of the active box (nx, ny, nz), or None when the grid is empty."""
        if self.index_min is None or self.index_max is None:
            return None
        return ints(h - l + 1 for l, h in zip(self.index_min, self.index_max, strict=True))


@dataclass(frozen=True, eq=False)
class DenseGrid:
    """One grid densified over an index box.

    Attributes
    ----------
    name: grid name.
    values: (nx, ny, nz) float32; ``values[a, b, c]`` is VDB voxel ``index_min + (a, b, c)``.
    origin_m: world position of the corner of ``values[0, 0, 0]`` (its centre minus half a voxel).
    voxel_size_m: side of the (cubic) voxels.
    background: the grid's background value (filled in where the box has no stored voxel).
    index_min: VDB index of ``values[0, 0, 0]``.
    source: ``"path:name"`` for messages.
    """

    name: str
    values: NDArray[np.float32]
    origin_m: tuple[float, float, float]
    voxel_size_m: float
    background: float
    index_min: Index
    source: str


@dataclass(frozen=True)
class LeafGrids:
    """Grids read as the 8³ leaves of one box (``openvdb_worker.leaves``): ``coords`` (n, 3)
    leaf coordinates from the box's low corner, ``arrays`` name → (n, 8, 8, 8[, 3]) float32,
    ``shape`` of the box (turned y-up when read z-up), ``origin_m`` the corner of the box's
    voxel (0, 0, 0) in the file's axes, ``backgrounds`` each grid's background."""

    coords: NDArray[np.int32]
    arrays: dict[str, NDArray[np.float32]]
    shape: tuple[int, int, int]
    origin_m: tuple[float, float, float]
    voxel_size_m: float
    backgrounds: dict[str, float]
