"""Temperature presets, grid-name aliases and the not-kelvin warning (DESIGN.md §3)."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.volume.presets import (
    PRESETS,
    ROLE_ALIASES,
    apply_preset,
    kelvin_warning,
    preset_parameters,
    resolve_grid_name,
)


def test_blender_maps_flame_like_cycles():
    """T = 1000 K·(ignition + flame·(max_temp − ignition)) where flame > 0.01, else vacuum."""
    flame = np.array([0.0, 0.005, 0.01, 0.0101, 0.5, 1.0])
    out = apply_preset("blender", {"flame": flame, "heat": np.full(6, 2.0)})
    expected = [0.0, 0.0, 0.0, 1000 * (1.5 + 0.0101 * 1.5), 2250.0, 3000.0]
    np.testing.assert_allclose(out["temperature_K"], expected, rtol=1e-12)
    assert out["absorption_per_m"] is None  # no density grid
    assert "preset blender" in out["description"]
    assert "no density grid: default absorption" in out["description"]


def test_blender_parameters_and_density():
    density = np.array([[[0.0, 0.2, 0.4]]])
    flame = np.array([[[0.5, 0.5, 0.0]]])
    out = apply_preset(
        "blender",
        {"flame": flame, "density": density},
        parameters={"ignition": 1.0, "max_temp": 2.0, "density_scale": 10.0},
    )
    np.testing.assert_allclose(out["temperature_K"], [[[1500.0, 1500.0, 0.0]]])
    np.testing.assert_allclose(out["absorption_per_m"], [[[0.0, 2.0, 4.0]]])
    assert "κ = 10 1/m · 'density'" in out["description"]


def test_blender_all_zero_density_falls_back_to_default_absorption():
    out = apply_preset("blender", {"flames": np.ones(3), "smoke": np.zeros(3)})
    assert out["absorption_per_m"] is None
    assert "'smoke' is all zero" in out["description"]


def test_blender_needs_a_flame_grid():
    with pytest.raises(
        ValueError, match="no flame grid: looked for flame, flames, fire; the file has"
    ):
        apply_preset("blender", {"temperature": np.ones(2), "density": np.ones(2)})


def test_blender_rejects_inverted_temperatures():
    with pytest.raises(ValueError, match="need 0 <= ignition < max_temp"):
        apply_preset("blender", {"flame": np.ones(2)}, parameters={"max_temp": 1.0})


@pytest.mark.parametrize("name", ["houdini", "embergen"])
def test_normalised_presets(name: str):
    grids = {"temperature": np.array([-0.5, 0.0, 1.0, 2.0]), "smoke": np.array([0, 1, 2, 3.0])}
    out = apply_preset(name, grids)
    np.testing.assert_allclose(out["temperature_K"], [0.0, 300.0, 1300.0, 2300.0])
    absorption = out["absorption_per_m"]
    assert absorption is not None
    np.testing.assert_allclose(absorption, [0.0, 1.0, 2.0, 3.0])
    out = apply_preset(name, {"heat": np.array([1.0])}, parameters={"kelvin_per_unit": 500.0})
    np.testing.assert_allclose(out["temperature_K"], [800.0])


def test_explicit_grid_names_beat_aliases():
    grids = {"flame": np.zeros(2), "fire_hi": np.array([1.0, 0.0])}
    out = apply_preset("blender", grids, grid_names={"flame": "fire_hi"})
    np.testing.assert_allclose(out["temperature_K"], [3000.0, 0.0])
    with pytest.raises(ValueError, match="no grid named 'nope' for flame; the file has: flame"):
        apply_preset("blender", grids, grid_names={"flame": "nope"})


def test_density_shape_must_match():
    with pytest.raises(ValueError, match=r"density grid 'density' has shape \(3,\)"):
        apply_preset("blender", {"flame": np.ones(2), "density": np.ones(3)})


def test_non_finite_grid_is_an_error():
    with pytest.raises(ValueError, match="grid 'flame' must be finite"):
        apply_preset("blender", {"flame": np.array([np.nan])})


def test_unknown_preset_and_options():
    with pytest.raises(ValueError, match=r"unknown preset 'hudini'; did you mean 'houdini'\?"):
        apply_preset("hudini", {})
    with pytest.raises(ValueError, match="has no option 'ambient'; did you mean 'ambient_K'"):
        preset_parameters("houdini", {"ambient": 290.0})
    assert preset_parameters("blender") == {
        "ignition": 1.5,
        "max_temp": 3.0,
        "density_scale": 1.0,
        "smoke_albedo": 0.5,
    }


def test_every_preset_is_documented():
    import incandescent.volume.presets as module

    for name in PRESETS:
        assert f"``{name}``" in (module.__doc__ or "")


@pytest.mark.parametrize(
    ("role", "names", "expected"),
    [
        ("temperature", ["density", "heat"], "heat"),
        ("temperature", ["heat", "temperature"], "temperature"),  # alias order wins
        ("temperature", ["Temp"], "Temp"),  # case-insensitive fallback
        ("flame", ["flames", "smoke"], "flames"),
        ("flame", ["fire"], "fire"),
        ("density", ["soot"], "soot"),
        ("density", ["smoke", "flame"], "smoke"),
    ],
)
def test_resolve_grid_name(role: str, names: list[str], expected: str):
    assert resolve_grid_name(role, names) == expected


def test_resolve_grid_name_errors():
    expected = "no density grid: looked for density, smoke, soot; the file has: flame, heat"
    with pytest.raises(ValueError, match=expected):
        resolve_grid_name("density", ["flame", "heat"])
    assert resolve_grid_name("density", ["flame"], required=False) is None
    with pytest.raises(ValueError, match="unknown grid role 'colour'"):
        resolve_grid_name("colour", ["x"])
    assert set(ROLE_ALIASES) >= {"temperature", "flame", "density"}


def test_kelvin_warning():
    message = kelvin_warning("heat", np.array([0.0, 2.5]))
    assert message is not None
    assert "grid 'heat' has max 2.5 < 300: probably not kelvin" in message
    assert "range = [LOW, HIGH]" in message
    assert kelvin_warning("Temperature", [[1.0]]) is not None
    assert kelvin_warning("temperature", [300.0, 2000.0]) is None
    assert kelvin_warning("density", [0.5]) is None
    assert kelvin_warning("temperature", np.empty(0)) is None
    assert kelvin_warning("temperature", [np.nan, 3000.0]) is None
