"""The equilibrium state relation: its tables against thermochemistry (Turns's adiabatic flame
temperatures, the lean limit's heat over air's heat capacity, the rich side's partial
oxidation), and its interpolation on every backend."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.simulation import FireSolver
from incandescent.simulation.arrays import ops_for
from incandescent.simulation.pool import FUELS, pool_fire
from incandescent.simulation.state_relation import (
    EQUILIBRIUM_FUELS,
    EQUILIBRIUM_STEPS,
    equilibrium_table_K,
    equilibrium_z_st,
    interpolate,
)

Z = np.linspace(0.0, 1.0, EQUILIBRIUM_STEPS + 1)


@pytest.mark.parametrize("fuel", EQUILIBRIUM_FUELS)
def test_the_tables_peak_at_the_fuel_s_adiabatic_flame_temperature(fuel):
    """Air and fuel at 300 K in the table's ends; the peak within 0.5 % of Turns's adiabatic
    flame temperature (2226 K methane, 2267 K propane; Turns 2012 Table 2.1), just rich of the
    fuel's Z_st (dissociation: within 0.005 of it), and Z_st the fuel table's s's to 1 %
    (propane's s is 15.57 by the molar masses, 15.7 in the table)."""
    table = equilibrium_table_K(fuel)
    assert table[0] == pytest.approx(300.0) and table[-1] == pytest.approx(300.0, abs=2.0)
    assert table.max() == pytest.approx(FUELS[fuel].adiabatic_K, rel=0.005)
    assert 0.0 <= Z[table.argmax()] - equilibrium_z_st(fuel) <= 0.005
    assert equilibrium_z_st(fuel) == pytest.approx(FUELS[fuel].stoichiometric_mixture, rel=0.01)


@pytest.mark.parametrize("fuel", EQUILIBRIUM_FUELS)
def test_lean_gas_is_heated_by_its_fuel_over_air_s_heat_capacity(fuel):
    """As Z → 0 the products are almost all air: T − T_air → Z ΔH_c / c_p,air, c_p,air = 1.005
    kJ/(kg·K) at 300 K — within 3 % at Z = 0.002 (≈ 100 K) — and falls below it as the gas
    heats (c_p grows): at Z_st/2, 10–25 % below."""
    table = equilibrium_table_K(fuel)
    heat = FUELS[fuel].heat_of_combustion_J_kg / 1005.0
    assert table[2] - 300.0 == pytest.approx(0.002 * heat, rel=0.03)
    half = round(equilibrium_z_st(fuel) / 2 * EQUILIBRIUM_STEPS)
    assert 0.75 < (table[half] - 300.0) / (Z[half] * heat) < 0.9


def test_rich_gas_at_equilibrium_is_far_cooler_than_burke_schumann_s():
    """Oxygen-starved, methane at equilibrium makes CO and H₂ (CH₄ + ½O₂ → CO + 2H₂ releases 36
    kJ/mol against 802 for CO₂ and H₂O): at φ ≈ 3 (Z = 0.15) the gas is below 1100 K, where
    Burke–Schumann's complete burning (linear from T_ad at Z_st to T_air at Z = 1) puts it above
    2000 K; the two agree at Z_st within 1 %."""
    table, z_st = equilibrium_table_K("methane"), FUELS["methane"].stoichiometric_mixture
    burke_schumann = 300.0 + 1926.0 * np.minimum(Z / z_st, (1.0 - Z) / (1.0 - z_st))
    assert table[150] < 1100.0 < 2000.0 < burke_schumann[150]
    assert table[55] == pytest.approx(burke_schumann[55], rel=0.01)


@pytest.mark.parametrize("backend", ["reference", "cpu"])
def test_the_table_is_interpolated_linearly_on_every_backend(backend):
    """At the nodes the table's values, between them the straight line (NumPy's interp),
    outside [0, 1] the ends'; float32 on Dr.Jit: to 1e-6 relative."""
    ops, table = ops_for(backend), equilibrium_table_K("methane")
    z = np.array([0.0, 0.0005, 0.0551, 0.15, 0.3337, 0.9999, 1.0, -0.1, 1.4])
    got = ops.numpy(interpolate(ops, ops.array(table), ops.array(z)))
    np.testing.assert_allclose(got, np.interp(np.clip(z, 0, 1), Z, table), rtol=1e-6)


def test_the_solver_s_flame_temperature_is_the_table_less_the_radiant_fraction():
    """With ``state_relation = "equilibrium"``: T_air + (1 − χ_r)(T_eq(Z) − T_air)."""
    settings = pool_fire(0.5, 50.0, changes={"state_relation": "equilibrium"})
    solver = FireSolver(settings, 16, "reference")
    z = np.array([0.0, 0.02, 0.055, 0.15])
    expected = 300.0 + 0.8 * (np.interp(z, Z, equilibrium_table_K("methane")) - 300.0)
    np.testing.assert_allclose(solver.flame_temperature(z), expected, rtol=1e-12)
