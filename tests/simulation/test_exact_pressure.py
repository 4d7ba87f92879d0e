"""The pressure projection's exact inverse (fast diagonalisation, Lynch, Rice & Thomas 1964)
against the assembled cell Laplacian, and the fire solver with it against the V-cycle."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.simulation import FireSettings, FireSolver, preset, pressure
from incandescent.simulation.arrays import ops_for
from incandescent.simulation.grid import cells

#: (x−, x+, y−, y+, z−, z+) open: a fire's box (floor closed), a chimney (walls closed), a wind's
#: inflow side closed, and a box open everywhere.
SIDES = [
    (True, True, False, True, True, True),
    (False, False, False, True, False, False),
    (False, True, False, True, True, True),
    (True, True, True, True, True, True),
]


@pytest.mark.parametrize("open_sides", SIDES)
@pytest.mark.parametrize("shape", [(6, 10, 8), (5, 7, 9)])
def test_the_exact_inverse_inverts_the_assembled_laplacian(shape, open_sides):
    """A · A⁻¹ b = b to float64 rounding, A the operator ``pressure.apply`` assembles cell by
    cell, on even and odd sides and for each kind of boundary."""
    ops = ops_for("reference")
    level = pressure.operator(ops, cells(shape), np.ones(shape, bool), open_sides)
    inverse = pressure.direct(shape, open_sides, np.float64)
    b = np.random.default_rng(1).standard_normal(int(np.prod(shape)))
    x = pressure.apply_direct(ops, inverse, b)
    np.testing.assert_allclose(pressure.apply(ops, level, x), b, atol=1e-11 * np.abs(b).max())


def test_a_closed_box_gets_the_mean_free_solution():
    """Closed on every side A is singular (the constant mode): for a right-hand side with zero
    sum the inverse solves it and leaves no constant in x; it never divides by the zero mode."""
    shape, closed = (6, 8, 4), (False,) * 6
    ops = ops_for("reference")
    level = pressure.operator(ops, cells(shape), np.ones(shape, bool), closed)
    b = np.random.default_rng(2).standard_normal(int(np.prod(shape)))
    b -= b.mean()
    x = pressure.apply_direct(ops, pressure.direct(shape, closed, np.float64), b)
    assert np.all(np.isfinite(x))
    assert abs(x.mean()) < 1e-12 * np.abs(x).max()
    np.testing.assert_allclose(pressure.apply(ops, level, x), b, atol=1e-11)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_the_exact_preconditioner_solves_a_boussinesq_projection_in_one_iteration(backend):
    """The explosion's first steps: with the exact inverse every projection takes one PCG
    iteration to max|r| ≤ 1e-4 max|b| (the settings' default tolerance; in float32 a tighter one
    can take a second); with the V-cycle several; the states agree within the solves' tolerance."""
    states = {}
    for choice in ("exact", "multigrid"):
        settings = preset("explosion", pressure_preconditioner=choice)
        solver = FireSolver(settings, 24, backend)
        state, iterations = solver.initial_state(), []
        for _ in range(3):
            state, report = solver.step(state, 1 / 96)
            iterations.append(report.pressure_iterations)
            assert report.pressure_residual <= 1e-4
        states[choice] = (solver.ops.numpy(state.velocity[1].values), iterations)
    assert states["exact"][1] == [1, 1, 1]
    assert min(states["multigrid"][1]) > 3
    exact, multigrid = states["exact"][0], states["multigrid"][0]
    np.testing.assert_allclose(exact, multigrid, atol=1e-3 * np.abs(multigrid).max())


def test_auto_picks_the_exact_inverse_only_where_it_is_exact_and_cheap():
    """Auto: exact on the host for a Boussinesq box without obstacles; the V-cycle with an
    obstacle, for the variable-density projection, and on the device."""
    box = FireSettings(domain_m=(1.0, 1.0, 1.0))
    assert FireSolver(box, 16, "reference").exact is not None
    obstacle = FireSettings(
        domain_m=(1.0, 1.0, 1.0), obstacles=({"kind": "box", "size": (0.2,) * 3},)
    )
    assert FireSolver(obstacle, 16, "reference").exact is None
    ideal = box.model_copy(update={"density": "ideal_gas"})
    assert FireSolver(ideal, 16, "reference").exact is None
    forced = ideal.model_copy(update={"pressure_preconditioner": "exact"})
    assert FireSolver(forced, 16, "reference").exact is not None


def test_the_exact_inverse_refuses_a_box_with_an_obstacle():
    settings = FireSettings(
        domain_m=(1.0, 1.0, 1.0),
        obstacles=({"kind": "sphere", "radius_m": 0.2},),
        pressure_preconditioner="exact",
    )
    with pytest.raises(ValueError, match="pressure_preconditioner: 'exact' needs a box"):
        FireSolver(settings, 16, "reference")


def test_the_products_split_over_threads_give_one_threads_result():
    """The exact inverse's products split by rows over 3 threads equal one thread's (float32,
    a grid whose rows do not divide evenly), and a second solve reusing the work grids gives the
    same answer: the scratch grids carry nothing from one solve to the next."""
    ops = ops_for("reference")
    shape, sides = (10, 12, 14), SIDES[0]
    one = pressure.direct(shape, sides, np.float32, workers=1)
    three = pressure.direct(shape, sides, np.float32, workers=3)
    rng = np.random.default_rng(3)
    b, c = (rng.standard_normal(int(np.prod(shape))).astype(np.float32) for _ in range(2))
    x_one = pressure.apply_direct(ops, one, b)
    np.testing.assert_allclose(pressure.apply_direct(ops, three, b), x_one, rtol=1e-6, atol=1e-6)
    first = pressure.apply_direct(ops, three, c).copy()
    pressure.apply_direct(ops, three, b)
    np.testing.assert_array_equal(pressure.apply_direct(ops, three, c), first)
