"""A steady wind (``wind_m_s``): it blows through an empty box unchanged, tilts a pool fire
downwind more the harder it blows without destabilising it, and is refused where it cannot
blow (a closed box) or where the solver cannot follow it (faster than sound)."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.simulation import FireSolver, preset
from incandescent.simulation.pool import FUELS, pool_fire, wind_tilt_deg
from incandescent.simulation.run import advance_frame


def _speeds_m_s(solver, state):
    return [solver.ops.numpy(v.values) * solver.h for v in state.velocity]


def test_the_wind_blows_through_an_empty_box_unchanged():
    """Uniform flow is a steady solution of the incompressible Euler equations: with no fire,
    ten frames later every open face still moves at the wind and nothing else moves."""
    solver = FireSolver(preset("campfire", wind_m_s=2.0, sources=()), 24, "cpu")
    state = solver.initial_state()
    for _ in range(10):
        state, _ = advance_frame(solver, state)
    u, v, w = _speeds_m_s(solver, state)
    assert np.allclose(u, 2.0, atol=1e-4)
    assert np.abs(v).max() < 1e-4 and np.abs(w).max() < 1e-4


def _hot_centroid_m(wind_m_s: float) -> tuple[float, float, float]:
    """(downwind offset of the luminous gas's centroid from the pool's axis, its height, the
    largest speed) over the second of two seconds of a 0.5 m, 50 kW pool fire at 24 cells,
    burning as the premixed equivalent (``combustion = "front"``). The diffusion flame is no
    use at 24 cells: its gas above 1000 K stays in the pool's first layer of 8 cm cells (its
    centroid 4–9 cm up), and in a wind of 1 or 3 m/s moves one cell downwind either way."""
    settings = pool_fire(0.5, 50.0, changes={"wind_m_s": wind_m_s}, combustion="front")
    solver = FireSolver(settings, 24, "cpu")
    state, offsets, heights, fastest = solver.initial_state(), [], [], 0.0
    for frame in range(48):
        state, _ = advance_frame(solver, state)
        fastest = max(fastest, *(np.abs(u).max() for u in _speeds_m_s(solver, state)))
        hot = np.nonzero(solver.ops.numpy(state.temperature.values).reshape(solver.shape) > 1000)
        if frame >= 24 and hot[0].size:
            offsets.append((hot[0].mean() + 0.5) * solver.h - solver.shape[0] * solver.h / 2)
            heights.append((hot[1].mean() + 0.5) * solver.h)
    return float(np.mean(offsets)), float(np.mean(heights)), fastest


def test_a_wind_tilts_the_flame_downwind_and_more_the_harder_it_blows():
    """Without wind the luminous gas stands over the pool (offset within a cell); at 1 and 3 m/s
    it leans downwind (+x), further at 3 than at 1, and no speed exceeds twice the still fire's
    largest plus the wind (the wind adds no energy of its own)."""
    still, _, still_fastest = _hot_centroid_m(0.0)
    light, light_height, _ = _hot_centroid_m(1.0)
    strong, strong_height, strong_fastest = _hot_centroid_m(3.0)
    cell = pool_fire(0.5, 50.0).domain_m[1] / 24
    assert abs(still) < cell
    assert light > cell and strong > light
    assert np.arctan2(strong, strong_height) > np.arctan2(light, light_height)
    assert strong_fastest < 2.0 * still_fastest + 3.0


def test_the_aga_tilt_correlation():
    """cos θ = 1/√u*: vertical up to u* = 1, 60° at u* = 4; u* ∝ u_w, so 4× the u_w of u* = 1
    gives 60° (here found by scaling the wind that makes u* = 1)."""
    methane = FUELS["methane"]
    assert wind_tilt_deg(0.0, 0.5, 50.0, methane) == 0.0
    low, high = 1e-3, 10.0
    for _ in range(60):  # the wind of u* = 1, by bisection on θ > 0
        mid = 0.5 * (low + high)
        low, high = (low, mid) if wind_tilt_deg(mid, 0.5, 50.0, methane) > 0 else (mid, high)
    assert wind_tilt_deg(4.0 * high, 0.5, 50.0, methane) == pytest.approx(60.0, abs=1e-6)
    # ṁ'' = 50 kW / 50 MJ/kg / 0.196 m² = 5.09 g/(m²·s): u* = 1 at (g ṁ'' D/ρ)^(1/3) = 0.277 m/s
    assert high == pytest.approx(0.277, rel=0.01)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"wind_m_s": 2.0, "walls": True}, "with walls = true the box is closed"),
        ({"wind_m_s": 400.0}, "wind_m_s: 400 m/s is faster than sound"),
        ({"wind_m_s": -1.0}, "wind_m_s"),
    ],
)
def test_impossible_winds_are_refused(changes, message):
    with pytest.raises(ValueError, match=message):
        preset("campfire", **changes)


def test_simulate_wind_flag_blows_through_the_frames(tmp_path):
    """``simulate --wind 2`` writes frames whose gas moves downwind at about the wind; a
    negative wind is a one-line error naming --wind and the key."""
    from typer.testing import CliRunner

    from incandescent.cli import app

    runner = CliRunner()
    common = ["simulate", "pool", "--pool", "0.2:10", "--resolution", "16", "--frames", "2"]
    done = runner.invoke(app, [*common, "-o", str(tmp_path / "a"), "--wind", "2"])
    assert done.exit_code == 0, done.output
    with np.load(tmp_path / "a" / "fire_0002.npz") as frame:
        assert np.median(frame["velocity"][..., 0]) == pytest.approx(2.0, rel=0.05)
    bad = runner.invoke(app, [*common, "-o", str(tmp_path / "b"), "--wind", "-1"])
    assert bad.exit_code == 2
    assert "--wind" in bad.output and "wind_m_s" in bad.output
