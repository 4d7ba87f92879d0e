"""Analytic renders (DESIGN.md §5): the marchers against closed-form solutions."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.camera import Camera
from incandescent.renderer import RenderSettings, render
from incandescent.spectra import blackbody_xyz
from incandescent.volume import Remap, Volume


def _face_on(depth_m: float) -> Camera:
    """Orthographic camera looking down −z at the face z = +depth/2 of a box centred at 0.

    The view (0.3 m) lies inside the 0.4 m wide slab, so no pixel centre grazes a side face
    (whether such a ray hits is decided by rounding, differently in float32 and float64)."""
    return Camera(
        eye=(0.0, 0.0, depth_m),
        target=(0.0, 0.0, 0.0),
        projection="orthographic",
        ortho_height_m=0.3,
    )


def _slab(temperature_K: float, kappa: float, shape=(4, 4, 10)) -> Volume:
    return Volume.from_arrays(np.full(shape, temperature_K), absorption=kappa, voxel_size_m=0.1)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_empty_volume_renders_black(backend):
    cold = Volume.from_arrays(np.full((6, 6, 6), 300.0))  # default absorption: none below 500 K
    img = render(cold, settings=RenderSettings(width=16, height=12), backend=backend)
    assert img.xyz.shape == (12, 16, 3)
    assert np.all(img.xyz == 0.0)
    assert np.all(img.transmittance == 1.0)


@pytest.mark.parametrize("step", [0.13, 0.5, 1.0, 3.7])
@pytest.mark.parametrize("optical_depth", [0.01, 0.3, 1.0, 5.0, 20.0])
@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_uniform_slab_matches_kirchhoff_solution(optical_depth, step, backend):
    """Face-on slab of thickness ℓ: Y = Y_bb(T)·(1 − e^{−κℓ}) for any step size (rtol 1e-3)."""
    thickness_m = 1.0
    kappa = optical_depth / thickness_m
    vol = _slab(2500.0, kappa)
    s = RenderSettings(width=5, height=5, step_voxels=step)
    expected = blackbody_xyz(2500.0) * -np.expm1(-optical_depth)
    img = render(vol, _face_on(3.0), s, backend=backend)
    np.testing.assert_allclose(img.xyz[2, 2], expected, rtol=1e-3, err_msg=backend)
    np.testing.assert_allclose(img.xyz, np.broadcast_to(expected, img.xyz.shape), rtol=1e-3)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_thick_slab_saturates_to_blackbody_and_terminates_early(backend):
    vol = _slab(1800.0, 200.0)
    s = RenderSettings(width=3, height=3)
    img = render(vol, _face_on(3.0), s, backend=backend)
    np.testing.assert_allclose(img.xyz[1, 1], blackbody_xyz(1800.0), rtol=1e-3)
    assert img.transmittance.max() < 1e-4
    full_samples = 9 * 10 / 0.5  # every ray would take 20 samples without early termination
    assert img.metadata["samples"] < full_samples / 4


def _two_layer(t_front: float, k_front: float, t_back: float, k_back: float) -> Volume:
    """Layers along z, 200 voxels each (the camera at +z sees the front layer first)."""
    temp = np.empty((2, 2, 400))
    kappa = np.empty_like(temp)
    temp[..., 200:], kappa[..., 200:] = t_front, k_front
    temp[..., :200], kappa[..., :200] = t_back, k_back
    return Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.005)


def _two_layer_solution(t_front, tau_front, t_back, tau_back) -> np.ndarray:
    """L = B_f (1 − e^{−τ_f}) + e^{−τ_f} B_b (1 − e^{−τ_b})."""
    front = blackbody_xyz(t_front) * -np.expm1(-tau_front)
    return front + np.exp(-tau_front) * blackbody_xyz(t_back) * -np.expm1(-tau_back)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_hot_behind_cold_differs_from_cold_behind_hot_as_two_layer_solution(backend):
    """Each layer is 1 m thick; the one-voxel blend at the interface bounds the error (< 1 %)."""
    hot, cold, k_hot, k_cold = 2400.0, 1500.0, 0.8, 1.5
    cam = Camera(eye=(0, 0, 5.0), target=(0, 0, 0), projection="orthographic", ortho_height_m=0.004)
    s = RenderSettings(width=2, height=2, jitter=False)
    hot_front = render(_two_layer(hot, k_hot, cold, k_cold), cam, s, backend=backend).xyz[0, 0]
    cold_front = render(_two_layer(cold, k_cold, hot, k_hot), cam, s, backend=backend).xyz[0, 0]
    np.testing.assert_allclose(hot_front, _two_layer_solution(hot, k_hot, cold, k_cold), rtol=1e-2)
    np.testing.assert_allclose(cold_front, _two_layer_solution(cold, k_cold, hot, k_hot), rtol=1e-2)
    assert hot_front[1] > 3 * cold_front[1]  # the cold layer in front hides most of the hot one


def _mirror_symmetric_field(n: int = 24) -> np.ndarray:
    """Symmetric under x → −x, with the edge layers cold (the paper's artefact case)."""
    x, y, z = np.meshgrid(*(np.linspace(-1, 1, n),) * 3, indexing="ij")
    temp = 300.0 + 2200.0 * np.exp(-(x**2 + 1.5 * (y - 0.2) ** 2 + (z + 0.3 * y) ** 2) * 3)
    temp[[0, -1], :, :] = 300.0
    temp[:, :, -3:] = 450.0
    return 0.5 * (temp + temp[::-1])  # exactly symmetric despite linspace rounding


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_mirror_symmetric_volume_renders_mirror_symmetric_image(backend, projection):
    temp = _mirror_symmetric_field()
    assert np.array_equal(temp, temp[::-1])
    vol = Volume.from_arrays(temp, absorption=np.where(temp > 400, 3.0, 0.2))
    cam = Camera(
        eye=(0.0, 0.4, 2.5),
        target=(0.0, 0.0, 0.0),
        fov_deg=35.0,
        projection=projection,
        ortho_height_m=1.2,
    )
    img = render(vol, cam, RenderSettings(width=20, height=14, jitter=False), backend=backend)
    y = img.xyz[..., 1]
    assert y.max() > 0
    np.testing.assert_allclose(y, y[:, ::-1], rtol=2e-5, atol=1e-6 * y.max())


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_jittered_mirror_symmetric_render_is_symmetric_within_jitter_noise(backend):
    temp = _mirror_symmetric_field()
    vol = Volume.from_arrays(temp)
    cam = Camera(eye=(0.0, 0.3, 2.5), target=(0.0, 0.0, 0.0), fov_deg=35.0)
    s = RenderSettings(width=20, height=14, supersample=2, step_voxels=0.25)
    y = render(vol, cam, s, backend=backend).xyz[..., 1]
    assert np.abs(y - y[:, ::-1]).max() < 0.02 * y.max()


def test_cutoff_makes_cold_voxels_vacuum(jit_backend):
    """With a remap cutoff, voxels below it neither emit nor absorb: same as T = 0, κ = 0 there."""
    temp = np.full((4, 4, 10), 2000.0)
    temp[..., 5:] = 900.0  # front half (camera at +z) is cooler and absorbs
    s = RenderSettings(width=3, height=3)
    cut = Volume.from_arrays(temp, absorption=1.0, voxel_size_m=0.1, remap=Remap(cutoff_K=1000.0))
    vacuum_temp = np.where(temp < 1000.0, 0.0, temp)
    vacuum = Volume.from_arrays(
        vacuum_temp, absorption=np.where(temp < 1000.0, 0.0, 1.0), voxel_size_m=0.1
    )
    uncut = Volume.from_arrays(temp, absorption=1.0, voxel_size_m=0.1)
    a, b, c = (
        render(v, _face_on(3.0), s, backend=jit_backend).xyz[1, 1] for v in (cut, vacuum, uncut)
    )
    np.testing.assert_array_equal(a, b)
    assert a[1] > 1.2 * c[1]  # without the cutoff the 900 K half absorbs the light behind it


def test_emission_scale_multiplies_emission_only(jit_backend):
    vol = _slab(2200.0, 1.0)
    scaled = Volume.from_arrays(
        np.full((4, 4, 10), 2200.0), absorption=1.0, voxel_size_m=0.1, emission_scale=3.0
    )
    s = RenderSettings(width=3, height=3)
    a = render(vol, _face_on(3.0), s, backend=jit_backend)
    b = render(scaled, _face_on(3.0), s, backend=jit_backend)
    np.testing.assert_allclose(b.xyz, 3.0 * a.xyz, rtol=1e-5)
    np.testing.assert_allclose(b.transmittance, a.transmittance, rtol=1e-6)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_depth_is_distance_to_first_emitting_sample(backend):
    """Slab faces at z = ±0.5 m, camera plane at z = 3 m: depth lies within the first step."""
    vol = _slab(2000.0, 1.0)
    img = render(vol, _face_on(3.0), RenderSettings(width=3, height=3), backend=backend)
    step_m = 0.5 * vol.voxel_size_m
    assert img.depth_m is not None
    assert np.all((img.depth_m >= 2.5) & (img.depth_m <= 2.5 + step_m))
    cold = Volume.from_arrays(np.full((4, 4, 4), 300.0))
    empty = render(cold, _face_on(3.0), RenderSettings(width=3, height=3), backend=backend)
    assert np.all(np.isinf(empty.depth_m))


def test_depth_matches_between_backends_and_reaches_the_exr(tmp_path, jit_backend):
    from incandescent.io.images import read_exr
    from incandescent.output import save_image

    temp = _mirror_symmetric_field()
    vol = Volume.from_arrays(temp)
    cam = Camera(eye=(0.4, 0.3, 2.5), target=(0.0, 0.0, 0.0), fov_deg=35.0)
    s = RenderSettings(width=12, height=9, supersample=2)
    ref, fast = (render(vol, cam, s, backend=b) for b in ("reference", jit_backend))
    hit = np.isfinite(ref.depth_m)
    assert hit.any() and (~hit).any()
    np.testing.assert_array_equal(np.isfinite(fast.depth_m), hit)
    np.testing.assert_allclose(fast.depth_m[hit], ref.depth_m[hit], rtol=1e-5)
    _, meta, extra = read_exr(save_image(fast, tmp_path / "d.exr"))
    np.testing.assert_array_equal(extra["Z"], fast.depth_m)
    assert "first emitting sample" in meta["Z"]
