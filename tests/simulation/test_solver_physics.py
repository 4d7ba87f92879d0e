"""The fire solver's source terms against closed forms: radiative cooling (Nguyen, Fedkiw &
Jensen 2002 eq. 9) and the first instants of buoyant rise (the Boussinesq approximation with an
ideal gas's density, g(1 − T_air/T) — β = 1/T_air at small excess —, Fedkiw, Stam & Jensen 2001
eq. 8's form) and of soot's weight."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.simulation import FireSettings, FireSolver
from incandescent.simulation.settings import air_density_kg_m3

QUIET = {"sources": (), "gravity_m_s2": 0.0, "vorticity": 0.0, "noise": 0.0}


def _cooled(backend: str, dt: float, t_end: float = 0.5) -> tuple[FireSolver, np.ndarray]:
    """T after ``t_end`` s from a uniform T_max with no flow and no fuel (φ far from the front)."""
    solver = FireSolver(FireSettings(domain_m=(1.0, 1.0, 1.0), **QUIET), 8, backend)
    s = solver.settings
    state = replace(
        solver.initial_state(),
        temperature=solver.cell_field(solver.ops.full(solver.cell.size, s.t_max_K)),
    )
    for _ in range(round(t_end / dt)):
        state, _ = solver.step(state, dt)
    return solver, solver.ops.numpy(state.temperature.values)


def _cooling_closed_form(s: FireSettings, t: float, theta0: float = 1.0) -> float:
    """T(t) of dT/dt = −c_T θ⁴, θ = (T − T_air)/(T_max − T_air): with k = c_T/(T_max − T_air),
    dθ/dt = −kθ⁴ integrates to θ(t) = θ₀ (1 + 3kθ₀³t)^(−1/3)."""
    k = s.cooling_K_s / (s.t_max_K - s.t_air_K)
    theta = theta0 * (1.0 + 3.0 * k * theta0**3 * t) ** (-1.0 / 3.0)
    return s.t_air_K + theta * (s.t_max_K - s.t_air_K)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_radiative_cooling_converges_to_the_closed_form(backend):
    """Nguyen et al. 2002 eq. 9 integrated by the solver's explicit Euler step: from T_max
    (2000 K) for 0.5 s at c_T = 3000 K/s the closed form gives 1404.42 K. Measured errors of
    the excess T − T_air: −0.894 %, −0.441 %, −0.219 % at Δt = 1/48, 1/96, 1/192 s (first order:
    halving Δt halves it, ratio 2.03 and 2.01), the same on float32; Richardson's
    2 T(1/96) − T(1/48) = 1404.560 K, 1.26e-4 of the excess from the closed form (the
    second-order remainder). Asserted: the field stays uniform, the error at Δt = 1/96 s under
    0.6 %, the ratio 2 ± 0.1 and the extrapolation within 5e-4 (a θ³ or a 2 c_T fails all three
    by far)."""
    errors, values = [], []
    for dt in (1 / 48, 1 / 96):
        solver, t = _cooled(backend, dt)
        s = solver.settings
        exact = _cooling_closed_form(s, 0.5)
        assert t.max() - t.min() == 0.0
        values.append(t[0])
        errors.append((t[0] - exact) / (exact - s.t_air_K))
    assert abs(errors[1]) < 0.006
    assert errors[0] / errors[1] == pytest.approx(2.0, abs=0.1)
    extrapolated = 2.0 * values[1] - values[0]
    assert (extrapolated - exact) / (exact - s.t_air_K) == pytest.approx(0.0, abs=5e-4)


RISE = {
    "sources": (),
    "vorticity": 0.0,
    "noise": 0.0,
    "cooling_K_s": 0.0,
    "soot_rate_per_s": 0.0,
    "soot_decay_per_s": 0.0,
    "smagorinsky": 0.0,
}


def _rise_ratio(
    backend: str,
    region: str,
    steps: int = 5,
    dt: float = 0.01,
    soot: float = 0.0,
    excess: float = 600.0,
    linear: bool = False,
) -> np.ndarray:
    """w/a_expected after each of ``steps`` steps, w (m/s) on the y-face at the region's centre
    (a column: 3/4 of the way up), 32³ cells: the region ΔT = 600 K hotter than the air, or at
    air temperature holding ``soot`` (unit soot), with the ideal gas's a = g(1 − T_air/T)
    (Boussinesq with ρ_air as inertia: 6.54 m/s² at 900 K) — or, with ``linear``, its small-excess
    form g β ΔT, β = 1/T_air — or soot's weight a = −g c/ρ_air (c = soot κ₁/σ_m)."""
    n = 32
    settings = FireSettings(domain_m=(1.0, 1.0, 1.0), **RISE)
    solver = FireSolver(settings, n, backend)
    x, y, z = (solver.ops.numpy(p).reshape(solver.shape) for p in solver.centres)
    c = n / 2
    if region == "column":
        inside, height = (x - c) ** 2 + (z - c) ** 2 < (n / 8) ** 2, 3 * n // 4
    else:
        inside, height = (x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2 < (n / 6) ** 2, n // 2
    excess = 0.0 if soot else excess
    fields = {
        "temperature": settings.t_air_K + excess * inside,
        "soot": soot * inside.astype(float),
    }
    state = replace(
        solver.initial_state(),
        **{k: solver.cell_field(solver.ops.array(v.ravel())) for k, v in fields.items()},
    )
    g, rho = settings.gravity_m_s2, air_density_kg_m3(settings.t_air_K)
    soot_kg_m3 = soot * settings.soot_kappa_per_m / settings.soot_mass_extinction_m2_kg
    hot = settings.t_air_K + excess
    thermal = g * excess / settings.t_air_K if linear else g * (1.0 - settings.t_air_K / hot)
    expected = thermal - g * soot_kg_m3 / rho
    ratios = []
    for k in range(1, steps + 1):
        state, _ = solver.step(state, dt)
        w = solver.ops.numpy(state.velocity[1].values).reshape(solver.face[1].shape)
        ratios.append(w[n // 2, height, n // 2] * solver.h / (expected * k * dt))
    return np.array(ratios)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_hot_column_rises_at_the_buoyant_acceleration(backend):
    """A vertical column of hot gas (radius 4 cells, floor to top): the force g(1 − T_air/T) ŷ
    (6.54 m/s² for ΔT = 600 K at T_air = 300 K) does not vary along y, so it is divergence-free
    and the projection leaves it alone but near the solid floor: w = a t before the column has
    moved. Measured w/(a t) = 0.9917 over the first 5 steps (the floor's pressure, 24 cells
    below), the same on float32. Asserted: within 2 % of 1 (a ×2 or ×½ buoyancy, or the linear
    g ΔT/T_air — 3× — fails)."""
    np.testing.assert_allclose(_rise_ratio(backend, "column"), 1.0, rtol=0.02)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_warm_column_rises_at_the_boussinesq_rate_beta_delta_t(backend):
    """At small excess the buoyancy is Boussinesq's g β ΔT with an ideal gas's β = 1/T_air:
    a column 3 K warmer rises at 0.0981 m/s² (g·3/303 = 0.990 of it, times the floor's 0.9917:
    0.982 expected). Asserted: within 2 % of g β ΔT (the old β = 0.006 m/s²/K is 5.5× off)."""
    ratio = _rise_ratio(backend, "column", excess=3.0, linear=True)
    np.testing.assert_allclose(ratio, 1.0, rtol=0.02)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_hot_sphere_rises_at_two_thirds_of_the_buoyant_acceleration(backend):
    """A hot sphere (radius 5.3 cells): a uniform force inside a sphere is ⅓ a pressure
    gradient — the potential of a uniformly polarised sphere, whose field inside is −P/3
    (Jackson, Classical Electrodynamics, 3rd ed., §4.4 eq. 4.58) — so the projection leaves
    w = ⅔ β ΔT g t at its centre at first. Measured w/(β ΔT g t) = 0.6700 over the first 5
    steps (the voxelised sphere and the domain's sides: +0.5 %). Asserted: within 2 % of ⅔."""
    np.testing.assert_allclose(_rise_ratio(backend, "sphere"), 2.0 / 3.0, rtol=0.02)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_sooty_column_sinks_under_the_weight_of_its_soot(backend):
    """A column of air at T_air holding unit soot (κ = 8/m): its mass 8/8700 kg/m³ (σ_m =
    8.7 m²/g, Mulholland & Croarkin 2000) weighs w = −g c/ρ_air t = −7.66e-3 m/s² · t, as the
    hot column's rise (the same geometry, so the same 0.9917 of it). Measured 0.9917 over the
    first 5 steps. Asserted: within 2 % of 1 (the old α = 0.5 m/s² per unit soot is 65×)."""
    np.testing.assert_allclose(_rise_ratio(backend, "column", soot=1.0), 1.0, rtol=0.02)
