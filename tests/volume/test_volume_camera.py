"""Volume and camera validation: bad input gets a clear error naming the value."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.camera import Camera, default_camera
from incandescent.renderer import RenderSettings, render
from incandescent.volume import Remap, Volume


def test_default_placement_centres_grid_with_largest_side_one_metre():
    vol = Volume.from_arrays(np.full((10, 20, 5), 1000.0))
    lo, hi = vol.bounds_m
    np.testing.assert_allclose(lo, [-0.25, -0.5, -0.125])
    np.testing.assert_allclose(hi, [0.25, 0.5, 0.125])
    assert vol.voxel_size_m == pytest.approx(0.05)


def test_default_absorption_follows_hot_gas():
    temp = np.full((4, 4, 4), 300.0)
    temp[1, 1, 1] = 1500.0
    vol = Volume.from_arrays(temp)
    assert vol.absorption_per_m[1, 1, 1] == pytest.approx(1.0 / (4 * 0.25))
    assert vol.absorption_per_m.sum() == vol.absorption_per_m[1, 1, 1]
    assert "default" in vol.absorption_source


def test_remap_maps_raw_field_to_kelvin():
    vol = Volume.from_arrays(np.full((2, 2, 2), 2.0), remap=Remap(offset=0.5, scale=1000.0))
    assert np.all(vol.temperature_K == 1500.0)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"temperature": np.full((2, 2), 1000.0)}, ValueError, r"3-D grid .* shape \(2, 2\)"),
        ({"temperature": np.zeros((0, 2, 2))}, ValueError, "empty"),
        ({"temperature": np.array([[[1000.0, np.nan]]])}, ValueError, r"finite; got nan"),
        ({"temperature": np.array([[[np.inf]]])}, ValueError, "finite; got inf"),
        ({"temperature": np.array([[[-5.0]]])}, ValueError, r"-5 K at voxel \(0, 0, 0\)"),
        ({"temperature": np.ones((2, 2, 2), dtype=bool)}, TypeError, "dtype bool"),
        ({"temperature": np.full((2, 2, 2), "hot")}, TypeError, "real number array"),
        (
            {"temperature": np.ones((2, 2, 2)), "absorption": np.ones((2, 2, 3))},
            ValueError,
            r"absorption grid has shape \(2, 2, 3\); expected the temperature's \(2, 2, 2\)",
        ),
        ({"temperature": np.ones((2, 2, 2)), "absorption": -1.0}, ValueError, "absorption"),
        ({"temperature": np.ones((2, 2, 2)), "voxel_size_m": 0.0}, ValueError, "voxel_size_m"),
        ({"temperature": np.ones((2, 2, 2)), "origin_m": (0, 0)}, ValueError, "origin_m"),
    ],
)
def test_volume_rejects_bad_input(kwargs, error, match):
    with pytest.raises(error, match=match):
        Volume.from_arrays(**kwargs)


def test_negative_kelvin_after_remap_names_the_remap():
    with pytest.raises(ValueError, match=r"negative after remap \(offset=1, scale=100\)"):
        Volume.from_arrays(np.full((2, 2, 2), 0.5), remap=Remap(offset=1.0, scale=100.0))


def test_values_below_cutoff_may_be_negative_and_become_vacuum():
    raw = np.array([[[-1.0, 2.0]]])
    vol = Volume.from_arrays(raw, absorption=1.0, remap=Remap(scale=1000.0, cutoff_K=500.0))
    assert vol.temperature_K.tolist() == [[[0.0, 2000.0]]]
    assert vol.absorption_per_m.tolist() == [[[0.0, 1.0]]]


#: 136 × 128 × 128 float32: several slabs of x on every core and several chunks per slab.
BIG = (136, 128, 128)


@pytest.mark.parametrize(
    ("role", "bad", "match"),
    [
        ("temperature", np.nan, r"finite; got nan at index \(135, 127, 127\)"),
        ("temperature", np.inf, r"finite; got inf at index \(135, 127, 127\)"),
        ("temperature", -np.inf, r"finite; got -inf at index \(135, 127, 127\)"),
        ("temperature", -3.0, r"-3 K at voxel \(135, 127, 127\)"),
        ("temperature", 2e5, r"2e\+05 K at voxel \(135, 127, 127\) is above .* ceiling"),
        ("absorption", np.nan, r"absorption must be finite; got nan at index \(135, 127, 127\)"),
        ("absorption", -2.0, r"absorption must be >= 0; got -2 at voxel \(135, 127, 127\)"),
    ],
)
def test_float32_grids_are_checked_to_the_last_voxel(role, bad, match):
    """The float32 grids are validated by chunked min/max (no full-size masks): a bad value in the
    last chunk of the last slab is still found and named."""
    grids = {
        "temperature": np.full(BIG, 1500.0, np.float32),
        "absorption": np.ones(BIG, np.float32),
    }
    grids[role][-1, -1, -1] = bad
    with pytest.raises(ValueError, match=match):
        Volume.from_arrays(grids["temperature"], absorption=grids["absorption"])


def _fresh(values) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=np.float32).reshape(-1).copy().reshape(BIG)


def test_copy_false_hands_over_fresh_float32_grids_and_copy_true_does_not():
    # each grid a reshape of a fresh array, as np.load returns them
    temp = _fresh(np.linspace(300.0, 2500.0, np.prod(BIG)))
    kappa = _fresh(np.full(BIG, 2.0))
    kept = Volume.from_arrays(temp, absorption=kappa, copy=False)
    assert kept.temperature_K is temp and kept.absorption_per_m is kappa
    assert not temp.flags.writeable and not kappa.flags.writeable
    assert kept.max_temperature_K == float(temp.max())  # from the validation pass
    temp2, kappa2 = _fresh(temp), _fresh(kappa)
    copied = Volume.from_arrays(temp2, absorption=kappa2)
    assert not np.shares_memory(copied.temperature_K, temp2) and temp2.flags.writeable
    assert not np.shares_memory(copied.absorption_per_m, kappa2)
    assert np.array_equal(copied.temperature_K, kept.temperature_K)


def test_copy_false_copies_views_and_grids_a_cutoff_changes():
    big = np.full((2,) + BIG, 1200.0, np.float32)
    view = Volume.from_arrays(big[0], absorption=1.0, copy=False)  # part of a larger array
    assert not np.shares_memory(view.temperature_K, big) and big.flags.writeable
    temp = _fresh(np.full(BIG, 1200.0))
    temp[0, 0, 0] = 200.0
    cut = Volume.from_arrays(temp, remap=Remap(cutoff_K=400.0), copy=False)
    assert not np.shares_memory(cut.temperature_K, temp) and temp[0, 0, 0] == 200.0
    assert cut.temperature_K[0, 0, 0] == 0.0 and cut.max_temperature_K == 1200.0
    all_cut = Volume.from_arrays(_fresh(np.full(BIG, 300.0)), remap=Remap(cutoff_K=400.0))
    assert all_cut.max_temperature_K == 0.0 == float(all_cut.temperature_K.max())


def test_npz_grids_are_handed_over_by_the_reader(tmp_path):
    """``load_volume`` keeps the arrays NumPy read instead of copying them again."""
    from incandescent.api import load_volume
    from incandescent.volume.validate import _handed_over

    temp = np.full(BIG, 1500.0, np.float32)
    np.savez(tmp_path / "v.npz", temperature=temp, absorption=np.ones(BIG, np.float32))
    with np.load(tmp_path / "v.npz") as data:
        assert _handed_over(data["temperature"])
    volume = load_volume(tmp_path / "v.npz")
    assert np.array_equal(volume.temperature_K, temp) and not volume.temperature_K.flags.writeable


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"eye": (0, 0, 1), "target": (0, 0, 1)}, "eye and target coincide"),
        ({"eye": (0, 2, 0), "target": (0, 0, 0)}, "parallel to the view direction"),
        ({"eye": (0, 0, 1), "up": (0, 0, 0)}, "parallel to the view direction"),
        ({"eye": (0, 0, 1), "fov_deg": 180.0}, r"fov_deg must be in \[0.01, 180\)"),
        ({"eye": (0, 0, 1), "fov_deg": -3}, "fov_deg"),
        ({"eye": (0, np.nan, 1)}, "camera eye must be finite"),
        ({"eye": (0, 1)}, "camera eye must be 3 numbers"),
        ({"eye": (0, 0, 1), "projection": "fisheye"}, "unknown camera projection 'fisheye'"),
    ],
)
def test_camera_rejects_degenerate_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Camera(**kwargs)


def test_default_camera_sees_the_whole_box():
    vol = Volume.from_arrays(np.full((8, 8, 8), 1500.0), absorption=1.0)
    img = render(vol, settings=RenderSettings(width=32, height=32), backend="cpu")
    covered = img.alpha > 0
    assert covered[16, 16]
    assert not covered[0, :].any() and not covered[-1, :].any()
    assert not covered[:, 0].any() and not covered[:, -1].any()


def test_image_orientation_row_zero_is_top_and_x_is_right():
    temp = np.full((8, 8, 8), 300.0)
    temp[6:, 6:, :] = 2000.0  # +x, +y corner
    vol = Volume.from_arrays(temp)
    cam = Camera(eye=(0, 0, 3), target=(0, 0, 0), projection="orthographic", ortho_height_m=1.0)
    y = render(vol, cam, RenderSettings(width=8, height=8), backend="cpu").luminance
    assert y[:4, 4:].sum() > 0  # upper right
    assert y[4:, :].sum() == 0 and y[:, :4].sum() == 0


def test_rays_are_column_major_for_kernels():
    cam = default_camera((np.zeros(3) - 1, np.ones(3)))
    origins, dirs = cam.generate_rays(3, 2)
    assert dirs.shape == (6, 3)
    # consecutive rays go down a column: same x film coordinate, decreasing y
    right, up, _ = cam.basis()
    assert np.dot(dirs[0], right) == pytest.approx(np.dot(dirs[1], right))
    assert np.dot(dirs[0], up) > np.dot(dirs[1], up)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"width": 0}, "width must be an integer"),
        ({"step_voxels": 0.0}, "step_voxels"),
        ({"supersample": 2.5}, "supersample"),
        ({"min_transmittance": 1.5}, "min_transmittance"),
        ({"layout": "sunny"}, "unknown layout 'sunny'"),
    ],
)
def test_settings_reject_bad_values(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RenderSettings(**kwargs)


def test_render_rejects_non_volume():
    with pytest.raises(
        TypeError, match="volume must be an incandescent Volume or SparseVolume; got ndarray"
    ):
        render(np.zeros((2, 2, 2)))  # type: ignore[arg-type]


def test_remap_from_range():
    remap = Remap.from_range(800.0, 2200.0)
    np.testing.assert_allclose(remap.apply(np.array([0.0, 0.5, 1.0])), [800.0, 1500.0, 2200.0])
    with pytest.raises(ValueError, match="0 <= LOW < HIGH"):
        Remap.from_range(2000.0, 1000.0)


def test_z_up_sources_are_rotated_into_the_y_up_world():
    """(x, y, z) ↦ (x, z, −y): every voxel centre lands where the rotation puts it."""
    from incandescent.config.assemble import _z_up_to_y_up

    rng = np.random.default_rng(3)
    grid = rng.random((3, 4, 5))
    origin, voxel = (0.5, -1.0, 2.0), 0.25
    rotated, new_origin = _z_up_to_y_up({"temperature": grid}, origin, voxel)
    new = rotated["temperature"]
    assert new.shape == (3, 5, 4)
    for i, j, k in [(0, 0, 0), (2, 3, 4), (1, 2, 0)]:
        centre = np.asarray(origin) + (np.array([i, j, k]) + 0.5) * voxel
        expected = np.array([centre[0], centre[2], -centre[1]])
        index = np.round((expected - np.asarray(new_origin)) / voxel - 0.5).astype(int)
        assert new[tuple(index)] == grid[i, j, k]


@pytest.mark.parametrize(("width", "height", "s"), [(5, 3, 1), (37, 20, 2), (16, 16, 1)])
def test_kernel_lane_order_is_a_permutation_of_the_camera_rays(width, height, s):
    from incandescent.renderer.rays import lane_order

    x, y, index = lane_order(width, height, s)
    assert np.array_equal(np.sort(index), np.arange(width * height * s * s))
    cam = default_camera((np.zeros(3) - 1, np.ones(3)))
    _, dirs = cam.generate_rays(width, height, s)
    right, up, _ = cam.basis()
    # the lane's sub-pixel (X, Y) is the one generate_rays puts at that index
    film_x = np.dot(dirs[index], right) / np.dot(dirs[index], cam.basis()[2])
    assert np.all(np.diff(film_x[np.argsort(x, kind="stable")]) >= -1e-12)
    film_y = np.dot(dirs[index], up) / np.dot(dirs[index], cam.basis()[2])
    assert np.all(np.diff(film_y[np.argsort(y, kind="stable")]) <= 1e-12)


def test_lanes_go_in_z_order_within_16x16_tiles_down_the_columns():
    from incandescent.renderer.rays import lane_order

    x, y, _ = (a.astype(int) for a in lane_order(40, 35, 1))  # 3 × 3 tiles, partial at the edges
    first = set(zip(x[:256], y[:256], strict=True))
    assert first == {(i, j) for i in range(16) for j in range(16)}  # one whole tile
    assert set(zip(x[:8], y[:8], strict=True)) == {(i, j) for i in range(4) for j in range(2)}
    assert (x[256], y[256]) == (0, 16)  # the next tile is the one below
    third = slice(512, 512 + 16 * 3)  # the bottom tile of the first column: rows 32..34 only
    assert set(y[third]) == {32, 33, 34} and set(x[third]) == set(range(16))


@pytest.mark.parametrize(("width", "height", "s"), [(5, 3, 1), (37, 20, 2), (16, 16, 3)])
def test_image_gathered_from_the_lanes_equals_the_scatter_into_camera_ray_order(width, height, s):
    """The fast path of the kernels' output (one gather by ``image_lanes``) is the general one
    (a scatter by ray index, then the sub-pixel reduction) to the bit, for mean and min."""
    from types import SimpleNamespace

    from incandescent.renderer import RenderSettings
    from incandescent.renderer.api import _scatter_rays
    from incandescent.renderer.rays import lane_order

    inputs = SimpleNamespace(settings=RenderSettings(width=width, height=height, supersample=s))
    index = lane_order(width, height, s)[2]
    values = np.random.default_rng(s).random((index.size, 3))
    for reduce in (np.mean, np.min):
        fast = _scatter_rays(values, index, inputs, 0.0, reduce)
        general = _scatter_rays(values, index.copy(), inputs, 0.0, reduce)
        assert fast.shape == (height, width, 3)
        np.testing.assert_array_equal(fast, general)
