"""Issue 32, DCC-ready VDBs: `convert --for blender|houdini` and `simulate --for` write the target's
up axis, grid names and units through OpenVDB itself, and the baked emission grid is each voxel's
η = κ·XYZ(B(T)) + species lines in linear Rec.709. Real Blender checks: tests/blender/."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _cli_errors import one_line_error
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.colorimetry.rgb_spaces import xyz_to_rgb
from incandescent.dcc import TARGETS, dcc_grids, emission_xyz, flame_from_kelvin, save_dcc_volume
from incandescent.io import openvdb
from incandescent.spectra.blackbody import blackbody_xyz
from incandescent.spectra.lines import load_lines, species_xyz
from incandescent.volume.grid import Volume
from incandescent.volume.presets import apply_preset

runner = CliRunner()
needs_openvdb = pytest.mark.skipif(openvdb.problem() is not None, reason=str(openvdb.problem()))
VOXEL_M = 0.1
ORIGIN_M = (1.0, 2.0, 3.0)


def _volume(species=None, velocity=None) -> Volume:
    """A 4×6×5 box (tall in y, ours up) with one hot voxel at (1, 4, 2): 1800 K, κ = 2 / m."""
    temperature = np.full((4, 6, 5), 300.0)
    kappa = np.zeros((4, 6, 5))
    temperature[1, 4, 2], kappa[1, 4, 2] = 1800.0, 2.0
    return Volume.from_arrays(temperature, kappa, voxel_size_m=VOXEL_M, origin_m=ORIGIN_M,
                              species=species, velocity_m_s=velocity)  # fmt: skip


def test_emission_grid_is_kappa_times_planck_xyz_in_rec709_in_1e4_cd_m2():
    volume = _volume()
    rgb = dcc_grids(volume, TARGETS["houdini"]).grids["emission"]
    expected = xyz_to_rgb(2.0 * blackbody_xyz(np.array([1800.0])), "srgb")[0] / 1e4
    np.testing.assert_allclose(rgb[1, 4, 2], expected, rtol=1e-4)  # the renderer's table
    cold = np.ones(rgb.shape[:3], bool)
    cold[1, 4, 2] = False
    assert not rgb[cold].any()  # κ = 0 or T = 300 K (κ = 0 there): no emission


def test_species_lines_are_baked_where_there_is_no_soot():
    fraction = np.zeros((4, 6, 5), np.float32)
    fraction[2, 1, 1] = 0.01
    volume = _volume(species={"Na": fraction}).replace(
        temperature_K=np.where(fraction > 0, 1500.0, _volume().temperature_K).astype(np.float32)
    )
    eta = emission_xyz(volume)
    lines = species_xyz(load_lines(None), "Na", np.array([1500.0]), "cie1931_2")[0]
    np.testing.assert_allclose(eta[2, 1, 1], 0.01 * lines, rtol=1e-5)
    assert eta[2, 1, 1, 1] > 0


def test_flame_inverts_blenders_flame_to_kelvin():
    kelvin = np.linspace(1600.0, 2950.0, 10)
    back = apply_preset("blender", {"flame": flame_from_kelvin(kelvin)})["temperature_K"]
    np.testing.assert_allclose(back, kelvin, rtol=1e-6)
    assert flame_from_kelvin(np.array([300.0, 1500.0])).tolist() == [0.0, 0.0]


def _read(path: Path) -> dict[str, dict]:
    return {g["name"]: g for g in openvdb.describe(path)}


@needs_openvdb
def test_blender_vdb_is_z_up_with_the_voxel_where_blender_draws_it(tmp_path):
    """OpenVDB reads our hot voxel back at Blender's (x, −z, y) of ours; Blender fills a voxel's
    cell from its index to the next (tests/blender measures it), so its centre is index + ½."""
    velocity = np.zeros((4, 6, 5, 3), np.float32)
    velocity[1, 4, 2] = (1.0, 2.0, 3.0)
    volume = _volume(velocity=velocity)
    path = save_dcc_volume(volume, tmp_path / "b.vdb", TARGETS["blender"])
    grids = _read(path)
    assert {"density", "temperature", "flame", "color", "velocity"} <= set(grids)
    info = grids["density"]
    assert info["index_min"] == info["index_max"]  # the one voxel with κ > 0
    centre = np.asarray(info["matrix"]) @ np.append(np.asarray(info["index_min"]) + 0.5, 1.0)
    ours = np.asarray(ORIGIN_M) + (np.array([1, 4, 2]) + 0.5) * VOXEL_M
    np.testing.assert_allclose(centre[:3], (ours[0], -ours[2], ours[1]), atol=1e-6)
    lo = info["index_min"]
    dense = openvdb.dense(path, ["velocity", "density"], lo, lo)
    np.testing.assert_allclose(dense["velocity"].reshape(3), (1.0, -3.0, 2.0))
    assert dense["density"].item() == pytest.approx(2.0)
    assert grids["temperature"]["metadata"]["unit"] == "K"
    assert grids["color"]["metadata"]["up_axis"] == "z"


@needs_openvdb
def test_houdini_vdb_keeps_y_up_and_names_velocity_vel(tmp_path):
    velocity = np.zeros((4, 6, 5, 3), np.float32)
    velocity[1, 4, 2] = (1.0, 2.0, 3.0)
    path = save_dcc_volume(_volume(velocity=velocity), tmp_path / "h.vdb", TARGETS["houdini"])
    grids = _read(path)
    assert {"density", "temperature", "flame", "emission", "vel"} <= set(grids)
    info = grids["density"]
    centre = np.asarray(info["matrix"]) @ np.append(info["index_min"], 1.0)  # OpenVDB: centred
    np.testing.assert_allclose(
        centre[:3], np.asarray(ORIGIN_M) + (np.array([1, 4, 2]) + 0.5) * VOXEL_M, atol=1e-6
    )
    lo = info["index_min"]
    np.testing.assert_allclose(openvdb.dense(path, ["vel"], lo, lo)["vel"].reshape(3), (1, 2, 3))


def test_bad_for_value_is_one_line(tmp_path):
    source = tmp_path / "v.npy"
    np.save(source, np.full((4, 4, 4), 1500.0))
    result = runner.invoke(app, ["convert", str(source), str(tmp_path / "o.vdb"), "--for", "maya"])
    one_line_error(result, "--for 'maya'", "blender, houdini")
    result = runner.invoke(
        app, ["convert", str(source), str(tmp_path / "o.npz"), "--for", "houdini"]
    )
    one_line_error(result, "--for houdini", ".vdb", "o.npz")
    assert not (tmp_path / "o.vdb").exists() and not (tmp_path / "o.npz").exists()


@needs_openvdb
def test_simulate_for_blender_writes_each_frame_for_blender(tmp_path):
    out = tmp_path / "fire"
    args = ["simulate", "candle", "-o", str(out), "--resolution", "8", "--frames", "2"]
    result = runner.invoke(app, [*args, "--format", "vdb", "--for", "blender", "--backend", "cpu"])
    assert result.exit_code == 0, result.output
    frames = sorted((out / "blender").glob("fire_*.vdb"))
    assert [f.name for f in frames] == ["fire_0001.vdb", "fire_0002.vdb"]
    grids = _read(frames[-1])
    assert {"density", "temperature", "flame", "velocity", "color"} <= set(grids)
    assert grids["color"]["max"] > 0  # the candle's frame emits
    info = runner.invoke(app, ["info", str(frames[-1])])
    assert "render it with --up-axis z --absorption-grid density" in " ".join(info.output.split())
