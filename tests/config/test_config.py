"""Scene files and dicts → Scene: round trips, path resolution, overrides and error messages."""

from __future__ import annotations

import dataclasses
import json
import runpy
from pathlib import Path

import numpy as np
import pytest

from incandescent.camera import Camera
from incandescent.config import Scene, SceneError, load_scene, merge_overrides, scene_from_dict
from incandescent.config.schema import DisplaySection, RenderSection
from incandescent.imaging import DisplaySettings
from incandescent.renderer import RenderSettings
from incandescent.volume import Remap, Volume

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

SCENE_TOML = """
[volume]
path = "data/fire.npz"
preset = "blender"
preset_options = { max_temp = 2.5 }
voxel_size_m = 0.01
origin_m = [0.0, -0.2, 0.0]

[volume.grids]
flame = "flames"
density = "smoke"

[volume.temperature]
cutoff_K = 400.0

[camera]
eye = [0.0, 0.5, 2.0]
target = [0.0, 0.1, 0.0]
fov_deg = 35.0

[render]
width = 64
height = 48
step_voxels = 0.25
supersample = 2
seed = 3
skip_empty = false
space = "rec2020"

[display]
exposure_ev = -1.5
tonemap = "reinhard"
white_balance = 1800.0
bits = 16

[output]
path = "out/fire.exr"
stats = "out/fire.json"
backend = "reference"
"""


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _error(tmp_path: Path, text: str, overrides: dict | None = None) -> str:
    path = _write(tmp_path, "scene.toml", text)
    with pytest.raises(SceneError) as info:
        load_scene(path, overrides)
    return str(info.value)


@pytest.fixture
def toml_scene(tmp_path: Path) -> Scene:
    return load_scene(_write(tmp_path, "scene.toml", SCENE_TOML))


def test_toml_values_reach_the_settings(toml_scene: Scene):
    settings = toml_scene.render_settings()
    assert settings == RenderSettings(
        width=64,
        height=48,
        step_voxels=0.25,
        supersample=2,
        seed=3,
        skip_empty=False,
        space="rec2020",
    )
    display = toml_scene.display_settings()
    assert display.space == "rec2020"  # follows render.space
    assert (display.exposure_ev, display.tonemap, display.white_balance, display.bits) == (
        -1.5,
        "reinhard",
        1800.0,
        16,
    )
    assert toml_scene.camera_or_none() == Camera(eye=(0, 0.5, 2), target=(0, 0.1, 0), fov_deg=35)
    assert toml_scene.remap() == Remap(cutoff_K=400.0)
    assert toml_scene.volume.grids.given() == {"flame": "flames", "density": "smoke"}
    assert toml_scene.volume.preset_options == {"max_temp": 2.5}
    assert toml_scene.output.backend == "reference"


def test_json_round_trip(toml_scene: Scene, tmp_path: Path):
    """TOML → Scene → JSON file in another folder → the same Scene (paths are absolute)."""
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    text = toml_scene.model_dump_json(exclude_none=True)
    assert load_scene(_write(folder, "scene.json", text)) == toml_scene


def test_json_scene_file(tmp_path: Path):
    data = {"volume": {"path": "t.npy"}, "render": {"width": 8, "height": 4}}
    scene = load_scene(_write(tmp_path, "scene.json", json.dumps(data)))
    assert scene.render_settings() == RenderSettings(width=8, height=4)
    assert scene.display_settings() == DisplaySettings()
    assert scene.camera_or_none() is None


def test_relative_paths_resolve_against_the_scene_folder(toml_scene: Scene, tmp_path: Path):
    assert toml_scene.volume.path == tmp_path / "data" / "fire.npz"
    assert toml_scene.output.path == tmp_path / "out" / "fire.exr"
    assert toml_scene.output.stats == tmp_path / "out" / "fire.json"


def test_absolute_paths_stay(tmp_path: Path):
    target = tmp_path.parent / "abs.npz"
    scene = load_scene(_write(tmp_path, "s.toml", f'[volume]\npath = "{target.as_posix()}"\n'))
    assert scene.volume.path == target


def test_overrides_beat_file_values(tmp_path: Path):
    path = _write(tmp_path, "s.toml", SCENE_TOML)
    overrides = {
        "render": {"width": 16, "height": None},  # None: flag not given
        "display": {"tonemap": "clip"},
        "output": {"path": "cli.png", "overwrite": True},
        "camera": {"fov_deg": 20.0},
    }
    scene = load_scene(path, overrides)
    assert (scene.render.width, scene.render.height) == (16, 48)
    assert scene.display.tonemap == "clip"
    assert scene.output.path == Path("cli.png")  # a flag's path is relative to the working dir
    assert scene.output.overwrite is True
    assert scene.camera.fov_deg == 20.0
    assert scene.camera.eye == (0.0, 0.5, 2.0)


def test_merge_overrides_is_a_copy():
    data = {"render": {"width": 8}}
    merged = merge_overrides(data, {"render": {"height": 4}, "output": {"path": "x.png"}})
    assert merged == {"render": {"width": 8, "height": 4}, "output": {"path": "x.png"}}
    assert data == {"render": {"width": 8}}


def test_scene_from_dict_with_base_dir(tmp_path: Path):
    scene = scene_from_dict({"volume": {"path": "v.npz"}}, base_dir=tmp_path)
    assert scene.volume.path == tmp_path / "v.npz"
    assert scene_from_dict({"volume": {"path": "v.npz"}}).volume.path == Path("v.npz")


def test_scene_is_frozen(toml_scene: Scene):
    with pytest.raises(ValueError, match="frozen"):
        toml_scene.render.width = 5  # type: ignore[misc]


def test_unknown_key_names_file_path_and_suggestion(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v.npz"\n[render]\nwidht = 64\n')
    assert message == "{}: render.widht: unknown key 'widht'; did you mean 'width'?".format(
        tmp_path / "scene.toml"
    )


def test_unknown_section_and_nested_keys(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v"\n[volume.grids]\nflames = "f"\n[rendr]\n')
    assert "2 problems" in message
    assert "volume.grids.flames: unknown key 'flames'; did you mean 'flame'?" in message
    assert "rendr: unknown key 'rendr'; did you mean 'render'?" in message


def test_unknown_key_without_close_match_lists_valid_keys(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v"\n[output]\nzzz = 1\n')
    assert "output.zzz: unknown key 'zzz'; valid keys: path, overwrite, stats, backend" in message


def test_unknown_key_from_an_override_says_so(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v"\n', {"render": {"hieght": 3}})
    assert "render.hieght: unknown key 'hieght'; did you mean 'height'? (from an override)" in (
        message
    )


def test_wrong_type_names_key_value_and_expected_type(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v"\n[render]\nwidth = "wide"\n')
    assert message.endswith("render.width: expected an integer; got 'wide' (str)")


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("[render]\nstep_voxels = true", "render.step_voxels: expected a finite number; got True"),
        ("[render]\nseed = 1.5", "render.seed: expected an integer; got 1.5 (float)"),
        ("[camera]\neye = [1, 2]", "camera.eye: expected a list of 3 finite numbers; got [1, 2]"),
        ("[camera]\neye = [1, 'a', 3]", "camera.eye: expected a list of 3 finite numbers"),
        ("[display]\nwhite_balance = true", "expected a string or a finite number; got True"),
        ("[volume.temperature]\noffset = nan", "volume.temperature.offset: expected a finite"),
        ("[output]\noverwrite = 'yes'", "output.overwrite: expected true or false; got 'yes'"),
    ],
)
def test_type_errors(tmp_path: Path, line: str, expected: str):
    assert expected in _error(tmp_path, f'[volume]\npath = "v"\n{line}\n')


def test_missing_required_key(tmp_path: Path):
    assert _error(tmp_path, "[render]\nwidth = 8\n").endswith("volume: required key is missing")
    assert "volume.path: required key is missing" in _error(tmp_path, "[volume]\n")


def test_toml_syntax_error_names_file_line_and_column(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v"\n[render]\nwidth = = 3\n')
    assert message.startswith(f"{tmp_path / 'scene.toml'}: TOML syntax error at line 4, column ")


def test_json_syntax_error(tmp_path: Path):
    path = _write(tmp_path, "scene.json", '{"volume": {"path": "v",}}')
    with pytest.raises(SceneError, match=r"scene\.json: JSON syntax error at line 1, column \d+"):
        load_scene(path)


def test_file_problems(tmp_path: Path):
    with pytest.raises(FileNotFoundError, match="no such scene file"):
        load_scene(tmp_path / "missing.toml")
    with pytest.raises(SceneError, match=r"unsupported scene format '\.yaml'"):
        load_scene(_write(tmp_path, "s.yaml", "a: 1"))
    with pytest.raises(SceneError, match="a scene is a table of sections; got list"):
        load_scene(_write(tmp_path, "s.json", "[1, 2]"))


def test_settings_errors_come_from_the_dataclasses(tmp_path: Path):
    message = _error(
        tmp_path,
        '[volume]\npath = "v"\n[render]\nwidth = 0\n[display]\ntonemap = "aces"\niso = 100.0\n'
        '[camera]\neye = [1, 1, 1]\ntarget = [1, 1, 1]\n[output]\nbackend = "gpu"\n',
    )
    assert "render: width must be an integer in 1..32768; got 0" in message
    assert "display: a physical camera needs iso, shutter_s and f_number together" in message
    assert "camera: camera eye and target coincide" in message
    assert "output: unknown backend 'gpu'; expected one of: auto, reference, cpu, cuda" in message
    assert message.count("\n  - ") == 4  # a section reports its first problem only
    assert "display: unknown tonemap 'aces'" in _error(
        tmp_path, '[volume]\npath = "v"\n[display]\ntonemap = "aces"\n'
    )


def test_many_problems_are_cut_short(tmp_path: Path):
    keys = "\n".join(f"bad{i} = 1" for i in range(8))
    message = _error(tmp_path, f'[volume]\npath = "v"\n[render]\n{keys}\n')
    assert "8 problems" in message
    assert message.endswith("... and 3 more")


def test_range_maps_normalised_values_to_kelvin(tmp_path: Path):
    scene = load_scene(
        _write(
            tmp_path, "s.toml", '[volume]\npath = "v"\n[volume.temperature]\nrange = [300, 2100]'
        )
    )
    np.testing.assert_allclose(scene.remap().apply(np.array([0.0, 0.5, 1.0])), [300, 1200, 2100])


def test_range_excludes_offset_and_scale(tmp_path: Path):
    message = _error(
        tmp_path, '[volume]\npath = "v"\n[volume.temperature]\nrange = [300, 2100]\nscale = 2.0\n'
    )
    assert "volume.temperature: give range = [LOW, HIGH] or offset/scale, not both" in message


def test_range_must_increase(tmp_path: Path):
    message = _error(tmp_path, '[volume]\npath = "v"\n[volume.temperature]\nrange = [900, 300]')
    assert "needs 0 <= LOW < HIGH" in message


def test_offset_scale_remap_uses_remap_validation(tmp_path: Path):
    scene = scene_from_dict({"volume": {"path": "v", "temperature": {"offset": 1, "scale": 500}}})
    assert scene.remap() == Remap(offset=1.0, scale=500.0)
    message = _error(tmp_path, '[volume]\npath = "v"\n[volume.temperature]\nscale = -1.0\n')
    assert "remap scale must be > 0" in message


def test_preset_checks(tmp_path: Path):
    assert "did you mean 'blender'?" in _error(tmp_path, '[volume]\npath = "v"\npreset = "blendr"')
    message = _error(
        tmp_path, '[volume]\npath = "v"\npreset = "blender"\npreset_options = {max_tmp = 3.0}'
    )
    assert "preset 'blender' has no option 'max_tmp'; did you mean 'max_temp'?" in message
    message = _error(
        tmp_path,
        '[volume]\npath = "v"\npreset = "houdini"\n[volume.temperature]\noffset = 1.0\n',
    )
    assert "preset 'houdini' maps temperature itself" in message


def test_absorption_constant_and_grid_exclusive(tmp_path: Path):
    message = _error(
        tmp_path, '[volume]\npath = "v"\nabsorption = 2.0\n[volume.grids]\nabsorption = "k"\n'
    )
    assert "give absorption (a constant, 1/m) or grids.absorption" in message


def test_volume_placement_uses_volume_validation(tmp_path: Path):
    assert "voxel_size_m must be a finite number > 0" in _error(
        tmp_path, '[volume]\npath = "v"\nvoxel_size_m = -0.1\n'
    )


def test_camera_for_fills_in_the_default_view():
    volume = Volume.from_arrays(np.full((4, 4, 4), 1500.0))
    scene = scene_from_dict({"volume": {"path": "v"}, "camera": {"fov_deg": 25.0}})
    assert scene.camera_or_none() is None
    camera = scene.camera_for(volume)
    assert camera.fov_deg == 25.0
    np.testing.assert_allclose(camera.target, 0.0, atol=1e-12)  # the box centre
    fixed = scene_from_dict(
        {"volume": {"path": "v"}, "camera": {"eye": [0, 0, 3], "target": [0] * 3}}
    )
    assert fixed.camera_for(volume) == Camera(eye=(0, 0, 3))


def test_sections_cover_the_dataclass_fields():
    """A field added to RenderSettings or DisplaySettings must be added to the schema too."""
    assert set(RenderSection.model_fields) == {f.name for f in dataclasses.fields(RenderSettings)}
    assert set(DisplaySection.model_fields) == {f.name for f in dataclasses.fields(DisplaySettings)}
    assert RenderSection().settings() == RenderSettings()
    assert DisplaySection().settings("srgb") == DisplaySettings()


def test_example_scene_loads_and_builds_a_volume():
    scene = load_scene(EXAMPLES / "flame.toml")
    assert scene.volume.path == EXAMPLES / "flame.npz"
    assert scene.volume.path.is_file()
    assert scene.output.path == EXAMPLES / "flame.png"
    data = np.load(scene.volume.path)
    volume = Volume.from_arrays(
        data[scene.volume.grids.temperature or "temperature"],
        voxel_size_m=scene.volume.voxel_size_m,
        remap=scene.remap(),
    )
    assert 2000.0 < volume.max_temperature_K <= 2100.0
    assert scene.camera_or_none() is not None
    scene.render_settings(), scene.display_settings()


def test_example_data_script_reproduces_the_file(tmp_path: Path):
    module = runpy.run_path(str(EXAMPLES / "make_flame.py"))
    written = module["main"](tmp_path / "flame.npz")
    np.testing.assert_array_equal(
        np.load(written)["temperature"], np.load(EXAMPLES / "flame.npz")["temperature"]
    )
