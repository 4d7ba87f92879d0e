"""The command line end to end on tiny sizes: real files in, real EXR/PNG/JSON out."""

from __future__ import annotations

import json
import typing
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.io.images import read_exr

runner = CliRunner()


def _run(*args: str):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture
def npy(tmp_path):
    temp = np.full((8, 8, 8), 300.0)
    temp[2:6, 2:6, 2:6] = 2000.0
    path = tmp_path / "hot.npy"
    np.save(path, temp)
    return path


def test_render_npy_to_exr_with_stats(npy, tmp_path):
    out, stats = tmp_path / "out.exr", tmp_path / "stats.json"
    result = _run(
        "render",
        npy,
        "-o",
        out,
        "--width",
        16,
        "--height",
        12,
        "--stats",
        stats,
        "--backend",
        "cpu",
    )
    assert result.exit_code == 0, result.output
    rgb, meta, extra = read_exr(out)
    assert rgb.shape == (12, 16, 3) and rgb.max() > 0
    assert meta["backend"] == "cpu" and meta["colour_space"] == "srgb"
    assert "A" in extra and extra["A"].max() > 0
    data = json.loads(stats.read_text())
    assert data["backend"] == "cpu" and data["samples"] > 0 and data["seconds"] >= 0
    assert "CPU" in data["device"] and data["absorption"].startswith("default")


def test_render_npz_grids_png_and_flags(tmp_path):
    temp = np.full((6, 6, 6), 1800.0)
    path = tmp_path / "grids.npz"
    np.savez(path, temperature=temp, absorption=np.full(temp.shape, 2.0))
    out, stats = tmp_path / "out.png", tmp_path / "s.json"
    result = _run(
        "render",
        path,
        "-o",
        out,
        "--width",
        10,
        "--height",
        8,
        "--eye",
        "0,0,3",
        "--target",
        "0,0,0",
        "--fov",
        30,
        "--step",
        0.25,
        "--exposure",
        -1,
        "--voxel-size",
        0.1,
        "--stats",
        stats,
    )
    assert result.exit_code == 0, result.output
    assert Image.open(out).size == (10, 8)
    assert json.loads(stats.read_text())["absorption"] == "grid ('absorption')"
    stats.unlink()
    result = _run(
        "render",
        path,
        "-o",
        tmp_path / "k.exr",
        "--absorption",
        0.5,
        "--width",
        4,
        "--height",
        4,
        "--stats",
        stats,
        "--backend",
        "reference",
    )
    assert result.exit_code == 0, result.output
    assert json.loads(stats.read_text())["absorption"] == "constant 0.5 1/m"


def test_render_refuses_to_overwrite_before_rendering(npy, tmp_path):
    out = tmp_path / "out.png"
    out.write_bytes(b"keep me")
    result = _run("render", npy, "-o", out, "--width", 4, "--height", 4)
    assert result.exit_code == 2
    assert "exists; pass --overwrite" in result.output
    assert out.read_bytes() == b"keep me"
    assert _run("render", npy, "-o", out, "--width", 4, "--height", 4, "--overwrite").exit_code == 0
    assert out.read_bytes() != b"keep me"


@pytest.mark.parametrize(
    ("setup", "args", "message"),
    [
        (
            lambda d: (d / "bad.npy").write_bytes(b"not numpy"),
            ["bad.npy"],
            "bad.npy: not a NumPy .npy array",
        ),
        (
            lambda d: np.savez(d / "x.npz", foo=np.ones((2, 2, 2))),
            ["x.npz"],
            "no temperature grid: looked for temperature, heat, temp, T; the file has: foo",
        ),
        (lambda d: None, ["missing.npy"], "missing.npy: no such volume file"),
        (
            lambda d: np.save(d / "t.npy", np.ones((2, 2, 2))),
            ["t.npy", "--eye", "1,2"],
            "--eye must be three numbers",
        ),
        (
            lambda d: np.save(d / "n.npy", np.full((2, 2, 2), np.nan)),
            ["n.npy"],
            "must be finite; got nan",
        ),
        (
            lambda d: np.save(d / "t.npy", np.ones((2, 2, 2))),
            ["t.npy", "--backend", "gpu"],
            "unknown backend 'gpu'",
        ),
        (
            lambda d: np.save(d / "t.npy", np.ones((2, 2, 2))),
            ["t.npy", "--offset", 5],
            "negative after remap",
        ),
    ],
)
def test_render_bad_input_is_one_clear_line(tmp_path, setup, args, message):
    setup(tmp_path)
    args = [tmp_path / args[0], *args[1:]]
    result = _run("render", *args, "-o", tmp_path / "o.png", "--width", 4, "--height", 4)
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.output.split())
    assert "Traceback" not in result.output
    assert not (tmp_path / "o.png").exists()


def test_demo_renders_a_png(tmp_path):
    out = tmp_path / "plume.png"
    result = _run("demo", "plume", "--size", 24, "--width", 32, "--height", 24, "-o", out)
    assert result.exit_code == 0, result.output
    image = np.asarray(Image.open(out))
    assert image.shape == (24, 32, 3) and image.max() > 100


def test_demo_unknown_scene(tmp_path):
    result = _run("demo", "volcano", "-o", tmp_path / "v.png")
    assert result.exit_code == 2 and "unknown demo 'volcano'" in result.output


def test_bench_json_reports_every_case():
    result = _run("bench", "--json", "--size", 16, "--pixels", 16, "--repeat", 1)
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    scene_names = [s["scene"] for s in report["scenes"]]
    assert scene_names == ["plume", "sparse", "soot"]
    cases = {r["case"] for r in report["scenes"][0]["results"]}
    assert {"cpu, all threads", "cpu, 1 thread", "reference (NumPy float64)"} <= cases
    for r in report["scenes"][0]["results"]:
        assert r["samples"] > 0 and r["ms_per_frame"] > 0 and r["samples_per_s"] > 0
    assert "cores" in report["cpu"]  # the CPU the figures belong to


def test_bench_fire_times_each_pressure_preconditioner_side_by_side():
    """`bench --fire 16`: the explosion at 16³ with the exact inverse (auto picks it: one
    pressure iteration a step) and the V-cycle (several), frames and steps timed."""
    result = _run("bench", "--json", "--fire", 16, "--repeat", 1)
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    rows = {r["preconditioner"]: r for r in report["fire"] if r["backend"] == "cpu"}
    assert set(rows) == {"auto: exact", "multigrid"}
    assert rows["auto: exact"]["pressure_iterations"] == [1]
    assert min(rows["multigrid"]["pressure_iterations"]) > 1
    for r in rows.values():
        assert r["cells"] == 16 and r["s_per_frame"] > 0 and r["ms_per_step"] > 0
        assert 1 <= min(r["steps_per_frame"]) and max(r["steps_per_frame"]) <= 4
    assert "cores" in report["cpu"]


@pytest.mark.parametrize(
    ("sizes", "message"), [("abc", "--fire 'abc': expected grid sizes"), ("8", "--fire 8: a grid")]
)
def test_bench_fire_refuses_a_size_it_cannot_run(sizes, message):
    result = _run("bench", "--fire", sizes)
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert message in " ".join(result.output.split())


def test_cpu_description_names_model_cores_and_widest_simd():
    from incandescent._parallel import workers
    from incandescent.benchmark import cpu_description

    zen3 = "model name\t: AMD EPYC 7B13\ncpu family\t: 25\nmodel\t\t: 1\nflags\t\t: fpu avx2 fma\n"
    text = cpu_description(zen3)
    assert text == f"AMD EPYC 7B13 (family 25 model 1), {workers()} cores, AVX2"
    assert cpu_description(zen3.replace("avx2", "avx2 avx512f")).endswith("AVX-512")


def test_help_documents_render_flags():
    text = " ".join(_run("render", "--help").output.split())
    for flag in (
        "--width",
        "--height",
        "--step",
        "--absorption",
        "--voxel-size",
        "--eye",
        "--target",
        "--fov",
        "--backend",
        "--exposure",
        "--stats",
        "--overwrite",
    ):
        assert flag in text


def test_demo_sphere_in_paper_mode(tmp_path):
    out = tmp_path / "sphere.png"
    result = _run(
        "demo",
        "sphere",
        "--brightness",
        "paper",
        "--width",
        24,
        "--height",
        24,
        "-o",
        out,
    )
    assert result.exit_code == 0, result.output
    image = np.asarray(Image.open(out))
    assert image[12, 12, 0] == 255  # the paper's saturation at the centre of the sphere


def test_demo_plate_writes_a_resumable_video(tmp_path):
    out = tmp_path / "plate.gif"
    args = ["demo", "plate", "--frames", 3, "--width", 32, "--height", 24, "-o", out]
    result = _run(*args)
    assert result.exit_code == 0, result.output
    assert Image.open(out).n_frames >= 1
    frames = sorted((tmp_path / "plate_frames").glob("frame_*.png"))
    assert len(frames) == 3
    frames[1].unlink()
    out.unlink()  # as after an interrupted run: the video is made last
    result = _run(*args)
    assert result.exit_code == 0, result.output
    assert "1 rendered, 2 reused" in " ".join(result.output.split())
    result = _run(*args, "--overwrite")  # renders every frame again
    assert result.exit_code == 0, result.output
    assert "3 rendered, 0 reused" in " ".join(result.output.split())


def test_temperature_range_maps_a_normalised_field(tmp_path):
    path = tmp_path / "norm.npy"
    np.save(path, np.full((4, 4, 4), 0.5))
    stats = tmp_path / "s.json"
    args = ["render", path, "-o", tmp_path / "n.exr", "--width", 4, "--height", 4]
    result = _run(*args, "--temperature-range", "1000:3000", "--stats", stats)
    assert result.exit_code == 0, result.output
    data = json.loads(stats.read_text())
    assert data["max_luminance_cd_m2"] > 0
    assert data["temperature"] == "grid 'temperature'; T = (raw − -0.5)·2000 K"  # the rule used
    bad = _run(*args, "--temperature-range", "3000:1000", "--overwrite")
    assert bad.exit_code == 2
    assert "range = [LOW, HIGH] needs 0 <= LOW < HIGH" in " ".join(bad.output.split())
    both = _run(*args, "--temperature-range", "0:1", "--scale", 2, "--overwrite")
    assert both.exit_code == 2
    assert "give range = [LOW, HIGH] or offset/scale, not both" in " ".join(both.output.split())


def test_animate_a_sequence_of_files_resumes(tmp_path):
    from incandescent.scenes import plume_temperature

    base = plume_temperature(12)
    for i in range(3):
        np.save(tmp_path / f"fire_{i:04d}.npy", base * (0.8 + 0.1 * i))
    out = tmp_path / "fire.gif"
    args = ["animate", str(tmp_path / "fire_####.npy"), "-o", out, "--width", 24, "--height", 16]
    result = _run(*args)
    assert result.exit_code == 0, result.output
    assert Image.open(out).n_frames == 3
    out.unlink()
    again = _run(*args)
    assert again.exit_code == 0, again.output
    assert "0 rendered, 3 reused" in " ".join(again.output.split())
    again = _run(*args, "--overwrite")
    assert again.exit_code == 0, again.output
    assert "3 rendered, 0 reused" in " ".join(again.output.split())
    missing = _run("animate", str(tmp_path / "nothing_*.npy"), "-o", tmp_path / "x.mp4")
    assert missing.exit_code == 2 and "no files match" in missing.output


def test_render_scene_file_with_flag_overrides(tmp_path):
    import shutil

    root = Path(__file__).resolve().parents[2] / "examples"
    for name in ("flame.toml", "flame.npz"):
        shutil.copy(root / name, tmp_path / name)
    result = _run("render", tmp_path / "flame.toml", "--width", 32, "--height", 48)
    assert result.exit_code == 0, result.output
    assert Image.open(tmp_path / "flame.png").size == (32, 48)  # [output] path, beside the file
    exr = tmp_path / "flame.exr"
    result = _run("render", tmp_path / "flame.toml", "-o", exr, "--width", 8, "--height", 8)
    assert result.exit_code == 0, result.output
    assert read_exr(exr)[0].shape == (8, 8, 3)


def test_scene_file_errors_name_the_key(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text('[volume]\npath = "v.npy"\n[render]\nwidht = 3\n')
    result = _run("render", scene)
    assert result.exit_code == 2
    text = " ".join(result.output.split())
    assert "render.widht: unknown key 'widht'; did you mean 'width'?" in text


def test_render_a_blender_fire_vdb_with_the_blender_preset(tmp_path):
    pytest.importorskip("tinyvdb")
    cache = Path(__file__).resolve().parents[1] / "data" / "blender_fire_0010.vdb"
    out, stats = tmp_path / "fire.exr", tmp_path / "s.json"
    result = _run(
        "render",
        cache,
        "--preset",
        "blender",
        "-o",
        out,
        "--width",
        24,
        "--height",
        32,
        "--stats",
        stats,
    )
    assert result.exit_code == 0, result.output
    rgb = read_exr(out)[0]
    assert np.isfinite(rgb).all() and rgb.max() > 0
    absorption = json.loads(stats.read_text())["absorption"]  # κ from Blender's density, named
    assert absorption.startswith("grid (preset blender") and "κ = 1 1/m · 'density'" in absorption


def test_info_lists_grids_and_warns_when_temperature_is_not_kelvin(tmp_path):
    path = tmp_path / "g.npz"
    np.savez(path, temperature=np.linspace(0, 2, 8).reshape(2, 2, 2), density=np.ones((2, 2, 2)))
    result = _run("info", path)
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "temperature" in text and "density" in text and "(2, 2, 2)" in text
    assert "grid 'temperature' has max 2 < 300: probably not kelvin" in text
    assert _run("info", tmp_path / "none.vdb").exit_code == 2


def test_info_on_a_blender_vdb_names_unreadable_grids(monkeypatch):
    """Through tinyvdb (OpenVDB switched off) the vector grid cannot be read, and info says so."""
    pytest.importorskip("tinyvdb")
    from incandescent.io import openvdb

    monkeypatch.setattr(openvdb, "interpreter", lambda: None)
    cache = Path(__file__).resolve().parents[1] / "data" / "blender_fire_0010.vdb"
    text = " ".join(_run("info", cache).output.split())
    assert "flame" in text and "0.9844" in text
    assert "velocity: cannot be read: holds vec3s values" in text


def test_info_on_a_blender_vdb_through_openvdb_reads_every_grid():
    from incandescent.io import openvdb

    if openvdb.problem():
        pytest.skip(openvdb.problem())
    cache = Path(__file__).resolve().parents[1] / "data" / "blender_fire_0010.vdb"
    result = _run("info", cache)
    text = " ".join(result.output.split())
    assert result.exit_code == 0 and "cannot be read" not in text
    assert "velocity │ vec3s" in text and "density │ float" in text


def test_render_hdf5_with_declared_axis_order(tmp_path):
    h5py = pytest.importorskip("h5py")
    temp = np.full((4, 6, 8), 300.0)
    temp[1:3, 2:4, 3:5] = 2200.0
    path = tmp_path / "cfd.h5"
    with h5py.File(path, "w") as f:
        f["fields/temperature"] = np.transpose(temp, (2, 1, 0))  # stored z, y, x as CFD codes do
    info = " ".join(_run("info", path, "--axes", "zyx").output.split())
    assert "fields/temperature" in info and "(4, 6, 8)" in info
    out = tmp_path / "cfd.exr"
    result = _run("render", path, "--axes", "zyx", "-o", out, "--width", 8, "--height", 8)
    assert result.exit_code == 0, result.output
    assert read_exr(out)[0].max() > 0


def test_render_with_species_fractions_and_grids(tmp_path):
    temp = np.full((6, 6, 6), 1900.0)
    lithium = np.zeros_like(temp)
    lithium[2:4, 2:4, 2:4] = 0.5
    path = tmp_path / "coloured.npz"
    np.savez(path, temperature=temp, lithium=lithium)
    stats = tmp_path / "s.json"
    base = ["render", path, "--width", 6, "--height", 6, "--absorption", 0.0]
    plain = _run(*base, "-o", tmp_path / "plain.exr")
    assert plain.exit_code == 0, plain.output
    lit = _run(
        *base, "-o", tmp_path / "lit.exr", "--species", "Na=0.05,Li=lithium", "--stats", stats
    )
    assert lit.exit_code == 0, lit.output
    assert read_exr(tmp_path / "plain.exr")[0].max() == 0  # κ = 0: no continuum
    assert read_exr(tmp_path / "lit.exr")[0].max() > 0  # the lines alone glow
    bad = _run(*base, "-o", tmp_path / "b.exr", "--species", "Na")
    assert bad.exit_code == 2 and "NAME=FRACTION or NAME=GRID" in bad.output


@pytest.mark.parametrize("name", ["sodium", "copper", "clean"])
def test_species_demos_render(tmp_path, name):
    out = tmp_path / f"{name}.png"
    result = _run("demo", name, "--size", 24, "--width", 16, "--height", 24, "-o", out)
    assert result.exit_code == 0, result.output
    assert np.asarray(Image.open(out)).max() > 50


def test_animate_with_an_orbiting_camera(tmp_path):
    from incandescent.scenes import plume_temperature

    for i in range(2):
        np.save(tmp_path / f"f_{i}.npy", plume_temperature(12))
    out = tmp_path / "orbit"
    args = ["animate", str(tmp_path / "f_*.npy"), "-o", out, "--width", 16, "--height", 16]
    result = _run(*args, "--orbit", 90)
    assert result.exit_code == 0, result.output
    first, second = (np.asarray(Image.open(p)) for p in sorted(out.glob("frame_*.png")))
    assert not np.array_equal(first, second)  # same volume, camera moved


def test_animate_takes_species_like_render(tmp_path):
    from incandescent.scenes import plume_temperature

    for i in (1, 2):
        np.save(tmp_path / f"f_{i:04d}.npy", plume_temperature(10) * (0.9 + 0.1 * i))
    args = ("animate", tmp_path / "f_####.npy", "--width", 12, "--height", 8)
    assert _run(*args, "-o", tmp_path / "plain").exit_code == 0
    coloured = _run(*args, "-o", tmp_path / "na", "--species", "Na=0.5")
    assert coloured.exit_code == 0, coloured.output
    plain_px = np.asarray(Image.open(tmp_path / "plain" / "frame_00001.png"), dtype=float)
    na_px = np.asarray(Image.open(tmp_path / "na" / "frame_00001.png"), dtype=float)
    assert not np.array_equal(plain_px, na_px)  # the sodium lines changed the frames


def test_help_keeps_the_defaults_in_brackets():
    """Rich markup used to eat "[temperature, heat, temp or T]"-like defaults from the help."""
    text = " ".join(_run("render", "--help").output.split())
    for default in ("[temperature, heat, temp or T]", "[preset's, else y]", "[shipped]", "[xyz]"):
        assert default in text, default


def test_bench_cold_frames_render_the_same_samples_as_warm():
    args = ("bench", "--json", "--size", 16, "--resolution", 16, "--repeat", 1, "--scenes", "soot")
    result = _run(*args, "--cold", "--no-reference")
    assert result.exit_code == 0, result.output
    cases = {r["case"]: r for r in json.loads(result.stdout)["scenes"][0]["results"]}
    cold = cases["cpu, all threads, cold (a new volume each frame)"]
    assert cold["samples"] == cases["cpu, all threads"]["samples"] > 0


def test_a_backend_that_cannot_run_is_refused_before_the_volume_is_read(tmp_path):
    """`render` loads its backend before reading the volume (a .vdb's OpenVDB worker starts
    meanwhile): a backend that cannot run fails first, naming itself, not the file."""
    from incandescent._jit import cuda_problem

    if cuda_problem() is None:
        pytest.skip("a CUDA GPU is present: the cuda backend can run")
    unreadable = tmp_path / "volume.npz"
    unreadable.write_bytes(b"not a zip archive")
    result = _run("render", unreadable, "-o", tmp_path / "out.exr", "--backend", "cuda")
    assert result.exit_code != 0
    assert "backend 'cuda' is unavailable" in result.output and "not a zip" not in result.output


def test_animate_lets_frames_reuse_freed_memory(tmp_path, monkeypatch):
    """`animate` renders a sequence in this process: it keeps freed frame buffers for the next
    frame (``animation.keep_frame_memory``; what that does: tests/animation/test_read_ahead.py)."""
    from incandescent import animation
    from incandescent.scenes import plume_temperature

    calls = []
    monkeypatch.setattr(animation, "keep_frame_memory", lambda: calls.append(1) or True)
    for i in range(2):
        np.save(tmp_path / f"f_{i}.npy", plume_temperature(12))
    args = ["animate", str(tmp_path / "f_*.npy"), "-o", tmp_path / "out", "--width", 16]
    result = _run(*args, "--height", 16)
    assert result.exit_code == 0, result.output
    assert calls == [1]


@pytest.mark.parametrize("terminal", [True, False])
def test_render_progress_bar_only_on_a_terminal(monkeypatch, terminal):
    """On a terminal the render shows a transient bar; elsewhere the report is a no-op, nothing
    is written and rich's progress module is not imported (made unimportable here)."""
    import io
    import sys

    from rich.console import Console

    from incandescent import cli

    out = io.StringIO()
    monkeypatch.setattr(cli, "console", Console(file=out, force_terminal=terminal, width=60))
    if not terminal:
        monkeypatch.setitem(sys.modules, "rich.progress", None)  # importing it raises
    with cli._render_progress() as report:
        for fraction in (0.25, 1.0):
            report(fraction)
    assert ("rendering" in out.getvalue()) is terminal


def test_bench_resolution_is_a_deprecated_alias_of_pixels(monkeypatch):
    """`bench --resolution` meant image pixels while `simulate --resolution` means cells: bench
    says --pixels now, and the old spelling still works for a release, with one warning."""
    from incandescent import benchmark

    seen = []
    monkeypatch.setattr(
        benchmark, "run", lambda scenes, size, pixels, *a, **k: seen.append(pixels) or {}
    )
    result = _run("bench", "--json", "--resolution", 24)
    assert result.exit_code == 0, result.output
    warned = [line for line in result.output.splitlines() if "deprecated" in line]
    assert len(warned) == 1 and "--pixels" in warned[0]
    assert _run("bench", "--json", "--pixels", 32).exit_code == 0
    assert _run("bench", "--json").exit_code == 0
    assert seen == [24, 32, 512]
    clash = _run("bench", "--pixels", 16, "--resolution", 24)
    assert clash.exit_code == 2 and "disagree" in clash.output
    assert "--resolution" not in _run("bench", "--help").output  # hidden: --pixels is documented


def test_every_flag_sets_a_key_of_the_scene_schema():
    """The flag → scene map is the flags' keys: each names a field of the pydantic schema, and
    one option name means one key in every command."""
    from typer.main import get_command

    from incandescent.cli import flags
    from incandescent.config.schema import Scene
    from incandescent.renderer.integrators import INTEGRATORS

    keys: dict[str, set] = {}
    for name in ("RENDER", "DEMO", "INFO", "CONVERT", "ANIMATE", "SIMULATE", "BENCH"):
        for flag in flags._flat(getattr(flags, name)):
            if flag.key is None:
                continue
            keys.setdefault(flag.name, set()).add(flag.key)
            section, *parts = flag.key.split(".")
            model = Scene.model_fields[section].annotation
            optional = [kind for kind in typing.get_args(model) if kind is not type(None)]
            model = optional[0] if optional else model  # an optional section: ``[sensor]``
            if section == "integrator" and parts != ["type"]:  # a parameter of an integrator
                assert any(hasattr(kind, parts[0]) for kind in INTEGRATORS.values())
                continue
            for part in parts:
                assert part in model.model_fields, (flag.name, flag.key)
                model = model.model_fields[part].annotation
    assert all(len(found) == 1 for found in keys.values()), keys
    assert set(get_command(app).commands) >= {"render", "animate", "bench"}


def test_animate_takes_a_scene_file_with_flags_over_it(tmp_path):
    """`animate scene.toml`: its [volume] path is the sequence (a #### pattern, relative to the
    file), its sections apply as in `render`, and flags override them."""
    from incandescent.scenes import plume_temperature

    base = plume_temperature(12)
    for i in range(3):
        np.save(tmp_path / f"fire_{i:04d}.npy", base * (0.8 + 0.1 * i))
    scene = tmp_path / "fire.toml"
    scene.write_text(
        '[volume]\npath = "fire_####.npy"\n[render]\nwidth = 20\nheight = 14\n'
        '[display]\ntonemap = "reinhard"\n',
        encoding="utf-8",
    )
    out = tmp_path / "frames"
    result = _run("animate", scene, "-o", out)
    assert result.exit_code == 0, result.output
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == 3 and Image.open(frames[0]).size == (20, 14)
    result = _run("animate", scene, "-o", tmp_path / "wide", "--width", 28)
    assert result.exit_code == 0, result.output
    assert Image.open(tmp_path / "wide" / "frame_00000.png").size == (28, 14)
    again = _run("animate", scene, "-o", out)
    assert "0 rendered, 3 reused" in " ".join(again.output.split())


def test_animate_of_a_scene_without_frame_size_makes_video_frames(tmp_path):
    """A scene (or pattern) that sets no frame size gets animate's video size, 640×360 scaled
    down here by one flag only: the other side stays the video default."""
    from incandescent.scenes import plume_temperature

    for i in range(2):
        np.save(tmp_path / f"f_{i}.npy", plume_temperature(10))
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps({"volume": {"path": "f_*.npy"}}), encoding="utf-8")
    result = _run("animate", scene, "-o", tmp_path / "out", "--height", 9, "--step", 2)
    assert result.exit_code == 0, result.output
    assert Image.open(tmp_path / "out" / "frame_00001.png").size == (640, 9)
