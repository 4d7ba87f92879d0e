"""Volumes from files: a scene's ``[volume]`` section (file, grid roles, preset, up axis, remap)
→ a validated :class:`~incandescent.volume.Volume`. What ``incandescent render FILE`` and
:func:`incandescent.api.load_volume` read through."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from incandescent.budget import Limits
from incandescent.config import GridNames, VolumeSection
from incandescent.io.volumes import open_grids
from incandescent.volume.grid import Remap, Volume
from incandescent.volume.presets import apply_preset, resolve_grid_name

OPTIONAL_ROLES = ("absorption", "emission_scale", "sodium_fraction")
#: Up axis of each preset's source application (ours is +y); Blender is z-up.
PRESET_UP_AXIS = {"blender": "z"}
PRESET_ROLES = ("temperature", "flame", "density")


def load_volume(
    path: str | Path,
    temperature_grid: str | None = None,
    absorption: float | None = None,
    voxel_size_m: float | None = None,
    remap: Remap | None = None,
) -> Volume:
    """Read a volume file (.npy, .npz, .vdb, .nvdb) into a validated Volume. A constant
    ``absorption`` (1/m) overrides the file's absorption grid."""
    spec = VolumeSection(
        path=Path(path),
        grids=GridNames(temperature=temperature_grid),
        absorption=absorption,
        voxel_size_m=voxel_size_m,
    )
    return volume_from_section(spec, remap or Remap())


def _grid_name(role: str, names: dict[str, str], available: tuple[str, ...], required: bool):
    if role in names:
        return names[role]
    if role in OPTIONAL_ROLES:
        return role if role in available else None
    return resolve_grid_name(role, available, required=required)


def volume_from_section(spec: VolumeSection, remap: Remap, limits: Limits | None = None) -> Volume:
    """The Volume a scene's ``[volume]`` section describes: file, grid roles, preset, remap.
    NumPy grids are checked against ``limits`` from their headers before they are read."""
    source = open_grids(spec.path, spec.axes, limits)
    names = spec.grids.given()
    core_roles = PRESET_ROLES if spec.preset else ("temperature",)
    try:
        roles = {r: _grid_name(r, names, source.names, not spec.preset) for r in core_roles}
    except ValueError as error:
        raise ValueError(f"{source.path}: {error}") from None
    for role in OPTIONAL_ROLES:
        roles[role] = _grid_name(role, names, source.names, required=False)
    if spec.absorption is not None:
        roles["absorption"] = None
    species_grids = {k: v for k, v in spec.species.items() if isinstance(v, str)}
    read = source.read(sorted({n for n in roles.values() if n} | set(species_grids.values())))
    grids = read.arrays
    by_role: dict[str, Any] = {role: grids[name] for role, name in roles.items() if name}
    by_role["species"] = {
        name: grids[value] if isinstance(value, str) else value
        for name, value in spec.species.items()
    }
    absorption_note = repr(roles["absorption"]) if roles.get("absorption") else None
    temperature_note = f"grid {roles['temperature']!r}" if roles.get("temperature") else None
    if spec.preset:
        out = apply_preset(spec.preset, grids, spec.preset_options, names)
        by_role["temperature"], by_role["absorption"] = (
            out["temperature_K"],
            out["absorption_per_m"],
        )
        absorption_note = out["description"] if out["absorption_per_m"] is not None else None
        temperature_note = out["description"]
    file_origin = read.origin_m  # in the source's axes
    voxel = spec.voxel_size_m or read.voxel_size_m
    up = spec.up_axis or PRESET_UP_AXIS.get(spec.preset or "", "y")
    if up == "z":
        by_role, file_origin = _z_up_to_y_up(by_role, file_origin, voxel)
    origin = spec.origin_m or file_origin
    return Volume.from_arrays(
        by_role["temperature"],
        spec.absorption if spec.absorption is not None else by_role.get("absorption"),
        by_role.get("emission_scale"),
        voxel,
        origin,
        remap=remap,
        source=str(source.path),
        sodium_fraction=by_role.get("sodium_fraction"),
        species=by_role.get("species"),
        absorption_source=None if spec.absorption is not None else absorption_note,
        temperature_source=temperature_note,
    )


def _z_up_to_y_up(grids: dict, origin, voxel_size_m):
    """Rotate z-up grids into our y-up world: (x, y, z) ↦ (x, z, −y), a proper rotation.

    ``a'[i, k, n_y − 1 − j] = a[i, j, k]``; the box corner moves to (o_x, o_z, −(o_y + L_y)).
    """

    def rotate(g):
        if g is None or np.ndim(g) == 0:
            return g
        if isinstance(g, dict):  # species fractions
            return {name: rotate(v) for name, v in g.items()}
        return np.flip(np.swapaxes(np.asarray(g), 1, 2), axis=2)

    rotated = {role: rotate(g) for role, g in grids.items()}
    if origin is None:
        return rotated, None
    length_y = np.asarray(grids["temperature"]).shape[1] * (voxel_size_m or 0.0)
    return rotated, (origin[0], origin[2], -(origin[1] + length_y))
