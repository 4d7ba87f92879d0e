"""The fire solver's source terms against closed forms: radiative cooling (Nguyen, Fedkiw &
Jensen 2002 eq. 9) and the first instants of buoyant rise (Fedkiw, Stam & Jensen 2001 eq. 8)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.simulation import FireSettings, FireSolver

QUIET = {"sources": (), "buoyancy_m_s2_K": 0.0, "vorticity": 0.0, "noise": 0.0}


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


RISE = {"sources": (), "vorticity": 0.0, "noise": 0.0, "cooling_K_s": 0.0, "soot_rate_per_s": 0.0}


def _rise_ratio(backend: str, hot_region: str, steps: int = 5, dt: float = 0.01) -> np.ndarray:
    """w/(β ΔT t) after each of ``steps`` steps, w (m/s) on the y-face at the hot region's
    centre (a column: 3/4 of the way up), ΔT = 600 K, β = 0.006 m/s²/K, 32³ cells."""
    beta, excess, n = 0.006, 600.0, 32
    settings = FireSettings(domain_m=(1.0, 1.0, 1.0), buoyancy_m_s2_K=beta, **RISE)
    solver = FireSolver(settings, n, backend)
    x, y, z = (solver.ops.numpy(p).reshape(solver.shape) for p in solver.centres)
    c = n / 2
    if hot_region == "column":
        hot, height = (x - c) ** 2 + (z - c) ** 2 < (n / 8) ** 2, 3 * n // 4
    else:
        hot, height = (x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2 < (n / 6) ** 2, n // 2
    t0 = settings.t_air_K + excess * hot
    t0_field = solver.cell_field(solver.ops.array(t0.ravel()))
    state = replace(solver.initial_state(), temperature=t0_field)
    ratios = []
    for k in range(1, steps + 1):
        state, _ = solver.step(state, dt)
        w = solver.ops.numpy(state.velocity[1].values).reshape(solver.face[1].shape)
        ratios.append(w[n // 2, height, n // 2] * solver.h / (beta * excess * k * dt))
    return np.array(ratios)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_hot_column_rises_at_the_buoyant_acceleration(backend):
    """A vertical column of hot gas (radius 4 cells, floor to top): the force β ΔT ŷ does not
    vary along y, so it is divergence-free and the projection leaves it alone but near the
    solid floor: w = β ΔT t (Fedkiw et al. 2001 eq. 8) before the column has moved. Measured
    w/(β ΔT t) = 0.9917 over the first 5 steps (the floor's pressure, 24 cells below), the same
    on float32. Asserted: within 2 % of 1 (a ×2 or ×½ buoyancy fails)."""
    np.testing.assert_allclose(_rise_ratio(backend, "column"), 1.0, rtol=0.02)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_hot_sphere_rises_at_two_thirds_of_the_buoyant_acceleration(backend):
    """A hot sphere (radius 5.3 cells): a uniform force inside a sphere is ⅓ a pressure
    gradient — the potential of a uniformly polarised sphere, whose field inside is −P/3
    (Jackson, Classical Electrodynamics, 3rd ed., §4.4 eq. 4.58) — so the projection leaves
    w = ⅔ β ΔT t at its centre at first. Measured w/(β ΔT t) = 0.6700 over the first 5 steps
    (the voxelised sphere and the domain's sides: +0.5 %). Asserted: within 2 % of ⅔."""
    np.testing.assert_allclose(_rise_ratio(backend, "sphere"), 2.0 / 3.0, rtol=0.02)
