"""A diffusion flame's equilibrium state relation T(Z): the temperature (K) of gas of mixture
fraction Z (``FireSettings.state_relation = "equilibrium"``; the default, ``burke_schumann`` —
fast chemistry to complete products, Burke & Schumann 1928, linear in Z on each side of Z_st up
to T_ad, FDS 5's — is ``FireSolver.flame_temperature``'s own).

The fuel–air mixture at chemical equilibrium, tabulated by
``scripts/equilibrium_table.py`` (Cantera, GRI-Mech 3.0; ``data/equilibrium_{fuel}.csv``).
On the rich side equilibrium makes CO and H₂, which release far less heat per O₂ than CO₂ and
H₂O: methane–air at Z = 0.15 (φ = 3) is 1024 K there and 2032 K by Burke–Schumann; on the lean
side it is up to 18 % hotter, its heat capacity smaller at lower temperatures (1174 K against
1001 K at Z = 0.02). Both are less the radiant fraction χ_r: T_air + (1 − χ_r)(T(Z) − T_air).
"""

from __future__ import annotations

import re
from functools import cache
from importlib.resources import files

import numpy as np

#: The tables' step in Z: 0, 0.001, …, 1.
EQUILIBRIUM_STEPS = 1000
#: The fuels with a table (those GRI-Mech 3.0 holds) and the temperature (K) of their fuel and air.
EQUILIBRIUM_FUELS = ("methane", "propane")
EQUILIBRIUM_T_AIR_K = 300.0


@cache
def _table_text(fuel: str) -> str:
    return files("incandescent.simulation").joinpath(f"data/equilibrium_{fuel}.csv").read_text()


def equilibrium_z_st(fuel: str) -> float:
    """The stoichiometric mixture fraction of ``fuel``'s table, as its header gives it."""
    found = re.search(r"Z_st = ([0-9.]+)", _table_text(fuel).splitlines()[0])
    if found is None:
        raise ValueError(f"equilibrium_{fuel}.csv: its header gives no Z_st")
    return float(found.group(1))


@cache
def equilibrium_table_K(fuel: str) -> np.ndarray:
    """The equilibrium temperature (K) of ``fuel`` and air at Z = 0, 0.001, …, 1 (read-only)."""
    rows = np.loadtxt(_table_text(fuel).splitlines(), delimiter=",", comments="#", skiprows=2)
    if rows.shape != (EQUILIBRIUM_STEPS + 1, 2):
        raise ValueError(f"equilibrium_{fuel}.csv: expected {EQUILIBRIUM_STEPS + 1} rows of Z, T")
    table = rows[:, 1].copy()
    table.flags.writeable = False
    return table


def interpolate(ops, table, mixture):
    """T(Z) linearly interpolated in a table on Z = 0, 1/N, …, 1 (N = ``EQUILIBRIUM_STEPS``),
    ``table`` an array of the backend ``ops``; Z clipped to [0, 1]."""
    x = ops.clip(mixture, 0.0, 1.0) * float(EQUILIBRIUM_STEPS)
    i = ops.clip(ops.floor_int(x), 0, EQUILIBRIUM_STEPS - 1)
    t = x - ops.to_float(i)
    return (1.0 - t) * ops.gather(table, i) + t * ops.gather(table, i + 1)
