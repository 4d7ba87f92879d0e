"""Backend parity (cpu and cuda vs the float64 reference), empty-space skipping, selection."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent import scenes
from incandescent._jit import array_module, cuda_problem
from incandescent.camera import Camera
from incandescent.renderer import RenderSettings, render
from incandescent.renderer.backends import BackendUnavailable, available_backends, resolve_backend
from incandescent.renderer.backends.kernel import Kernel
from incandescent.renderer.backends.medium import (
    device_grid,
    host_packed,
    host_signed,
    packed_medium,
    signed_medium,
    threshold_K,
)
from incandescent.volume import Remap, Volume, build_macrocells
from incandescent.volume.macrocells import empty_radius


def _random_volume(seed: int, shape=(7, 9, 6)) -> Volume:
    rng = np.random.default_rng(seed)
    temp = rng.uniform(600.0, 3200.0, shape)
    kappa = rng.uniform(0.0, 6.0, shape) * (rng.random(shape) > 0.3)
    scale = rng.uniform(0.5, 2.0, shape)
    return Volume.from_arrays(
        temp,
        absorption=kappa,
        emission_scale=scale,
        voxel_size_m=0.05,
        origin_m=(-0.2, -0.1, -0.15),
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jit_backend_matches_reference(jit_backend, seed):
    vol = _random_volume(seed)
    cam = Camera(eye=(0.7, 0.5, 0.9), target=(0.0, 0.1, 0.0), fov_deg=45.0)
    s = RenderSettings(width=23, height=17, supersample=2, step_voxels=0.37, seed=seed)
    ref = render(vol, cam, s, backend="reference")
    fast = render(vol, cam, s, backend=jit_backend)
    assert ref.xyz.max() > 0
    np.testing.assert_allclose(fast.xyz, ref.xyz, rtol=1e-4, atol=1e-6 * ref.xyz.max())
    np.testing.assert_allclose(fast.transmittance, ref.transmittance, rtol=1e-4, atol=1e-6)
    assert fast.metadata["samples"] <= ref.metadata["samples"]
    assert fast.metadata["backend"] == jit_backend


@pytest.mark.parametrize("absorption", [None, 3.5])
def test_two_valued_absorption_matches_reference(jit_backend, absorption):
    """κ ∈ {0, κ₀} (the default absorption; a constant κ with a cutoff) is stored as T with a sign
    bit in the kernel; the image must still match the float64 reference. The cutoff puts 0 K
    vacuum next to hot voxels, so some samples are colder than the emission tables: they must
    still absorb (they did not before this test, a 1.6 % error)."""
    rng = np.random.default_rng(4)
    temp = rng.uniform(200.0, 2600.0, (9, 7, 8))
    vol = Volume.from_arrays(temp, absorption=absorption, remap=Remap(cutoff_K=450.0))
    assert vol.two_valued_absorption_per_m is not None
    cam = Camera(eye=(1.1, 0.6, 1.4), target=(0.0, 0.05, 0.0), fov_deg=50.0)
    s = RenderSettings(width=21, height=19, step_voxels=0.41, seed=3)
    ref = render(vol, cam, s, backend="reference")
    fast = render(vol, cam, s, backend=jit_backend)
    assert ref.xyz.max() > 0
    np.testing.assert_allclose(fast.xyz, ref.xyz, rtol=1e-4, atol=1e-6 * ref.xyz.max())
    np.testing.assert_allclose(fast.transmittance, ref.transmittance, rtol=1e-4, atol=1e-6)


def test_two_valued_absorption_is_detected():
    temp = np.full((4, 4, 4), 1500.0)
    temp[0] = 300.0
    assert Volume.from_arrays(temp).two_valued_absorption_per_m == 1.0  # 1/L, L = 1 m
    assert Volume.from_arrays(temp, absorption=2.0).two_valued_absorption_per_m == 2.0
    graded = np.linspace(0.0, 1.0, 64).reshape(4, 4, 4)
    assert Volume.from_arrays(temp, absorption=graded).two_valued_absorption_per_m is None
    assert Volume.from_arrays(temp, absorption=0.0).two_valued_absorption_per_m is None
    given = np.where(graded > 0.5, 2.5, 0.0)  # a grid, not made from T: found by the scan
    assert Volume.from_arrays(temp.astype(np.float32), absorption=given).medium.kappa_known is False
    assert Volume.from_arrays(temp, absorption=given).two_valued_absorption_per_m == 2.5
    assert Volume.from_arrays(temp.astype(np.float32), given).two_valued_absorption_per_m == 2.5
    assert scenes.plume(16).two_valued_absorption_per_m is not None  # the bench scenes: one of each
    assert scenes.soot_plume(16).two_valued_absorption_per_m is None
    all_vacuum = Volume.from_arrays(temp, absorption=2.0, remap=Remap(cutoff_K=2000.0))
    assert all_vacuum.two_valued_absorption_per_m is None
    # what from_arrays knows from how κ was made (its MediumSummary) equals a scan of the grid;
    # float32 grids take it from the validation's hottest voxel, others from κ's maximum
    made = [Volume.from_arrays(temp), Volume.from_arrays(temp, absorption=2.0), all_vacuum]
    for t in (temp.astype(np.float32), np.full((4, 4, 4), 499.5, np.float32)):
        for kwargs in ({}, {"absorption": 0.3}, {"absorption": 0.0}):
            made += [
                Volume.from_arrays(t, **kwargs, remap=Remap(cutoff_K=c)) for c in (0, 1e3, 2e3)
            ]
    assert sum(v.two_valued_absorption_per_m is None for v in made) >= 6  # both answers occur
    for vol in made:
        scanned = vol.replace(medium=None)  # nothing known: scanned
        assert scanned.two_valued_absorption_per_m == vol.two_valued_absorption_per_m


def test_device_grid_layouts_are_the_grids_in_c_order():
    """The kernel's grids are unpadded, voxels in C order: (κ, T) packed low/high in 64 bits, and
    T's bits with the sign bit set where κ = 0."""
    rng = np.random.default_rng(1)
    temp = rng.uniform(300.0, 2000.0, (6, 4, 5))
    vol = Volume.from_arrays(temp, absorption=np.where(temp > 900.0, 2.5, 0.0))
    pair = np.stack([vol.absorption_per_m, vol.temperature_K], axis=-1).astype("<f4")
    np.testing.assert_array_equal(host_packed(vol), pair.view("<u8").ravel())
    signed = np.where(vol.absorption_per_m > 0, vol.temperature_K, -vol.temperature_K)
    np.testing.assert_array_equal(host_signed(vol), signed.astype("<f4").view("<u4").ravel())


@pytest.mark.parametrize("kind", ["cpu", "cuda"])
def test_device_layouts_equal_the_host_ones(kind):
    """Built by one Dr.Jit pass on the CPU (uploaded from the host build on CUDA), each layout
    holds exactly the host build's bits; an extra grid is its float32 values in C order."""
    if kind not in available_backends():
        pytest.skip(f"backend {kind} unavailable")
    m = array_module(kind)
    rng = np.random.default_rng(2)
    temp = rng.uniform(300.0, 2000.0, (6, 4, 5))
    two = Volume.from_arrays(temp, absorption=np.where(temp > 900.0, 2.5, 0.0))
    graded = Volume.from_arrays(temp, absorption=rng.uniform(0.0, 3.0, temp.shape))
    np.testing.assert_array_equal(np.asarray(signed_medium(m, two)), host_signed(two))
    np.testing.assert_array_equal(np.asarray(packed_medium(m, graded)), host_packed(graded))
    strided = rng.uniform(0.0, 2.0, (5, 4, 3, 2))[..., 1]  # float64, not contiguous
    extra = device_grid(m, two, ("test",), strided)
    np.testing.assert_array_equal(np.asarray(extra), strided.astype(np.float32).ravel())


@pytest.mark.parametrize(
    ("absorption", "cutoff_K"), [(None, 0.0), (None, 640.3), (1.5, 0.0), (1.5, 640.3)]
)
def test_kappa_made_from_t_absorbs_exactly_where_the_stored_t_reaches_its_threshold(
    absorption, cutoff_K
):
    """κ made from T (the default, a constant, with or without a cutoff) is > 0 exactly where the
    stored float32 T ≥ ``absorbing_from_K``, also for float64 temperatures (remapped) within a
    float32 rounding of 500 K or of the cutoff; a κ grid or a ``replace`` copy does not claim it."""
    rng = np.random.default_rng(4)
    kelvin = rng.uniform(0.0, 1200.0, (9, 8, 7))
    edges = [500.0, 640.3]
    near = [v for e in edges for v in (e, np.nextafter(e, 0.0), np.nextafter(e, 1e4), e - 2e-5)]
    kelvin.flat[: len(near)] = near
    remap = Remap(scale=2.0, cutoff_K=cutoff_K)  # float64 remap: T is rounded to float32 after
    vol = Volume.from_arrays(kelvin / 2.0, absorption=absorption, remap=remap)
    threshold = vol.absorbing_from_K
    assert threshold is not None and threshold == float(np.float32(threshold))
    absorbs = vol.temperature_K >= np.float32(threshold)
    assert 0 < absorbs.sum() < absorbs.size or (absorption is not None and cutoff_K == 0)
    np.testing.assert_array_equal(vol.absorption_per_m > 0, absorbs)
    assert vol.replace(medium=None).absorbing_from_K is None
    given = Volume.from_arrays(kelvin, absorption=np.where(kelvin > 500.0, 1.5, 0.0))
    assert given.absorbing_from_K is None and given.two_valued_absorption_per_m == 1.5


def test_kappa_made_from_t_renders_as_the_signed_layout(jit_backend):
    """The kernel reading T alone and testing T ≥ 500 K per corner draws exactly what it draws
    from the layout with κ = 0 in T's sign bit (the same volume without what construction knew),
    voxels at exactly 500 K and just below it included."""
    rng = np.random.default_rng(5)
    values = np.array([0.0, 300.0, 500.0, np.nextafter(np.float32(500), 0), 900.0, 2200.0])
    vol = Volume.from_arrays(rng.choice(values.astype(np.float32), (10, 12, 9)))
    unknown = vol.replace(medium=None)
    assert threshold_K(vol) == 500.0 and threshold_K(unknown) is None
    s = RenderSettings(width=24, height=20)
    made, signed = (render(v, settings=s, backend=jit_backend) for v in (vol, unknown))
    assert made.xyz.max() > 0
    np.testing.assert_array_equal(made.xyz, signed.xyz)
    np.testing.assert_array_equal(made.transmittance, signed.transmittance)


def test_corners_clamp_to_the_edge_voxel_as_the_padded_grid_did():
    """Trilinear lookups through the clamped corners equal lookups in the grid padded by one
    edge-replicated voxel (the edge rule), inside, in the outer half voxel and outside, and read
    nothing past the grid (NaN there would show)."""
    m = array_module("cpu")
    rng = np.random.default_rng(3)
    shape = (5, 1, 4)  # one axis a single voxel thick
    grid = rng.uniform(0.0, 1.0, shape).astype(np.float32)
    vol = Volume.from_arrays(np.full(shape, 1500.0), absorption=1.0)
    kernel = Kernel(m, _march_inputs_for(vol))
    points = rng.uniform(-1.0, 1.0, (400, 3)) * 1.2 * np.array(shape) + np.array(shape) / 2
    points[:6] = [(0, 0, 0), (5, 1, 4), (0.25, 0.5, 3.9), (4.75, 0, 0.1), (2.5, 0.5, 2), (-1, 2, 9)]
    p = m.Array3f(*(m.Float(points[:, a].astype(np.float32)) for a in range(3)))
    beyond = np.concatenate([grid.ravel(), np.full(64, np.nan, np.float32)])
    got = np.asarray(kernel.trilinear(m.Float(beyond), kernel.corners(p)))
    padded = np.pad(grid, 1, mode="edge").astype(np.float64)
    u = np.clip(points, 0.0, np.array(shape, dtype=np.float64)) + 0.5  # padded voxel coordinate
    i0 = np.minimum(np.floor(u).astype(int), np.array(shape))
    w = u - i0
    expected = np.zeros(len(points))
    for corner in np.ndindex(2, 2, 2):
        weight = np.prod(np.where(corner, w, 1.0 - w), axis=1)
        expected += weight * padded[tuple((i0 + corner).T)]
    np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-6)


def _march_inputs_for(vol):
    from incandescent.camera import default_camera
    from incandescent.renderer.api import _march_inputs
    from incandescent.renderer.integrators import EmissionAbsorption

    settings, integrator = RenderSettings(width=8, height=8), EmissionAbsorption()
    camera, models = default_camera(vol.bounds_m), integrator.models(vol)
    return _march_inputs(vol, camera, settings, "cpu", integrator, models)


def test_empty_radius_is_the_chebyshev_distance_to_the_nearest_occupied_cell():
    rng = np.random.default_rng(0)
    occupied = rng.random((9, 6, 11)) > 0.985
    cells = np.indices(occupied.shape).reshape(3, -1).T
    nearest = np.abs(cells[:, None, :] - np.argwhere(occupied)[None]).max(axis=2).min(axis=1)
    assert nearest.max() >= 3
    np.testing.assert_array_equal(empty_radius(occupied), nearest.reshape(occupied.shape))
    assert np.all(empty_radius(np.zeros((3, 4, 5), dtype=bool)) == 5)
    full = empty_radius(np.ones((3, 4, 5), dtype=bool))
    assert full.dtype == np.float32 and np.all(full == 0)


@pytest.mark.parametrize(
    "camera",
    [
        Camera(eye=(1.3, 0.4, 0.9), target=(0.0, 0.0, 0.0), fov_deg=55.0),
        Camera(eye=(0.0, 0.0, 2.0), target=(0.0, 0.0, 0.0), fov_deg=40.0),  # axis-parallel rays
        Camera(
            eye=(0.5, 0.8, 1.5),
            target=(0.0, 0.0, 0.0),
            projection="orthographic",
            ortho_height_m=1.2,
        ),
    ],
)
def test_multi_cell_jumps_leave_image_unchanged(jit_backend, camera):
    """Small hot blobs far apart in a big box: rays jump whole blocks of empty macrocells."""
    temp = np.full((40, 40, 40), 300.0)
    for corner in [(3, 5, 4), (30, 28, 6), (18, 33, 31), (6, 20, 34)]:
        x, y, z = corner
        temp[x : x + 4, y : y + 3, z : z + 4] = 1800.0
    vol = Volume.from_arrays(temp)
    s = RenderSettings(width=31, height=27, macrocell_voxels=4)
    assert vol.macrocells(4).empty_radius.max() >= 3
    dense = render(vol, camera, s.replace(skip_empty=False), backend=jit_backend)
    skipped = render(vol, camera, s, backend=jit_backend)
    assert dense.xyz.max() > 0
    np.testing.assert_allclose(skipped.xyz, dense.xyz, rtol=1e-5, atol=1e-7 * dense.xyz.max())
    np.testing.assert_allclose(skipped.transmittance, dense.transmittance, rtol=1e-6, atol=1e-7)
    assert skipped.metadata["samples"] < dense.metadata["samples"] / 3


def test_skipping_leaves_image_unchanged_and_saves_samples(jit_backend):
    vol = scenes.sparse_flame(48, flame_fraction=0.3)
    s = RenderSettings(width=40, height=32, macrocell_voxels=8)
    dense = render(vol, settings=s.replace(skip_empty=False), backend=jit_backend)
    skipped = render(vol, settings=s, backend=jit_backend)
    assert dense.xyz.max() > 0
    np.testing.assert_allclose(skipped.xyz, dense.xyz, rtol=1e-5, atol=1e-7 * dense.xyz.max())
    np.testing.assert_allclose(skipped.transmittance, dense.transmittance, rtol=1e-6, atol=1e-7)
    assert skipped.metadata["samples"] < dense.metadata["samples"] / 3


@pytest.mark.parametrize("cell", [1, 3, 8, 16])
def test_skipping_is_exact_for_any_macrocell_size(cell):
    vol = _random_volume(5, shape=(12, 10, 14))
    s = RenderSettings(width=15, height=11, macrocell_voxels=cell)
    dense = render(vol, settings=s.replace(skip_empty=False), backend="cpu")
    skipped = render(vol, settings=s, backend="cpu")
    np.testing.assert_allclose(skipped.xyz, dense.xyz, rtol=1e-5, atol=1e-7 * dense.xyz.max())


def test_macrocells_include_a_one_voxel_border():
    kappa = np.zeros((16, 16, 16), dtype=np.float32)
    kappa[8, 3, 3] = 1.0  # first voxel of cell x=1; cell x=0 must see it through its border
    cells = build_macrocells(kappa, 8)
    assert cells.shape == (2, 2, 2)
    assert cells.max_absorption[0, 0, 0] == 1.0
    assert cells.max_absorption[1, 0, 0] == 1.0
    assert cells.max_absorption[0, 1, 0] == 0.0


def test_renders_are_reproducible_and_seeded(jit_backend):
    vol = scenes.plume(24)
    s = RenderSettings(width=16, height=16)
    a, b = (render(vol, settings=s, backend=jit_backend).xyz for _ in range(2))
    np.testing.assert_array_equal(a, b)
    c = render(vol, settings=s.replace(seed=7), backend=jit_backend).xyz
    assert not np.array_equal(a, c)
    np.testing.assert_allclose(c.sum(), a.sum(), rtol=0.05)


def test_backend_selection_explicit_env_and_errors(monkeypatch):
    assert resolve_backend("reference") == "reference"
    monkeypatch.setenv("INCANDESCENT_BACKEND", "reference")
    assert resolve_backend("auto") == "reference"
    assert resolve_backend(None) == "reference"
    assert resolve_backend("cpu") == "cpu"  # explicit beats the environment
    monkeypatch.setenv("INCANDESCENT_BACKEND", "gpu")
    with pytest.raises(ValueError, match="environment INCANDESCENT_BACKEND 'gpu'"):
        resolve_backend("auto")
    monkeypatch.delenv("INCANDESCENT_BACKEND")
    with pytest.raises(ValueError, match="unknown backend 'vulkan'; expected one of"):
        resolve_backend("vulkan")
    assert resolve_backend("auto") == available_backends()[0]


@pytest.mark.skipif(cuda_problem() is None, reason="a GPU is present")
def test_cuda_unavailable_is_a_clear_error():
    with pytest.raises(BackendUnavailable, match="backend 'cuda' is unavailable: no NVIDIA GPU"):
        resolve_backend("cuda")
    assert "cuda" not in available_backends()


class _FakeDrJit:
    """Stands in for drjit to exercise the libLLVM checks without the real library state."""

    class JitBackend:
        LLVM, CUDA = "llvm", "cuda"

    def __init__(self, has_llvm: bool, version=(19, 1, 7)):
        self._has_llvm, self._version = has_llvm, version

        class detail:  # noqa: N801 - mirrors drjit.detail
            @staticmethod
            def llvm_version():
                return version

        self.detail = detail

    def has_backend(self, backend):
        return self._has_llvm if backend == "llvm" else False


@pytest.mark.parametrize(
    ("fake", "expected"),
    [
        (_FakeDrJit(False), "Dr.Jit found no libLLVM; the CPU backend needs a shared libLLVM"),
        (_FakeDrJit(True, (15, 0, 6)), "Dr.Jit loaded libLLVM 15.0.6; the CPU backend needs"),
        (_FakeDrJit(True, (19, 1, 7)), None),
    ],
)
def test_llvm_check_names_what_to_install(monkeypatch, fake, expected):
    from incandescent import _jit as jit

    monkeypatch.setattr(jit, "drjit_module", lambda: fake)
    problem = jit.llvm_problem.__wrapped__()
    if expected is None:
        assert problem is None
    else:
        assert problem.startswith(expected)
        assert "apt-get install libllvm19" in problem and "brew install llvm" in problem


def test_kernel_inputs_start_on_cache_lines_so_each_render_traces_one_kernel():
    """Dr.Jit writes a mapped input's alignment into the kernel: lane arrays on 64-byte
    boundaries and chunks of whole 64-byte lines keep one kernel (and its disk-cache entry)."""
    from incandescent.renderer.backends import chunks

    for offset in range(4):
        a = chunks._aligned(np.arange(1000 + offset, dtype=np.uint32)[offset:])
        assert a.ctypes.data % 64 == 0
        np.testing.assert_array_equal(a, np.arange(offset, 1000 + offset))
    sizes = [
        chunks._next_chunk(r, s, u)
        for r in (1 << 15, 50_001)
        for s in (0.01, 0.3)
        for u in (10.0, 777.0)
    ]
    assert all(n % chunks.ALIGN_LANES == 0 and n >= chunks.MIN_CHUNK_RAYS for n in sizes)


def test_a_new_camera_or_seed_reuses_the_compiled_kernel(monkeypatch):
    """Camera placement, field of view and jitter seed are kernel inputs, not constants traced
    into it: a moving camera or a new seed does not compile the megakernel again."""
    from incandescent.renderer.backends import chunks

    seen: list[dict] = []
    real = chunks._compile_seconds
    monkeypatch.setattr(chunks, "_compile_seconds", lambda e: seen.append(e) or real(e))
    vol = scenes.plume(12)
    s = RenderSettings(width=24, height=20, jitter=True)
    render(vol, Camera(eye=(0.1, 0.2, 2.0), fov_deg=40.0), s, backend="cpu")
    seen.clear()
    render(vol, Camera(eye=(1.5, 0.7, 1.2), fov_deg=33.0), s.replace(seed=7), backend="cpu")
    marches = [e for e in seen if "cache_hit" in e]  # compiled kernels (not copies, reductions)
    assert marches and all(e["cache_hit"] for e in marches)
