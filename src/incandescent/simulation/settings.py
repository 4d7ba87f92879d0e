"""Fire simulation settings: a validated pydantic model (unknown keys are errors, as in scene
files), and the presets ``candle``, ``torch``, ``campfire`` and ``explosion``.

Physical quantities are in SI units (m, s, K, m/s); positions of sources and obstacles are
fractions of the domain (0..1 along x, y, z; y is up).
"""

from __future__ import annotations

import difflib
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

Fraction3 = tuple[float, float, float]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


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


class Obstacle(_Model):
    """A solid ``box`` (``size`` in domain fractions) or ``sphere`` (``radius_m``) at ``centre``."""

    kind: Literal["box", "sphere"] = "box"
    centre: Fraction3 = (0.5, 0.5, 0.5)
    size: Fraction3 = (0.1, 0.1, 0.1)
    radius_m: float = Field(default=0.05, gt=0)


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
    max_steps_per_frame: int = Field(default=8, ge=1, le=256)
    maccormack: bool = True
    flame_speed_m_s: float = Field(default=0.5, ge=0, description="S: the reaction front's speed")
    density_ratio: float = Field(
        default=5.0, ge=1, description="ρ_fuel/ρ_products: the front's expansion"
    )
    t_air_K: float = Field(default=300.0, gt=0)
    t_ignition_K: float = Field(default=1000.0, gt=0)
    t_max_K: float = Field(default=2000.0, gt=0)
    cooling_K_s: float = Field(
        default=3000.0, ge=0, description="c_T of the radiative cooling term"
    )
    buoyancy_m_s2_K: float = Field(default=0.006, ge=0, description="β: upward acceleration per K")
    soot_weight_m_s2: float = Field(default=0.5, ge=0, description="α: downward pull per unit soot")
    vorticity: float = Field(default=3.0, ge=0, description="ε of vorticity confinement")
    soot_rate_per_s: float = Field(default=2.0, ge=0, description="soot made per s in hot products")
    soot_min_K: float = Field(default=1200.0, gt=0)
    soot_decay_per_s: float = Field(default=0.4, ge=0)
    soot_kappa_per_m: float = Field(default=8.0, ge=0, description="κ (1/m) of unit soot")
    ch_fraction: float = Field(default=0.05, ge=0, le=1, description="CH* in the reaction zone")
    c2_fraction: float = Field(default=0.02, ge=0, le=1, description="C₂ in the reaction zone")
    pressure_tolerance: float = Field(default=1e-4, gt=0, lt=1)
    walls: bool = Field(
        default=False, description="solid side walls (a chimney); default open sides"
    )
    noise: float = Field(default=0.2, ge=0, le=1, description="seeded turbulence at the sources")
    seed: int = Field(default=0, ge=0)
    sources: tuple[Source, ...] = (Source(),)
    obstacles: tuple[Obstacle, ...] = ()

    @model_validator(mode="after")
    def _check(self) -> FireSettings:
        if not self.t_air_K < self.t_ignition_K < self.t_max_K:
            raise ValueError(
                f"temperatures must rise: t_air_K {self.t_air_K} < t_ignition_K "
                f"{self.t_ignition_K} < t_max_K {self.t_max_K}"
            )
        if min(self.domain_m) <= 0:
            raise ValueError(f"domain_m must be positive; got {self.domain_m}")
        return self


PRESETS: dict[str, FireSettings] = {
    "candle": FireSettings(
        domain_m=(0.08, 0.16, 0.08),
        flame_speed_m_s=0.15,
        cooling_K_s=6000.0,
        buoyancy_m_s2_K=0.004,
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
        buoyancy_m_s2_K=0.01,
        soot_rate_per_s=4.0,
        sources=(Source(kind="sphere", centre=(0.5, 0.2, 0.5), radius_m=0.4, stop_s=0.15),),
    ),
}


def preset(name: str, **changes) -> FireSettings:
    """A preset's settings with ``changes`` applied (validated; a bad one is a one-line
    ``ValueError`` naming the key)."""
    if name not in PRESETS:
        raise ValueError(f"unknown fire preset {name!r}; expected one of: {', '.join(PRESETS)}")
    try:
        return FireSettings(**(PRESETS[name].model_dump() | changes))
    except ValidationError as error:
        raise ValueError(_one_line(error, f"fire settings ({name})")) from None


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
        problem = f"{item['msg']}; got {item.get('input')!r}"
    more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
    return f"{source}: {key + ': ' if key else ''}{problem}{more}"
