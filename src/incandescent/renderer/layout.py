"""Dense or sparse: which device layout a render marches (``RenderSettings.layout``).

* ``dense``: the grids as they are (``backends.march``) — fastest per sample, memory
  ∝ the whole box;
* ``sparse``: 9³ bricks of the occupied 8³ leaves (``backends.bricks``) — memory ∝ the occupied
  part, one more lookup per sample; images equal the dense layout's (same values read, same
  macrocells, same samples).

``auto`` takes sparse for a :class:`SparseVolume` (densifying a big cache is what it avoids) and for
a dense volume whose occupied leaves are under :data:`AUTO_SPARSE_FRACTION` of the box, or whose
dense layout would not fit in memory while the sparse one does; dense otherwise and whenever the
sparse layout cannot carry the render (it marches blackbody emission from T and κ, and the
velocity for motion blur: emission–absorption with models that read T and κ alone — no species
lines, no emission-scale grid —, 8-voxel macrocells).
"""

from __future__ import annotations

import numpy as np

from incandescent.budget import Limits
from incandescent.renderer.settings import RenderSettings
from incandescent.volume import Volume
from incandescent.volume.macrocells import dilate_cells
from incandescent.volume.sparse import AUTO_SPARSE_FRACTION, LEAF, SparseVolume


def sparse_problem(
    volume, settings: RenderSettings, integrator, models, backend: str
) -> str | None:
    """Why the sparse layout cannot carry this render (``integrator`` with ``models``), or None."""
    if backend == "reference":
        return "the float64 reference marches dense grids"
    problem = integrator.sparse_problem(models)
    if problem:
        return problem
    if volume.emission_scale is not None or volume.species:
        return "the volume has grids besides T and κ"
    if settings.skip_empty and settings.macrocell_voxels != LEAF:
        return f"its macrocells are its {LEAF}-voxel leaves (macrocell_voxels={LEAF})"
    return None


def layout_volume(
    volume: Volume | SparseVolume,
    settings: RenderSettings,
    integrator,
    models: tuple,
    backend: str,
    limits: Limits,
) -> Volume | SparseVolume:
    """The volume in the layout the march uses: a :class:`SparseVolume` marches sparse."""
    problem = sparse_problem(volume, settings, integrator, models, backend)
    if settings.layout == "sparse" and problem:
        raise ValueError(f"layout 'sparse' cannot render this: {problem}; use layout 'dense'")
    if problem or settings.layout == "dense":
        return _dense(volume, limits)
    if isinstance(volume, SparseVolume):
        return volume
    if settings.layout == "sparse" or _sparse_pays(volume, limits):
        return _sparse_of(volume, blur_rings(volume, settings))
    return volume


def blur_rings(volume, settings: RenderSettings) -> int:
    """Macrocells a blurred sample may read away from its own: the largest displacement
    max|v_i|·max|t| along any axis, in cells (DESIGN §4: skipping stays exact); 0 without blur."""
    shutter = settings.shutter_s
    if shutter is None or volume.velocity_m_s is None:
        return 0
    reach = volume.max_speed_m_s * max(abs(t) for t in shutter) / volume.voxel_size_m
    return int(np.ceil(reach / settings.macrocell_voxels))


def _dense(volume, limits: Limits) -> Volume:
    if isinstance(volume, Volume):
        return volume
    limits.check_memory(8.0 * float(_voxels(volume)), f"densifying a {volume.shape} sparse volume")
    if "dense" not in volume._cache:
        volume._cache["dense"] = volume.to_dense()
    return volume._cache["dense"]


def _voxels(volume) -> int:
    nx, ny, nz = volume.shape
    return nx * ny * nz


def _sparse_pays(volume: Volume, limits: Limits) -> bool:
    """Few occupied leaves (from the κ macrocells of leaf size, cached), or no room for dense."""
    occupied = dilate_cells(volume.macrocells(LEAF).max_absorption > 0)  # the leaves kept, at most
    if float(occupied.mean()) < AUTO_SPARSE_FRACTION:
        return True
    return 8.0 * float(_voxels(volume)) > limits.memory_bytes()


def _sparse_of(volume: Volume, rings: int = 0) -> SparseVolume:
    key = ("sparse", rings)
    if key not in volume._cache:
        volume._cache[key] = SparseVolume.from_volume(volume, rings)
    return volume._cache[key]
