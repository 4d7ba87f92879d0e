"""A diffusion flame (``combustion = "mixing"``): Burke & Schumann's flame temperature, the fuel
fed at the rate asked for, the flame sheet where Z = Z_st, the fast backends against the float64
reference, refusals, and a resumed run equal to an uninterrupted one."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from _backends import assert_states_close

from incandescent.simulation import FireSolver, preset
from incandescent.simulation.pool import FUELS, pool_fire
from incandescent.simulation.settings import air_density_kg_m3

#: No buoyancy, confinement or source noise: only the feed and the fuel's own slow jet move gas.
STILL = {"gravity_m_s2": 0.0, "vorticity": 0.0, "noise": 0.0, "walls": True}


def _pool(resolution: int = 16, backend: str = "reference", **changes) -> FireSolver:
    return FireSolver(
        pool_fire(0.5, 50.0, changes=changes, combustion="mixing"), resolution, backend
    )


def test_the_flame_temperature_is_burke_and_schumann_s():
    """T(Z) = T_air + (1 − χ_r)(T_ad − T_air) ψ(Z): T_air in air (Z = 0) and in pure fuel (Z = 1),
    the peak at Z_st, linear on either side. On the lean side the excess is the heat of the
    fuel burnt: (T − T_air)/Z = (1 − χ_r) ΔH_c / c_p, with c_p 1.2–1.6 kJ/(kg·K), the mean heat
    capacity of hydrocarbon–air products between 300 K and T_ad (Turns 2012, Table 2.1)."""
    solver = _pool()
    s = solver.settings
    z_st, peak = s.stoichiometric_mixture, (1 - s.radiant_fraction) * (s.t_max_K - s.t_air_K)
    z = np.array([0.0, z_st / 2, z_st, (1 + z_st) / 2, 1.0])
    expected = s.t_air_K + peak * np.array([0.0, 0.5, 1.0, 0.5, 0.0])
    np.testing.assert_allclose(solver.flame_temperature(z), expected, rtol=1e-12, atol=1e-9)
    lean = (solver.flame_temperature(np.array([0.01])) - s.t_air_K) / 0.01
    cp = (1 - s.radiant_fraction) * FUELS["methane"].heat_of_combustion_J_kg / float(lean[0])
    assert 1200.0 < cp < 1600.0
    assert z_st == pytest.approx(1 / 18.2)


def test_the_pool_feeds_its_fuel_at_the_rate_asked_for():
    """In a closed, still box the fuel in the gas, Σ ρZ h³ (ρ the gas's own with the low-Mach
    expansion, the air's without: ``_fuel_per_air``), grows by ṁ_f = Q/ΔH_c each second
    (1.0 g/s for 50 kW of methane): to rounding after 10 steps (Z is carried in flux form,
    ``operators.advect_conservative``; the fuel's own 8 mm/s jet carries air in)."""
    solver = _pool(**STILL)
    state, dt = solver.initial_state(), 0.02
    for _ in range(10):
        state, _ = solver.step(state, dt)
    fuel_kg = _fuel_kg(solver, state)
    fed_kg_s = 50e3 / FUELS["methane"].heat_of_combustion_J_kg
    assert fuel_kg == pytest.approx(fed_kg_s * 10 * dt, rel=1e-9)


def test_the_flame_sheet_lies_where_the_mixture_is_stoichiometric():
    """φ = (Z_st − Z)/|∇Z| on a Z falling linearly along x through Z_st at x₀ = 7.3 cells: the
    signed distance x − x₀ in cells (to 1e-3: |∇Z| + 10⁻⁶ in the divisor), the fuel side
    negative, and the frames' CH* peaks in the cell whose centre lies nearest x₀."""
    from incandescent.simulation.frames import reaction_zone

    solver = _pool()
    x = solver.ops.numpy(solver.centres[0]).reshape(solver.shape)
    z_st = solver.settings.stoichiometric_mixture
    mixture = z_st - 0.004 * (x - 7.3)
    phi = solver.ops.numpy(solver.sheet_distance(solver.ops.array(mixture.ravel())))
    phi = phi.reshape(solver.shape)
    inner = (slice(1, -1),) * 3  # central differences: one-sided at the sides
    np.testing.assert_allclose(phi[inner], (x - 7.3)[inner], rtol=1e-3, atol=1e-3)
    zone = reaction_zone(phi)[:, 5, 5]
    assert int(np.argmax(zone)) == 7


#: The diffusion flame's variants, as ``pool_fire`` changes: fast chemistry with the low-Mach
#: expansion (the pool's default), without it, mixing-limited burning (without: refused), and
#: fast chemistry with the expansion and the equilibrium state relation.
VARIANTS = {
    "expansion": {},
    "fast": {"expansion": False},
    "mixing_time": {"reaction": "mixing_time"},
    "equilibrium": {"state_relation": "equilibrium"},
}


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_the_jit_backends_burn_as_the_float64_reference(jit_backend, variant):
    """Eight steps of the pool at 24 cells from a rich blob of fuel (Z = 0.3) over it: every
    field as the reference's within 1e-5 — with ``expansion`` 1e-4: its divergence is a
    difference of densities over Δt, in which float32's rounding grows (measured up to 4.7e-5
    in T, 1.6e-5 in u)."""
    states = {}
    for backend in ("reference", jit_backend):
        solver = _pool(24, backend, pressure_tolerance=1e-6, **VARIANTS[variant])
        x, y, z = (solver.ops.numpy(p) for p in solver.centres)
        blob = 0.3 * np.exp(-((x - 12) ** 2 + (y - 4) ** 2 + (z - 12) ** 2) / 8.0)
        state = replace(solver.initial_state(), mixture=solver.cell_field(solver.ops.array(blob)))
        for _ in range(8):
            state, _ = solver.step(state, 1 / 48)
        states[backend] = (solver, state)
    names = ("temperature", "soot", "mixture")
    rtol = 1e-4 if variant == "expansion" else 1e-5
    assert_states_close(states["reference"], states[jit_backend], names, rtol, nonzero=True)


def _cells_of(solver: FireSolver, mixture: np.ndarray, burnt_K: np.ndarray):
    """(Z, T) as the backend's arrays, tiled over the solver's cells."""
    n = solver.cell.size
    return tuple(solver.ops.array(np.resize(v, n)) for v in (mixture, burnt_K))


def test_mixing_limited_burning_is_fast_chemistry_when_mixing_is_instant():
    """``reaction = "mixing_time"``: unburnt gas (T = T_air) over a Δt a million times τ_mix
    burns to Burke & Schumann's flame temperature at every Z, lean, stoichiometric and rich —
    the fast-chemistry limit, to rounding (float64)."""
    solver = _pool(reaction="mixing_time")
    z = np.array([0.0, 0.01, 0.03, solver.settings.stoichiometric_mixture, 0.2, 0.6, 1.0])
    mixture, cold = _cells_of(solver, z, np.full(z.size, solver.settings.t_air_K))
    strain = solver.ops.full(solver.cell.size, 1.0)
    tau = float(np.max(solver.ops.numpy(solver.mixing_time_s(strain))))
    burnt = solver.ops.numpy(solver._burn(mixture, cold, strain, 1e6 * tau))
    expected = solver.ops.numpy(solver.flame_temperature(mixture))
    np.testing.assert_allclose(burnt, expected, rtol=1e-12)


def test_mixing_limited_burning_is_a_partially_stirred_reactor():
    """Over Δt = τ_mix ln 2 half the fuel that can burn burns (1 − e^(−Δt/τ_mix) = ½): lean gas
    at Z = 0.03 from cold reaches half its flame temperature's excess, rich gas at Z = 0.3 half
    of what its air allows; and gas already burnt as far as it can stays (T = T(Z))."""
    solver = _pool(reaction="mixing_time")
    s = solver.settings
    z = np.array([0.03, 0.3])
    mixture, cold = _cells_of(solver, z, np.full(2, s.t_air_K))
    strain = solver.ops.full(solver.cell.size, 2.0)
    tau = solver.ops.numpy(solver.mixing_time_s(strain))[0]
    half = solver.ops.numpy(solver._burn(mixture, cold, strain, tau * np.log(2.0)))[:2]
    full = solver.ops.numpy(solver.flame_temperature(mixture))[:2]
    np.testing.assert_allclose(half - s.t_air_K, 0.5 * (full - s.t_air_K), rtol=1e-12)
    _, done = _cells_of(solver, z, full)
    again = solver.ops.numpy(solver._burn(mixture, done, strain, 10.0 * tau))[:2]
    np.testing.assert_allclose(again, full, rtol=1e-12)


def test_the_mixing_time_is_fds_s():
    """τ_mix = min(τ_u, τ_g) written out (McDermott, McGrattan & Floyd 2011): τ_g = √(2Δ/g) for
    the 0.5 m pool's cells at 16 cells (Δ = 0.125 m: 0.160 s); τ_u = C_u Δ/√(⅔ k_sgs), k_sgs =
    (ν_t/(C_ν Δ))², ν_t = (C_s Δ)²|S| (C_u 0.4, C_ν 0.1, C_s 0.2): 1.2247/|S| whatever Δ — at
    |S| = 20/s, 0.0612 s; at 2/s the free fall's 0.160 s is the shorter."""
    solver = _pool(reaction="mixing_time")
    h = solver.h
    assert h == pytest.approx(0.125)
    strain = solver.ops.array(np.resize([20.0, 2.0], solver.cell.size))
    tau = solver.ops.numpy(solver.mixing_time_s(strain))[:2]
    c_u, c_nu, c_s = 0.4, 0.1, 0.2
    turbulence = c_u * h / np.sqrt(2 / 3 * ((c_s * h) ** 2 * 20.0 / (c_nu * h)) ** 2)
    np.testing.assert_allclose(tau, [turbulence, np.sqrt(2 * h / 9.80665)], rtol=1e-12)
    assert tau[0] == pytest.approx(0.0612, abs=1e-4) and tau[1] == pytest.approx(0.160, abs=1e-3)


def test_a_diffusion_flame_lifts_and_heats_the_gas_above_the_pool():
    """2 s at 24 cells (cpu): gas above 1000 K, the hottest no hotter than the flame's peak,
    and its heat carried up (Σ (T − T_air) w > 0 over the cells above the pool's layer). At 24
    cells the fuel fed burns in the pool's one layer of 8 cm cells (1821 K at 0.5 s); with the
    low-Mach expansion the burning gas pushes the air back, the layer goes rich (Z up to 0.079
    > Z_st by 2 s) and soot forms over it (``test_soot_forms_on_the_rich_side_only``). Without
    the expansion the air drawn over the pool kept it lean (Z ≤ 0.053 up to 4 s, no soot)."""
    solver = _pool(24, "cpu")
    s, state = solver.settings, solver.initial_state()
    for _ in range(96):
        state, _ = solver.step(state, 1 / 48)
    t = solver.ops.numpy(state.temperature.values).reshape(solver.shape)
    peak = s.t_air_K + (1 - s.radiant_fraction) * (s.t_max_K - s.t_air_K)
    assert 1000.0 < t.max() <= peak + 1e-3
    up = solver.ops.numpy(state.velocity[1].values).reshape(solver.face[1].shape)
    w = 0.5 * (up[:, 1:-1] + up[:, 2:])  # at the centres of the cells above the first layer
    assert float(((t[:, 1:] - s.t_air_K) * w).sum()) > 0.0


def test_soot_forms_on_the_rich_side_only():
    """Gas at Z = 0.3 (rich, 1441 K) and at Z = 0.04 (lean, 1422 K), both above
    ``soot_min_K`` (1200 K): one step of 10 ms makes ``soot_rate_per_s`` × 10 ms of
    soot in the rich cells, and none in the lean ones."""
    solver = _pool(16, **STILL)
    x = solver.ops.numpy(solver.centres[0])
    rich = x < 8
    mixture = np.where(rich, 0.3, 0.04)
    t = solver.flame_temperature(mixture)
    assert t.min() > solver.settings.soot_min_K
    burnt = {"mixture": solver.cell_field(mixture), "temperature": solver.cell_field(t)}
    state, _ = solver.step(replace(solver.initial_state(), **burnt), 0.01)
    soot = solver.ops.numpy(state.soot.values)
    made = solver.settings.soot_rate_per_s * 0.01 * np.exp(-solver.settings.soot_decay_per_s * 0.01)
    inner = rich & (x < 6)  # away from where the mixing across x = 8 changes Z
    np.testing.assert_allclose(soot[inner], made, rtol=1e-9)
    assert soot[~rich & (x > 10)].max() == 0.0


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: preset("campfire", combustion="mixing"),
         "sources.0.fuel_kg_s: combustion = 'mixing' burns the fuel a source feeds"),
        (lambda: preset("torch", sources=[{"kind": "nozzle", "fuel_kg_s": 0.001}]),
         "sources.0.fuel_kg_s: 0.001 kg/s is unused by combustion = 'front'"),
        (lambda: pool_fire(0.5, 50.0, combustion="premixed"),
         "combustion must be 'front' or 'mixing'; got 'premixed'"),
        (lambda: pool_fire(0.5, 50.0, changes={"combustion": "fast"}),
         "combustion must be 'front' or 'mixing'; got 'fast'"),
        (lambda: preset("campfire", reaction="mixing_time"),
         "reaction: 'mixing_time' burns a diffusion flame's fuel, which combustion = 'front'"),
        (lambda: preset("campfire", expansion=True),
         "expansion: the low-Mach expansion is built for combustion = 'mixing' with reaction"),
        (lambda: pool_fire(0.5, 50.0, changes={"expansion": True, "reaction": "mixing_time"}),
         "expansion: the low-Mach expansion is built for combustion = 'mixing' with reaction"),
        (lambda: pool_fire(0.5, 50.0, "heptane", changes={"state_relation": "equilibrium"}),
         "state_relation 'equilibrium' has tables for methane, propane (GRI-Mech 3.0), not"),
        (lambda: preset("campfire", state_relation="equilibrium"),
         "state_relation: 'equilibrium' is the fast diffusion flame's T(Z); got combustion"),
        (lambda: pool_fire(0.5, 50.0, changes={"state_relation": "equilibrium", "t_air_K": 290}),
         "t_air_K: 290 K, but the equilibrium tables are of fuel and air at 300 K"),
        (lambda: pool_fire(0.5, 50.0, "propane", changes={
            "state_relation": "equilibrium", "equilibrium_fuel": "methane"}),
         "stoichiometric_mixture: 0.0598802, but methane's equilibrium table has Z_st"),
    ],
)  # fmt: skip
def test_a_flame_without_its_fuel_is_refused_in_one_line(make, message):
    with pytest.raises(ValueError, match=re.escape(message)) as error:
        make()
    assert "\n" not in str(error.value)


def test_a_resumed_diffusion_flame_equals_an_uninterrupted_one(tmp_path):
    """Its checkpoint carries the mixture fraction: 2 frames, then resumed to 3, equal 3 at once
    (by then the fuel fed has burnt the gas over the pool to 390 K, 427 K without the low-Mach
    expansion; a resume that lost Z, or the density carried as the temperature, would restart
    the feed from nothing)."""
    from incandescent.simulation import simulate

    settings = pool_fire(0.5, 50.0, combustion="mixing")
    simulate(settings, 16, 2, tmp_path / "a", backend="reference")
    simulate(settings, 16, 3, tmp_path / "a", backend="reference")
    simulate(settings, 16, 3, tmp_path / "b", backend="reference")
    with np.load(tmp_path / "a/fire_0003.npz") as a, np.load(tmp_path / "b/fire_0003.npz") as b:
        assert a["temperature"].max() > 380.0
        np.testing.assert_array_equal(a["temperature"], b["temperature"])
        np.testing.assert_array_equal(a["CH"], b["CH"])


def _fuel_per_air(solver: FireSolver, state) -> np.ndarray:
    """The fuel per volume as a fraction of the air's density, per cell: ρZ/ρ_air = Z T_air/T
    with ``expansion`` (the gas's own density), else Z (carried as in a flow of the air's
    density, ``FireSolver._feed``)."""
    z = solver.ops.numpy(state.mixture.values)
    if not solver.settings.expansion:
        return z
    return z * solver.settings.t_air_K / solver.ops.numpy(state.temperature.values)


def _through_sides_kg_s(solver: FireSolver, state, per_air: np.ndarray, ambient: float) -> float:
    """What leaves through the open sides (kg/s) of a quantity with ``per_air`` per volume in
    each cell (a fraction of ρ_air) and ``ambient`` in the far field: Σ u·n q h² over their
    faces, q the cell's beside the face where gas leaves (the flux form's upwind value; its
    limited slope vanishes at a side), the ambient's where it enters."""
    ops, h = solver.ops, solver.h
    q = per_air.reshape(solver.shape)
    kg_s = 0.0
    for a in range(3):
        u_m_s = ops.numpy(state.velocity[a].values).reshape(solver.face[a].shape) * h
        for side, (index, sign) in enumerate(((0, -1.0), (-1, 1.0))):
            if solver.open_sides[2 * a + side]:
                out_m_s = sign * np.take(u_m_s, index, axis=a)
                upwind = np.where(out_m_s > 0.0, np.take(q, index, axis=a), ambient)
                kg_s += float((out_m_s * upwind).sum())
    return kg_s * air_density_kg_m3(solver.settings.t_air_K) * h * h


def _leaving_kg_s(solver: FireSolver, state) -> float:
    """Fuel leaving through the open sides (kg/s; none enters)."""
    return _through_sides_kg_s(solver, state, _fuel_per_air(solver, state), 0.0)


def _fuel_kg(solver: FireSolver, state) -> float:
    per_air = _fuel_per_air(solver, state)
    return float(per_air.sum()) * air_density_kg_m3(solver.settings.t_air_K) * solver.h**3


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_the_fuel_fed_leaves_or_stays_so_the_fire_releases_q(variant):
    """Z is carried in flux form: over 1 s of the 0.5 m, 50 kW pool at 24 cells (after 2 s, the
    plume through the top), the fuel fed equals what left through the sides (each step's
    outflow at the velocity that carries the next) plus what the domain gained, to 1 % (measured
    0.994: the outflow is read at each step's start, the flux form's own sub-steps move). Every
    kilogram of it leaves lean, so the heat the gas carries away is (1 − χ_r)ΔH_c per kg fed:
    (1 − χ_r)Q. Carried semi-Lagrangian, 3.3 g/s left the 32-cell pool for the 1 g/s fed.
    With ``expansion`` the fuel is carried as ρZ, its own mass per volume (measured 0.9992)."""
    solver = _pool(24, "cpu", **VARIANTS[variant])
    state, dt = solver.initial_state(), 1 / 96
    for _ in range(2 * 96):
        state, _ = solver.step(state, dt)
    start_kg, left_kg = _fuel_kg(solver, state), 0.0
    for _ in range(96):
        left_kg += _leaving_kg_s(solver, state) * dt
        state, _ = solver.step(state, dt)
    fed_kg = solver.settings.sources[0].fuel_kg_s * 1.0
    assert left_kg > 0.3 * fed_kg  # the plume has reached the top: the test has something to add
    assert left_kg + _fuel_kg(solver, state) - start_kg == pytest.approx(fed_kg, rel=0.01)


def _gas_kg(solver: FireSolver, state) -> float:
    """The gas's mass (kg): Σ ρ h³, ρ = ρ_air T_air/T."""
    t = solver.ops.numpy(state.temperature.values)
    s = solver.settings
    return float((s.t_air_K / t).sum()) * air_density_kg_m3(s.t_air_K) * solver.h**3


@pytest.mark.parametrize(("expansion", "bound"), [(True, 0.01), (False, None)])
def test_with_expansion_the_gas_keeps_its_mass(expansion, bound):
    """The continuity equation, ∂ρ/∂t + ∇·(ρu) = ṁ_f: over 1 s of the 0.5 m, 50 kW pool at 24
    cells (after 2 s), the gas's mass in the domain (ρ = ρ_air T_air/T) changes by the fuel fed
    plus the air drawn in through the sides less the gas that left them, within ``bound`` of
    the mass heating would have driven out (Σ (ρ_air − ρ)h³ at the end). Measured: 0.07 g of
    72 g (0.001; 48 g of air drawn in net). Without the expansion (∇·u = 0) heated gas loses
    mass in place: 85 g of 112 g (0.76) missing."""
    solver = _pool(24, "cpu", expansion=expansion)
    state, dt = solver.initial_state(), 1 / 96
    for _ in range(2 * 96):
        state, _ = solver.step(state, dt)
    start_kg, net_in_kg = _gas_kg(solver, state), 0.0
    for _ in range(96):
        density = solver.settings.t_air_K / solver.ops.numpy(state.temperature.values)
        net_in_kg -= _through_sides_kg_s(solver, state, density, 1.0) * dt
        state, _ = solver.step(state, dt)
    fed_kg = solver.settings.sources[0].fuel_kg_s * 1.0
    miss_kg = _gas_kg(solver, state) - start_kg - fed_kg - net_in_kg
    heated_kg = air_density_kg_m3(300.0) * solver.h**3 * solver.cell.size - _gas_kg(solver, state)
    if bound is None:
        assert abs(miss_kg) > 0.5 * heated_kg
    else:
        assert abs(miss_kg) < bound * heated_kg
