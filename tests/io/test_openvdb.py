"""Reading ``.vdb`` with OpenVDB itself (io.openvdb, the worker under the system Python): files
made here by pyopenvdb — active tiles at both internal tree levels, half floats, vec3s, grids with
different boxes — and the real Blender cache read exactly as OpenVDB reads them; corrupt files are
clear errors and the worker comes back. Skipped, with the reason, where python3-openvdb is absent
(``scripts/setup.sh`` installs it, so CI runs these)."""

from __future__ import annotations

import json
import os
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

from incandescent.io import openvdb, vdb

pytestmark = pytest.mark.skipif(openvdb.problem() is not None, reason=str(openvdb.problem()))

# The libopenvdb reference files of test_vdb.py, read here through OpenVDB instead of tinyvdb:
# the same expectations hold (values, boxes, backgrounds, placement, half floats).
from test_vdb import (  # noqa: E402, F401
    test_half_float_file_reads_the_same_values,
    test_list_grids_reports_names_boxes_transform_and_ranges,
    test_read_grid_values_origin_and_axis_order_match_openvdb,
    test_read_grids_share_one_box_filled_with_each_background,
)

DATA = Path(__file__).parents[1] / "data"
BLENDER = DATA / "blender_fire_0010.vdb"


def _system_python(script: str) -> str:
    """Run ``script`` under the interpreter that has pyopenvdb; its stdout."""
    python = openvdb.interpreter()
    assert python is not None
    done = subprocess.run(
        [python, "-c", textwrap.dedent(script)],
        env=openvdb._clean_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.fixture(scope="module")
def tiled(tmp_path_factory) -> Path:
    """A float grid with a 128³ tile (upper internal level), an 8³ tile (lower internal level)
    and three leaf voxels, pruned, voxel 0.1 m, translated; saved as half floats."""
    path = tmp_path_factory.mktemp("vdb") / "tiled.vdb"
    _system_python(f"""
        import pyopenvdb as vdb
        g = vdb.FloatGrid(background=0.25)
        g.name = "density"
        g.fill((0, 0, 0), (127, 127, 127), 2.0)      # one tile of an upper internal node
        g.fill((128, 0, 0), (135, 7, 7), 3.0)        # one tile of a lower internal node
        a = g.getAccessor()
        for ijk, v in (((130, 20, 5), 0.5), ((140, 3, 3), 1.5), ((-1, 2, 3), 4.0)):
            a.setValueOn(ijk, v)
        g.prune()
        g.transform = vdb.createLinearTransform(voxelSize=0.1)
        g.transform.translate((1.0, -2.0, 0.5))
        g.saveFloatAsHalf = True
        v = vdb.Vec3SGrid()
        v.name = "velocity"
        v.fill((2, 3, 4), (9, 10, 11), (1.0, -2.0, 0.5))
        v.transform = g.transform
        vdb.write("{path}", grids=[g, v])
        print(g.activeVoxelCount(), g.leafCount())
    """)
    return path


def test_tiles_at_both_internal_levels_read_as_openvdb_stores_them(tiled):
    info = {i.name: i for i in vdb.list_grids(tiled)}["density"]
    assert info.active_voxels == 128**3 + 8**3 + 3
    assert (info.index_min, info.index_max) == ((-1, 0, 0), (140, 127, 127))
    grid = vdb.read_grid(tiled, "density", max_voxels=200**3)
    values = grid.values
    assert values.shape == (142, 128, 128) and values.dtype == np.float32
    lo = np.array(grid.index_min)
    expected = np.full(values.shape, 0.25, np.float32)
    expected[0 - lo[0] : 128 - lo[0], :, :] = 2.0
    expected[128 - lo[0] : 136 - lo[0], 0:8, 0:8] = 3.0
    for (i, j, k), v in (((130, 20, 5), 0.5), ((140, 3, 3), 1.5), ((-1, 2, 3), 4.0)):
        expected[i - lo[0], j, k] = v
    np.testing.assert_array_equal(values, expected)  # half floats of these values are exact
    assert info.half_float is True and info.compression.startswith("blosc")


def test_placement_follows_the_file_transform(tiled):
    grid = vdb.read_grid(tiled, "density", max_voxels=200**3)
    assert grid.voxel_size_m == pytest.approx(0.1)
    # voxel centres at integer index coordinates: the corner of voxel (-1, 0, 0) is at
    # translation + (index − 0.5)·voxel
    np.testing.assert_allclose(grid.origin_m, (1.0 - 0.15, -2.0 - 0.05, 0.5 - 0.05), atol=1e-12)


def test_vector_grids_read_as_three_components(tiled):
    grid = vdb.read_grid(tiled, "velocity")
    assert grid.values.shape == (8, 8, 8, 3)
    np.testing.assert_array_equal(grid.values, np.broadcast_to([1.0, -2.0, 0.5], (8, 8, 8, 3)))
    info = {i.name: i for i in vdb.list_grids(tiled)}["velocity"]
    assert info.value_max == pytest.approx(np.sqrt(1 + 4 + 0.25), rel=1e-6)  # the magnitude


def test_grids_with_different_boxes_share_the_union_box(tiled):
    both = vdb.read_grids(tiled, ["density", "velocity"], max_voxels=200**3)
    assert both["density"].values.shape[:3] == both["velocity"].values.shape[:3]
    assert both["velocity"].values[:, 60, 60].tolist() == [[0.0, 0.0, 0.0]] * 142  # background


def _openvdb_totals(path: Path) -> dict:
    """Active count and sum of active values per float grid, as OpenVDB computes them."""
    out = _system_python(f"""
        import json, pyopenvdb as vdb
        totals = {{}}
        for meta in vdb.readAllGridMetadata("{path}"):
            if meta.valueTypeName != "float":
                continue
            g = vdb.read("{path}", meta.name)
            s = sum(item["value"] * item["count"] for item in g.citerOnValues())
            totals[meta.name] = [g.activeVoxelCount(), s]
        print(json.dumps(totals))
    """)
    return json.loads(out)


def test_the_blender_cache_reads_every_grid_as_openvdb_does():
    """tinyvdb dropped the active tiles of density, temperature and shadow (41 % of density's
    active voxels); OpenVDB reads them all."""
    totals = _openvdb_totals(BLENDER)
    infos = {i.name: i for i in vdb.list_grids(BLENDER)}
    assert all(info.unreadable is None for info in infos.values()), infos
    for name, (count, total) in totals.items():
        info = infos[name]
        assert info.active_voxels == count
        grid = vdb.read_grid(BLENDER, name)
        box_sum = float(grid.values.astype(np.float64).sum())
        inactive = grid.values.size - count  # background-filled voxels of the box
        np.testing.assert_allclose(box_sum - inactive * grid.background, total, rtol=1e-5)


@pytest.mark.parametrize("cut", [0.3, 0.7])
def test_truncated_files_are_clear_errors_and_the_worker_comes_back(tmp_path, tiled, cut):
    data = tiled.read_bytes()
    bad = tmp_path / "cut.vdb"
    bad.write_bytes(data[: int(len(data) * cut)])
    with pytest.raises(ValueError, match="cut.vdb"):
        vdb.read_grid(bad, "density", max_voxels=200**3)
    assert vdb.read_grid(tiled, "velocity").values.shape == (8, 8, 8, 3)  # worker alive again


def test_a_killed_worker_is_replaced(tiled):
    vdb.list_grids(tiled)
    for worker in openvdb._WORKERS.values():
        worker.process.kill()
        worker.process.wait()
    openvdb._DESCRIBED.clear()  # ask the worker again, not the remembered description
    assert {i.name for i in vdb.list_grids(tiled)} == {"density", "velocity"}


def test_a_description_is_remembered_until_the_file_changes(tiled, tmp_path, monkeypatch):
    """A render describes its file three times (open, extent, read); OpenVDB reads it once."""
    copy = tmp_path / "copy.vdb"
    copy.write_bytes(tiled.read_bytes())
    asked = []
    real_ask = openvdb.ask
    monkeypatch.setattr(
        openvdb, "ask", lambda path, request: asked.append(request) or real_ask(path, request)
    )
    first = vdb.list_grids(copy, ranges=False)
    assert vdb.list_grids(copy, ranges=False) == first and len(asked) == 1
    vdb.list_grids(copy)  # other options: asked
    assert len(asked) == 2
    os.utime(copy, ns=(copy.stat().st_atime_ns, copy.stat().st_mtime_ns + 10**9))
    assert vdb.list_grids(copy, ranges=False) == first and len(asked) == 3  # changed: asked


def test_finding_the_interpreter_starts_the_worker_reads_use(monkeypatch):
    """No separate probe process: the worker that answered is kept for the reads."""
    python = openvdb.interpreter()
    openvdb.interpreter.cache_clear()
    for worker in openvdb._WORKERS.values():
        worker.close()
    openvdb._WORKERS.clear()
    assert openvdb.interpreter() == python
    assert openvdb._WORKERS[python].process.poll() is None  # running, ready for requests
    openvdb.interpreter.cache_clear()
    monkeypatch.setenv(openvdb.ENV_VAR, "/bin/true")  # starts, never says it is ready
    assert openvdb.interpreter() is None
    openvdb.interpreter.cache_clear()
    monkeypatch.delenv(openvdb.ENV_VAR)
    assert openvdb.interpreter() == python


def test_info_json_agrees_with_openvdb():
    from typer.testing import CliRunner

    from incandescent.cli import app

    result = CliRunner().invoke(app, ["info", "--json", str(BLENDER)])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    grids = {g["name"]: g for g in report["grids"]}
    for name, (count, total) in _openvdb_totals(BLENDER).items():
        assert grids[name]["active_voxels"] == count and grids[name]["readable"]
        assert grids[name]["sum"] == pytest.approx(total, rel=1e-9)
    velocity = grids["velocity"]
    assert velocity["type"] == "vec3s" and velocity["sum"] is None and velocity["max"] > 0
    assert any("--preset blender" in w for w in report["warnings"])


def _cli(*args):
    from typer.testing import CliRunner

    from incandescent.cli import app

    return CliRunner().invoke(app, [str(a) for a in args])


def test_convert_writes_a_vdb_that_openvdb_reads_back_identically(tmp_path):
    from incandescent.scenes import plume_temperature

    temp = plume_temperature(20)
    np.savez(tmp_path / "in.npz", temperature=temp, absorption=np.where(temp > 600, 2.0, 0.0))
    out = tmp_path / "out.vdb"
    result = _cli("convert", tmp_path / "in.npz", out)
    assert result.exit_code == 0, result.output
    described = {g["name"]: g for g in openvdb.describe(out)}
    assert described["temperature"]["metadata"]["unit"] == "kelvin"
    assert described["absorption"]["metadata"]["unit"] == "1/m"
    back = vdb.read_grids(out, ["temperature", "absorption"])
    lo = back["temperature"].index_min
    hi = tuple(i + n for i, n in zip(lo, back["temperature"].values.shape, strict=True))
    np.testing.assert_array_equal(
        back["temperature"].values, temp[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]]
    )
    assert _cli("convert", tmp_path / "in.npz", out).exit_code == 2  # exists: refused


def test_a_converted_blender_cache_renders_the_same_image(tmp_path):
    from incandescent import api
    from incandescent.config import VolumeSection
    from incandescent.renderer import RenderSettings

    direct = api.volume_from_section(VolumeSection(path=BLENDER, preset="blender"), api.Remap())
    assert _cli("convert", BLENDER, tmp_path / "c.vdb", "--preset", "blender").exit_code == 0
    assert _cli("convert", tmp_path / "c.vdb", tmp_path / "c.npz").exit_code == 0
    again = api.load_volume(tmp_path / "c.npz")
    camera = api.camera_from(direct)
    s = RenderSettings(width=48, height=40)
    a, b = (api.render(v, camera, s, "cpu") for v in (direct, again))
    np.testing.assert_array_equal(a.xyz, b.xyz)
    assert a.metadata["samples"] == b.metadata["samples"]


def test_animate_takes_the_volume_options_render_takes(tmp_path):
    """A Blender cache sequence animates from the command line (--preset, --up-axis)."""
    import shutil

    for i in (1, 2):
        shutil.copy(BLENDER, tmp_path / f"fire_{i:04d}.vdb")
    out = tmp_path / "fire.gif"
    args = ("animate", tmp_path / "fire_####.vdb", "-o", out, "--width", 24, "--height", 16)
    result = _cli(*args, "--preset", "blender", "--up-axis", "z")
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 0


FIRE_SMOKE = DATA / "blender_fire_smoke_0012.vdb"


def test_a_fire_and_smoke_cache_reads_and_renders_with_kappa_from_density(tmp_path):
    """A Blender fire + smoke bake (half floats, Blosc, shadow all tiles): info --json agrees
    with OpenVDB, and render --preset blender takes κ from the density grid and says so."""
    report = json.loads(_cli("info", "--json", FIRE_SMOKE).stdout)
    grids = {g["name"]: g for g in report["grids"]}
    for name, (count, total) in _openvdb_totals(FIRE_SMOKE).items():
        assert grids[name]["active_voxels"] == count and grids[name]["readable"]
        assert grids[name]["sum"] == pytest.approx(total, rel=1e-9)
    assert grids["shadow"]["active_voxels"] == 65536  # all of them active tiles
    stats = tmp_path / "s.json"
    args = ("render", FIRE_SMOKE, "-o", tmp_path / "f.png", "--width", 32, "--height", 48)
    result = _cli(*args, "--preset", "blender", "--stats", stats)
    assert result.exit_code == 0, result.output
    data = json.loads(stats.read_text())
    assert "κ = 1 1/m · 'density'" in data["absorption"]
    assert "T = 1000 K · (1.5 + 'flame'" in data["temperature"]  # the rule that gave T


def test_without_openvdb_the_tiled_grid_says_how_to_install_it(monkeypatch):
    monkeypatch.setattr(openvdb, "interpreter", lambda: None)
    shadow = {i.name: i for i in vdb.list_grids(FIRE_SMOKE)}["shadow"]
    assert "active tiles" in shadow.unreadable and "python3-openvdb" in shadow.unreadable


@pytest.mark.parametrize("codec", ["zip", "none"])
def test_blosc_zip_and_uncompressed_bakes_read_the_same_voxels(codec):
    names = ["density", "flame", "temperature", "velocity"]
    blosc = vdb.read_grids(DATA / "blender_fire_smoke_blosc_0004.vdb", names)
    other = vdb.read_grids(DATA / f"blender_fire_smoke_{codec}_0004.vdb", names)
    for name in names:
        np.testing.assert_array_equal(other[name].values, blosc[name].values)
        assert other[name].values.any()


def test_other_value_types_are_listed_with_a_note():
    infos = {i.name: i for i in vdb.list_grids(DATA / "openvdb_types.vdb")}
    assert "bool values (a mask)" in infos["mask"].unreadable
    assert infos["velocity"].unreadable is None and infos["empty"].active_voxels == 0


@pytest.mark.parametrize(
    "section",
    [
        {"path": BLENDER, "preset": "blender"},  # z-up, turned by the leaf reader
        {"path": FIRE_SMOKE, "preset": "blender"},  # κ from the density grid
    ],
    ids=["blender fire", "blender fire+smoke"],
)
def test_a_cache_read_as_leaves_renders_the_dense_read_image(section):
    """Leaves straight from OpenVDB (never densified) give the dense read's volume and image."""
    from incandescent import api
    from incandescent.config import VolumeSection
    from incandescent.renderer import RenderSettings
    from incandescent.volume.sparse import SparseVolume

    spec = VolumeSection(**section)
    dense = api.volume_from_section(spec, api.Remap(), layout="dense")
    leaves = api.volume_from_section(spec, api.Remap(), layout="sparse")
    assert isinstance(leaves, SparseVolume) and not isinstance(dense, SparseVolume)
    assert leaves.shape == dense.shape and leaves.voxel_size_m == dense.voxel_size_m
    np.testing.assert_allclose(leaves.origin_m, dense.origin_m, rtol=0, atol=1e-12)
    back = leaves.to_dense()
    kept = back.temperature_K > 0
    np.testing.assert_array_equal(back.absorption_per_m, dense.absorption_per_m)
    np.testing.assert_array_equal(back.temperature_K[kept], dense.temperature_K[kept])
    camera = api.camera_from(dense)
    s = RenderSettings(width=40, height=48)
    images = [api.render(v, camera, s.replace(layout=lay), "cpu")
              for v in (dense, leaves) for lay in ("dense", "sparse")]  # fmt: skip
    assert images[0].xyz.max() > 0
    for image in images[1:]:
        np.testing.assert_array_equal(image.xyz, images[0].xyz)
        assert image.metadata["samples"] == images[0].metadata["samples"]


def test_a_background_that_absorbs_is_not_read_as_leaves(tiled):
    """The tiled grid's background (0.25) is density that absorbs everywhere: not sparse."""
    from incandescent import api
    from incandescent.config import GridNames, VolumeSection

    spec = VolumeSection(path=tiled, grids=GridNames(temperature="density", absorption="density"))
    with pytest.raises(ValueError, match=r"background values absorb \(κ = 0.25 1/m\)"):
        api.volume_from_section(spec, api.Remap(scale=1000.0), layout="sparse")


def test_a_cache_bigger_than_any_dense_box_reads_sparse_and_renders(tmp_path):
    """Two small hot blobs 560 voxels apart: a 608³ box (over the old 512³ dense guard, 0.9 GB
    per dense float grid) read as its few leaves by default, and rendered."""
    from incandescent import api
    from incandescent.renderer import RenderSettings
    from incandescent.volume.sparse import SparseVolume

    path = tmp_path / "far.vdb"
    _system_python(f"""
        import pyopenvdb as vdb
        g = vdb.FloatGrid()
        g.name = "temperature"
        g.fill((0, 0, 0), (23, 23, 23), 1800.0)
        g.fill((584, 584, 584), (607, 607, 607), 1500.0)
        g.transform = vdb.createLinearTransform(voxelSize=0.01)
        vdb.write("{path}", grids=[g])
    """)
    volume = api.load_volume(path)
    assert isinstance(volume, SparseVolume)
    assert (
        volume.shape == (608, 608, 608) and len(volume.leaf_coords) == 2 * 4**3
    )  # 3³ + a ring each
    image = api.render(volume, None, RenderSettings(width=64, height=64), "cpu")
    assert image.metadata["layout"] == "sparse" and image.xyz.max() > 0


def test_a_volume_with_velocity_writes_a_vec3_grid_openvdb_reads_back(tmp_path):
    """save_volume to .vdb carries the velocity as a vec3s grid (what simulate --format vdb
    writes, and what Blender reads for motion blur)."""
    from incandescent import api

    rng = np.random.default_rng(2)
    temp = np.where(rng.random((6, 5, 4)) > 0.5, 1500.0, 0.0)
    velocity = rng.standard_normal((6, 5, 4, 3)).astype(np.float32)
    volume = api.Volume.from_arrays(temp, velocity_m_s=velocity)
    path = api.save_volume(volume, tmp_path / "v.vdb")
    infos = {g.name: g for g in vdb.list_grids(path)}
    assert infos["velocity"].value_type == "vec3s"
    box = infos["velocity"]
    back = openvdb.dense(path, ["velocity"], box.index_min, box.index_max)["velocity"]
    lo = np.asarray(box.index_min)
    hi = np.asarray(box.index_max) + 1
    np.testing.assert_array_equal(back, velocity[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]])


def test_a_blurred_cache_read_as_leaves_renders_the_dense_read_image():
    """With a shutter, the leaf reader keeps the velocity of every leaf within a frame's travel
    of the gas (from the file's largest speed), so sparse equals dense with motion blur too."""
    from incandescent import api
    from incandescent.config import VolumeSection
    from incandescent.renderer import RenderSettings
    from incandescent.volume.sparse import SparseVolume

    spec = VolumeSection(path=FIRE_SMOKE, preset="blender", velocity_scale=0.05)
    fps = 24.0
    dense = api.volume_from_section(spec, api.Remap(), layout="dense", blur_fps=fps)
    leaves = api.volume_from_section(spec, api.Remap(), layout="sparse", blur_fps=fps)
    assert isinstance(leaves, SparseVolume) and leaves.velocity_m_s is not None
    assert leaves.max_speed_m_s == pytest.approx(dense.max_speed_m_s)
    camera = api.camera_from(dense)
    s = RenderSettings(width=32, height=40, supersample=2, shutter=(-0.5, 0.5), fps=fps)
    images = [api.render(v, camera, s.replace(layout=lay), "cpu")
              for v, lay in ((dense, "dense"), (leaves, "sparse"))]  # fmt: skip
    sharp = api.render(dense, camera, s.replace(shutter=None), "cpu")
    assert np.abs(images[0].xyz - sharp.xyz).max() > 0.01 * sharp.xyz.max()  # it does blur
    np.testing.assert_array_equal(images[1].xyz, images[0].xyz)
    assert images[1].metadata["samples"] == images[0].metadata["samples"]
