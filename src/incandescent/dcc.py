"""VDBs that Blender and Houdini read the right way up, with our colours baked in (issue 32).

``incandescent convert IN OUT.vdb --for blender|houdini`` and ``simulate --format vdb --for …``
write a Volume for a target application: its up axis, its grid names and units, metadata it
shows, and a **physical emission grid** — the emission coefficient η (radiance per metre of path)
in linear Rec.709, so a stock Principled Volume renders our colours (``docs/blender.md``).

Targets (:data:`TARGETS`):

``blender``
    +Z up (Blender's world: "Blender uses a right-handed coordinate system with the Z axis
    pointing upwards", Blender manual, Editors › 3D Viewport › Navigation). Our +y-up point
    (x, y, z) is Blender's (x, −z, y); velocities turn the same way. Blender draws and renders a
    grid's voxel i over the cell from index i to i + 1 (OpenVDB centres it at i): the transform
    written is shifted half a voxel down each axis so each voxel lands where it is
    (:attr:`Target.cell_shift`). Grids: ``density`` (κ),
    ``temperature`` (K), ``flame``, ``velocity`` (m/s) and ``color`` (η, vec3) — the names the
    Principled Volume reads by default (Density Attribute ``density``, Temperature Attribute
    ``temperature``) and Mantaflow writes (``flame``, ``velocity``).
``houdini``
    +Y up, as ours (Houdini's world is right-handed and Y-up: SideFX, Houdini documentation,
    "Houdini uses a right-handed, Y-up coordinate system"): axes unchanged. Grids: Houdini Pyro's
    field names ``density``, ``temperature``, ``flame`` and ``vel`` (SideFX, Houdini
    documentation, Pyro › Flame field and Pyro fields), plus ``emission`` (η, vec3).

Units (each grid's ``unit`` and ``description`` metadata say them):

* ``density`` = κ / (1 m⁻¹): the absorption coefficient in 1/m as a number. A Principled
  Volume with *Density* 1, *Color* black and *Absorption Color* black absorbs σ_a = density per
  scene unit (Blender, ``gpu_shader_material_volume_principled.glsl``), which is κ with 1 unit =
  1 m (our grids are placed in metres).
* ``temperature`` in K (the Principled Volume's *Blackbody* reads kelvin).
* ``flame``: Blender's convention inverted — Cycles takes T = 1000 K · (ignition + flame ·
  (max_temp − ignition)) where flame > 0.01 (``volume.presets``, ``blender``), so flame =
  clip((T / 1000 K − 1.5) / (3.0 − 1.5), 0, 1) with Blender's default Flame Ignition 1.5 and
  Maximum Temperature 3.0. Below 1500 K flame is 0 (those voxels still emit in ``color``).
* ``color``/``emission``: η = κ·XYZ(B(T)) + Σ species lines, converted XYZ → linear Rec.709
  (sRGB primaries, D65; no adaptation: RGB (1, 1, 1) is the white of luminance 1), each voxel's
  term from the renderer's emission models (Planck × CIE CMFs through their tables, ≤ 1e-4;
  the species lines exact), in 10⁴ (cd/m²) per metre (:data:`EMISSION_UNIT_CD_M2`: EEVEE holds
  volume light in half floats, which a flame's cd/m² overflow). Integrated along a ray with the
  absorption it gives the radiance our renderer gives, in 10⁴ cd/m²; Emission Strength 10⁴ gives
  our EXRs' absolute cd/m² in Cycles.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent.colorimetry.rgb_spaces import xyz_to_rgb
from incandescent.emission import Emission
from incandescent.spectra.lut import T_MIN_K
from incandescent.volume.grid import Volume
from incandescent.volume.presets import BLENDER_FLAME_THRESHOLD, preset_parameters

#: Voxels whose emission is computed at once (bounds the temporaries of the species' lines).
CHUNK_VOXELS = 65536
#: The RGB space of the emission grid: linear Rec.709 (Blender's scene-linear default).
EMISSION_SPACE = "srgb"
#: The emission grid's unit, cd/m² per metre: η is written divided by it. EEVEE keeps volume
#: grids and its volume light in half floats (largest 65504): a flame's η (10⁶–10⁸ (cd/m²)/m)
#: would overflow to nothing (measured: a 10⁶ grid renders black in EEVEE 3.4, 10³ renders). In
#: this unit a flame's η and the radiance it builds are 10²–10⁴; Emission Strength 10⁴ gives
#: absolute cd/m² in Cycles.
EMISSION_UNIT_CD_M2 = 1e4


@dataclass(frozen=True)
class Target:
    """An application's conventions: up axis and the grid name of each quantity."""

    name: str
    up: str
    density: str
    temperature: str
    flame: str
    velocity: str
    emission: str
    #: Where the application puts voxel (i, j, k) of a grid whose transform maps index → world:
    #: centred at the index (OpenVDB's and Houdini's convention, 0.0) or filling the cell from
    #: the index to the next (Blender's, 0.5: its Cycles render of one voxel at index 1 with
    #: voxel size 1 is centred at 1.5, tests/blender). The file's transform is shifted by
    #: −``cell_shift`` voxels so the application shows each voxel where it is.
    cell_shift: float = 0.0


TARGETS: dict[str, Target] = {
    "blender": Target("blender", "z", "density", "temperature", "flame", "velocity", "color", 0.5),
    "houdini": Target("houdini", "y", "density", "temperature", "flame", "vel", "emission"),
}


def target(name: str, origin: str = "--for") -> Target:
    """The target called ``name``; an unknown one is a one-line error naming the choices."""
    if name not in TARGETS:
        raise ValueError(f"{origin} {name!r}: unknown target; expected one of {', '.join(TARGETS)}")
    return TARGETS[name]


def emission_xyz(volume: Volume, emission: Emission | None = None) -> NDArray[np.float32]:
    """η per voxel, (nx, ny, nz, 3) XYZ in (cd/m²)/m: κ·S(T) of the source models plus the
    coefficient models (species lines), times the volume's emission scale — S from the source's
    grey table (within 1e-4 of the Planck × CMF integral, what the cpu and cuda backends use; the
    exact integral costs ~25 µs a voxel), the lines' exact terms as the float64 reference
    computes them (zero below ``T_MIN_K``)."""
    models = (emission or Emission()).models(volume)
    temperature = np.asarray(volume.temperature_K)
    hot = np.flatnonzero(temperature >= T_MIN_K)
    eta = np.zeros((temperature.size, 3), dtype=np.float32)
    kappa = np.asarray(volume.absorption_per_m).ravel()
    for start in range(0, hot.size, CHUNK_VOXELS):
        at = hot[start : start + CHUNK_VOXELS]
        eta[at] = _voxel_eta(models, volume, temperature.ravel()[at], kappa[at], at)
    if volume.emission_scale is not None:
        eta *= np.asarray(volume.emission_scale, dtype=np.float32).reshape(-1, 1)
    return eta.reshape(temperature.shape + (3,))


def _voxel_eta(models, volume: Volume, temperature_K, kappa, at) -> NDArray[np.float64]:
    """η at the flat voxel indices ``at``: κ·Σ sources + Σ coefficients (XYZ per metre)."""
    source = np.zeros((at.size, 3))
    eta = np.zeros((at.size, 3))
    for model in models:
        values = [np.asarray(g).ravel()[at].astype(np.float64) for g in model.grids(volume)]
        if model.kind == "source":  # its grey table, as the fast backends (≤ 1e-4 of exact)
            source = source + model.tables[0].lookup(temperature_K)
        else:
            eta = model.reference_add(eta, temperature_K, values, None)
    return eta + kappa[:, None] * source


def flame_from_kelvin(temperature_K: NDArray) -> NDArray[np.float32]:
    """Blender's flame for a temperature in K (its default Flame Ignition and Maximum
    Temperature), the inverse of the ``blender`` preset where flame > 0.01; 0 elsewhere."""
    p = preset_parameters("blender")
    flame = (np.asarray(temperature_K) / 1000.0 - p["ignition"]) / (p["max_temp"] - p["ignition"])
    flame = np.clip(flame, 0.0, 1.0)
    return np.where(flame > BLENDER_FLAME_THRESHOLD, flame, 0.0).astype(np.float32)


def _to_z_up(array: NDArray, direction: bool = False) -> NDArray:
    """Our (x, y, z) grid, +y up, as Blender's: index (i, a, b) holds ours (i, b, nz − 1 − a), so
    Blender's (x, y, z) = ours (x, −z, y); a ``direction`` grid's components (velocity) turn the
    same way (a colour's do not)."""
    turned = np.swapaxes(array, 1, 2)[:, ::-1, :]
    if direction:
        turned = np.stack([turned[..., 0], -turned[..., 2], turned[..., 1]], axis=-1)
    return np.ascontiguousarray(turned, dtype=np.float32)


def z_up_origin(volume: Volume) -> tuple[float, float, float]:
    """The corner of voxel (0, 0, 0) of :func:`_to_z_up`'s grid in Blender's world, m."""
    ox, oy, oz = volume.origin_m
    nz = volume.shape[2]
    return (ox, -(oz + nz * volume.voxel_size_m), oy)


@dataclass(frozen=True)
class DCCGrids:
    """Grids for a target, in its axes: name → float32 array, their placement and metadata."""

    grids: dict[str, NDArray[np.float32]]
    voxel_size_m: float
    origin_m: tuple[float, float, float]
    metadata: dict[str, dict[str, str]]


def dcc_grids(volume: Volume, to: Target, emission: Emission | None = None) -> DCCGrids:
    """The Volume's grids renamed, converted and turned for ``to`` (see the module docstring)."""
    eta = emission_xyz(volume, emission) / EMISSION_UNIT_CD_M2
    rgb = xyz_to_rgb(eta, EMISSION_SPACE).astype(np.float32)
    ours: dict[str, tuple[NDArray, str, str]] = {
        to.density: (volume.absorption_per_m, "1/m", "absorption coefficient κ (density = κ·1 m)"),
        to.temperature: (volume.temperature_K, "K", "gas temperature"),
        to.flame: (flame_from_kelvin(volume.temperature_K), "1", _FLAME),
        to.emission: (rgb, f"{EMISSION_UNIT_CD_M2:g} cd/m^2 per m", _EMISSION),
    }
    if volume.velocity_m_s is not None:
        ours[to.velocity] = (volume.velocity_m_s, "m/s", "gas velocity")
    turn: Callable[..., NDArray] = _to_z_up if to.up == "z" else _float32
    grids = {
        name: turn(np.asarray(values), direction=name == to.velocity)
        for name, (values, _, _) in ours.items()
    }
    origin = z_up_origin(volume) if to.up == "z" else tuple(map(float, volume.origin_m))
    origin = tuple(o - to.cell_shift * volume.voxel_size_m for o in origin)
    meta = {name: _metadata(to, unit, what) for name, (_, unit, what) in ours.items()}
    meta[to.emission]["emission_strength_hint"] = f"{_strength_hint(rgb, volume):.6g}"
    return DCCGrids(grids, volume.voxel_size_m, origin, meta)  # type: ignore[arg-type]


_FLAME = "Blender flame: (T/1000 K - 1.5)/1.5 clipped to 0..1 (0 where <= 0.01)"
_EMISSION = (
    "emission coefficient, linear Rec.709 (sRGB primaries, D65), Planck x CIE 1931 plus species "
    "lines, in 1e4 cd/m^2 per m: Principled Volume Emission Color, Emission Strength 1 (1e4: "
    "absolute cd/m^2 in Cycles)"
)


def _float32(array: NDArray, direction: bool = False) -> NDArray[np.float32]:
    return np.ascontiguousarray(array, dtype=np.float32)


def _metadata(to: Target, unit: str, what: str) -> dict[str, str]:
    return {
        "unit": unit,
        "description": what,
        "up_axis": to.up,
        "written_by": "incandescent",
        "target": to.name,
    }


def _strength_hint(rgb: NDArray, volume: Volume) -> float:
    """An Emission Strength that brings the brightest 1 % of lines of sight through the grid to
    about 1 (a starting point for a display; 1 is the physical value): 1 / the 99th percentile
    of the column sums of η's luminance times the voxel side, along the up axis."""
    luminance = np.tensordot(rgb, (0.2126, 0.7152, 0.0722), axes=([-1], [0]))
    columns = luminance.sum(axis=1) * volume.voxel_size_m
    lit = columns[columns > 0]
    return 1.0 / float(np.percentile(lit, 99)) if lit.size else 1.0


def save_dcc_volume(
    volume: Volume,
    path: str | Path,
    to: Target,
    emission: Emission | None = None,
    overwrite: bool = False,
) -> Path:
    """Write ``volume`` for ``to`` as a ``.vdb`` through OpenVDB (atomic, read back before it
    replaces anything, as :func:`incandescent.io.output.save_volume`)."""
    from incandescent.io.output import save_vdb_grids

    out = dcc_grids(volume, to, emission)
    return save_vdb_grids(out.grids, path, out.voxel_size_m, out.origin_m, out.metadata, overwrite)


def convert_file(source: Path, output: Path, to: Target, limits=None, overwrite=False) -> Path:
    """A volume file as the renderer reads it (every grid it can use: ``config.carry``) written
    for ``to`` — what ``simulate --for`` does to each frame it writes."""
    from incandescent.config.assemble import volume_from_section
    from incandescent.config.carry import carried
    from incandescent.config.schema import VolumeSection
    from incandescent.volume.grid import Remap

    spec, velocity, _ = carried(VolumeSection(path=source), None, limits)
    volume = volume_from_section(spec, Remap(), limits, "dense", velocity=velocity)
    assert isinstance(volume, Volume)  # a dense read
    return save_dcc_volume(volume, output, to, overwrite=overwrite)
