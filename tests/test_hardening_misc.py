"""Issue 25, smaller surfaces: an output that is an input, the default camera's target, a
negative --velocity-scale, strict ``info --json`` and non-finite voxels, NUL bytes in paths, and
scene-file paths that leave the scene's folder. Every input here is made by the test."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from incandescent.cli import app

runner = CliRunner()
SMALL = ("--width", "8", "--height", "8")


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


def _one_line_error(result, *words: str) -> str:
    """The command failed with exit status 2 and one line naming ``words``; the line."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), result.output
    for word in words:
        assert word in lines[0], (word, lines[0])
    return lines[0]


@pytest.fixture
def volume(tmp_path) -> Path:
    """A 10³ grid with hot gas in its middle 6³ voxels (the content box is not the whole box)."""
    temp = np.zeros((10, 10, 10))
    temp[2:8, 2:8, 2:8] = 1500.0
    path = tmp_path / "box.npz"
    np.savez(path, temperature=temp)
    return path


def _scene(folder: Path, text: str, name: str = "scene.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


# --- 1. an output that is the input by another name ------------------------------------------


@pytest.mark.parametrize("how", ["symlink", "hardlink", "dotdot"])
def test_render_never_replaces_its_input_volume_even_with_overwrite(tmp_path, volume, how):
    before = volume.read_bytes()
    if how == "symlink":
        out = tmp_path / "link.png"
        out.symlink_to(volume)
    elif how == "hardlink":
        out = tmp_path / "hard.png"
        os.link(volume, out)
    else:  # a symlink reached through a sub-folder and ..
        (tmp_path / "sub").mkdir()
        (tmp_path / "box.png").symlink_to(volume.name)
        out = tmp_path / "sub" / ".." / "box.png"
    result = _run("render", volume, "-o", out, "--overwrite", *SMALL)
    _one_line_error(result, "input", str(out))
    assert volume.read_bytes() == before


def test_render_stats_never_replace_the_scene_file_or_the_volume(tmp_path, volume):
    scene = _scene(tmp_path, '[volume]\npath = "box.npz"\n')
    scene_bytes, volume_bytes = scene.read_bytes(), volume.read_bytes()
    for target in (scene, volume):
        link = tmp_path / f"stats_{target.stem}.json"
        link.symlink_to(target)
        out = tmp_path / "out.png"
        result = _run("render", scene, "-o", out, "--stats", link, "--overwrite", *SMALL)
        _one_line_error(result, "input", str(link))
        assert not out.exists()
    assert scene.read_bytes() == scene_bytes and volume.read_bytes() == volume_bytes


def test_the_image_as_the_scene_file_by_a_hard_link_is_refused(tmp_path, volume):
    scene = _scene(tmp_path, '[volume]\npath = "box.npz"\n[output]\npath = "same.png"\n')
    os.link(scene, tmp_path / "same.png")
    result = _run("render", scene, "--overwrite", *SMALL)
    _one_line_error(result, "input")
    assert scene.read_text().startswith("[volume]")


# --- 2. the default camera's target, and an eye that is the target ----------------------------


def test_the_default_target_of_gas_centred_on_the_origin_is_exactly_the_origin(volume):
    from incandescent import api
    from incandescent.camera.camera import default_camera

    vol = api.Volume.from_arrays(np.load(volume)["temperature"])
    assert default_camera(vol.content_bounds_m).target == (0.0, 0.0, 0.0)
    rng = np.random.default_rng(25)
    for _ in range(200):  # boxes symmetric about 0 whose corners are each rounded
        voxel, first = rng.uniform(0.001, 0.3), int(rng.integers(0, 50))
        n = int(rng.integers(first + 1, 200))
        origin = -n * voxel / 2
        lo, hi = origin + first * voxel, origin + (n - first) * voxel
        camera = default_camera((np.full(3, lo), np.full(3, hi)))
        assert camera.target == (0.0, 0.0, 0.0), (lo, hi)


@pytest.mark.parametrize("eye", ["[0.0, 0.0, 0.0]", "[1e-17, -2.8e-17, 0.0]"])
def test_a_scene_eye_at_the_default_target_is_refused_naming_the_keys(tmp_path, volume, eye):
    scene = _scene(tmp_path, f'[volume]\npath = "box.npz"\n[camera]\neye = {eye}\n')
    result = _run("render", scene, "-o", tmp_path / "o.png", *SMALL)
    _one_line_error(result, "camera.eye", "camera.target", "coincide")
    assert not (tmp_path / "o.png").exists()


def test_eye_and_target_a_rounding_apart_coincide_and_say_where_they_come_from(tmp_path, volume):
    far = 1e3
    text = f"[camera]\neye = [{far}, 0.0, 0.0]\ntarget = [{far * (1 + 1e-15)}, 0.0, 0.0]\n"
    scene = _scene(tmp_path, '[volume]\npath = "box.npz"\n' + text)
    line = _one_line_error(_run("render", scene, "-o", tmp_path / "o.png", *SMALL), "coincide")
    assert "camera" in line and "override" not in line  # no flag was given


# --- 3. negative --velocity-scale --------------------------------------------------------------


@pytest.mark.parametrize("value", ["-1", "-1e-30", "nan", "inf", "-inf"])
@pytest.mark.parametrize("command", ["render", "animate"])
def test_a_bad_velocity_scale_names_the_flag_before_reading(tmp_path, value, command):
    missing = tmp_path / "never_read.npz"  # does not exist: the flag is refused first
    source = str(missing) if command == "render" else str(tmp_path / "f_*.npz")
    result = _run(command, source, "-o", tmp_path / "out.png", f"--velocity-scale={value}")
    _one_line_error(result, "--velocity-scale", ">= 0")
    assert list(tmp_path.iterdir()) == []


def test_a_negative_velocity_scale_in_a_scene_file_says_the_bound(tmp_path, volume):
    scene = _scene(tmp_path, '[volume]\npath = "box.npz"\nvelocity_scale = -2.0\n')
    _one_line_error(_run("render", scene, "-o", tmp_path / "o.png"), "volume.velocity_scale", ">=")


# --- 4. info: strict JSON, and non-finite voxels warned about as render refuses them -----------


def _strict(text: str) -> dict:
    def refuse(token: str):
        raise AssertionError(f"not JSON: {token}")

    return json.loads(text, parse_constant=refuse)


def _nan_npz(tmp_path: Path) -> Path:
    temp = np.full((4, 4, 4), 1500.0)
    temp[1, 2, 3] = np.nan
    velocity = np.zeros((4, 4, 4, 3))
    velocity[0, 0, 0] = (np.inf, 0.0, -np.inf)
    path = tmp_path / "nan.npz"
    np.savez(path, temperature=temp, velocity=velocity, density=np.ones((4, 4, 4)))
    return path


@pytest.mark.filterwarnings("error::RuntimeWarning")  # no NumPy warning on stderr either
def test_info_names_every_grid_with_non_finite_voxels_as_render_refuses(tmp_path):
    path = _nan_npz(tmp_path)
    text = " ".join(_run("info", path).output.split())
    assert "temperature: 1 of 64 values are NaN or infinite (first nan at index (1, 2, 3))" in text
    assert "velocity: 2 of 192 values are NaN or infinite" in text
    assert "density:" not in text
    report = _strict(_run("info", "--json", path).stdout)
    finite = {g["name"]: g["finite"] for g in report["grids"]}
    assert finite == {"temperature": False, "velocity": False, "density": True}
    assert sum("NaN or infinite" in w for w in report["warnings"]) == 2
    render = _run("render", path, "-o", tmp_path / "o.png", *SMALL)
    assert render.exit_code == 2 and "must be finite" in render.output  # the same rule


def test_info_json_of_a_vdb_with_nan_and_inf_is_strict_json(tmp_path):
    from incandescent.io import openvdb

    if openvdb.problem() is not None:
        pytest.skip(str(openvdb.problem()))
    import subprocess
    import textwrap

    path = tmp_path / "nan.vdb"
    script = f"""
        import pyopenvdb as vdb
        g = vdb.FloatGrid(); g.name = "temperature"
        a = g.getAccessor()
        for ijk, v in (((0, 0, 0), 1500.0), ((1, 0, 0), float("nan")), ((2, 0, 0), 1200.0)):
            a.setValueOn(ijk, v)
        v = vdb.Vec3SGrid(); v.name = "velocity"
        b = v.getAccessor()
        b.setValueOn((0, 0, 0), (float("nan"), 0.0, 0.0))
        b.setValueOn((1, 0, 0), (float("inf"), 1.0, 1.0))
        vdb.write("{path}", grids=[g, v])
    """
    python = openvdb.interpreter()
    done = subprocess.run([python, "-c", textwrap.dedent(script)], env=openvdb._clean_env(),
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    result = _run("info", "--json", path)
    assert result.exit_code == 0, result.output
    report = _strict(result.stdout)
    grids = {g["name"]: g for g in report["grids"]}
    assert grids["temperature"]["sum"] is None and grids["velocity"]["max"] is None
    assert not grids["temperature"]["finite"] and not grids["velocity"]["finite"]
    assert any("shown as null" in w for w in report["warnings"])
    assert any(w.startswith("velocity: holds NaN or infinite") for w in report["warnings"])
    assert "velocity: holds NaN" in " ".join(_run("info", path).output.split())


# --- 5. NUL bytes in paths ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("suffix", "text", "key"),
    [
        (".json", '{"volume": {"path": "bo\\u0000x.npz"}}', "volume.path"),
        (".toml", '[volume]\npath = "box.npz"\n[output]\npath = "a\\u0000b.png"\n', "output.path"),
        (".toml", '[volume]\npath = "box.npz"\n[output]\nstats = "s\\u0000.json"\n',
         "output.stats"),
        (".toml", '[volume]\npath = "box.npz"\n[emission]\nline_table = "t\\u0000.csv"\n',
         "emission.line_table"),
    ],
)  # fmt: skip
def test_a_nul_byte_in_a_scene_files_path_is_one_line_naming_the_key(
    tmp_path, volume, suffix, text, key
):
    scene = _scene(tmp_path, text, "scene" + suffix)
    for command in (("render", scene, "-o", tmp_path / "o.png"), ("info", scene)):
        _one_line_error(_run(*command), str(scene), key, "NUL byte")
    assert not (tmp_path / "o.png").exists()


def test_a_nul_byte_in_a_scene_or_volume_path_given_to_the_api_is_a_scene_error(tmp_path):
    from incandescent.config import SceneError, load_scene, scene_from_dict

    with pytest.raises(SceneError, match=r"scene file path: a path cannot contain a NUL byte"):
        load_scene(str(tmp_path / "a\0.toml"))
    with pytest.raises(SceneError, match=r"volume.path: a path cannot contain a NUL"):
        scene_from_dict({"volume": {"path": "vol\0.npz"}})


def test_a_nul_byte_cannot_reach_the_command_line_of_a_process():
    """execve(2) takes NUL-terminated strings: a NUL in an argument never reaches the CLI (the
    caller fails first), so a command-line volume path cannot hold one; typer refuses one given
    to the app in-process (exit status 2, no traceback)."""
    import subprocess
    import sys

    with pytest.raises(ValueError, match="null byte"):
        subprocess.run([sys.executable, "-m", "incandescent.cli", "render", "a\0.npz"])
    result = _run("render", "a\0.npz", "-o", "o.png")
    assert result.exit_code == 2 and "Traceback" not in result.output


# --- 6. scene-file paths stay inside the scene's folder ----------------------------------------


@pytest.fixture
def nested(tmp_path, volume) -> Path:
    """tmp/outer/scene/ holding the volume; tmp/victim.json an unrelated file."""
    folder = tmp_path / "outer" / "scene"
    folder.mkdir(parents=True)
    (folder / "box.npz").write_bytes(volume.read_bytes())
    (tmp_path / "victim.json").write_text('{"keep": true}')
    return folder


@pytest.mark.parametrize(
    ("key", "line"),
    [
        ("output.stats", '[output]\npath = "o.png"\nstats = "../../victim.json"\noverwrite = true'),
        ("output.path", '[output]\npath = "sub/../../../victim.png"\noverwrite = true'),
        ("volume.path", '[output]\npath = "o.png"'),
    ],
)
def test_a_relative_path_out_of_the_scene_folder_is_refused_naming_the_key(
    tmp_path, nested, key, line
):
    volume = "../../box.npz" if key == "volume.path" else "box.npz"
    (tmp_path / "box.npz").write_bytes((nested / "box.npz").read_bytes())
    scene = _scene(nested, f'[volume]\npath = "{volume}"\n{line}\n')
    result = _run("render", scene, *SMALL)
    _one_line_error(result, str(scene), key, "leaves the scene's folder", "absolute path")
    assert (tmp_path / "victim.json").read_text() == '{"keep": true}'
    assert sorted(p.name for p in nested.iterdir()) == ["box.npz", "scene.toml"]


def test_an_output_through_a_symlink_out_of_the_scene_folder_is_refused(tmp_path, nested):
    (nested / "out").symlink_to(tmp_path)
    scene = _scene(nested, '[volume]\npath = "box.npz"\n[output]\nstats = "out/victim.json"\n'
                   'path = "o.png"\noverwrite = true\n')  # fmt: skip
    _one_line_error(_run("render", scene, *SMALL), "output.stats", "leaves the scene's folder")
    assert (tmp_path / "victim.json").read_text() == '{"keep": true}'


def test_paths_inside_the_folder_and_absolute_paths_are_taken(tmp_path, nested):
    (nested / "renders").mkdir()
    elsewhere = tmp_path / "elsewhere.json"
    scene = _scene(nested, '[volume]\npath = "./renders/../box.npz"\n[output]\n'
                   f'path = "renders/o.png"\nstats = "{elsewhere}"\n')  # fmt: skip
    result = _run("render", scene, *SMALL)
    assert result.exit_code == 0, result.output
    assert (nested / "renders" / "o.png").is_file() and json.loads(elsewhere.read_text())


def test_a_scene_overwrite_never_replaces_the_scene_or_its_volume(tmp_path, nested):
    before = (nested / "box.npz").read_bytes()
    text = {"volume": {"path": "box.npz"}, "output": {"path": "o.png", "stats": "scene.json",
                                                       "overwrite": True}}  # fmt: skip
    scene = _scene(nested, json.dumps(text), "scene.json")
    scene_text = scene.read_text()
    _one_line_error(_run("render", scene, *SMALL), "input")
    assert scene.read_text() == scene_text and not (nested / "o.png").exists()
    os.link(nested / "box.npz", nested / "alias.png")
    scene = _scene(nested, '[volume]\npath = "box.npz"\n[output]\npath = "alias.png"\n'
                   "overwrite = true\n")  # fmt: skip
    _one_line_error(_run("render", scene, *SMALL), "input")
    assert (nested / "box.npz").read_bytes() == before
