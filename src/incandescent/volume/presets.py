"""Temperature presets and grid-name aliases for volumes exported by common tools.

Simulation tools rarely store kelvin (DESIGN.md §3, "Temperature remap"). A *preset* turns the
grids of one tool's cache into ``temperature_K`` (kelvin, 0 = vacuum) and ``absorption_per_m``
(κ in 1/m, or ``None`` for the renderer's default absorption), with a description saying exactly
what it did. Grid roles are found by name through :data:`ROLE_ALIASES` (Houdini calls its
temperature ``heat`` or ``temperature``, EmberGen its flame ``flames``, and so on).

Presets (parameters in brackets, with their defaults; override them with ``parameters=``):

``blender``
    Blender's Mantaflow gas caches. The VDB grid Blender calls "temperature" (or "heat") is
    Mantaflow's *heat*, a dimensionless buoyancy quantity around 0–3 — not kelvin. Cycles and
    EEVEE instead derive a temperature from the *flame* grid:
    ``T = 1000 K · (ignition + flame · (max_temp − ignition))`` where ``flame > 0.01``, else 0
    (no emission), with the domain's *Flame Ignition* [``ignition`` = 1.5] and *Maximum
    Temperature* [``max_temp`` = 3.0]. This preset reproduces that (voxels with flame ≤ 0.01 are
    vacuum, 0 K). Absorption: κ = ``density_scale`` · density [1/m per unit, 1.0], as Cycles'
    Principled Volume with *Density* 1 treats the smoke density as an extinction coefficient per
    scene unit (metres). A fire-only flow has no smoke: when the density grid is absent or all
    zero, κ is left to the renderer's default (``None``).
    Source: Blender, ``source/blender/makesrna/intern/rna_fluid.cc``,
    ``rna_FluidModifier_temperature_grid_get`` ("Output is such that 0..1 maps to 0..1000K");
    Blender manual, Physics › Fluid › Domain › Gas › Fire (Flame Ignition, Maximum Temperature).

``houdini``
    Houdini Pyro. The ``temperature`` field (``heat`` in older setups) is dimensionless: ambient
    air is 0 and burning regions are typically 1–2. Houdini's own shaders map it to colour with a
    ramp, so there is no canonical kelvin. **Convention (ours):**
    ``T = ambient_K + kelvin_per_unit · temperature`` [300 K, 1000 K], clamped at 0 K — ambient
    air at room temperature, 1 → 1300 K (a dull red glow), 2 → 2300 K (a yellow-white flame core).
    Absorption: κ = ``density_scale`` · density [1.0], the soot density as κ in 1/m (Karma's pyro
    shader with density scale 1 in a scene in metres).
    Source: SideFX Houdini documentation, Pyro Solver and Pyro fields (``density``,
    ``temperature``, ``flame``, ``heat``).

``embergen``
    JangaFX EmberGen VDB exports (combustion mode: channels smoke, temperature, fuel, flames;
    grid names ``temperature``, ``flames``, ``smoke`` or ``density``). EmberGen's temperature is
    also a dimensionless simulation quantity with ambient 0. **Convention (ours):** the same
    mapping as ``houdini``, ``T = ambient_K + kelvin_per_unit · temperature`` [300 K, 1000 K],
    κ = ``density_scale`` · smoke [1.0]. Source: JangaFX EmberGen documentation, export channels.

**Lit smoke** (``[volume] scattering = "preset"``, ``--scattering preset``): the preset's κ is
then read as the smoke's *extinction* and split into scattering σ_s = ``smoke_albedo`` · κ and
absorption (1 − ``smoke_albedo``) · κ [0.5]. For ``blender`` this is Cycles' and EEVEE's
Principled Volume at its defaults: σ_s = Color · density, σ_a = (1 − Color)(1 − √Absorption
Color) · density, Color 0.5 and Absorption Color black (Blender,
``source/blender/gpu/shaders/material/gpu_shader_material_volume_principled.glsl``). For
``houdini`` and ``embergen`` it is our convention (the same split).

``openfoam``
    OpenFOAM cases (read through VTK, ``io.vtk``): the temperature is the field ``T`` (or
    ``temperature``), already kelvin — OpenFOAM is SI and the reader checks the field's
    dimensions. Soot: a volume fraction f_v (``soot``, ``fv``, ``soot_fv``, ``sootVolumeFraction``)
    or a mass fraction Y (``Ysoot``, ``Y_soot``, ``soot_Y``), turned into a volume fraction
    f_v = Y·ρ/ρ_soot with the gas density ρ = p·M/(R·T) of an ideal gas [``pressure_Pa`` =
    101325, ``molar_mass_kg_mol`` = 0.02897, air] and the soot density [``soot_density_kg_m3`` =
    1800]. Absorption at 550 nm in the Rayleigh limit: κ = 6π·E(m)·f_v/λ [``soot_E_m`` = 0.26 at
    550 nm], times ``density_scale`` [1.0]; with the renderer's κ_λ ∝ 1/λ (soot_alpha 1) this is
    the same law at every wavelength. Without a soot field κ is the renderer's default.
    Sources: Bohren & Huffman, *Absorption and Scattering of Light by Small Particles* (1983),
    eq. 5.11 (small-particle absorption cross-section); Chang & Charalampopoulos, Proc. R. Soc.
    Lond. A 430 (1990) 577 (E(m) of soot); soot density 1800 kg/m³ as in fireFoam's soot models.

Use a preset's ``parameters`` (or the scene's ``volume.preset_options``) when a cache was made
with other domain settings; use ``volume.temperature`` (offset/scale or range) for anything else.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate

#: Grid roles and the file grid names that fill them, in order of preference.
ROLE_ALIASES: dict[str, tuple[str, ...]] = {
    "temperature": ("temperature", "heat", "temp", "T"),
    "flame": ("flame", "flames", "fire"),
    "density": ("density", "smoke", "soot"),
    "absorption": ("absorption",),
    "emission_scale": ("emission_scale",),
    "sodium_fraction": ("sodium_fraction",),
    "velocity": ("velocity", "vel", "v"),
}
ROLES: tuple[str, ...] = tuple(ROLE_ALIASES)

#: ``[volume] scattering`` value asking for the preset's smoke rule (not a grid name).
PRESET_SCATTERING = "preset"
#: Below this maximum, a grid named like a temperature is probably not in kelvin, K.
KELVIN_PLAUSIBLE_MAX_K = 300.0
#: Cycles' flame threshold: voxels with flame at or below it do not emit.
BLENDER_FLAME_THRESHOLD = 0.01


class PresetResult(TypedDict):
    """What :func:`apply_preset` returns."""

    temperature_K: NDArray[np.float64]
    absorption_per_m: NDArray[np.float64] | None
    description: str


Grids = Mapping[str, ArrayLike]
Params = Mapping[str, float]


@dataclass(frozen=True)
class Preset:
    """A named mapping from a tool's grids to kelvin and κ (see the module docstring)."""

    name: str
    summary: str
    temperature_role: str
    defaults: Mapping[str, float]
    to_kelvin: Callable[[NDArray[np.float64], Params], NDArray[np.float64]]
    formula: str
    #: role → the file names that fill it, replacing :data:`ROLE_ALIASES` for those roles
    aliases: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    #: (grids, explicit names, parameters, T in K) → (κ in 1/m or None, what was done);
    #: None: κ = density_scale · the density grid (:func:`_preset_absorption`)
    absorption: Callable[..., tuple[NDArray[np.float64] | None, str]] | None = None


def _blender_kelvin(flame: NDArray[np.float64], p: Params) -> NDArray[np.float64]:
    if not 0.0 <= p["ignition"] < p["max_temp"]:
        raise ValueError(
            f"blender preset: need 0 <= ignition < max_temp; got ignition={p['ignition']:g}, "
            f"max_temp={p['max_temp']:g}"
        )
    kelvin = 1000.0 * (p["ignition"] + flame * (p["max_temp"] - p["ignition"]))
    return np.where(flame > BLENDER_FLAME_THRESHOLD, kelvin, 0.0)


def _normalised_kelvin(temperature: NDArray[np.float64], p: Params) -> NDArray[np.float64]:
    _validate.positive_scalar(p["kelvin_per_unit"], "kelvin_per_unit")
    return np.maximum(p["ambient_K"] + p["kelvin_per_unit"] * temperature, 0.0)


#: Soot: the Rayleigh-limit absorption κ = 6π·E(m)·f_v/λ at this wavelength (Bohren & Huffman
#: 1983, eq. 5.11); the gas constant for the ideal-gas density of the openfoam preset.
SOOT_WAVELENGTH_M = 550e-9
GAS_CONSTANT_J_MOL_K = 8.314462618
#: OpenFOAM field names: temperature; soot as a volume fraction; soot as a mass fraction.
OPENFOAM_ALIASES: dict[str, tuple[str, ...]] = {
    "temperature": ("T", "temperature"),
    "flame": (),
    "density": ("soot", "fv", "soot_fv", "sootVolumeFraction", "Ysoot", "Y_soot", "soot_Y"),
}
OPENFOAM_MASS_FRACTIONS = frozenset({"Ysoot", "Y_soot", "soot_Y"})


def _openfoam_absorption(
    grids: Grids, grid_names: Mapping[str, str] | None, p: Params, kelvin: NDArray[np.float64]
) -> tuple[NDArray[np.float64] | None, str]:
    """κ (1/m) from a soot volume or mass fraction (see the module docstring, ``openfoam``)."""
    picked = _pick(grids, "density", grid_names, False, OPENFOAM_ALIASES)
    if picked is None:
        return None, "no soot field: default absorption"
    name, soot = picked
    how = f"f_v = {name!r}"
    if name in OPENFOAM_MASS_FRACTIONS:
        with np.errstate(divide="ignore"):
            rho = np.where(kelvin > 0, p["pressure_Pa"] * p["molar_mass_kg_mol"]
                           / (GAS_CONSTANT_J_MOL_K * kelvin), 0.0)  # fmt: skip
        soot = soot * rho / p["soot_density_kg_m3"]
        how = (
            f"f_v = {name!r}·ρ/{p['soot_density_kg_m3']:g} kg/m³, ρ = p·M/(R·T) at "
            f"{p['pressure_Pa']:g} Pa, M = {p['molar_mass_kg_mol']:g} kg/mol"
        )
    factor = p["density_scale"] * 6.0 * np.pi * p["soot_E_m"] / SOOT_WAVELENGTH_M
    return factor * np.maximum(soot, 0.0), f"{how}; κ = 6π·{p['soot_E_m']:g}·f_v/550 nm"


_NORMALISED = {
    "ambient_K": 300.0,
    "kelvin_per_unit": 1000.0,
    "density_scale": 1.0,
    "smoke_albedo": 0.5,
}
_NORMALISED_FORMULA = "T = {ambient_K:g} K + {kelvin_per_unit:g} K · {grid} (clamped at 0 K)"

PRESETS: dict[str, Preset] = {
    "blender": Preset(
        "blender",
        "Blender Mantaflow: temperature from the flame grid, as Cycles renders it",
        "flame",
        {"ignition": 1.5, "max_temp": 3.0, "density_scale": 1.0, "smoke_albedo": 0.5},
        _blender_kelvin,
        "T = 1000 K · ({ignition:g} + {grid} · ({max_temp:g} − {ignition:g})) where {grid} > 0.01",
    ),
    "houdini": Preset(
        "houdini",
        "Houdini Pyro: normalised temperature (our convention)",
        "temperature",
        _NORMALISED,
        _normalised_kelvin,
        _NORMALISED_FORMULA,
    ),
    "embergen": Preset(
        "embergen",
        "EmberGen: normalised temperature (our convention)",
        "temperature",
        _NORMALISED,
        _normalised_kelvin,
        _NORMALISED_FORMULA,
    ),
    "openfoam": Preset(
        "openfoam",
        "OpenFOAM: T in kelvin, soot fraction to κ",
        "temperature",
        {
            "pressure_Pa": 101325.0,
            "molar_mass_kg_mol": 0.02897,
            "soot_density_kg_m3": 1800.0,
            "soot_E_m": 0.26,
            "density_scale": 1.0,
            "smoke_albedo": 0.5,
        },
        lambda temperature, p: np.maximum(temperature, 0.0),
        "T = {grid} (kelvin)",
        OPENFOAM_ALIASES,
        _openfoam_absorption,
    ),
}


def _did_you_mean(value: str, choices: Iterable[str]) -> str:
    close = difflib.get_close_matches(value, list(choices), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def get_preset(name: str) -> Preset:
    """The preset called ``name``; errors list the valid names."""
    if name not in PRESETS:
        raise ValueError(
            f"unknown preset {name!r}{_did_you_mean(name, PRESETS)} (presets: {', '.join(PRESETS)})"
        )
    return PRESETS[name]


def preset_parameters(name: str, parameters: Params | None = None) -> dict[str, float]:
    """The preset's defaults updated by ``parameters``; unknown or non-finite values are errors."""
    preset = get_preset(name)
    merged = dict(preset.defaults)
    for key, value in (parameters or {}).items():
        if key not in merged:
            raise ValueError(
                f"preset {name!r} has no option {key!r}{_did_you_mean(key, merged)}"
                f" (options: {', '.join(merged)})"
            )
        if isinstance(value, bool) or not np.isfinite(value):
            raise ValueError(f"preset {name!r} option {key} must be a finite number; got {value!r}")
        merged[key] = float(value)
    return merged


def resolve_grid_name(
    role: str,
    available_names: Iterable[str],
    required: bool = True,
    aliases: Mapping[str, tuple[str, ...]] | None = None,
) -> str | None:
    """The grid in ``available_names`` that fills ``role``, found through :data:`ROLE_ALIASES`
    (or a preset's ``aliases`` for the roles it names).

    Exact names are preferred in alias order, then a case-insensitive match. When nothing
    matches: ``ValueError`` naming the aliases tried and the available names if ``required``,
    else ``None``.
    """
    if role not in ROLE_ALIASES:
        raise ValueError(f"unknown grid role {role!r}; expected one of: {', '.join(ROLES)}")
    names = list(available_names)
    aliases_of_role = (aliases or {}).get(role, ROLE_ALIASES[role])
    for alias in aliases_of_role:
        if alias in names:
            return alias
    by_lower = {n.lower(): n for n in names}
    by_leaf = {n.rsplit("/", 1)[-1].lower(): n for n in names}  # HDF5 paths: "fields/temperature"
    for alias in aliases_of_role:
        for lookup in (by_lower, by_leaf):
            if alias in lookup:
                return lookup[alias]
    if not required:
        return None
    raise ValueError(
        f"no {role} grid: looked for {', '.join(aliases_of_role) or 'none'}; "
        f"the file has: {', '.join(names) or 'no grids'}"
    )


def _pick(
    grids: Grids,
    role: str,
    grid_names: Mapping[str, str] | None,
    required: bool,
    aliases: Mapping[str, tuple[str, ...]] | None = None,
) -> tuple[str, NDArray[np.float64]] | None:
    chosen = (grid_names or {}).get(role)
    if chosen is not None and chosen not in grids:
        raise ValueError(
            f"no grid named {chosen!r} for {role}; the file has: {', '.join(grids) or 'no grids'}"
        )
    name = chosen or resolve_grid_name(role, grids, required, aliases)
    if name is None:
        return None
    arr = _validate.finite(_validate.real_array(grids[name], f"grid {name!r}"), f"grid {name!r}")
    return name, arr


def apply_preset(
    name: str,
    grids: Grids,
    parameters: Params | None = None,
    grid_names: Mapping[str, str] | None = None,
) -> PresetResult:
    """Map a tool's raw grids to kelvin and κ with the preset ``name``.

    Parameters
    ----------
    name:
        ``"blender"``, ``"houdini"``, ``"embergen"`` or ``"openfoam"`` (the module docstring).
    grids:
        The file's grids by their names in the file (e.g. ``{"flame": ..., "density": ...}``).
    parameters:
        Overrides of the preset's options (e.g. ``{"max_temp": 2.5}``).
    grid_names:
        Explicit role → file grid name, bypassing the aliases (e.g. ``{"flame": "fire_hi"}``).

    Returns
    -------
    ``{"temperature_K": float64 array in K (0 = vacuum), "absorption_per_m": float64 array in 1/m
    or None (use the default absorption), "description": what was done, for logs and metadata}``.

    Examples
    --------
    >>> out = apply_preset("blender", {"flame": np.array([0.005, 0.5])})
    >>> out["temperature_K"].tolist()
    [0.0, 2250.0]
    """
    preset = get_preset(name)
    params = preset_parameters(name, parameters)
    picked = _pick(grids, preset.temperature_role, grid_names, True, preset.aliases)
    assert picked is not None  # required=True raised otherwise
    grid, raw = picked
    kelvin = preset.to_kelvin(raw, params)
    if preset.absorption is not None:
        absorption, how = preset.absorption(grids, grid_names, params, kelvin)
    else:
        absorption, how = _preset_absorption(grids, grid_names, params["density_scale"], raw.shape)
    formula = preset.formula.format(grid=repr(grid), **params)
    description = f"preset {name} ({preset.summary}): {formula}; {how}"
    return {"temperature_K": kelvin, "absorption_per_m": absorption, "description": description}


def _preset_absorption(
    grids: Grids, grid_names: Mapping[str, str] | None, scale: float, shape: tuple[int, ...]
) -> tuple[NDArray[np.float64] | None, str]:
    picked = _pick(grids, "density", grid_names, required=False)
    if picked is None:
        return None, "no density grid: default absorption"
    grid, density = picked
    if density.shape != shape:
        raise ValueError(
            f"density grid {grid!r} has shape {density.shape}; expected the temperature's {shape}"
        )
    if not (density > 0).any():
        return None, f"density grid {grid!r} is all zero: default absorption"
    return scale * density, f"κ = {scale:g} 1/m · {grid!r}"


def kelvin_warning(name: str, values: ArrayLike) -> str | None:
    """A warning when a grid named like a temperature cannot be kelvin (max < 300 K), else None.

    Mantaflow heat (0–3), Houdini and EmberGen temperature (0–2) are typical culprits
    (DESIGN.md §3). Grids with other names, empty grids and grids without finite values pass.
    """
    lowered = name.lower()
    if not any(alias in lowered for alias in ("temp", "heat")):
        return None
    arr = np.asarray(values, dtype=np.float64)
    finite = arr[np.isfinite(arr)]
    if finite.size == 0 or finite.max() >= KELVIN_PLAUSIBLE_MAX_K:
        return None
    return (
        f"grid {name!r} has max {finite.max():g} < {KELVIN_PLAUSIBLE_MAX_K:g}: "
        "probably not kelvin; "
        "map it with volume.temperature (offset/scale, or range = [LOW, HIGH] in K) or a preset "
        f"({', '.join(PRESETS)})"
    )
