"""Sparse volumes and the sparse (brick) layout: the same image, samples and macrocells as dense."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent import scenes
from incandescent.camera import Camera
from incandescent.renderer import Paper2011, RenderSettings, render
from incandescent.renderer.backends.bricks import plan
from incandescent.volume import Volume, build_macrocells
from incandescent.volume.sparse import SparseVolume, leaf_macrocells


def _blobs(shape=(37, 20, 29), graded=False) -> Volume:
    """Hot blobs (one on the grid's edge) in vacuum, on a grid that is not whole leaves."""
    temp = np.zeros(shape)
    for x, y, z in [(2, 3, 4), (20, 12, 22), (33, 16, 1)]:
        temp[x : x + 4, y : y + 4, z : z + 5] = 1700.0
    temp[30:, 15:, :3] = 1200.0  # reaches the x, y and z edges of the grid
    kappa = np.where(temp > 0, np.linspace(0.5, 4.0, temp.size).reshape(shape), 0.0)
    return Volume.from_arrays(temp, absorption=kappa if graded else None)


CASES = {
    "plume (two-valued κ)": lambda: scenes.plume(40),
    "soot plume (graded κ)": lambda: scenes.soot_plume(36),
    "sparse flame": lambda: scenes.sparse_flame(96),
    "edge blobs": lambda: _blobs(graded=True),
    "fireball shell (SparseVolume)": lambda: scenes.explosion_shell(72),
}
CAMERAS = [
    None,
    Camera(eye=(0.0, 0.0, 2.0), target=(0.0, 0.0, 0.0)),  # axis-parallel rays
    Camera(eye=(0.7, 0.2, 0.4), target=(0.0, 0.0, 0.0), fov_deg=70.0),  # inside the box's reach
]


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("camera", CAMERAS, ids=["default", "axis", "close"])
def test_sparse_layout_renders_the_dense_image_exactly(jit_backend, case, camera):
    volume = CASES[case]()
    s = RenderSettings(width=48, height=40, supersample=1)
    dense = render(volume, camera, s.replace(layout="dense"), backend=jit_backend)
    sparse = render(volume, camera, s.replace(layout="sparse"), backend=jit_backend)
    assert dense.metadata["layout"] == "dense" and sparse.metadata["layout"] == "sparse"
    assert dense.xyz.max() > 0
    assert sparse.metadata["samples"] == dense.metadata["samples"]
    np.testing.assert_array_equal(sparse.xyz, dense.xyz)
    np.testing.assert_array_equal(sparse.transmittance, dense.transmittance)
    np.testing.assert_array_equal(sparse.depth_m, dense.depth_m)


def test_a_sparse_volume_renders_as_its_dense_volume_on_every_backend(jit_backend):
    sparse = SparseVolume.from_volume(_blobs())
    s = RenderSettings(width=24, height=20)
    fast = render(sparse, None, s, backend=jit_backend)
    ref = render(sparse, None, s, backend="reference")  # densified for the float64 reference
    assert fast.metadata["layout"] == "sparse" and ref.metadata["layout"] == "dense"
    np.testing.assert_allclose(fast.xyz, ref.xyz, rtol=1e-4, atol=1e-6 * ref.xyz.max())


def test_leaf_macrocells_equal_the_dense_block_maxima():
    rng = np.random.default_rng(3)
    for shape in [(37, 20, 29), (16, 16, 16), (9, 40, 8)]:
        kappa = np.where(rng.random(shape) > 0.97, rng.random(shape), 0.0).astype(np.float32)
        sparse = SparseVolume.from_volume(Volume.from_arrays(np.full(shape, 1500.0), kappa))
        cells = leaf_macrocells(sparse.leaf_coords, sparse.leaf_absorption_per_m, sparse.leaf_shape)
        np.testing.assert_array_equal(cells, build_macrocells(kappa, 8).max_absorption)


def test_from_volume_keeps_what_an_absorbing_sample_can_read():
    volume = scenes.sparse_flame(128)
    sparse = SparseVolume.from_volume(volume)
    assert sparse.leaf_fraction < 0.05  # the flame's leaves and their neighbours, not the box
    dense = sparse.to_dense()
    kept = np.zeros(volume.shape, dtype=bool)
    for c in sparse.leaf_coords:
        x, y, z = c * 8
        kept[x : x + 8, y : y + 8, z : z + 8] = True
    np.testing.assert_array_equal(dense.temperature_K[kept], volume.temperature_K[kept])
    np.testing.assert_array_equal(dense.absorption_per_m, volume.absorption_per_m)
    np.testing.assert_allclose(sparse.content_bounds_m, volume.content_bounds_m)
    assert sparse.max_temperature_K == volume.max_temperature_K


def test_bricks_cover_the_leaves_they_read():
    """Brick b reads leaves b − 1 and b per axis: every brick next to a leaf is stored."""
    sparse = SparseVolume.from_leaves(
        (24, 24, 24), [[1, 1, 1]], np.full((1, 8, 8, 8), 1500.0), np.ones((1, 8, 8, 8))
    )
    p = plan(sparse)
    stored = np.argwhere(p.slots > 0)
    assert p.brick_shape == (4, 4, 4) and p.bricks == 1 + 8
    assert {tuple(b) for b in stored} == {(x, y, z) for x in (1, 2) for y in (1, 2) for z in (1, 2)}


def test_auto_layout_chooses_by_occupancy_and_what_sparse_carries():
    s = RenderSettings(width=16, height=16)
    assert render(scenes.sparse_flame(96), None, s).metadata["layout"] == "sparse"
    assert render(scenes.plume(32), None, s).metadata["layout"] == "dense"
    lines = Volume.from_arrays(scenes.plume_temperature(24), species={"Na": 0.02})
    assert render(lines, None, s).metadata["layout"] == "dense"
    with pytest.raises(
        ValueError, match="layout 'sparse' cannot render this: the lines model reads grids"
    ):
        render(lines, None, s.replace(layout="sparse"))
    with pytest.raises(ValueError, match="macrocells are its 8-voxel leaves"):
        render(scenes.plume(24), None, s.replace(layout="sparse", macrocell_voxels=4))
    with pytest.raises(ValueError, match="the paper2011 integrator is not emission"):
        render(scenes.plume(24), None, s.replace(layout="sparse"), integrator=Paper2011())


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"leaf_coords": [[5, 0, 0]]}, r"leaf \(5, 0, 0\) lies outside a grid of \[3, 3, 3\]"),
        ({"leaf_coords": [[0, 0, 0], [0, 0, 0]]}, "unique"),
        ({"temperature_K": np.full((1, 8, 8, 8), np.nan)}, "finite and >= 0"),
        ({"absorption_per_m": np.ones((1, 4, 8, 8))}, r"must be \(1, 8, 8, 8\) leaves"),
        ({"shape": (24, 0, 24)}, "3 positive voxel counts"),
    ],
)
def test_from_leaves_names_what_is_wrong(change, message):
    args = {
        "shape": (24, 24, 24),
        "leaf_coords": [[0, 1, 2]],
        "temperature_K": np.full((1, 8, 8, 8), 1500.0),
        "absorption_per_m": np.ones((1, 8, 8, 8)),
    }
    args.update(change)
    if len(args["leaf_coords"]) == 2:
        args["temperature_K"] = np.full((2, 8, 8, 8), 1500.0)
        args["absorption_per_m"] = np.ones((2, 8, 8, 8))
    with pytest.raises(ValueError, match=message):
        SparseVolume.from_leaves(**args, source="test")
