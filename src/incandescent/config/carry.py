"""What ``convert`` carries from a file to its output: every grid the renderer can use.

A render uses a file's temperature and absorption (or a preset's roles), and — when asked — its
velocity (motion blur, ``--shutter``) and species fraction grids (``--species CH=CH``). A
conversion that kept only what the scene names would drop the last two, so that the converted
file no longer renders as its source: a simulated frame's CH, C₂ and velocity grids. Here the
scene's ``[volume]`` section is widened to read them too, and whatever the output cannot hold is
listed, so ``convert`` says what it leaves out instead of dropping it silently.
"""

from __future__ import annotations

from incandescent.budget import Limits
from incandescent.config.schema import VolumeSection
from incandescent.io.volumes import open_grids
from incandescent.volume.presets import ROLES, resolve_grid_name


def carried(
    spec: VolumeSection, line_table: str | None, limits: Limits
) -> tuple[VolumeSection, bool, list[str]]:
    """``spec`` with the file's species grids added (a grid named as a species of the line
    table), whether to read its velocity grid, and a note per grid left out."""
    names = open_grids(spec.path, spec.axes, limits, spec.resolution).names
    species = dict(spec.species) | _species_grids(names, line_table, spec)
    velocity_grid = spec.grids.velocity or resolve_grid_name("velocity", names, required=False)
    notes = []
    velocity = velocity_grid is not None
    if velocity and spec.velocity_units == "voxels/frame":
        velocity = False  # m/s needs a frame rate the conversion does not have
        notes.append(
            f'velocity grid {velocity_grid!r} (in voxels/frame: give velocity_units = "m/s" or '
            "convert it with the frame rate yourself)"
        )
    used = set(spec.grids.given().values()) | {v for v in species.values() if isinstance(v, str)}
    used |= {velocity_grid} if velocity and velocity_grid else set()
    notes += [f"grid {name!r} (no role the renderer reads)" for name in _unused(names, used)]
    return spec.model_copy(update={"species": species}), velocity, notes


def _species_grids(names, line_table: str | None, spec: VolumeSection) -> dict[str, str]:
    """Species of the line table that the file holds as a grid of the same name."""
    from incandescent.spectra.lines import load_lines, species_names

    known = species_names(load_lines(line_table))
    return {n: n for n in names if n in known and n not in spec.species}


def _unused(names, used: set[str]) -> list[str]:
    """Grids neither used nor found by a role's aliases (temperature, flame, density, …)."""
    found = {resolve_grid_name(role, names, required=False) for role in ROLES if role != "velocity"}
    return [n for n in names if n not in used and n not in found]
