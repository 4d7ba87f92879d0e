"""Pool fires as fire scientists specify them — a diameter D (m), a heat release rate Q (kW) and a
fuel — and the correlations they are judged by (Cetegen & Ahmed's puffing, Heskestad's flame
height, McCaffrey's plume), with the measurements that compare a simulation with them.

A pool fire is a diffusion flame, and :func:`pool_fire` makes one by default (``combustion =
"mixing"``): the fuel alone, ṁ_f = Q/ΔH_c, fed over the pool's disc at its vapour's speed and
burning where it has mixed with air (the mixture fraction under fast chemistry, ``solver``), its
gas moving with the ideal gas's inertia. With ``combustion = "front"`` it feeds Nguyen et al.
2002's premixed front the *premixed equivalent* instead: the fuel with its stoichiometric air,
ṁ_f(1 + s), entering over the disc at the speed that carries that mass at the air's density,
burning at the fuel's laminar burning velocity S_L into products at its adiabatic flame
temperature (expanding by T_ad/T_air, ideal gas at constant pressure). Either way the heat
released is Q (ρ_mix V̇ c_p (T_ad − T_air) = ṁ_f ΔH_c for the premixed equivalent). How far each
is from the correlations is what the validation (``benchmarks/fire_validation.py``,
``docs/simulation.md``) measures.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from incandescent.simulation.settings import (
    M_AIR_KG_MOL,
    STANDARD_GRAVITY_M_S2,
    FireSettings,
    Source,
    air_density_kg_m3,
    from_changes,
)
from incandescent.simulation.state_relation import EQUILIBRIUM_FUELS


@dataclass(frozen=True)
class Fuel:
    """What a pool fire needs of its fuel: ΔH_c (J/kg, net), the stoichiometric air-to-fuel mass
    ratio s, the laminar burning velocity S_L (m/s) and the adiabatic flame temperature (K) of
    its stoichiometric mixture with air at 298 K and one atmosphere, and its molar mass
    (kg/mol: the vapour's density, the speed it leaves the pool at)."""

    heat_of_combustion_J_kg: float
    stoichiometric_air: float
    laminar_speed_m_s: float
    adiabatic_K: float
    molar_mass_kg_mol: float

    @property
    def stoichiometric_mixture(self) -> float:
        """Z_st = 1/(1 + s): the mixture fraction of the stoichiometric fuel–air mixture."""
        return 1.0 / (1.0 + self.stoichiometric_air)


#: ΔH_c: Tewarson, SFPE Handbook of Fire Protection Engineering (5th ed., 2016), Table A.39
#: (methane 50.0, propane 46.0, n-heptane 44.6 MJ/kg); s from the reactions CₙH_m + (n + m/4)
#: (O₂ + 3.76 N₂) (17.2, 15.7, 15.2); S_L: Law, Combustion Physics (2006) Fig. 7.5.1 and Davis &
#: Law 1998 (Combust. Sci. Technol. 140:427) at φ = 1 (0.37, 0.39, 0.38 m/s); T_ad: Turns, An
#: Introduction to Combustion (3rd ed., 2012), Table 2.1 at φ = 1 (2226, 2267, 2274 K); molar
#: masses from the IUPAC atomic weights (CH₄ 16.04, C₃H₈ 44.10, C₇H₁₆ 100.20 g/mol).
FUELS: dict[str, Fuel] = {
    "methane": Fuel(50.0e6, 17.2, 0.37, 2226.0, 0.01604),
    "propane": Fuel(46.0e6, 15.7, 0.39, 2267.0, 0.04410),
    "heptane": Fuel(44.6e6, 15.2, 0.38, 2274.0, 0.10020),
}


def fuel_named(name: str) -> Fuel:
    """The fuel ``name``; an unknown one is a one-line ValueError listing the known ones."""
    if name not in FUELS:
        raise ValueError(f"pool fire: unknown fuel {name!r}; expected one of: {', '.join(FUELS)}")
    return FUELS[name]


def inflow_m_s(diameter_m: float, heat_release_kW: float, fuel: Fuel, t_air_K: float) -> float:
    """The premixed equivalent's speed over the pool (m/s): ṁ_f (1 + s)/(ρ_air · πD²/4) with
    ṁ_f = Q/ΔH_c (the mixture's density taken as the air's: within 3 % for these fuels)."""
    fuel_kg_s = heat_release_kW * 1e3 / fuel.heat_of_combustion_J_kg
    area_m2 = math.pi * diameter_m**2 / 4.0
    return fuel_kg_s * (1.0 + fuel.stoichiometric_air) / (air_density_kg_m3(t_air_K) * area_m2)


def pool_domain_m(diameter_m: float, heat_release_kW: float) -> tuple[float, float, float]:
    """A box that holds the fire and the start of its plume: 3 D wide, and as tall as the larger
    of 4 D and 2.5 × Heskestad's flame height (so McCaffrey's plume region is inside)."""
    height = max(4.0 * diameter_m, 2.5 * heskestad_height_m(heat_release_kW, diameter_m))
    return (3.0 * diameter_m, height, 3.0 * diameter_m)


def pool_fire(
    diameter_m: float,
    heat_release_kW: float,
    fuel: str = "methane",
    changes: Mapping[str, Any] | None = None,
    source: str | None = None,
    combustion: str = "mixing",
) -> FireSettings:
    """A pool fire of ``diameter_m`` releasing ``heat_release_kW`` of ``fuel`` (see the module
    docstring), in :func:`pool_domain_m`'s box, the pool a disc on the floor; ``changes``: any
    FireSettings keys over these (from ``source``, a file or flag; validated as a preset's).
    ``combustion`` (or the key of that name in ``changes``): "mixing", a diffusion flame fed
    the fuel alone at ṁ_f = Q/ΔH_c, its gas with the ideal gas's inertia
    (:func:`_diffusion_flame`), and with fast chemistry (``reaction = "fast"``) the low-Mach
    expansion of its burning gas (``expansion``); "front", the premixed equivalent burning at
    a front, with the air's inertia everywhere (Boussinesq), as before issue 28's diffusion
    flame."""
    changes = dict(changes or {})
    combustion = changes.pop("combustion", combustion)  # a settings file may choose it too
    if combustion not in ("front", "mixing"):
        raise ValueError(f"pool fire: combustion must be 'front' or 'mixing'; got {combustion!r}")
    for name, value in (("diameter_m", diameter_m), ("heat_release_kW", heat_release_kW)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ValueError(f"pool fire: {name} must be a positive number; got {value!r}")
    f = fuel_named(fuel)
    t_air = changes.get("t_air_K", 300.0)
    t_air = t_air if isinstance(t_air, int | float) and t_air > 0 else 300.0  # checked below
    burn = _diffusion_flame if combustion == "mixing" else _premixed_equivalent
    keys = {"domain_m": pool_domain_m(diameter_m, heat_release_kW), "t_max_K": f.adiabatic_K}
    keys |= burn(diameter_m, heat_release_kW, f, t_air)
    if combustion == "mixing":  # the low-Mach expansion is built for fast chemistry alone
        keys["expansion"] = changes.get("reaction", "fast") == "fast"
        keys |= _equilibrium_fuel(fuel, changes)
    where = f"pool fire D={diameter_m:g} m, Q={heat_release_kW:g} kW"
    return from_changes("campfire", keys | changes, f"{where}{', ' + source if source else ''}")


def _equilibrium_fuel(fuel: str, changes: Mapping[str, Any]) -> dict:
    """``equilibrium_fuel``: the fuel's own table, where GRI-Mech 3.0 holds the fuel."""
    if fuel in EQUILIBRIUM_FUELS:
        return {"equilibrium_fuel": fuel}
    if changes.get("state_relation") == "equilibrium":
        raise ValueError(
            f"pool fire: state_relation 'equilibrium' has tables for {', '.join(EQUILIBRIUM_FUELS)}"
            f" (GRI-Mech 3.0), not {fuel!r}; use state_relation 'burke_schumann'"
        )
    return {}


def _premixed_equivalent(diameter_m, heat_release_kW, f: Fuel, t_air: float) -> dict:
    """The fuel with its stoichiometric air entering over the pool (:func:`inflow_m_s`),
    burning at S_L into products at T_ad (expanding by T_ad/T_air)."""
    jet = inflow_m_s(diameter_m, heat_release_kW, f, t_air)
    return {
        "flame_speed_m_s": f.laminar_speed_m_s,
        "density_ratio": f.adiabatic_K / t_air,
        "sources": (
            Source(kind="nozzle", centre=POOL_CENTRE, radius_m=diameter_m / 2.0, jet_m_s=jet),
        ),
    }


def _diffusion_flame(diameter_m, heat_release_kW, f: Fuel, t_air: float) -> dict:
    """The fuel alone, ṁ_f = Q/ΔH_c, leaving the pool at its vapour's speed ṁ_f/(ρ_f πD²/4)
    (ρ_f the ideal gas's at T_air), burning where it has mixed to Z_st (``combustion =
    "mixing"``): the heat released is Q, (1 − χ_r) of it carried by the gas; no vorticity
    confinement (an artistic device that vanishes as h → 0). The gas moves with
    its own inertia (``density = "ideal_gas"``): with the air's, the plume over a 0.5 m, 50 kW
    pool at 48 cells rose at 0.7 m/s 0.19 m up and 1.7 m/s at 0.35 m, against McCaffrey's 3.0
    and 4.1."""
    fuel_kg_s = heat_release_kW * 1e3 / f.heat_of_combustion_J_kg
    vapour_kg_m3 = air_density_kg_m3(t_air) * f.molar_mass_kg_mol / M_AIR_KG_MOL
    jet = fuel_kg_s / (vapour_kg_m3 * math.pi * diameter_m**2 / 4.0)
    source = Source(
        kind="nozzle", centre=POOL_CENTRE, radius_m=diameter_m / 2.0, jet_m_s=jet,
        fuel_kg_s=fuel_kg_s,
    )  # fmt: skip
    return {
        "combustion": "mixing",
        "density": "ideal_gas",
        "vorticity": 0.0,  # confinement is an artistic device (DESIGN §7): none in a science case
        "stoichiometric_mixture": f.stoichiometric_mixture,
        "sources": (source,),
    }


#: The pool's centre, in domain fractions: on the floor. A nozzle is the cells within a cell of
#: its centre's height (``FireSolver._source_distance``), so centred on the floor plane the pool
#: is the bottom layer of cells at every resolution. (Until issue 28's 44th stop it was centred
#: 0.02 of the domain up: the bottom two layers at 64 cells, but layers 2–3 at 128, with two
#: cells of air under the pool — which starved the 1 m, 200 kW pool's flame at 128 cells.)
POOL_CENTRE = (0.5, 0.0, 0.5)


# --- the correlations -----------------------------------------------------------------------


def puffing_hz(diameter_m: float) -> float:
    """f = 1.5 D^(−1/2) Hz (D in m): the puffing of buoyant pool fires from 0.03 to 50 m
    (Cetegen & Ahmed 1993, Combust. Flame 93:157, their fit to 40 years of data)."""
    return 1.5 / math.sqrt(diameter_m)


def heskestad_height_m(heat_release_kW: float, diameter_m: float) -> float:
    """L = 0.235 Q^(2/5) − 1.02 D (m; Q in kW): the mean height of the luminous flame, where it
    is present half the time (Heskestad 1983, Fire Saf. J. 5:103; SFPE Handbook ch. 13)."""
    return 0.235 * heat_release_kW**0.4 - 1.02 * diameter_m


#: The specific heat of air at constant pressure near 300 K, kJ/(kg·K) (1.005: Incropera's table).
AIR_CP_KJ_KG_K = 1.005


def characteristic_diameter_m(heat_release_kW: float, t_air_K: float = 293.0) -> float:
    """D* = (Q / (ρ_∞ c_p T_∞ √g))^(2/5) (m; Q in kW, air at 1 atm): the length scale of a
    buoyant fire (Baum & McCaffrey 1989); D*/δx is how finely a grid of cell δx resolves it (the
    resolution index of FDS's validation, McGrattan et al., FDS User's Guide)."""
    rho = air_density_kg_m3(t_air_K)
    scale = rho * AIR_CP_KJ_KG_K * t_air_K * math.sqrt(STANDARD_GRAVITY_M_S2)
    return (heat_release_kW / scale) ** 0.4


def mccaffrey_excess_K(height_m: np.ndarray, heat_release_kW: float, t_air_K: float = 300.0):
    """The time-mean centreline excess temperature ΔT (K) of a fire plume (McCaffrey 1979,
    NBSIR 79-1910): 2gΔT/T_air = (κ/C)² (z/Q^(2/5))^(2η−1) with (κ, η) = (6.8, ½) in the
    continuous flame (z/Q^(2/5) < 0.08 m/kW^(2/5)), (1.9, 0) intermittent (< 0.2), (1.1, −⅓)
    plume — there ΔT ∝ z^(−5/3); C = 0.9."""
    z = np.asarray(height_m, dtype=float) / heat_release_kW**0.4
    kappa = np.where(z < 0.08, 6.8, np.where(z < 0.2, 1.9, 1.1))
    eta = np.where(z < 0.08, 0.5, np.where(z < 0.2, 0.0, -1.0 / 3.0))
    return t_air_K / (2.0 * 9.81) * (kappa / 0.9) ** 2 * z ** (2.0 * eta - 1.0)


#: McCaffrey's three regions of a fire's centreline, by z/Q^(2/5) (m/kW^(2/5)): the continuous
#: flame, the intermittent flame and the plume (``mccaffrey_excess_K``'s constants change there).
MCCAFFREY_REGIONS = {
    "continuous": (0.0, 0.08),
    "intermittent": (0.08, 0.2),
    "plume": (0.2, math.inf),
}


def mccaffrey_ratios(
    height_m: np.ndarray, excess_K: np.ndarray, heat_release_kW: float, top_m: float = math.inf
) -> dict[str, float | None]:
    """A time-mean excess profile ΔT(z) (K) against McCaffrey's, region by region
    (``MCCAFFREY_REGIONS``): the geometric mean of ΔT / ΔT_McCaffrey over the heights of the
    region below ``top_m`` where ΔT > 0; None for a region with no such height."""
    z, dT = np.asarray(height_m, dtype=float), np.asarray(excess_K, dtype=float)
    scaled = z / heat_release_kW**0.4
    ratios: dict[str, float | None] = {}
    for name, (low, high) in MCCAFFREY_REGIONS.items():
        keep = (scaled >= low) & (scaled < high) & (z < top_m) & (dT > 0)
        log_ratio = np.log(dT[keep] / mccaffrey_excess_K(z[keep], heat_release_kW))
        ratios[name] = float(np.exp(log_ratio.mean())) if keep.any() else None
    return ratios


def burning_rate_kg_m2_s(diameter_m: float, heat_release_kW: float, fuel: Fuel) -> float:
    """ṁ'' = Q/(ΔH_c · πD²/4): the fuel burnt per area of pool (kg/(m²·s))."""
    return heat_release_kW * 1e3 / fuel.heat_of_combustion_J_kg / (math.pi * diameter_m**2 / 4.0)


def wind_tilt_deg(
    wind_m_s: float, diameter_m: float, heat_release_kW: float, fuel: Fuel, t_air_K: float = 300.0
) -> float:
    """The angle from the vertical (degrees) of a pool fire's flame in a wind u_w, by the
    American Gas Association's correlation (AGA 1974; Beyler, SFPE Handbook 5th ed. ch. 66):
    cos θ = 1 for u* ≤ 1, 1/√u* above, with u* = u_w / (g ṁ'' D / ρ_air)^(1/3)."""
    scale = (9.81 * burning_rate_kg_m2_s(diameter_m, heat_release_kW, fuel) * diameter_m
             / air_density_kg_m3(t_air_K)) ** (1.0 / 3.0)  # fmt: skip
    u_star = wind_m_s / scale
    return 0.0 if u_star <= 1.0 else math.degrees(math.acos(1.0 / math.sqrt(u_star)))


# --- measuring a simulation -----------------------------------------------------------------


def dominant_hz(signal: np.ndarray, rate_hz: float, lowest_hz: float = 0.5) -> float:
    """The frequency (Hz) of the largest peak of a signal's periodogram above ``lowest_hz``
    (the mean removed, a Hann window; parabolic interpolation between bins where the largest
    bin is a local peak — the first usable bin may lie on the flank of a lower one's)."""
    x = np.asarray(signal, dtype=float)
    x = (x - x.mean()) * np.hanning(x.size)
    power = np.abs(np.fft.rfft(x)) ** 2
    freq = np.fft.rfftfreq(x.size, 1.0 / rate_hz)
    usable = np.nonzero(freq >= lowest_hz)[0]
    k = int(usable[np.argmax(power[usable])])
    peak = float(k)
    if 0 < k < power.size - 1:
        a, b, c = np.log(power[k - 1 : k + 2] + 1e-300)
        if b >= max(a, c) and a - 2.0 * b + c < 0:  # a local peak: its vertex is within ½ bin
            peak += 0.5 * (a - c) / (a - 2.0 * b + c)
    return peak * rate_hz / x.size


def intermittency_height_m(present: np.ndarray, cell_m: float) -> float:
    """The height (m) where flame is present half the time: ``present`` (samples, heights) says
    whether each horizontal layer holds flame; its fraction over the samples, falling with
    height above the layer that holds flame most often (the pool's, or just above it), crosses ½
    there (linear between layer centres; heights from the floor). 0 if no layer holds flame
    half the time."""
    fraction = np.asarray(present, dtype=float).mean(axis=0)
    if fraction.size == 0 or fraction.max() < 0.5:
        return 0.0
    base = int(np.argmax(fraction))
    above = np.nonzero(fraction[base:] < 0.5)[0]
    if above.size == 0:
        return fraction.size * cell_m
    j = base + int(above[0])
    t = (fraction[j - 1] - 0.5) / (fraction[j - 1] - fraction[j])
    return (j - 0.5 + t) * cell_m


def centreline_K(temperature_K: np.ndarray) -> np.ndarray:
    """The temperature (K) up the domain's vertical centreline: the mean of the 2×2 central
    columns of an (nx, ny, nz) grid, one value per layer."""
    nx, _, nz = temperature_K.shape
    return temperature_K[nx // 2 - 1 : nx // 2 + 1, :, nz // 2 - 1 : nz // 2 + 1].mean(axis=(0, 2))


def plume_peak(temperature_K: np.ndarray, cell_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The hottest point of each layer of an (nx, ny, nz) grid (a time-mean field: the mean
    plume's axis, wherever it has drifted) and its horizontal distance (m) from the domain's
    vertical centreline, where ``centreline_K`` looks: (peak temperature K, offset m) per layer."""
    nx, ny, nz = temperature_K.shape
    layers = np.moveaxis(temperature_K, 1, 0).reshape(ny, nx * nz)
    i, k = np.unravel_index(layers.argmax(axis=1), (nx, nz))
    offset_m = np.hypot(i + 0.5 - nx / 2, k + 0.5 - nz / 2) * cell_m
    return layers.max(axis=1), offset_m


def power_law_slope(height_m: np.ndarray, excess_K: np.ndarray) -> float:
    """d ln ΔT / d ln z: the least-squares slope of a centreline profile in log–log."""
    z, dT = np.asarray(height_m, dtype=float), np.asarray(excess_K, dtype=float)
    keep = (z > 0) & (dT > 0)
    return float(np.polyfit(np.log(z[keep]), np.log(dT[keep]), 1)[0])
