"""Write the fire solver's equilibrium state relations, T(Z) of a fuel–air mixture at chemical
equilibrium (``FireSettings.state_relation = "equilibrium"``), with Cantera.

Each fuel's table: the mixture fraction Z (the fuel's mass share of a mixture of fuel and air,
both at 300 K) from 0 to 1 in steps of 0.001, and the temperature (K) the mixture reaches at
chemical equilibrium at constant enthalpy and one atmosphere (Cantera's ``equilibrate("HP")``
with GRI-Mech 3.0, Smith et al. 1999, which holds methane and propane; air O₂ : N₂ = 1 : 3.76 by
moles, gas phase only). Not run by the tests or at run time: the tables are committed under
``src/incandescent/simulation/data/`` and this script says how they were made. Usage (Cantera
is not a dependency of incandescent): ``pip install cantera`` then
``python scripts/equilibrium_table.py [OUT_DIR]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cantera as ct  # type: ignore[import-not-found]
import numpy as np

FUELS = {"methane": "CH4", "propane": "C3H8"}
T_AIR_K = 300.0
STEPS = 1000


def table(species: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(Z, T_K, Z_st) of one fuel."""
    gas = ct.Solution("gri30.yaml")
    gas.TPX = T_AIR_K, ct.one_atm, "O2:1, N2:3.76"
    air = gas.Y.copy()
    gas.TPX = T_AIR_K, ct.one_atm, f"{species}:1"
    fuel = gas.Y.copy()
    z = np.linspace(0.0, 1.0, STEPS + 1)
    temperature = np.empty_like(z)
    for i, share in enumerate(z):
        gas.TPY = T_AIR_K, ct.one_atm, share * fuel + (1.0 - share) * air
        gas.equilibrate("HP")
        temperature[i] = gas.T
    gas.TPX = T_AIR_K, ct.one_atm, "O2:1, N2:3.76"
    gas.set_equivalence_ratio(1.0, f"{species}:1", "O2:1, N2:3.76")
    return z, temperature, float(gas.mixture_fraction(f"{species}:1", "O2:1, N2:3.76"))


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("src/incandescent/simulation/data")
    for name, species in FUELS.items():
        z, temperature, z_st = table(species)
        header = (
            f"# {name} ({species}) and air (O2:N2 1:3.76 by moles), both at {T_AIR_K:g} K, at "
            f"chemical equilibrium at constant enthalpy and 1 atm: Cantera {ct.__version__}, "
            f"GRI-Mech 3.0 (gas phase); Z_st = {z_st:.5f}, peak {temperature.max():.1f} K at "
            f"Z = {z[temperature.argmax()]:.3f}. Made by scripts/equilibrium_table.py.\n"
            "mixture_fraction,temperature_K\n"
        )
        rows = "".join(f"{a:.3f},{b:.2f}\n" for a, b in zip(z, temperature, strict=True))
        (out / f"equilibrium_{name}.csv").write_text(header + rows)


if __name__ == "__main__":
    main()
