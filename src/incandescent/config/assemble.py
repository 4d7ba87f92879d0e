"""Volumes from files: a scene's ``[volume]`` section (file, grid roles, preset, up axis, remap)
→ a validated :class:`~incandescent.volume.Volume`. What ``incandescent render FILE`` and
:func:`incandescent.api.load_volume` read through."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from incandescent.budget import Limits
from incandescent.config.schema import GridNames, VolumeSection
from incandescent.io.volumes import DENSE_READ_BYTES_PER_VOXEL, open_grids
from incandescent.io.vtk import openfoam_up_axis
from incandescent.volume.grid import Remap, Volume
from incandescent.volume.presets import (
    PRESET_SCATTERING,
    apply_preset,
    get_preset,
    preset_parameters,
    resolve_grid_name,
)
from incandescent.volume.sparse import AUTO_SPARSE_FRACTION, LEAF, SparseVolume

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
    layout: str = "auto",
) -> Volume | SparseVolume:
    """Read a volume file (.npy, .npz, .vdb, .nvdb) into a validated Volume (a SparseVolume of
    its leaves for a sparse OpenVDB file; ``layout`` as in :func:`volume_from_section`). A
    constant ``absorption`` (1/m) overrides the file's absorption grid."""
    spec = VolumeSection(
        path=Path(path),
        grids=GridNames(temperature=temperature_grid),
        absorption=absorption,
        voxel_size_m=voxel_size_m,
    )
    return volume_from_section(spec, remap or Remap(), layout=layout)


def _grid_name(
    role: str, names: dict[str, str], available: tuple[str, ...], required: bool, aliases=None
):
    if role in names:
        return names[role]
    if role in OPTIONAL_ROLES:
        return role if role in available else None
    return resolve_grid_name(role, available, required, aliases)


def volume_from_section(
    spec: VolumeSection,
    remap: Remap,
    limits: Limits | None = None,
    layout: str = "auto",
    blur_fps: float | None = None,
    velocity: bool = False,
) -> Volume | SparseVolume:
    """The Volume a scene's ``[volume]`` section describes: file, grid roles, preset, remap.
    NumPy grids are checked against ``limits`` from their headers before they are read. An
    OpenVDB file is read as sparse leaves (a :class:`SparseVolume`, never densified) when
    ``layout`` is "sparse", or "auto" and the file is sparse or too big to densify.
    ``blur_fps``: the render blurs motion at this frame rate, so the velocity grid is read too
    (``spec.velocity_units`` "voxels/frame" are converted to m/s with it). ``velocity``: read
    the velocity grid (in m/s) without blurring — what ``convert`` carries to its output."""
    limits = limits or Limits()
    source = open_grids(spec.path, spec.axes, limits, spec.resolution)
    roles = _roles(spec, source)
    if blur_fps is not None or velocity or spec.upres:
        roles["velocity"] = _velocity_grid(spec, source, "up-resolving" if spec.upres else None)
    if _reads_leaves(spec, source, roles, layout, limits):
        if spec.upres:
            raise ValueError(f"{source.path}: volume.upres needs a dense grid; this one is sparse")
        return _sparse_volume(spec, source, roles, remap, blur_fps)
    species_grids = {k: v for k, v in spec.species.items() if isinstance(v, str)}
    extra_grids = set(species_grids.values()) | _scattering_grid(spec)
    read = source.read(sorted({n for n in roles.values() if n} | extra_grids))
    grids = read.arrays
    if spec.upres:
        grids = _upresolved(spec, grids, str(roles["velocity"]), read.voxel_size_m, limits,
                            source.path)  # fmt: skip
    by_role: dict[str, Any] = {role: grids[name] for role, name in roles.items() if name}
    by_role["species"] = {
        name: grids[value] if isinstance(value, str) else value
        for name, value in spec.species.items()
    }
    voxel = spec.voxel_size_m or read.voxel_size_m
    if spec.upres and voxel:
        voxel = voxel / spec.upres
    file_origin = read.origin_m  # in the source's axes
    if _up_axis(spec) == "z":
        by_role, file_origin = _z_up_to_y_up(by_role, file_origin, voxel)
        grids = {name: _rotated(g) for name, g in grids.items()}
    if by_role.get("velocity") is not None:
        by_role["velocity"] = _velocity_m_s(spec, by_role["velocity"], voxel, blur_fps)
    origin = spec.origin_m or file_origin
    volume = _assembled(spec, source, roles, grids, by_role, remap, voxel, origin)
    return _scattering(volume, spec, grids)


def _scattering_grid(spec: VolumeSection) -> set[str]:
    """The names of the σ_s and g grids the section names (``scattering = "grid"``,
    ``phase_g = "grid"``), if any."""
    names = {spec.scattering, spec.phase_g} - {PRESET_SCATTERING}
    return {name for name in names if isinstance(name, str)}


def _scattering(volume: Volume, spec: VolumeSection, grids) -> Volume:
    """``volume`` with the section's σ_s (a constant, a grid of the file, the albedo, or the
    preset's smoke rule: κ split into scattering and absorption, ``volume.presets``)."""
    if spec.scattering is None and spec.albedo is None:
        return volume
    g = grids[spec.phase_g] if isinstance(spec.phase_g, str) else spec.phase_g
    if spec.scattering == PRESET_SCATTERING:
        assert spec.preset is not None, "the schema checks that a preset is named"
        albedo = preset_parameters(spec.preset, spec.preset_options)["smoke_albedo"]
        split = volume.with_extinction_split(albedo, g)
        return split.replace(scattering_alpha=spec.scattering_alpha)
    value = grids[spec.scattering] if isinstance(spec.scattering, str) else spec.scattering
    return volume.with_scattering(value, spec.albedo, g, spec.scattering_alpha)


#: The time (s) a frame's sub-grid turbulence carries its gas when up-resolved: one frame at
#: 24 fps, the simulator's default rate.
UPRES_DT_S = 1.0 / 24.0
#: Peak bytes per fine voxel while up-resolving: the noise's three complex128 potentials and
#: curl, the float64 wavenumbers, the displacement and each grid's fine copy; the advected
#: noise adds its phases' fine texture coordinates and their lookups (tracemalloc at 2× with two
#: grids: 233 B fixed, 272 B advected).
UPRES_BYTES_PER_FINE_VOXEL = 290


def _upresolved(spec: VolumeSection, grids: dict, velocity: str, voxel_m, limits,
                path) -> dict:  # fmt: skip
    """The file's grids ``spec.upres`` times finer with sub-grid turbulence (``simulation.
    upres``) from the velocity grid (m/s); the velocity itself trilinearly up-sampled.
    ``voxel_m``: the file's voxel (the section's ``voxel_size_m`` wins when given). A file
    numbered as a frame of a sequence (``fire_0120.npz``) takes its noise advected through the
    frames before it (``_sequence``); a lone file, fixed noise."""
    from incandescent.simulation.upres import advected_noise, upres_fields, upsample

    factor = int(spec.upres or 1)
    if not (spec.voxel_size_m or voxel_m):
        raise ValueError("volume.upres needs the voxel size in m (volume.voxel_size_m)")
    voxel_m = float(spec.voxel_size_m or voxel_m)

    if spec.velocity_units != "m/s":
        raise ValueError("volume.upres needs the velocity in m/s (velocity_units = 'm/s')")
    fine = int(np.prod(np.shape(grids[velocity])[:3])) * factor**3
    limits.check_memory(
        fine * UPRES_BYTES_PER_FINE_VOXEL, f"up-resolving {factor}× ({fine:,} voxels)"
    )
    speed = np.asarray(grids[velocity], dtype=np.float32) * spec.velocity_scale
    scalars = {k: v for k, v in grids.items() if k != velocity and np.ndim(v) == 3}
    noise = None
    sequence = _sequence(Path(path), spec, velocity, speed.shape, limits)
    if sequence is not None:
        frame, history = sequence
        noise = advected_noise(frame, speed.shape[:3], history, voxel_m, factor, UPRES_DT_S)
    out = upres_fields(scalars, speed, voxel_m, factor, UPRES_DT_S, noise=noise)
    out[velocity] = np.stack([upsample(speed[..., a], factor) for a in range(3)], axis=-1)
    return out


def _sequence(path: Path, spec: VolumeSection, velocity: str, shape, limits):
    """(frame number, frame → that frame's velocity in m/s or None) when ``path`` is numbered
    as a frame (``NAME_0120.ext``, ``NAME0120.ext``) and at least its predecessor is there with a
    velocity grid of the same shape; else None. Frames read once each (cached)."""
    import re

    match = re.fullmatch(r"(.*?)(\d+)", path.stem)
    if match is None:
        return None
    stem, digits = match.groups()
    cache: dict[int, np.ndarray | None] = {}

    def history(frame: int) -> np.ndarray | None:
        if frame not in cache:
            other = path.with_name(f"{stem}{frame:0{len(digits)}d}{path.suffix}")
            cache[frame] = _frame_velocity(other, spec, velocity, shape, limits)
        return cache[frame]

    number = int(digits)
    return (number, history) if history(number - 1) is not None else None


def _frame_velocity(path: Path, spec: VolumeSection, velocity: str, shape, limits):
    """``path``'s velocity grid in m/s, or None where the file, the grid or its shape is not
    the sequence's (a gap in the sequence: the noise's advection restarts after it)."""
    if not path.is_file():
        return None
    try:
        source = open_grids(path, spec.axes, limits, spec.resolution)
        grid = source.read([velocity]).arrays[velocity]
    except (ValueError, KeyError, OSError):
        return None
    grid = np.asarray(grid, dtype=np.float32) * spec.velocity_scale
    return grid if grid.shape == tuple(shape) else None


def _velocity_grid(spec: VolumeSection, source, purpose: str | None = None) -> str:
    """The velocity grid's name (given, or found by its aliases): blurring (or ``purpose``)
    needs one."""
    if spec.grids.velocity is not None and spec.grids.velocity not in source.names:
        raise ValueError(
            f"{source.path}: no grid named {spec.grids.velocity!r} (the velocity grid); the file "
            f"has: {', '.join(source.names)}"
        )
    name = spec.grids.velocity or resolve_grid_name("velocity", source.names, required=False)
    if name is None:
        raise ValueError(
            f"{source.path}: {purpose or 'motion blur (a shutter)'} needs a velocity grid; none "
            f"is named velocity/vel/v among {list(source.names)} (name it with "
            "volume.grids.velocity)"
        )
    return name


def _velocity_m_s(spec: VolumeSection, velocity, voxel_m: float | None, fps: float | None):
    """The velocity grid in m/s: as given, or voxels/frame × voxel side × frames per second;
    times ``velocity_scale``."""
    values = np.asarray(velocity)
    if values.ndim != 4 or values.shape[-1] != 3:
        raise ValueError(f"{spec.path}: the velocity grid must hold 3-vectors; got {values.shape}")
    factor = float(spec.velocity_scale)
    if spec.velocity_units == "voxels/frame":
        side = voxel_m if voxel_m is not None else 1.0 / max(values.shape[:3])
        factor *= side * float(fps or 0.0)
    return values if factor == 1.0 else values * np.float32(factor)


def _roles(spec: VolumeSection, source) -> dict[str, str | None]:
    """Grid name per role (temperature or the preset's roles, then the optional ones)."""
    names = spec.grids.given()
    core_roles = PRESET_ROLES if spec.preset else ("temperature",)
    aliases = get_preset(spec.preset).aliases if spec.preset else None
    try:
        roles = {
            r: _grid_name(r, names, source.names, not spec.preset, aliases) for r in core_roles
        }
    except ValueError as error:
        raise ValueError(f"{source.path}: {error}") from None
    for role in OPTIONAL_ROLES:
        roles[role] = _grid_name(role, names, source.names, required=False)
    if spec.absorption is not None:
        roles["absorption"] = None
    return roles


def _up_axis(spec: VolumeSection) -> str:
    """Given, else the preset's, else an OpenFOAM case's (against its gravity), else y."""
    if spec.up_axis or spec.preset in PRESET_UP_AXIS:
        return spec.up_axis or PRESET_UP_AXIS[spec.preset or ""]
    return openfoam_up_axis(spec.path) or "y"


def _assembled(spec, source, roles, grids, by_role, remap, voxel, origin, box_side_m=None):
    """Preset (if any), then :meth:`Volume.from_arrays` of the roles' grids."""
    absorption_note = repr(roles["absorption"]) if roles.get("absorption") else None
    temperature_note = f"grid {roles['temperature']!r}" if roles.get("temperature") else None
    if spec.preset:
        names = spec.grids.given()
        out = apply_preset(spec.preset, grids, spec.preset_options, names)
        by_role["temperature"], by_role["absorption"] = (
            out["temperature_K"],
            out["absorption_per_m"],
        )
        absorption_note = out["description"] if out["absorption_per_m"] is not None else None
        temperature_note = out["description"]
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
        box_side_m=box_side_m,
        velocity_m_s=by_role.get("velocity"),
        copy=False,  # a reader's fresh arrays: handed over, not copied again
        soot_alpha=spec.soot_alpha,
    )


def _reads_leaves(spec, source, roles, layout: str, limits: Limits) -> bool:
    """Read sparse leaves? Only T and κ (and a preset's inputs) travel as leaves."""
    extra = any(roles.get(r) for r in ("emission_scale", "sodium_fraction"))
    extra = extra or bool(spec.species) or spec.scattering is not None or spec.albedo is not None
    if layout == "dense" or source.read_leaves is None or extra:
        return False
    if layout == "sparse":
        return True
    names = sorted({n for n in roles.values() if n})
    box, active = source.extent(names)
    dense_bytes = float(box) * DENSE_READ_BYTES_PER_VOXEL * len(names)
    return active < AUTO_SPARSE_FRACTION * box or dense_bytes > limits.memory_bytes()


def _sparse_volume(spec, source, roles, remap: Remap, blur_fps: float | None) -> SparseVolume:
    """The roles' grids read as leaves, through the same preset and remap as a dense read; with
    a velocity grid, the leaves within a frame's travel of the gas keep their velocity."""
    names = sorted({n for n in roles.values() if n})
    rings = _blur_leaf_rings(spec, source, roles.get("velocity"), blur_fps)
    leaves = source.read_leaves(names, _up_axis(spec) == "z", rings)
    count = len(leaves.coords)
    if count == 0:
        raise ValueError(f"{source.path}: grids {names} hold only their background values")
    voxel = spec.voxel_size_m or leaves.voxel_size_m
    flat = {
        n: a.reshape((count * LEAF, LEAF, LEAF) + a.shape[4:]) for n, a in leaves.arrays.items()
    }
    side = voxel * max(leaves.shape)
    by_role = _by_role(roles, flat)
    if by_role.get("velocity") is not None:
        by_role["velocity"] = _velocity_m_s(spec, by_role["velocity"], voxel, blur_fps)
    volume = _assembled(spec, source, roles, flat, by_role, remap, voxel, None, side)
    _check_vacuum_background(spec, source, roles, leaves, remap, voxel, side)
    origin = leaves.origin_m
    if _up_axis(spec) == "z":  # the box was turned by the reader: place it as _z_up_to_y_up does
        ny = leaves.shape[2] * voxel
        origin = (origin[0], origin[2], -(origin[1] + ny))
    velocity = volume.velocity_m_s
    return SparseVolume(
        leaves.shape,
        leaves.coords,
        volume.temperature_K.reshape(count, LEAF, LEAF, LEAF),
        volume.absorption_per_m.reshape(count, LEAF, LEAF, LEAF),
        tuple(float(o) for o in (spec.origin_m or origin)),  # type: ignore[arg-type]
        voxel,
        volume.absorption_source,
        volume.temperature_source,
        None if velocity is None else velocity.reshape(count, LEAF, LEAF, LEAF, 3),
        spec.soot_alpha,
    )


def _blur_leaf_rings(spec, source, velocity_grid: str | None, fps: float | None) -> int:
    """Extra rings of leaves a blurred render may read: the fastest gas's travel in a frame (a
    shutter lasts at most one frame either side), in leaves, from the file's largest speed."""
    if velocity_grid is None or fps is None:
        return 0
    stats = source.value_max(velocity_grid) if source.value_max else None
    if stats is None:
        raise ValueError(
            f"{source.path}: the velocity grid's largest value is unknown (non-finite values, "
            "or a grid OpenVDB cannot measure); motion blur needs finite velocities in m/s"
        )
    largest, file_voxel = stats
    if not np.isfinite(largest):
        raise ValueError(
            f"{source.path}: the velocity grid {velocity_grid!r} holds non-finite values "
            f"(largest |v| = {largest}); motion blur needs finite velocities in m/s"
        )
    voxel = spec.voxel_size_m or file_voxel
    speed = float(np.abs(_velocity_m_s(spec, np.full((1, 1, 1, 3), largest), voxel, fps)).max())
    travel = speed / fps / voxel  # voxels in one frame
    if travel > MAX_BLUR_TRAVEL_VOXELS:
        raise ValueError(
            f"{source.path}: the velocity grid {velocity_grid!r} moves gas {travel:.3g} voxels "
            f"in a frame ({speed:.3g} m/s at {fps:g} fps); blurring supports at most "
            f"{MAX_BLUR_TRAVEL_VOXELS} — check volume.velocity_units and --velocity-scale"
        )
    return int(np.ceil(travel / LEAF))


#: A frame's travel that blurring reads leaves for (64 leaves): beyond it, a blur streak is
#: longer than any box this renderer reads sparse in memory — a unit error, not a flame.
MAX_BLUR_TRAVEL_VOXELS = 64 * LEAF


def _by_role(roles, grids) -> dict[str, Any]:
    return {role: grids[name] for role, name in roles.items() if name} | {"species": {}}


def _check_vacuum_background(spec, source, roles, leaves, remap, voxel, side) -> None:
    """Leaves not read hold the grids' backgrounds; the sparse volume takes them as vacuum, so
    the backgrounds must map to κ = 0 (else read densely)."""
    shape = (1, 1, 1)
    backgrounds = {
        n: np.full(shape + leaves.arrays[n].shape[4:], b) for n, b in leaves.backgrounds.items()
    }
    volume = _assembled(
        spec, source, roles, backgrounds, _by_role(roles, backgrounds), remap, voxel, None, side
    )
    kappa = float(volume.absorption_per_m.max())
    if kappa > 0:
        raise ValueError(
            f"{source.path}: the grids' background values absorb (κ = {kappa:g} 1/m), so the "
            "file is not sparse; read it densely (--layout dense)"
        )


def _rotated(g):
    """A z-up grid turned y-up (see :func:`_z_up_to_y_up`); a vector grid's components too:
    (v_x, v_y, v_z) ↦ (v_x, v_z, −v_y)."""
    out = np.flip(np.swapaxes(np.asarray(g), 1, 2), axis=2)
    if out.ndim == 4 and out.shape[-1] == 3:
        out = np.stack([out[..., 0], out[..., 2], -out[..., 1]], axis=-1)
    return out


def _z_up_to_y_up(grids: dict, origin, voxel_size_m):
    """Rotate z-up grids into our y-up world: (x, y, z) ↦ (x, z, −y), a proper rotation.

    ``a'[i, k, n_y − 1 − j] = a[i, j, k]``; the box corner moves to (o_x, o_z, −(o_y + L_y)).
    """

    def rotate(g):
        if g is None or np.ndim(g) == 0:
            return g
        if isinstance(g, dict):  # species fractions
            return {name: rotate(v) for name, v in g.items()}
        return _rotated(g)

    rotated = {role: rotate(g) for role, g in grids.items()}
    if origin is None:
        return rotated, None
    first = next(np.asarray(g) for g in grids.values() if np.ndim(g) >= 3)
    length_y = first.shape[1] * (voxel_size_m or 0.0)
    return rotated, (origin[0], origin[2], -(origin[1] + length_y))
