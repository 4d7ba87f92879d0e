"""The per-camera in-scatter cache (``renderer.integrators.in_scatter_cache``): against the
transfer integral of a homogeneous emitting cube, against the per-sample estimator on the fire
demo (its bias: the interpolation's and what is left of the logarithm's), backend parity with
the same samples, and the combinations it refuses."""

from __future__ import annotations

import numpy as np
import pytest
from test_emission_light import _blob, _cube_expected

import incandescent as inc
from incandescent.renderer.integrators import MultipleScattering, SingleScattering
from incandescent.renderer.integrators import in_scatter_cache as cache
from incandescent.renderer.lights import EmissionLight, EnvironmentLight
from incandescent.scenes import SCENES

FIRE = (EmissionLight(),)


def _cached(pairs: int, lights=FIRE) -> SingleScattering:
    return SingleScattering(lights=lights, in_scatter="cache", cache_pairs=pairs)


def _cube_pixel(backend: str, integrator):
    """(the render of the emitting cube's central pixel, its transfer integral's luminance)."""
    n, h, kappa, sigma, g, temp = 16, 0.01, 6.0, 14.0, 0.3, 1800.0
    cube = inc.Volume.from_arrays(np.full((n,) * 3, temp), absorption=kappa, voxel_size_m=h)
    cube = cube.with_scattering(sigma, phase_g=g)
    camera = inc.Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), fov_deg=1.0)
    settings = inc.RenderSettings(width=1, height=1, jitter=False)
    got = inc.render(cube, camera, settings, backend, integrator=integrator)
    return got, _cube_expected(n, h, kappa, sigma, g, temp)


def test_a_homogeneous_emitting_cube_matches_the_transfer_integral(jit_backend):
    """The cube of ``test_emission_light`` (uniform T = 1800 K, κ = 6, σ_s = 14 per m, g = 0.3,
    16 voxels of 1 cm), its central pixel, with J cached at the voxel centres (256 samples
    each): within 0.1 % of the transfer integral, as the per-sample estimator at 1024 pairs
    (measured 1.3e-4 and −1.1e-4 at two seeds on cpu: J of a homogeneous cube is smooth, its
    interpolation nearly exact)."""
    got, expected = _cube_pixel(jit_backend, _cached(256))
    assert got.luminance[0, 0] == pytest.approx(expected, rel=1e-3)
    assert got.metadata["in_scatter"] == "cache" and got.metadata["cache_pairs"] == 256


def _blocks(y: np.ndarray) -> np.ndarray:
    return y.reshape(4, 8, 4, 8).mean(axis=(1, 3))


@pytest.mark.slow
def test_the_cache_converges_to_the_per_sample_render_of_the_fire_demo():
    """The fire demo lit by its own fire (albedo 0.7, g = 0.3, its 32 × 48 × 32 voxels), 32²
    pixels without jitter: the cache (64 samples a voxel) against the per-sample render (16
    pairs a sample) — measured at seeds 0 and 1: mean −0.95 % and −1.5 %, median 8×8 block
    0.990 and 0.986, worst bright block 2.7 % and 2.4 % off (the per-sample render's own block
    noise ~0.6 %); at 8 samples a voxel −1.5 % and −1.6 %, worst block 2.9 % and 3.5 %.
    (Interpolated linearly, J overshoots: +13.5 % at 128²; in ln J without the Jensen
    correction, −3.1 % at 8 samples a voxel.)"""
    lit = SCENES["fire"].build(None).with_scattering(albedo=0.7, phase_g=0.3)
    settings = inc.RenderSettings(width=32, height=32, jitter=False)

    def luminance(integrator) -> np.ndarray:
        return inc.render(lit, None, settings, "cpu", integrator=integrator).luminance

    per_sample = luminance(SingleScattering(lights=FIRE, spp=16))
    bright = _blocks(per_sample) > 0.05 * _blocks(per_sample).max()
    for pairs in (64, 8):
        cached = luminance(_cached(pairs))
        assert -0.025 < cached.mean() / per_sample.mean() - 1.0 < 0.005
        ratio = _blocks(cached)[bright] / _blocks(per_sample)[bright]
        assert abs(np.median(ratio) - 1.0) < 0.025
        assert np.abs(ratio - 1.0).max() < 0.05


def test_dr_jit_builds_the_reference_cache_with_the_same_samples(jit_backend):
    """Both backends hash (voxel, sample) into the same directions: the float64 reference's
    cached render and Dr.Jit's agree to 1e-4 with the fire and a sky; another seed draws
    another cache."""
    volume = _blob(8)
    camera = inc.Camera(eye=(0.2, 0.1, 0.4), target=(0.04, 0.04, 0.04), fov_deg=40.0)
    settings = inc.RenderSettings(width=8, height=8)
    lit = _cached(2, lights=(EmissionLight(), EnvironmentLight(500.0)))
    ref = inc.render(volume, camera, settings, "reference", integrator=lit).xyz
    cpu = inc.render(volume, camera, settings, jit_backend, integrator=lit).xyz
    assert np.abs(cpu - ref).max() < 1e-4 * np.abs(ref).max()
    other = inc.render(volume, camera, inc.RenderSettings(width=8, height=8, seed=5),
                       jit_backend, integrator=lit).xyz  # fmt: skip
    assert np.abs(other - cpu).max() > 1e-3 * np.abs(ref).max()


def test_an_orthographic_camera_caches_along_its_forward():
    """Every camera ray of an orthographic camera has its forward direction: the views the
    cache is built for; a pinhole's are the directions from its eye."""
    spec = inc.renderer.rays.ray_spec(
        inc.Camera(eye=(0.0, 0.0, 1.0), target=(0.0, 0.0, 0.0), projection="orthographic"),
        _blob(8), inc.RenderSettings(width=4, height=4),
    )  # fmt: skip
    _, views = cache.centres_and_views(spec, (8, 8, 8), np.arange(512))
    np.testing.assert_allclose(views, np.broadcast_to([0.0, 0.0, -1.0], (512, 3)), atol=1e-12)
    pinhole = spec.__class__(**{**spec.__dict__, "perspective": True})
    centres, views = cache.centres_and_views(pinhole, (8, 8, 8), np.array([0, 511]))
    eye = (np.asarray(spec.eye) - np.asarray(spec.origin_m)) / spec.voxel_size_m
    expected = (centres - eye) / np.linalg.norm(centres - eye, axis=1)[:, None]
    np.testing.assert_allclose(views, expected, atol=1e-12)


def test_only_voxels_a_scattering_lookup_reaches_are_cached():
    sigma = np.zeros((6, 6, 6))
    sigma[2, 3, 3] = 1.0
    index = cache.needed_voxels(sigma)
    assert index.size == 27
    assert set(map(tuple, np.stack(np.unravel_index(index, sigma.shape), axis=1))) == {
        (x, y, z) for x in (1, 2, 3) for y in (2, 3, 4) for z in (2, 3, 4)
    }


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: MultipleScattering(lights=FIRE, in_scatter="cache"), "max_bounces 64"),
        (lambda: SingleScattering(lights=FIRE, in_scatter="cache", spectral_bins=8),
         "spectral_bins 8"),
        (lambda: SingleScattering(lights=FIRE, in_scatter="grid"), "in_scatter"),
        (lambda: _cached(0), "cache_pairs"),
    ],
)  # fmt: skip
def test_what_the_cache_does_not_cover_is_one_line(build, message):
    with pytest.raises(ValueError, match=message) as error:
        build()
    assert "\n" not in str(error.value)


def test_motion_blur_with_the_cache_is_one_line():
    volume = _blob(8)
    volume = volume.with_velocity(np.ones(volume.shape + (3,), dtype=np.float32))
    settings = inc.RenderSettings(width=4, height=4, shutter=(-0.25, 0.25))
    with pytest.raises(ValueError, match="motion blur") as error:
        inc.render(volume, None, settings, "cpu", integrator=_cached(1))
    assert "\n" not in str(error.value)


def test_a_rig_of_cameras_with_the_cache_is_one_line():
    camera = inc.Camera(eye=(0.2, 0.1, 0.4), target=(0.04, 0.04, 0.04))
    rig = inc.camera.Rig((camera, inc.Camera(eye=(-0.2, 0.1, 0.4), target=(0.04, 0.04, 0.04))))
    with pytest.raises(ValueError, match="a rig of 2 cameras") as error:
        inc.render(_blob(8), rig, inc.RenderSettings(width=8, height=4), integrator=_cached(1))
    assert "\n" not in str(error.value)


def test_the_default_estimates_at_every_sample():
    """``in_scatter`` defaults to today's estimator: the render is the one without the key."""
    volume = _blob(8)
    settings = inc.RenderSettings(width=8, height=8)
    a = inc.render(volume, None, settings, "cpu", integrator=SingleScattering(lights=FIRE))
    b = inc.render(volume, None, settings, "cpu",
                   integrator=SingleScattering(lights=FIRE, in_scatter="per-sample"))  # fmt: skip
    np.testing.assert_array_equal(a.xyz, b.xyz)
    assert "in_scatter" not in a.metadata


def test_the_flags_and_scene_keys_ask_for_the_cache(tmp_path):
    """``--in-scatter cache --cache-pairs N`` and ``[integrator] in_scatter = "cache"`` give the
    render of the same volume built in Python; a wrong value or multiple scattering with the
    cache is one line, exit 2, nothing written."""
    from typer.testing import CliRunner

    from incandescent.cli import app
    from incandescent.io.images import read_exr
    from incandescent.scenes import synthetic

    np.save(tmp_path / "gas.npy", synthetic.plume_temperature(12))
    gas = ["render", str(tmp_path / "gas.npy"), "--width", "10", "--height", "8", "--albedo",
           "0.7", "--fire-light"]  # fmt: skip
    runner = CliRunner()
    by_flags = runner.invoke(app, [*gas, "--in-scatter", "cache", "--cache-pairs", "3", "-o",
                                   str(tmp_path / "a.exr")])  # fmt: skip
    assert by_flags.exit_code == 0, by_flags.output
    scene = tmp_path / "lit.toml"
    scene.write_text(
        f'[volume]\npath = "{tmp_path / "gas.npy"}"\nalbedo = 0.7\n[render]\nwidth = 10\n'
        'height = 8\n[integrator]\nin_scatter = "cache"\ncache_pairs = 3\n[[light]]\n'
        'type = "emission"\n'
    )
    by_scene = runner.invoke(app, ["render", str(scene), "-o", str(tmp_path / "b.exr")])
    assert by_scene.exit_code == 0, by_scene.output
    lit = inc.Volume.from_arrays(synthetic.plume_temperature(12)).with_scattering(albedo=0.7)
    python = inc.render(lit, None, inc.RenderSettings(width=10, height=8), integrator=_cached(3))
    a, b = (read_exr(tmp_path / f"{n}.exr")[0] for n in "ab")
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a[..., :3], python.rgb(), rtol=1e-6, atol=1e-9)
    for extra, message in (
        (["--in-scatter", "grid"], "in_scatter"),
        (["--in-scatter", "cache", "--max-bounces", "3"], "max_bounces 3"),
    ):
        bad = runner.invoke(app, [*gas, *extra, "-o", str(tmp_path / "c.exr")])
        assert bad.exit_code == 2 and message in bad.output, bad.output
        assert len(bad.output.strip().splitlines()) == 1, bad.output
    assert not (tmp_path / "c.exr").exists()


def test_the_lit_demo_renders_from_the_cache(tmp_path):
    """``demo campfire --in-scatter cache`` is the campfire lit from the cache (its fire's light
    and sky), close to the per-sample demo; with ``--max-bounces 3`` it is one line."""
    from typer.testing import CliRunner

    from incandescent.cli import app
    from incandescent.io.images import read_exr

    base = ["demo", "campfire", "--width", "24", "--height", "24"]
    runs = {"cache": ["--in-scatter", "cache"], "per_sample": []}
    for name, extra in runs.items():
        result = CliRunner().invoke(app, [*base, *extra, "-o", str(tmp_path / f"{name}.exr")])
        assert result.exit_code == 0, result.output
    cached, per_sample = (read_exr(tmp_path / f"{n}.exr")[0] for n in runs)
    meta = read_exr(tmp_path / "cache.exr")[1]
    assert meta["in_scatter"] == "cache" and meta["cache_pairs"] == "16"
    assert cached[..., 1].sum() == pytest.approx(per_sample[..., 1].sum(), rel=0.05)
    bad = CliRunner().invoke(app, [*base, "--in-scatter", "cache", "--max-bounces", "3", "-o",
                                   str(tmp_path / "bad.exr")])  # fmt: skip
    assert bad.exit_code == 2 and "max_bounces 3" in bad.output, bad.output
    assert not (tmp_path / "bad.exr").exists()


def _coarse(pairs: int, lights=FIRE) -> SingleScattering:
    return SingleScattering(lights=lights, in_scatter="cache", cache_pairs=pairs, cache_voxels=2)


def test_a_cache_of_two_voxel_cells_matches_the_cube_and_the_reference(jit_backend):
    """``cache_voxels = 2``: one estimate per 2×2×2 block, interpolated on that lattice. The
    cube's central pixel (256 samples a cell) within 0.5 % of the transfer integral; both
    backends draw the same samples (1e-4 of the peak, the fire and a sky); its cells reach one
    cell beyond the blocks within a voxel of σ_s > 0; a cell size other than 1 or 2 is one
    line."""
    got, expected = _cube_pixel(jit_backend, _coarse(256))
    assert got.luminance[0, 0] == pytest.approx(expected, rel=5e-3)
    assert got.metadata["cache_voxels"] == 2
    volume = _blob(8)
    view = inc.Camera(eye=(0.2, 0.1, 0.4), target=(0.04, 0.04, 0.04), fov_deg=40.0)
    lit = _coarse(2, lights=(EmissionLight(), EnvironmentLight(500.0)))
    small = inc.RenderSettings(width=8, height=8)
    ref = inc.render(volume, view, small, "reference", integrator=lit).xyz
    fast = inc.render(volume, view, small, jit_backend, integrator=lit).xyz
    assert np.abs(fast - ref).max() < 1e-4 * np.abs(ref).max()
    one = np.zeros((7, 6, 6))
    one[4, 3, 3] = 1.0  # within a voxel: x 3–5 → blocks 1–2; y, z 2–4 → blocks 1–2
    cells = cache.needed_voxels(one, 2)
    assert cache.lattice(one.shape, 2) == (4, 3, 3)
    assert set(map(tuple, np.stack(np.unravel_index(cells, (4, 3, 3)), axis=1))) == {
        (x, y, z) for x in (0, 1, 2, 3) for y in (0, 1, 2) for z in (0, 1, 2)
    }
    with pytest.raises(ValueError, match=r"cache_voxels must be one of \(1, 2\); got 3"):
        SingleScattering(lights=FIRE, in_scatter="cache", cache_voxels=3)
