"""Fire simulation settings: a validated pydantic model (unknown keys are errors, as in scene
files), and the presets ``candle``, ``torch``, ``campfire`` and ``explosion``.

Physical quantities are in SI units (m, s, K, m/s); positions of sources and obstacles are
fractions of the domain (0..1 along x, y, z; y is up).

Validation is strict, as for scene files (``config.load``; the same parsers,
``io.textfiles``): no bool or string is taken for a number, no list for a flag. Every way in —
a preset with changes, a settings file — goes through :func:`from_changes` (JSON-mode
validation, the scene loader's). Settings the solver cannot
model are refused naming the key: a source centred outside the domain, ``t_max_K`` beyond the
emission tables, and gas driven faster than sound (the solver is incompressible, a low-Mach
model): buoyant rise over the domain's height, a nozzle's jet, the front's expansion.
"""

from __future__ import annotations

import difflib
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from incandescent.simulation.state_relation import EQUILIBRIUM_T_AIR_K, equilibrium_z_st
from incandescent.volume.grid import T_CEILING_K

Fraction3 = tuple[float, float, float]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class Source(_Model):
    """Where gaseous fuel enters: a ``sphere`` or ``disc`` (flat, facing up) of ``radius_m`` at
    ``centre`` (domain fractions), or a ``nozzle`` (a disc blowing fuel up at ``jet_m_s``);
    active from ``start_s`` to ``stop_s`` (None: for ever)."""

    kind: Literal["sphere", "disc", "nozzle"] = "sphere"
    centre: Fraction3 = (0.5, 0.08, 0.5)
    radius_m: float = Field(default=0.05, gt=0)
    jet_m_s: float = Field(default=0.0, ge=0)
    start_s: float = Field(default=0.0, ge=0)
    stop_s: float | None = None
    fuel_kg_s: float = Field(
        default=0.0,
        ge=0,
        description="the fuel's mass flow (kg/s) with combustion = 'mixing'; 0 with 'front'",
    )


class Obstacle(_Model):
    """A solid ``box`` (``size`` in domain fractions) or ``sphere`` (``radius_m``) at ``centre``."""

    kind: Literal["box", "sphere"] = "box"
    centre: Fraction3 = (0.5, 0.5, 0.5)
    size: Fraction3 = (0.1, 0.1, 0.1)
    radius_m: float = Field(default=0.05, gt=0)


#: Standard atmosphere (Pa), the molar mass of dry air (kg/mol), the gas constant (J/(mol·K)).
P_ATM_PA, M_AIR_KG_MOL, R_J_MOL_K = 101_325.0, 0.028_964_7, 8.314_462_618


def air_density_kg_m3(t_air_K: float) -> float:
    """ρ = p M / (R T) of dry air at one atmosphere (ideal gas): 1.177 kg/m³ at 300 K."""
    return P_ATM_PA * M_AIR_KG_MOL / (R_J_MOL_K * t_air_K)


#: Standard gravity (m/s²; CGPM 1901).
STANDARD_GRAVITY_M_S2 = 9.80665
#: Keys of settings before issue 28 that became physics: key → what replaced it.
REMOVED_KEYS = {
    "buoyancy_m_s2_K": "buoyancy is now the ideal gas's, g·(1 − T_air/T) (set gravity_m_s2)",
    "soot_weight_m_s2": "soot's weight is now its mass, soot κ / soot_mass_extinction_m2_kg",
}


class FireSettings(_Model):
    """Nguyen, Fedkiw & Jensen 2002 ("Physically Based Modeling and Animation of Fire"), with
    Fedkiw, Stam & Jensen 2001's buoyancy and vorticity confinement."""

    domain_m: Fraction3 = Field(
        default=(0.5, 1.0, 0.5), description="box size along x, y (up), z in m"
    )
    fps: float = Field(default=24.0, gt=0, le=1000)
    cfl: float = Field(
        default=2.0, gt=0, le=8, description="max cells a sample is advected per step"
    )
    max_steps_per_frame: int = Field(
        default=64,
        ge=1,
        le=1024,
        description="safety limit: a frame that needs more steps takes its rest in the last one, "
        "over the CFL number, and says so (progress line, diagnostics.jsonl)",
    )
    maccormack: bool = True
    combustion: Literal["front", "mixing"] = Field(
        default="front",
        description="'front': Nguyen's premixed front (the level set); 'mixing': a diffusion "
        "flame, the fuel burning where it has mixed with air (mixture fraction, fast chemistry)",
    )
    reaction: Literal["fast", "mixing_time"] = Field(
        default="fast",
        description="combustion = 'mixing': 'fast', fuel burns at once where it meets air "
        "(Burke–Schumann); 'mixing_time', at min(Y_F, Y_air/s)/τ_mix, τ_mix the cell's "
        "sub-grid mixing time (FDS 6's eddy-dissipation model)",
    )
    state_relation: Literal["burke_schumann", "equilibrium"] = Field(
        default="burke_schumann",
        description="combustion = 'mixing', reaction = 'fast': the burning gas's T(Z), less the "
        "radiant fraction: 'burke_schumann', linear in Z each side of Z_st up to t_max_K (FDS "
        "5's); 'equilibrium', the fuel–air mixture at chemical equilibrium (GRI-Mech 3.0 "
        "tables, air and fuel at 300 K; equilibrium_fuel's)",
    )
    equilibrium_fuel: Literal["methane", "propane"] = Field(
        default="methane", description="state_relation = 'equilibrium': whose table"
    )
    expansion: bool = Field(
        default=False,
        description="combustion = 'mixing', reaction = 'fast' (pool_fire's default): the "
        "heat's expansion, the low-Mach constraint ∇·u = −(1/ρ) Dρ/Dt, the density and the "
        "fuel ρZ carried",
    )
    density: Literal["boussinesq", "ideal_gas"] = Field(
        default="boussinesq",
        description="the gas's inertia: 'boussinesq', the air's everywhere; 'ideal_gas', its "
        "own, ρ = ρ_air T_air/T (the variable-density projection: hot gas accelerates faster)",
    )
    stoichiometric_mixture: float = Field(
        default=0.055,
        gt=0,
        lt=1,
        description="Z_st = 1/(1 + s), s the air-to-fuel mass ratio (combustion = 'mixing')",
    )
    radiant_fraction: float = Field(
        default=0.2,
        ge=0,
        lt=1,
        description="χ_r: the share of the heat radiated away (combustion = 'mixing')",
    )
    flame_speed_m_s: float = Field(default=0.5, ge=0, description="S: the reaction front's speed")
    density_ratio: float = Field(
        default=5.0, ge=1, description="ρ_fuel/ρ_products: the front's expansion"
    )
    t_air_K: float = Field(default=300.0, gt=0)
    t_ignition_K: float = Field(default=1000.0, gt=0)
    t_max_K: float = Field(
        default=2000.0, gt=0, le=T_CEILING_K, description="the emission tables end at 1e5 K"
    )
    cooling_K_s: float = Field(
        default=3000.0, ge=0, description="c_T of the radiative cooling term"
    )
    gravity_m_s2: float = Field(
        default=STANDARD_GRAVITY_M_S2,
        ge=0,
        description="g: buoyancy is g·(1 − T_air/T) − g·(soot mass)/ρ_air (ideal gas)",
    )
    soot_mass_extinction_m2_kg: float = Field(
        default=8700.0,
        gt=0,
        description="σ_m: soot's extinction per kg (m²/kg); its mass is soot κ / σ_m",
    )
    vorticity: float = Field(default=3.0, ge=0, description="ε of vorticity confinement")
    smagorinsky: float = Field(
        default=0.2,
        ge=0,
        le=0.5,
        description="C_s: sub-grid mixing of heat and soot, D = (C_s h)²|S|/Pr_t (0: none)",
    )
    turbulent_prandtl: float = Field(
        default=0.5, gt=0, description="Pr_t (= Sc_t): eddy viscosity over eddy diffusivity"
    )
    soot_rate_per_s: float = Field(default=2.0, ge=0, description="soot made per s in hot products")
    soot_min_K: float = Field(default=1200.0, gt=0)
    soot_decay_per_s: float = Field(default=0.4, ge=0)
    soot_kappa_per_m: float = Field(default=8.0, ge=0, description="κ (1/m) of unit soot")
    ch_fraction: float = Field(
        default=0.002,
        ge=0,
        le=1,
        description="CH* in the reaction zone (of the line table's luminance-scaled unit)",
    )
    c2_fraction: float = Field(
        default=0.06,
        ge=0,
        le=1,
        description="C₂* in the reaction zone: 30× CH*'s, as much radiant power (see DESIGN §7)",
    )
    pressure_tolerance: float = Field(default=1e-4, gt=0, lt=1)
    pressure_preconditioner: Literal["auto", "multigrid", "exact"] = Field(
        default="auto",
        description="the pressure solve's preconditioner: 'multigrid', one V-cycle (any "
        "obstacles; on the device); 'exact', the obstacle-free box's exact inverse by fast "
        "diagonalisation on the host (one iteration for a Boussinesq fire); 'auto': exact for a "
        "Boussinesq fire without obstacles on the cpu and reference backends, multigrid otherwise",
    )
    walls: bool = Field(
        default=False, description="solid side walls (a chimney); default open sides"
    )
    wind_m_s: float = Field(
        default=0.0,
        ge=0,
        description="a steady wind along +x (m/s): the far field moves at it, air enters through "
        "the x− side at it; 0: still air (needs open sides)",
    )
    noise: float = Field(default=0.2, ge=0, le=1, description="seeded turbulence at the sources")
    seed: int = Field(default=0, ge=0)
    sources: tuple[Source, ...] = (Source(),)
    obstacles: tuple[Obstacle, ...] = ()

    def buoyancy_m_s2(self, t_K: float) -> float:
        """The upward acceleration (m/s²) of gas at ``t_K`` in air at ``t_air_K``: the
        Boussinesq approximation (the ambient's density ρ_air as inertia) with the ideal gas's
        density unlinearised, g(ρ_air − ρ)/ρ_air = g(1 − T_air/T) — g(T − T_air)/T_air (β = 1/T)
        for small excess, at most g (0.85 g at 2000 K, where the linear form gave 5.7 g)."""
        return self.gravity_m_s2 * (1.0 - self.t_air_K / t_K)

    @model_validator(mode="after")
    def _check(self) -> FireSettings:
        if not self.t_air_K < self.t_ignition_K < self.t_max_K:
            raise ValueError(
                f"temperatures must rise: t_air_K {self.t_air_K} < t_ignition_K "
                f"{self.t_ignition_K} < t_max_K {self.t_max_K}"
            )
        if min(self.domain_m) <= 0:
            raise ValueError(f"domain_m must be positive; got {self.domain_m}")
        _check_sources_inside(self)
        _check_fuel_flows(self)
        _check_below_sound(self)
        if self.wind_m_s > 0 and self.walls:
            raise ValueError(
                f"wind_m_s: {self.wind_m_s:g} m/s blows through the open sides; with walls = "
                "true the box is closed: set walls = false or wind_m_s = 0"
            )
        return self

    def sound_speed_m_s(self) -> float:
        """The speed of sound in air at ``t_air_K`` (m/s): the solver's bound on gas speeds."""
        return SOUND_M_S_PER_SQRT_K * math.sqrt(self.t_air_K)


#: c = √(γ R T / M) for air (γ = 1.4, M = 0.02897 kg/mol): 20.05 m/s per √K (347 m/s at 300 K).
SOUND_M_S_PER_SQRT_K = 20.05


def _check_sources_inside(settings: FireSettings) -> None:
    """Each source's centre lies in the domain (fractions 0..1): elsewhere it burns nothing."""
    size = " × ".join(f"{d:g}" for d in settings.domain_m)
    for index, source in enumerate(settings.sources):
        if not all(0.0 <= c <= 1.0 for c in source.centre):
            raise ValueError(
                f"sources.{index}.centre: {list(source.centre)} is outside the domain; a centre "
                f"is given in fractions 0..1 of domain_m ({size} m along x, y up, z)"
            )


def _check_fuel_flows(settings: FireSettings) -> None:
    """A diffusion flame burns the fuel its sources feed (``fuel_kg_s`` > 0 each); the premixed
    front ignores a fuel flow, so one set there would be silently unused: refused. So are
    ``mixing_time`` with the front and ``expansion`` with anything but fast chemistry."""
    for index, source in enumerate(settings.sources):
        if settings.combustion == "mixing" and source.fuel_kg_s <= 0.0:
            raise ValueError(
                f"sources.{index}.fuel_kg_s: combustion = 'mixing' burns the fuel a source "
                "feeds; give each source a fuel flow > 0 kg/s"
            )
        if settings.combustion == "front" and source.fuel_kg_s > 0.0:
            raise ValueError(
                f"sources.{index}.fuel_kg_s: {source.fuel_kg_s:g} kg/s is unused by combustion "
                "= 'front' (the premixed front burns at flame_speed_m_s); set combustion = "
                "'mixing' or fuel_kg_s = 0"
            )
    if settings.combustion == "front" and settings.reaction != "fast":
        raise ValueError(
            f"reaction: {settings.reaction!r} burns a diffusion flame's fuel, which combustion "
            "= 'front' does not have (its front burns at flame_speed_m_s); set combustion = "
            "'mixing' or reaction = 'fast'"
        )
    _check_state_relation(settings)
    if settings.expansion and (settings.combustion, settings.reaction) != ("mixing", "fast"):
        raise ValueError(
            f"expansion: the low-Mach expansion is built for combustion = 'mixing' with reaction "
            f"= 'fast'; got combustion = {settings.combustion!r}, reaction = "
            f"{settings.reaction!r} (the front expands by density_ratio)"
        )


def _check_state_relation(settings: FireSettings) -> None:
    """The equilibrium tables serve a fast diffusion flame of their fuel in air at 300 K."""
    if settings.state_relation != "equilibrium":
        return
    if (settings.combustion, settings.reaction) != ("mixing", "fast"):
        raise ValueError(
            "state_relation: 'equilibrium' is the fast diffusion flame's T(Z); got combustion "
            f"= {settings.combustion!r}, reaction = {settings.reaction!r} (set combustion = "
            "'mixing', reaction = 'fast', or state_relation = 'burke_schumann')"
        )
    if abs(settings.t_air_K - EQUILIBRIUM_T_AIR_K) > 1.0:
        raise ValueError(
            f"t_air_K: {settings.t_air_K:g} K, but the equilibrium tables are of fuel and air "
            f"at {EQUILIBRIUM_T_AIR_K:g} K; set t_air_K = 300 or state_relation = 'burke_schumann'"
        )
    z_st = equilibrium_z_st(settings.equilibrium_fuel)
    if abs(settings.stoichiometric_mixture / z_st - 1.0) > 0.02:
        raise ValueError(
            f"stoichiometric_mixture: {settings.stoichiometric_mixture:g}, but "
            f"{settings.equilibrium_fuel}'s equilibrium table has Z_st = {z_st:g}; set "
            "equilibrium_fuel to the fire's fuel, or state_relation = 'burke_schumann'"
        )


def _check_below_sound(settings: FireSettings) -> None:
    """Refuse settings that drive the gas faster than sound (the solver models slow flames)."""
    c = settings.sound_speed_m_s()
    where = f"faster than sound ({c:.0f} m/s at t_air_K); the solver models slow "
    where += "(incompressible) flames"
    height = settings.domain_m[1]
    rise = math.sqrt(2.0 * settings.buoyancy_m_s2(settings.t_max_K) * height)
    if rise > c:
        most = c * c / (2.0 * (1.0 - settings.t_air_K / settings.t_max_K) * height)
        raise ValueError(
            f"gravity_m_s2: {settings.gravity_m_s2:g} lifts gas at t_max_K to about "
            f"{rise:.3g} m/s over the domain's {height:g} m height, {where}: use at most {most:.3g}"
        )
    expansion = (settings.density_ratio - 1.0) * settings.flame_speed_m_s
    if expansion > c:
        raise ValueError(
            f"flame_speed_m_s: {settings.flame_speed_m_s:g} × (density_ratio "
            f"{settings.density_ratio:g} − 1) expands the burnt gas at {expansion:.3g} m/s, {where}"
        )
    if settings.wind_m_s > c:
        raise ValueError(f"wind_m_s: {settings.wind_m_s:g} m/s is {where}")
    for index, source in enumerate(settings.sources):
        if source.jet_m_s > c:
            raise ValueError(f"sources.{index}.jet_m_s: {source.jet_m_s:g} m/s is {where}")


PRESETS: dict[str, FireSettings] = {
    "candle": FireSettings(
        domain_m=(0.08, 0.16, 0.08),
        flame_speed_m_s=0.15,
        cooling_K_s=6000.0,
        vorticity=1.0,
        noise=0.05,
        soot_rate_per_s=1.0,
        sources=(Source(kind="sphere", centre=(0.5, 0.12, 0.5), radius_m=0.006),),
    ),
    "torch": FireSettings(
        domain_m=(0.3, 0.6, 0.3),
        flame_speed_m_s=0.4,
        sources=(Source(kind="nozzle", centre=(0.5, 0.05, 0.5), radius_m=0.015, jet_m_s=2.0),),
    ),
    "campfire": FireSettings(
        domain_m=(1.0, 1.5, 1.0),
        flame_speed_m_s=0.6,
        soot_rate_per_s=3.0,
        sources=(Source(kind="disc", centre=(0.5, 0.04, 0.5), radius_m=0.2),),
    ),
    "explosion": FireSettings(
        domain_m=(4.0, 4.0, 4.0),
        flame_speed_m_s=4.0,
        density_ratio=8.0,
        t_max_K=2400.0,
        cooling_K_s=1500.0,
        soot_rate_per_s=4.0,
        sources=(Source(kind="sphere", centre=(0.5, 0.2, 0.5), radius_m=0.4, stop_s=0.15),),
    ),
}


#: Keys that drive the gas (accelerations, expansion, confinement, soot's weight) or let one
#: step carry it further: where a run goes non-finite, the culprit is among them.
DRIVING_KEYS = (
    "gravity_m_s2",
    "soot_rate_per_s",
    "vorticity",
    "flame_speed_m_s",
    "density_ratio",
    "cfl",
)


def likely_unstable(settings: FireSettings) -> str:
    """The driving keys set above 10× their largest preset value, as ``key = value`` (else all
    of them, and ``max_steps_per_frame``), for the message of a run gone non-finite."""
    high = [
        f"{key} = {getattr(settings, key):g} (at most {_preset_max(key):g} in the presets)"
        for key in DRIVING_KEYS
        if getattr(settings, key) > 10.0 * _preset_max(key)
    ]
    if high:
        return ", ".join(high)
    return f"one of {', '.join(DRIVING_KEYS)} too high, or max_steps_per_frame too low"


def _preset_max(key: str) -> float:
    return max(float(getattr(p, key)) for p in PRESETS.values())


def preset(name: str, **changes) -> FireSettings:
    """A preset's settings with ``changes`` applied (validated; a bad one is a one-line
    ``ValueError`` naming the key)."""
    return from_changes(name, changes)


def from_changes(name: str, changes: Mapping[str, Any], source: str | None = None) -> FireSettings:
    """Preset ``name`` with ``changes`` (from ``source``: a file, a flag) over its keys, validated
    strictly in JSON mode, as scene files are; errors are one line naming the key."""
    if name not in PRESETS:
        raise ValueError(f"unknown fire preset {name!r}; expected one of: {', '.join(PRESETS)}")
    data = PRESETS[name].model_dump(mode="json") | dict(changes)
    where = f"fire settings ({name}{', from ' + source if source else ''})"
    for key in REMOVED_KEYS.keys() & data.keys():
        raise ValueError(f"{where}: {key} was removed: {REMOVED_KEYS[key]}")
    try:
        text = json.dumps(data, default=_jsonable, allow_nan=True)
        return FireSettings.model_validate_json(text)
    except RecursionError:
        raise ValueError(f"{where}: nested too deeply to be fire settings") from None
    except ValidationError as error:
        raise ValueError(_one_line(error, where)) from None


def _jsonable(value: Any) -> Any:
    """JSON for the values Python callers pass beyond JSON's types (tuples, NumPy numbers)."""
    if isinstance(value, (tuple, set)):
        return list(value)
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    return str(value)


SETTINGS_SUFFIXES = (".toml", ".json")


def read_settings_file(path: str | Path) -> dict[str, Any]:
    """The table of FireSettings keys in a ``.toml``/``.json`` file; every problem (missing,
    not a file, not UTF-8, a syntax error, nesting too deep, not a table) is one ``ValueError``
    (or ``OSError``) naming the file and what was expected."""
    from incandescent.io.textfiles import parse_json, parse_toml
    from incandescent.io.volumes import check_input_file

    path = Path(path)
    if path.suffix.lower() not in SETTINGS_SUFFIXES:
        got = repr(path.suffix) if path.suffix else "no suffix"
        raise ValueError(
            f"{path}: unsupported settings format ({got}); expected a .toml or .json file of "
            "FireSettings keys"
        )
    check_input_file(path, "settings file")
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{path}: not UTF-8 text ({error}); expected TOML or JSON") from None
    parse = parse_toml if path.suffix.lower() == ".toml" else parse_json
    try:
        data = parse(text, path)
    except RecursionError:
        raise ValueError(f"{path}: nested too deeply to be fire settings") from None
    if not isinstance(data, dict):
        raise ValueError(
            f'{path}: expected a table of FireSettings keys (e.g. {{"seed": 3}}); got a '
            f"{type(data).__name__}"
        )
    return data


def _one_line(error: ValidationError, source: str) -> str:
    """The first problem of ``error`` as one line: the key, and what is wrong with it."""
    problems = error.errors()
    item = problems[0]
    key = ".".join(str(part) for part in item["loc"])
    if item["type"] == "extra_forbidden":
        close = difflib.get_close_matches(key, list(FireSettings.model_fields), n=1)
        problem = f"unknown key; did you mean {close[0]!r}?" if close else "unknown key"
    elif item["type"] == "value_error":  # a model-level rule: its message says it all
        problem = str(item["msg"]).removeprefix("Value error, ")
    else:
        value = item.get("input")
        problem = f"{item['msg']}{_about(item['loc'])}; got {value!r} ({type(value).__name__})"
    more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
    return f"{source}: {key + ': ' if key else ''}{problem}{more}"


def _about(loc: tuple) -> str:
    """`` (the field's description)`` for a top-level key that has one, else ``""``."""
    field = FireSettings.model_fields.get(str(loc[0])) if len(loc) == 1 else None
    return f" ({field.description})" if field is not None and field.description else ""
