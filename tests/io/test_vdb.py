"""OpenVDB / NanoVDB input through tinyvdb (io.vdb): the reader used where OpenVDB itself is not
installed, and always for NanoVDB. Reference files from libopenvdb, files written by tinyvdb, a
real Blender Mantaflow fire cache, an error battery and a bounded fuzz of the reader. OpenVDB's
own reader (the default where installed) is tested in tests/io/test_openvdb.py."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

tinyvdb = pytest.importorskip("tinyvdb")

from incandescent.io import openvdb, vdb  # noqa: E402


@pytest.fixture(autouse=True)
def _tinyvdb_only(monkeypatch):
    """This file is tinyvdb's contract: OpenVDB, where installed, is switched off."""
    monkeypatch.setattr(openvdb, "interpreter", lambda: None)


DATA = Path(__file__).parents[1] / "data"
TWO_GRIDS = DATA / "openvdb_two_grids.vdb"
BLENDER = DATA / "blender_fire_0010.vdb"
VOXEL = 0.25
TRANSLATION = np.array([1.0, -2.0, 0.5])
TEMPERATURE_BOX = ((-3, 5, 10), (1, 10, 16))
DENSITY_BOX = ((0, 4, 12), (6, 8, 20))


def pattern(lo, hi) -> np.ndarray:
    """The values make_reference_vdbs.py stored: i + 10 j + 12.5 k over [lo, hi] inclusive."""
    axes = (np.arange(a, b + 1) for a, b in zip(lo, hi, strict=True))
    i, j, k = np.meshgrid(*axes, indexing="ij")
    return (i + 10.0 * j + 12.5 * k).astype(np.float32)


def corner(index_min) -> tuple[float, ...]:
    """World corner of voxel ``index_min``: voxel centres sit at integer index coordinates."""
    return tuple(TRANSLATION + (np.asarray(index_min) - 0.5) * VOXEL)


# ------------------------------------------------------------------ files written by libopenvdb


def test_list_grids_reports_names_boxes_transform_and_ranges():
    infos = {info.name: info for info in vdb.list_grids(TWO_GRIDS)}
    assert set(infos) == {"temperature", "density"}
    t = infos["temperature"]
    assert (t.value_type, t.active_voxels) == ("float", 5 * 6 * 7)
    assert (t.index_min, t.index_max, t.shape) == (*TEMPERATURE_BOX, (5, 6, 7))
    assert t.voxel_size_m == (VOXEL,) * 3 and t.translation_m == tuple(TRANSLATION)
    matrix = np.asarray(t.index_to_world)
    np.testing.assert_array_equal(matrix @ [2, 0, 4, 1], [1.5, -2.0, 1.5, 1.0])
    assert (t.value_min, t.value_max, t.background) == (172.0, 301.0, 7.5)
    assert t.compression == "blosc + active values" and t.unreadable is None
    assert infos["density"].shape == (7, 5, 9) and infos["density"].background == 0.0


def test_read_grid_values_origin_and_axis_order_match_openvdb():
    grid = vdb.read_grid(TWO_GRIDS, "temperature")
    assert grid.values.dtype == np.float32 and grid.values.shape == (5, 6, 7)
    np.testing.assert_array_equal(grid.values, pattern(*TEMPERATURE_BOX))
    assert grid.index_min == TEMPERATURE_BOX[0] and grid.voxel_size_m == VOXEL
    assert grid.origin_m == corner(TEMPERATURE_BOX[0])
    assert grid.background == 7.5 and grid.source.endswith("openvdb_two_grids.vdb:temperature")


def test_read_grids_share_one_box_filled_with_each_background():
    grids = vdb.read_grids(TWO_GRIDS, ["temperature", "density"])
    lo, hi = (-3, 4, 10), (6, 10, 20)
    for grid in grids.values():
        assert grid.values.shape == (10, 7, 11) and grid.index_min == lo
        assert grid.origin_m == corner(lo)
    t, d = grids["temperature"].values, grids["density"].values
    np.testing.assert_array_equal(t[0:5, 1:7, 0:7], pattern(*TEMPERATURE_BOX))
    np.testing.assert_array_equal(d[3:10, 0:5, 2:11], pattern(*DENSITY_BOX))
    assert t[9, 0, 10] == 7.5 and d[0, 6, 0] == 0.0  # outside each grid's data: its background
    del hi


def test_half_float_file_reads_the_same_values():
    info = vdb.list_grids(DATA / "openvdb_half.vdb")[0]
    assert info.half_float is True
    grid = vdb.read_grid(DATA / "openvdb_half.vdb", "temperature")
    np.testing.assert_array_equal(grid.values, pattern(*TEMPERATURE_BOX))  # exact in half


# ------------------------------------------------------------------ files written by tinyvdb


def _write_with_tinyvdb(path: Path, grids: dict, compression: int) -> None:
    """tinyvdb 0.9 writes a grid only into a template file: reuse the reference file's grids
    (voxel 0.25 m, translation (1, -2, 0.5)) as templates, one per new grid."""
    handle = tinyvdb.from_bytes(TWO_GRIDS.read_bytes())
    handle.read_grids()
    for index, (name, (coords, values, background)) in enumerate(grids.items()):
        coords = np.ascontiguousarray(coords, dtype=np.int32)
        values = np.ascontiguousarray(values, dtype=np.float32)
        handle.replace_grid_from_sparse(index, coords.tobytes(), values.tobytes(), name, background)
    path.write_bytes(handle.to_bytes(compression=compression))
    handle.close()


def _random_sparse(seed: int, lo, size: int):
    rng = np.random.default_rng(seed)
    coords = np.unique(rng.integers(0, size, size=(60, 3)), axis=0) + np.asarray(lo)
    return coords, rng.uniform(0.5, 3.0, len(coords)).astype(np.float32)


COMPRESSIONS = {
    "none": tinyvdb.COMPRESS_NONE,
    "zip": tinyvdb.COMPRESS_ZIP,
    "blosc": tinyvdb.COMPRESS_BLOSC,
    "zip+mask": tinyvdb.COMPRESS_ZIP | tinyvdb.COMPRESS_ACTIVE_MASK,
}


@pytest.mark.parametrize("compression", COMPRESSIONS.values(), ids=COMPRESSIONS.keys())
def test_round_trip_through_tinyvdb_writer(tmp_path, compression):
    coords, values = _random_sparse(1, (-4, 2, 7), 6)
    path = tmp_path / "flame.vdb"
    _write_with_tinyvdb(path, {"flame": (coords, values, 0.25)}, compression)
    grid = vdb.read_grid(path, "flame")
    lo = coords.min(axis=0)
    assert grid.index_min == tuple(lo) and grid.values.shape == tuple(coords.max(axis=0) - lo + 1)
    assert grid.origin_m == corner(lo) and grid.voxel_size_m == VOXEL
    expected = np.full(grid.values.shape, 0.25, dtype=np.float32)
    expected[tuple((coords - lo).T)] = values
    np.testing.assert_array_equal(grid.values, expected)


def test_round_trip_two_grids_line_up_on_the_union_box(tmp_path):
    flame = _random_sparse(2, (0, 0, 0), 5)
    heat = _random_sparse(3, (3, -2, 1), 5)
    path = tmp_path / "two.vdb"
    _write_with_tinyvdb(path, {"flame": (*flame, 0.0), "heat": (*heat, 0.0)}, COMPRESSIONS["zip"])
    grids = vdb.read_grids(path, ["flame", "heat"])
    lo = np.minimum(flame[0].min(axis=0), heat[0].min(axis=0))
    for (coords, values), grid in zip((flame, heat), grids.values(), strict=True):
        assert grid.index_min == tuple(lo) and grid.origin_m == corner(lo)
        np.testing.assert_array_equal(grid.values[tuple((coords - lo).T)], values)
    assert grids["flame"].values.shape == grids["heat"].values.shape


# ------------------------------------------------------------------ NanoVDB


def test_nanovdb_grids_match_the_openvdb_source():
    path = DATA / "nanovdb_two_grids.nvdb"
    infos = {info.name: info for info in vdb.list_grids(path)}
    assert set(infos) == {"temperature", "density"}  # both segments, not only the first
    assert infos["temperature"].index_min == TEMPERATURE_BOX[0]
    assert infos["temperature"].translation_m == tuple(TRANSLATION)
    nano = vdb.read_grids(path, ["temperature", "density"])
    openvdb = vdb.read_grids(TWO_GRIDS, ["temperature", "density"])
    for name in nano:
        np.testing.assert_array_equal(nano[name].values, openvdb[name].values)
        assert nano[name].origin_m == openvdb[name].origin_m
    assert nano["temperature"].background == 7.5


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("nanovdb_fp16.nvdb", "holds Fp16 values; only NanoVDB Float grids can be read"),
        ("nanovdb_rotated.nvdb", "rotated or sheared index→world map"),
        ("nanovdb_blosc.nvdb", "cannot read NanoVDB grid 'temperature'"),
    ],
)
def test_nanovdb_unsupported_variants_are_clear_errors(name, message):
    path = DATA / name
    grid = vdb.list_grids(path)[0].name if "blosc" not in name else "temperature"
    with pytest.raises(ValueError, match=message) as caught:
        vdb.read_grid(path, grid)
    assert name in str(caught.value)


# ------------------------------------------------------------------ error battery


def _error(path, name="density", **kwargs) -> str:
    with pytest.raises(ValueError, match=re.escape(str(path))) as caught:
        vdb.read_grid(path, name, **kwargs)
    return str(caught.value)


def test_missing_file_and_wrong_suffix(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such volume file"):
        vdb.read_grid(tmp_path / "absent.vdb", "density")
    (tmp_path / "grid.txt").write_text("x")
    assert "unsupported volume format '.txt'" in _error(tmp_path / "grid.txt")


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "not an OpenVDB file"),
        (np.random.default_rng(0).bytes(4096), "not an OpenVDB file"),
        (b"\x89PNG\r\n\x1a\n" + bytes(200), "not an OpenVDB file"),
        (TWO_GRIDS.read_bytes()[:20], "not a readable OpenVDB file"),
        (TWO_GRIDS.read_bytes()[:3000], "not a readable OpenVDB file"),
    ],
    ids=["empty", "random", "png", "header-only", "truncated"],
)
def test_not_a_vdb_or_truncated(tmp_path, content, message):
    path = tmp_path / "bad.vdb"
    path.write_bytes(content)
    assert message in _error(path)


def test_not_a_nanovdb_file(tmp_path):
    path = tmp_path / "bad.nvdb"
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    assert "not a readable NanoVDB file" in _error(path)
    path.write_bytes((DATA / "nanovdb_two_grids.nvdb").read_bytes()[:1000])
    assert "truncated" in _error(path)


def test_unknown_grid_lists_the_available_ones():
    message = _error(TWO_GRIDS, "heat")
    assert "no grid named 'heat'; the file has: 'temperature', 'density'" in message


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("velocity", "grid 'velocity' holds vec3s values; only float grids can be read"),
        ("mask", "grid 'mask' holds bool values"),
        ("empty", "have no active voxels"),
    ],
)
def test_unreadable_grid_kinds(name, message):
    assert message in _error(DATA / "openvdb_types.vdb", name)


def test_grids_with_different_transforms_cannot_share_a_box():
    with pytest.raises(ValueError, match="do not share one index→world transform"):
        vdb.read_grids(DATA / "openvdb_types.vdb", ["density", "coarse"])


@pytest.mark.parametrize("name", ["openvdb_nonuniform.vdb", "openvdb_rotated.vdb"])
def test_non_uniform_or_rotated_transform_is_an_error(name):
    assert vdb.list_grids(DATA / name)[0].unreadable is not None
    assert "not a uniform scale plus translation" in _error(DATA / name)


def test_active_tiles_are_detected_not_read_as_background():
    info = vdb.list_grids(DATA / "openvdb_tiles.vdb")[0]
    assert info.active_voxels == 16**3 and "active tiles" in (info.unreadable or "")
    assert "4096 active voxels but only 0 are stored in leaf nodes" in _error(
        DATA / "openvdb_tiles.vdb", "tiles"
    )


def test_box_larger_than_the_limit_is_refused():
    assert "more than max_voxels=100" in _error(TWO_GRIDS, "temperature", max_voxels=100)


def test_repeated_or_missing_names():
    with pytest.raises(ValueError, match="grid names repeat"):
        vdb.read_grids(TWO_GRIDS, ["density", "density"])
    with pytest.raises(ValueError, match="no grid names given"):
        vdb.read_grids(TWO_GRIDS, [])


def test_non_finite_values_are_an_error(tmp_path):
    path = tmp_path / "nan.vdb"
    coords = np.array([[0, 0, 0], [1, 0, 0]])
    _write_with_tinyvdb(path, {"flame": (coords, [1.0, np.nan], 0.0)}, COMPRESSIONS["none"])
    assert "grid 'flame' has 1 non-finite values" in _error(path, "flame")


def test_repeated_grid_names_in_a_file_are_an_error(tmp_path):
    path = tmp_path / "twice.vdb"
    _write_with_tinyvdb(path, {"density": ([[0, 0, 0]], [1.0], 0.0)}, COMPRESSIONS["none"])
    assert "grid names repeat (['density', 'density'])" in _error(path)


# ------------------------------------------------------------------ fuzz (bounded)


def test_corrupt_grid_count_is_refused_before_tinyvdb_allocates(tmp_path):
    """Three bytes of the grid count made tinyvdb 0.9 commit 3.6 GB before failing."""
    content = bytearray(TWO_GRIDS.read_bytes())
    content[63] = 123  # grid count 2 → 8 060 930
    path = tmp_path / "count.vdb"
    path.write_bytes(bytes(content))
    assert (
        "not a readable OpenVDB file, corrupt header (a grid count of 8060930 in 32000 bytes)"
        in _error(path)
    )


def _read_everything(path: Path) -> list:
    """Every readable grid of the file, densified (what a render would read)."""
    return [
        (info, vdb.read_grid(path, info.name, max_voxels=10**6))
        for info in vdb.list_grids(path)
        if info.unreadable is None and info.active_voxels
    ]


@pytest.mark.parametrize(
    "source", [TWO_GRIDS, DATA / "nanovdb_two_grids.nvdb"], ids=["vdb", "nvdb"]
)
@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_fuzzed_files_raise_only_value_error(tmp_path, source, data):
    """Mutated or truncated bytes of a valid file: the reader raises a ValueError naming the file,
    or — for a mutation the format cannot detect, such as one in a voxel value — returns grids
    that are what their header says: the stated box, float32, one voxel size."""
    content = bytearray(source.read_bytes())
    if data.draw(st.booleans(), label="truncate"):
        content = content[: data.draw(st.integers(0, len(content) - 1), label="length")]
    else:
        for _ in range(data.draw(st.integers(1, 8), label="flips")):
            at = data.draw(st.integers(0, len(content) - 1), label="at")
            content[at] = data.draw(st.integers(0, 255), label="byte")
    path = tmp_path / f"fuzz{source.suffix}"
    path.write_bytes(bytes(content))
    try:
        grids = _read_everything(path)
    except ValueError as error:  # anything else fails the test
        assert "fuzz" in str(error), str(error)  # noqa: PT017 (hypothesis: no pytest.raises)
        return
    for info, grid in grids:
        box = tuple(hi - lo + 1 for lo, hi in zip(info.index_min, info.index_max, strict=True))
        assert grid.values.shape == box and grid.values.dtype == np.float32
        assert np.isfinite(grid.voxel_size_m) and grid.voxel_size_m > 0


# ------------------------------------------------------------------ the Blender Mantaflow cache


def test_blender_cache_grids_as_openvdb_reports_them():
    infos = {info.name: info for info in vdb.list_grids(BLENDER)}
    assert set(infos) == {"density", "flame", "shadow", "temperature", "velocity"}
    flame = infos["flame"]
    # values from libopenvdb's vdb_print on the same file
    assert (flame.active_voxels, flame.index_min, flame.index_max) == (
        4158,
        (4, 4, 1),
        (27, 27, 20),
    )
    assert flame.value_max == 0.984375 and flame.half_float is True and flame.compression == "blosc"
    assert infos["temperature"].active_voxels == 7049 and infos["temperature"].value_max < 3.0
    assert infos["density"].index_min == (3, 3, 1) and infos["density"].index_max == (28, 28, 22)
    assert infos["flame"].voxel_size_m == (1 / 32,) * 3 and infos["flame"].translation_m == (0,) * 3
    assert "active tiles" in (infos["shadow"].unreadable or "")
    assert "vec3s" in (infos["velocity"].unreadable or "")


#: Sums of each grid over its active box as densified by libopenvdb 10 (pyopenvdb copyToArray).
OPENVDB_SUMS = {
    "density": 72.23448979854584,
    "flame": 2609.3907327651978,
    "temperature": 9054.012923657894,
}


@pytest.mark.parametrize("name", OPENVDB_SUMS)
def test_blender_grids_densify_as_libopenvdb_does(name):
    grid = vdb.read_grid(BLENDER, name)
    assert grid.values.astype(np.float64).sum() == OPENVDB_SUMS[name]


def cycles_fire(flame: np.ndarray) -> np.ndarray:
    """Blender Cycles' fire temperature: T = 1000 K·(1.5 + flame·(3.0 − 1.5)) where flame > 0.01."""
    return np.where(flame > 0.01, 1000.0 * (1.5 + flame * (3.0 - 1.5)), 0.0)


@pytest.mark.slow
def test_blender_fire_renders_bright_where_the_flame_is():
    from incandescent import Camera, RenderSettings, render
    from incandescent.volume import Remap, Volume

    grids = vdb.read_grids(BLENDER, ["flame", "temperature", "density"])
    flame, heat, density = (grids[name].values for name in ("flame", "temperature", "density"))
    assert flame.shape == heat.shape == density.shape == (26, 26, 22)
    assert heat[flame > 0.1].mean() > heat[flame <= 0.01].mean()  # hot where it burns
    grid = grids["flame"]
    volume = Volume.from_arrays(
        cycles_fire(flame),
        absorption=20.0 * density,
        voxel_size_m=grid.voxel_size_m,
        origin_m=grid.origin_m,
        remap=Remap(cutoff_K=1.0),
        source=grid.source,
    )
    lo, hi = volume.bounds_m
    centre = (lo + hi) / 2
    camera = Camera(  # Blender is z-up: look along +y, z up the image, x to the right
        eye=tuple(centre - [0, 3, 0]),
        target=tuple(centre),
        up=(0, 0, 1),
        projection="orthographic",
        ortho_height_m=float((hi - lo)[2]) * 1.2,
    )
    image = render(volume, camera, RenderSettings(width=48, height=64), backend="cpu")
    luminance = image.luminance
    assert np.all(np.isfinite(image.xyz)) and luminance.max() > 0
    burning = _pixels_over(flame.max(axis=1) > 0.1, camera, volume, image.width, image.height)
    assert burning.any() and (~burning).any()
    assert luminance[burning].mean() > 20 * max(float(luminance[~burning].mean()), 1e-30)


def _pixels_over(mask_xz: np.ndarray, camera, volume, width: int, height: int) -> np.ndarray:
    """Pixels whose orthographic ray (along +y) passes through a voxel column where mask is set."""
    right, up, _ = camera.basis()
    half_h = camera.ortho_height_m / 2
    half_w = half_h * width / height
    cols, rows = np.meshgrid(np.arange(width), np.arange(height))
    fx = 2 * (cols + 0.5) / width - 1
    fy = 1 - 2 * (rows + 0.5) / height
    world = (
        np.asarray(camera.eye) + (fx * half_w)[..., None] * right + (fy * half_h)[..., None] * up
    )
    index = np.floor((world - np.asarray(volume.origin_m)) / volume.voxel_size_m).astype(int)
    i, k = index[..., 0], index[..., 2]
    inside = (i >= 0) & (i < mask_xz.shape[0]) & (k >= 0) & (k < mask_xz.shape[1])
    out = np.zeros((height, width), dtype=bool)
    out[inside] = mask_xz[i[inside], k[inside]]
    return out


def test_a_crash_in_the_isolated_nanovdb_reader_is_a_clear_error(tmp_path):
    """tinyvdb can segfault on corrupt NanoVDB data (found by fuzzing): the read runs in a worker
    process, and a worker that dies becomes a ValueError naming the file; the next read works."""
    import os

    from incandescent.io.vdb import nanovdb

    path = tmp_path / "crash.nvdb"
    with pytest.raises(ValueError, match="crash.nvdb: the NanoVDB reader .tinyvdb. crashed"):
        nanovdb.run_isolated(path, os.abort)
    assert nanovdb.run_isolated(path, abs, -3) == 3  # a fresh worker after the crash


def test_a_grid_a_flag_names_but_cannot_be_read_stops_with_the_reason():
    """No silent fallback and no misleading "no such grid": through tinyvdb the Blender cache's
    shadow grid is all active tiles; naming it as the temperature stops with that reason."""
    from incandescent.config import GridNames, VolumeSection
    from incandescent.config.assemble import volume_from_section
    from incandescent.volume import Remap

    spec = VolumeSection(path=BLENDER, grids=GridNames(temperature="shadow"))
    with pytest.raises(ValueError, match=r"grid 'shadow' is needed but has 65536 active voxels"):
        volume_from_section(spec, Remap())
