"""Synthetic flames with emitting species: coloured flames and a sooty vs a clean flame.

Every scene reuses the turbulent plume of :func:`incandescent.scenes.plume_temperature` (a 1 m box,
x and z across, y up) and adds per-voxel fractions of species from the line table
(:mod:`incandescent.spectra.lines`) and a soot absorption κ, all *following the hot gas*: each is a
peak value times the weight

    w(T) = clip((T − T_on) / (T_peak − T_on), 0, 1),   T_on = 500 K,

which is 0 in cold air and 1 in the hottest voxel. T_on equals the renderer's default-absorption
threshold, so a species grid and a soot grid occupy the same voxels (and the same macrocells).

Units (see :mod:`incandescent.spectra.lines`): a voxel with species fraction f at temperature T
emits f · ``species_xyz(T)`` per metre of path, where ``species_xyz(2000 K)`` has the luminance
of a 2000 K blackbody per unit optical depth; soot of absorption κ (1/m) emits κ · B(T) and
absorbs. At fraction 1 and κ = 1/m a 2000 K voxel's lines are therefore as bright as its soot.
Lines are emission only (optically thin).

These are illustrations, not combustion models: real metal-salt flames, CH* and C2 emission are
partly chemiluminescent (not in thermal equilibrium), and soot forms and burns in specific zones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.camera import Camera
from incandescent.scenes.synthetic import plume_temperature
from incandescent.volume import Volume

#: Temperature at which species and soot begin to follow the hot gas, K.
T_ON_K = 500.0
#: Peak temperature of the demo flames, K (the line table's reference temperature).
FLAME_PEAK_K = 2000.0


@dataclass(frozen=True)
class ColouredFlame:
    """A coloured flame: one species seeded into the plume.

    Attributes
    ----------
    name: demo name ("sodium", ...).
    species: species in the line table ("Na", ...).
    colour: the colour the flame is known for.
    fraction: peak species fraction (in the hottest voxel).
    """

    name: str
    species: str
    colour: str
    fraction: float = 1.0


#: The coloured flames of the gallery, in display order.
COLOURED_FLAMES: tuple[ColouredFlame, ...] = (
    ColouredFlame("sodium", "Na", "yellow"),
    ColouredFlame("lithium", "Li", "crimson red"),
    ColouredFlame("strontium", "Sr", "red"),
    ColouredFlame("copper", "Cu", "blue"),
    ColouredFlame("barium", "Ba", "green"),
)
#: Soot absorption of the coloured flames in the hottest voxel, 1/m: a faint continuum under the
#: lines (1/20 of the lines' luminance per metre at 2000 K).
COLOURED_SOOT_PER_M = 0.05
#: Soot absorption in the core of the sooty flame, 1/m (optical depth ~1 across the core).
SOOTY_KAPPA_PER_M = 4.0
#: Species fractions of the clean (blue) flame: CH* (431 nm) and C2 Swan bands, chosen so that
#: both emit the same radiant power at 2000 K (the C2*/CH* ratio of hydrocarbon flames is of
#: order 1). Fractions are in luminance units (module doc): the CH band lies where the eye is
#: ~40× less sensitive than at the Swan bands, so equal power needs ~1/40 of the fraction.
CLEAN_SPECIES: dict[str, float] = {"CH": 0.025, "C2": 1.0}


def hot_gas_weight(
    temperature_K: NDArray, t_on_K: float = T_ON_K, t_peak_K: float | None = None
) -> NDArray[np.float32]:
    """w(T) = clip((T − t_on) / (t_peak − t_on), 0, 1); t_peak defaults to the hottest voxel."""
    temp = np.asarray(temperature_K, dtype=np.float64)
    peak = float(temp.max()) if t_peak_K is None else float(t_peak_K)
    if not peak > t_on_K:
        raise ValueError(f"the gas must be hotter than {t_on_K:g} K somewhere; hottest {peak:g} K")
    return np.clip((temp - t_on_K) / (peak - t_on_K), 0.0, 1.0).astype(np.float32)


def flame_temperature(n: int = 96, peak_K: float = FLAME_PEAK_K) -> NDArray[np.float32]:
    """The plume temperature field (K) shared by every scene here."""
    return plume_temperature(n, peak_K)


def species_flame(
    species: dict[str, float],
    soot_kappa_per_m: float = 0.0,
    n: int = 96,
    peak_K: float = FLAME_PEAK_K,
) -> Volume:
    """The plume with species at peak fractions ``species`` and soot κ peaking at
    ``soot_kappa_per_m`` (1/m), each ∝ :func:`hot_gas_weight`; 1 m box."""
    temperature = flame_temperature(n, peak_K)
    weight = hot_gas_weight(temperature)
    fractions = {name: weight * np.float32(f) for name, f in species.items()}
    return Volume.from_arrays(
        temperature,
        absorption=weight * np.float32(soot_kappa_per_m),
        species=fractions,
        source=f"species_flame({n})",
    )


def coloured_flame(name: str, n: int = 96, soot_kappa_per_m: float = COLOURED_SOOT_PER_M) -> Volume:
    """One of :data:`COLOURED_FLAMES` by name ("sodium", "lithium", "strontium", "copper",
    "barium"), with a faint soot continuum (``soot_kappa_per_m=0`` for none)."""
    flames = {f.name: f for f in COLOURED_FLAMES}
    if name not in flames:
        raise ValueError(f"unknown coloured flame {name!r}; expected one of {', '.join(flames)}")
    flame = flames[name]
    return species_flame({flame.species: flame.fraction}, soot_kappa_per_m, n)


def sooty_flame(n: int = 96, kappa_per_m: float = SOOTY_KAPPA_PER_M) -> Volume:
    """A luminous, sooty flame: soot κ following the hot gas (``kappa_per_m`` in the core), no
    line emitters. Soot here is grey (the LUT renderer's κ)."""
    return species_flame({}, kappa_per_m, n)


def clean_flame(n: int = 96, species: dict[str, float] | None = None) -> Volume:
    """A clean (soot-free) flame: κ = 0, CH* and C2 Swan band emission following the hot gas."""
    return species_flame(dict(CLEAN_SPECIES if species is None else species), 0.0, n)


def flame_camera(fov_deg: float = 24.0) -> Camera:
    """Front view framing the plume's 1 m box (y up); suits a 3:4 portrait image."""
    return Camera(eye=(0.0, -0.07, 2.1), target=(0.0, -0.07, 0.0), fov_deg=fov_deg)
