"""Pool fires from D and Q: the premixed equivalent carries Q, the correlations give their
published values, and the measurements recover known signals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from incandescent.simulation.pool import (
    FUELS,
    characteristic_diameter_m,
    dominant_hz,
    heskestad_height_m,
    inflow_m_s,
    intermittency_height_m,
    mccaffrey_excess_K,
    mccaffrey_ratios,
    plume_peak,
    pool_fire,
    power_law_slope,
    puffing_hz,
)
from incandescent.simulation.settings import air_density_kg_m3


@pytest.mark.parametrize("fuel", sorted(FUELS))
def test_the_premixed_inflow_releases_the_heat_asked_for(fuel):  # combustion = "front"
    """The mixture entering over the pool, burnt to T_ad, carries Q: ṁ_mix c_p (T_ad − T_air)
    with ṁ_mix = ρ_air v πD²/4 and c_p the products' mean heat capacity — ≈ 1.4 kJ/(kg·K) for
    stoichiometric hydrocarbon–air products between 300 K and T_ad (Turns 2012 Table 2.1's T_ad
    over its ΔH: 50 MJ/kg / 18.2 / (2226 − 298) K = 1.43 for methane). Asserted: the implied
    c_p within 1.2..1.6 kJ/(kg·K) for every fuel (a missing (1 + s) factor gives ~25)."""
    d, q = 0.5, 100.0
    f = FUELS[fuel]
    mixture_kg_s = air_density_kg_m3(300.0) * inflow_m_s(d, q, f, 300.0) * math.pi * d * d / 4
    cp = q * 1e3 / (mixture_kg_s * (f.adiabatic_K - 300.0))
    assert 1200.0 < cp < 1600.0


def test_a_pool_fire_is_a_nozzle_over_the_pool_in_a_box_around_its_flame():
    """By default a diffusion flame fed the fuel alone: ṁ_f = Q/ΔH_c (2.17 g/s of propane for
    100 kW), leaving the pool at ṁ_f/(ρ_f πD²/4) with ρ_f = 1.79 kg/m³ (propane vapour at 300 K:
    1.177 × 44.10/28.96), Z_st = 1/(1 + 15.7), no vorticity confinement (artistic); with
    combustion = "front" the premixed equivalent, expanding by T_ad/T_air at the front."""
    s = pool_fire(0.5, 100.0, "propane")
    (source,) = s.sources
    assert source.kind == "nozzle" and source.radius_m == 0.25
    assert s.domain_m[0] == s.domain_m[2] == 1.5
    assert s.domain_m[1] >= 2.5 * heskestad_height_m(100.0, 0.5)
    assert s.t_max_K == FUELS["propane"].adiabatic_K
    assert (s.combustion, s.density, s.vorticity) == ("mixing", "ideal_gas", 0.0)
    assert source.fuel_kg_s == pytest.approx(100e3 / 46.0e6)
    assert source.jet_m_s == pytest.approx(100e3 / 46.0e6 / (1.7924 * math.pi * 0.25**2), 1e-3)
    assert s.stoichiometric_mixture == pytest.approx(1 / 16.7)
    front = pool_fire(0.5, 100.0, "propane", combustion="front")
    assert (front.combustion, front.density, front.sources[0].fuel_kg_s) == (
        "front",
        "boussinesq",
        0,
    )
    assert front.density_ratio == pytest.approx(FUELS["propane"].adiabatic_K / 300.0)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((0.5, 100.0, "kerosene"), "unknown fuel 'kerosene'; expected one of: methane"),
        ((-0.5, 100.0), "diameter_m must be a positive number; got -0.5"),
        ((0.5, float("nan")), "heat_release_kW must be a positive number; got nan"),
    ],
)
def test_bad_pool_fires_are_one_line_errors(args, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        pool_fire(*args)


def test_the_correlations_give_their_published_values():
    """Cetegen & Ahmed: 1.5 Hz at D = 1 m, 3.35 Hz at 0.2 m; Heskestad: Q = 1000 kW, D = 1 m →
    0.235·15.85 − 1.02 = 2.70 m; McCaffrey's
    plume region at z/Q^(2/5) = 0.3: ΔT = 300/(2·9.81)·(1.1/0.9)²·0.3^(−5/3) = 170 K, and his
    continuous flame's ΔT = 300/19.62·(6.8/0.9)² = 873 K independent of height."""
    assert puffing_hz(1.0) == 1.5 and puffing_hz(0.2) == pytest.approx(3.354, abs=1e-3)
    assert heskestad_height_m(1000.0, 1.0) == pytest.approx(2.704, abs=1e-3)
    q = 100.0
    plume = mccaffrey_excess_K(0.3 * q**0.4, q)
    assert float(plume) == pytest.approx(300 / 19.62 * (1.1 / 0.9) ** 2 * 0.3 ** (-5 / 3), 1e-9)
    flame = mccaffrey_excess_K(np.array([0.02, 0.05]) * q**0.4, q)
    np.testing.assert_allclose(flame, 300 / 19.62 * (6.8 / 0.9) ** 2, rtol=1e-9)


def test_the_characteristic_fire_diameter_is_baum_and_mccaffreys():
    """D* = (Q/(ρ c_p T √g))^(2/5): ρ c_p T √g of air at 293 K is 1.204·1.005·293·3.132 = 1110
    kW/m^(5/2), so a 1110 kW fire has D* = 1 m and one of 1110·2^(5/2) kW has D* = 2 m."""
    assert characteristic_diameter_m(1110.0) == pytest.approx(1.0, rel=2e-3)
    assert characteristic_diameter_m(1110.0 * 2**2.5) == pytest.approx(2.0, rel=2e-3)


def test_the_dominant_frequency_of_a_noisy_puff_is_found():
    """2.37 Hz plus noise and a drift, 8 s at 24 Hz: found within 0.05 Hz (the bins are 0.125
    Hz; the parabolic interpolation does better)."""
    rng = np.random.default_rng(3)
    t = np.arange(192) / 24.0
    signal = np.sin(2 * np.pi * 2.37 * t) + 0.3 * rng.normal(size=t.size) + 0.2 * t
    assert dominant_hz(signal, 24.0) == pytest.approx(2.37, abs=0.05)


def test_the_half_intermittency_height_of_a_flickering_tip():
    """A tip uniform between 1.0 and 2.0 m is above z half the time at z = 1.5 m."""
    cell = 0.05
    tips = np.linspace(1.0, 2.0, 401)
    z = (np.arange(60) + 0.5) * cell
    present = z[None, :] < tips[:, None]
    assert intermittency_height_m(present, cell) == pytest.approx(1.5, abs=cell / 2)
    present[:, :3] = False  # cold air in the layers under the pool (a fine grid's)
    assert intermittency_height_m(present, cell) == pytest.approx(1.5, abs=cell / 2)
    assert intermittency_height_m(present[:, :0], cell) == 0.0
    assert intermittency_height_m(present & (z > 9.0), cell) == 0.0


def test_the_slope_of_a_power_law():
    z = np.linspace(0.5, 3.0, 20)
    assert power_law_slope(z, 170.0 * z ** (-5 / 3)) == pytest.approx(-5 / 3, abs=1e-9)


def test_mccaffreys_regions_compare_a_profile_region_by_region():
    """A profile 1.6× McCaffrey's in his continuous flame, on it in the intermittent flame and
    half of it in the plume reads 1.6 / 1 / 0.5; heights at or above ``top_m`` and cold ones
    are left out; a region the profile does not reach reads None."""
    q = 100.0
    z = np.linspace(0.01, 0.5, 200) * q**0.4
    scaled = z / q**0.4
    factor = np.where(scaled < 0.08, 1.6, np.where(scaled < 0.2, 1.0, 0.5))
    excess = factor * mccaffrey_excess_K(z, q)
    top = 0.4 * q**0.4
    excess[z >= top] = 1e4  # the outflow's layers: left out
    excess[5] = -3.0  # a cold layer: left out
    ratios = mccaffrey_ratios(z, excess, q, top_m=top)
    assert ratios == pytest.approx({"continuous": 1.6, "intermittent": 1.0, "plume": 0.5})
    assert mccaffrey_ratios(z[scaled < 0.15], excess[scaled < 0.15], q)["plume"] is None


def test_the_plume_peak_follows_a_plume_off_the_centreline():
    """A Gaussian plume whose axis lies 0.3 m off the centreline and narrows upward: the peak
    finds its temperature and its offset where the central columns see only its flank."""
    cell, (nx, ny, nz) = 0.05, (40, 30, 40)
    x = (np.arange(nx) + 0.5) * cell - nx * cell / 2
    z = (np.arange(nz) + 0.5) * cell - nz * cell / 2
    axis_x, axis_z = 0.3 - cell / 2, -cell / 2  # a cell centre: the peak lands on it exactly
    width = np.linspace(0.3, 0.1, ny)
    r2 = (x[:, None, None] - axis_x) ** 2 + (z[None, None, :] - axis_z) ** 2
    field = 300.0 + 500.0 * np.exp(-r2 / width[None, :, None] ** 2)
    peak_K, offset_m = plume_peak(field, cell)
    assert peak_K == pytest.approx(800.0, rel=1e-12)
    assert offset_m == pytest.approx(np.hypot(axis_x, axis_z), abs=1e-12)
    centre = field[nx // 2 - 1 : nx // 2 + 1, :, nz // 2 - 1 : nz // 2 + 1].mean(axis=(0, 2))
    assert (centre < peak_K - 100.0).all()


@pytest.mark.parametrize("resolution", [24, 64, 128])
def test_the_pool_is_the_bottom_layer_of_cells_at_every_resolution(resolution):
    """The pool's fuel enters through the floor's cells: its nozzle is the bottom layer, one
    cell thick, at any resolution — no air under it (centred 0.02 of the domain up it was the
    bottom two layers at 64 cells but layers 2–3 at 128, and the 1 m, 200 kW pool's flame
    there burnt lean and short). Asserted: the source's cells are exactly layer 0's cells
    within D/2 of the axis."""
    from incandescent.simulation.solver import FireSolver

    solver = FireSolver(pool_fire(1.0, 200.0), resolution)
    inside = solver.ops.numpy(solver.sources[0]).reshape(solver.shape) < 0.0
    layers = np.nonzero(inside.any(axis=(0, 2)))[0]
    assert layers.tolist() == [0]
    nx, _, nz = solver.shape
    x = (np.arange(nx) + 0.5 - nx / 2) * solver.h  # the grid's centre (its sides are whole
    z = (np.arange(nz) + 0.5 - nz / 2) * solver.h  # multigrid-friendly cells, ≈ the domain)
    disc = np.hypot(x[:, None], z[None, :]) < 0.5
    assert np.array_equal(inside[:, 0, :], disc)
