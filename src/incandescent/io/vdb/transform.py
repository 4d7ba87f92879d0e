"""The box and index→world checks shared by the VDB readers: grids read together go onto ONE
box (the union of their active boxes) and must share one uniform, axis-aligned transform."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent.io.vdb.results import GridInfo, Index, floats, ints

#: Relative tolerance when comparing voxel sizes and translations.
TRANSFORM_RTOL = 1e-6
#: An inclusive index box (low corner, high corner), int64.
Box = tuple[NDArray, NDArray]


def union_box(path: Path, infos: Mapping[str, GridInfo], max_voxels: int) -> Box:
    """The union of the grids' active boxes; refused when empty or over ``max_voxels``."""
    boxes = [(i.index_min, i.index_max) for i in infos.values() if i.index_min and i.index_max]
    if not boxes:
        raise ValueError(f"{path}: grids {list(infos)} have no active voxels; nothing to read")
    lo = np.min([b[0] for b in boxes], axis=0).astype(np.int64)
    hi = np.max([b[1] for b in boxes], axis=0).astype(np.int64)
    shape = hi - lo + 1
    if int(np.prod(shape)) > max_voxels:
        raise ValueError(
            f"{path}: the active box of {list(infos)} spans {tuple(int(n) for n in shape)} = "
            f"{int(np.prod(shape))} voxels, more than max_voxels={max_voxels}; raise the limit "
            "if the memory is there (4 bytes per voxel per grid)"
        )
    return lo, hi


def common_transform(path: Path, infos: Mapping[str, GridInfo]) -> tuple[float, NDArray]:
    """(voxel side m, translation m) the grids share, or an error listing each grid's."""
    voxel, translation = None, None
    for info in infos.values():
        size = _uniform_voxel_size(path, info)
        offset = np.asarray(info.translation_m, dtype=np.float64)
        if voxel is None or translation is None:
            voxel, translation = size, offset
            continue
        tolerance = TRANSFORM_RTOL * max(voxel, size)
        if abs(size - voxel) > tolerance or np.abs(offset - translation).max() > tolerance:
            described = {i.name: (i.voxel_size_m, i.translation_m) for i in infos.values()}
            raise ValueError(
                f"{path}: grids do not share one index→world transform, so they cannot be read "
                f"onto one box: (voxel size, translation) = {described}"
            )
    assert voxel is not None and translation is not None  # infos is never empty
    return voxel, translation


def _uniform_voxel_size(path: Path, info: GridInfo) -> float:
    problem = transform_problem(info.index_to_world, info.voxel_size_m)
    if problem:
        raise ValueError(f"{path}: grid {info.name!r} {problem}")
    return float(info.voxel_size_m[0])


def transform_problem(matrix: tuple | None, voxel_size_m: tuple) -> str | None:
    """Why an index→world map is not the uniform scale + translation the renderer needs."""
    size = np.asarray(voxel_size_m, dtype=np.float64)
    linear = None if matrix is None else np.asarray(matrix, dtype=np.float64)[:3, :3]
    shear = 0.0 if linear is None else float(np.abs(linear - np.diag(np.diag(linear))).max())
    if (
        linear is None
        or not np.all(np.isfinite(size))
        or size.min() <= 0
        or size.max() - size.min() > TRANSFORM_RTOL * size.max()
        or shear > TRANSFORM_RTOL * size.max()
    ):
        return (
            f"has an index→world transform that is not a uniform scale plus translation "
            f"(voxel size {voxel_size_m}, matrix {matrix}); the renderer needs cubic, "
            "axis-aligned voxels — resample the grid first"
        )
    return None


def placement(
    path: Path, info: GridInfo, box: Box, voxel: float, translation: NDArray
) -> tuple[Index, tuple[float, float, float], str]:
    """(index of the box's low corner, world position m of that voxel's corner — its centre
    minus half a voxel —, ``"path:name"`` for messages)."""
    lo = ints(box[0])
    origin = floats(t + (i - 0.5) * voxel for t, i in zip(translation, lo, strict=True))
    return lo, origin, f"{path}:{info.name}"
