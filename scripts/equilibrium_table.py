"""Write the fire solver's equilibrium state relations, T(Z) of a fuel–air mixture at chemical
equilibrium (``FireSettings.state_relation = "equilibrium"``), with Cantera.

Each fuel's table: the mixture fraction Z (the fuel's mass share of a mixture of fuel and air,
both at 300 K) from 0 to 1 in steps of 0.001, and the temperature (K) the mixture reaches at
chemical equilibrium at constant enthalpy and one atmosphere (Cantera's ``equilibrate("HP")``
with GRI-Mech 3.0, Smith et al. 1999, which holds methane and propane; air O₂ : N₂ = 1 : 3.76 by
moles, gas phase only). Not run by the tests or at run time: the tables are committed under
``src/incandescent/simulation/data/`` and this script says how they were made. Usage (Cantera
is not a dependency of incandescent): ``pip install cantera`` then
``python scripts/equilibrium_table.py [OUT_DIR]``; ``python scripts/equilibrium_table.py --plot
PNG`` draws methane's committed table against Burke–Schumann's, both as the solver uses them
(less χ_r = 0.2; no Cantera needed).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

FUELS = {"methane": "CH4", "propane": "C3H8"}
T_AIR_K = 300.0
STEPS = 1000


def table(species: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(Z, T_K, Z_st) of one fuel."""
    import cantera as ct  # type: ignore[import-not-found]

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


def write_tables(out: Path) -> None:
    """Each fuel's table as ``out/equilibrium_{fuel}.csv``."""
    import cantera as ct  # type: ignore[import-not-found]

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


def plot(path: Path) -> None:
    """Methane's flame temperature as the solver computes it (``FireSolver.flame_temperature``
    of a methane pool fire, χ_r = 0.2): Burke–Schumann against equilibrium (the committed
    table)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from incandescent.simulation import FireSolver
    from incandescent.simulation.pool import pool_fire

    z = np.linspace(0.0, 1.0, STEPS + 1)
    fig, ax = plt.subplots(figsize=(6.0, 3.4))
    for relation, label in (("burke_schumann", "Burke–Schumann (default)"), ("equilibrium", None)):
        settings = pool_fire(0.5, 50.0, changes={"state_relation": relation})
        solver = FireSolver(settings, 8, "reference")  # its flame_temperature, in float64
        ax.plot(z, solver.flame_temperature(z), label=label or relation)
    ax.axhline(1000.0, color="grey", lw=0.8, ls=":", label="1000 K")
    ax.axvline(settings.stoichiometric_mixture, color="grey", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlim(1e-3, 1.0)
    ax.set_xlabel("mixture fraction Z (Z_st: grey)")
    ax.set_ylabel("T (K), χ_r = 0.2")
    ax.set_title("methane–air: the gas's temperature by its mixture fraction", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    if sys.argv[1:2] == ["--plot"]:
        plot(Path(sys.argv[2]))
        return
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("src/incandescent/simulation/data")
    write_tables(out)


if __name__ == "__main__":
    main()
