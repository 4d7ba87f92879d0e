"""Single scattering in spectral bins (``renderer.integrators.spectral_scattering``): soot's
κ_λ = κ·(550/λ)^α beside σ_s,λ = σ_s·(550/λ)^β, against the closed form of a sunlit slab at
every nanometre (the float64 reference) and in the bins (Dr.Jit), the bins converging to the
nanometre limit, grey laws giving the grey render, Rayleigh's blue, and the bad inputs."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

import incandescent as inc
from incandescent.constants import K_M
from incandescent.renderer.integrators import SingleScattering
from incandescent.renderer.integrators.spectral_scattering import (
    light_bins,
    light_spectrum,
    spectral_scale,
)
from incandescent.renderer.lights import (
    DirectionalLight,
    PointLight,
    SpotLight,
    henyey_greenstein,
)
from incandescent.scenes import synthetic
from incandescent.spectra.bins import make_bins
from incandescent.spectra.cmf import cmfs

KAPPA, SIGMA, G, NZ, H, ALPHA = 1.5, 4.0, 0.3, 10, 0.02, 0.5
SUN = DirectionalLight((np.sin(ALPHA), 0.0, np.cos(ALPHA)), 100.0)
FACE_ON = inc.Camera(eye=(0.0, 0.0, 3.0), projection="orthographic", ortho_height_m=0.02)
ONE_RAY = inc.RenderSettings(width=1, height=1, jitter=False, step_voxels=0.1)


def _slab(soot_alpha: float, beta: float) -> inc.Volume:
    """A cold slab NZ voxels thick along z (κ at 550 nm with soot's α, σ_s at 550 nm with β)."""
    cold = inc.Volume.from_arrays(np.zeros((40, 4, NZ)), absorption=KAPPA, voxel_size_m=H)
    return cold.with_soot_alpha(soot_alpha).with_scattering(SIGMA, phase_g=G, scattering_alpha=beta)


def _slab_radiance(sigma_scale, kappa_scale) -> np.ndarray:
    """L/E per wavelength (or bin) of the sunlit slab seen face on (the grey closed form of
    ``test_single_scattering`` with σ_t,λ = κ k_λ + σ_s s_λ)."""
    sigma_t, m = KAPPA * kappa_scale + SIGMA * sigma_scale, 1.0 + 1.0 / np.cos(ALPHA)
    phase = henyey_greenstein(-np.cos(ALPHA), G)
    thickness = NZ * H
    return SIGMA * sigma_scale * phase * -np.expm1(-sigma_t * thickness * m) / (sigma_t * m)


def _exact_nm(soot_alpha: float, beta: float) -> np.ndarray:
    """The slab's XYZ: K_m Σ_λ x̄ȳz̄ E_λ L_λ/E Δλ over the CIE 1 nm samples."""
    cmf = cmfs()
    lam = cmf.wavelength_nm
    per_nm = light_spectrum(SUN, lam, "cie1931_2") * _slab_radiance(
        spectral_scale(lam, beta), spectral_scale(lam, soot_alpha)
    )
    return K_M * cmf.step_nm * (per_nm[:, None] * cmf.xyz_bar).sum(axis=0)


def _exact_bins(n: int, soot_alpha: float, beta: float) -> np.ndarray:
    """The same slab in ``n`` bins: each bin's XYZ of the sun × the bin's L/E."""
    bins = make_bins(n, soot_alpha)
    per_bin = _slab_radiance(spectral_scale(bins.centre_nm, beta), bins.kappa_scale)
    return (light_bins(SUN, bins, "cie1931_2") * per_bin[:, None]).sum(axis=0)


def _render(
    volume, backend, bins, shadows="march", lights=(SUN,), camera=FACE_ON, settings=ONE_RAY
):
    """The single-scattering render of ``volume`` in ``bins`` spectral bins."""
    lit = SingleScattering(lights=lights, shadows=shadows, spectral_bins=bins)
    return inc.render(volume, camera, settings, backend, integrator=lit)


@pytest.mark.parametrize(("shadows", "rtol"), [("march", 1e-4), ("grid", 2.5e-2)])
def test_the_reference_matches_the_slab_at_every_nanometre(shadows, rtol):
    """Soot α = 1, Rayleigh β = 4: the float64 reference (every 1 nm sample, whatever the bin
    count) is the closed form to the march's error (measured 2.0e-5 to 6.9e-5 marched). The
    grid of optical depths clamps the top half voxel to its centre's depth (the edge rule), an
    error that grows with the optical depth per voxel: measured 0.34 % (Y) and 1.3 % in Z, where
    blue's σ_t·h ≈ 0.33 (0.34 % to 0.38 % with β = 0)."""
    image = _render(_slab(1.0, 4.0), "reference", 8, shadows)
    np.testing.assert_allclose(image.xyz[0, 0], _exact_nm(1.0, 4.0), rtol=rtol)


@pytest.mark.parametrize("backend", [b for b in ALL_BACKENDS if b.id != "reference"])
def test_dr_jit_bins_match_the_binned_slab_and_converge_to_the_nanometre_limit(backend):
    """Dr.Jit in N bins is the binned closed form to 1e-4 (measured 2e-5 to 7e-5); the bins'
    own error against every nanometre falls with N (Z: 3.4 %, 0.62 %, 0.047 % at 4, 16, 64)."""
    errors = []
    for n in (4, 16, 64):
        xyz = _render(_slab(1.0, 4.0), backend, n).xyz[0, 0]
        np.testing.assert_allclose(xyz, _exact_bins(n, 1.0, 4.0), rtol=1e-4)
        errors.append(np.abs(xyz / _exact_nm(1.0, 4.0) - 1).max())
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-3, errors


def test_grey_laws_in_bins_are_the_grey_render():
    """α = β = 0 in 16 bins: the grey single-scattering render to 1e-5 (measured 2e-6)."""
    grey = _render(_slab(0.0, 0.0), "cpu", 0).xyz[0, 0]
    np.testing.assert_allclose(_render(_slab(0.0, 0.0), "cpu", 16).xyz[0, 0], grey, rtol=1e-5)


def _chromaticity_x(xyz) -> float:
    return float(xyz[0] / np.sum(xyz))


def test_rayleigh_scattering_is_bluer_than_the_sun_and_its_shadowed_light_redder():
    """β = 4 (particles ≪ λ): the slab's scattered light is bluer than grey scattering's (lower
    chromaticity x); light that crossed 2 m of such gas to a thin probe layer is redder."""
    grey, rayleigh = (_render(_slab(0.0, b), "cpu", 16).xyz[0, 0] for b in (0.0, 4.0))
    assert _chromaticity_x(rayleigh) < _chromaticity_x(grey) - 0.02
    sigma = np.full((8, 4, 100), 2.0, dtype=np.float32)
    sigma[:, :, :2] = 1e-3  # the probe: a thin, faint layer at the far side from the sun
    cold = inc.Volume.from_arrays(np.zeros(sigma.shape), absorption=0.0, voxel_size_m=H)
    sun = DirectionalLight((0.0, 0.0, 1.0), 100.0)
    camera = inc.Camera(eye=(3.0, 0.0, -0.98), target=(0.0, 0.0, -0.98),
                        projection="orthographic", ortho_height_m=0.01)  # fmt: skip

    def probe(beta):
        volume = cold.with_scattering(sigma, scattering_alpha=beta)
        return _render(volume, "cpu", 16, lights=(sun,), camera=camera).xyz[0, 0]

    assert _chromaticity_x(probe(4.0)) > _chromaticity_x(probe(0.0)) + 0.02


def test_dr_jit_bins_approach_the_reference_with_emission_point_and_spot_lights():
    """A hot, sooty, scattering plume lit by a point and a spot light (58 % of its light
    scattered, the rest its own emission), shadows from the grid: Dr.Jit in 64 bins against the
    float64 reference at every nanometre, within 0.5 % of the brightest pixel (measured 0.13 %)."""
    volume = inc.Volume.from_arrays(synthetic.plume_temperature(12), absorption=3.0)
    volume = volume.with_soot_alpha(1.4).with_scattering(6.0, phase_g=0.2, scattering_alpha=2.0)
    lights = (PointLight((0.3, 0.2, 0.3), 1.0), SpotLight((0.0, 0.6, 0.0), 2.0, None))
    settings = inc.RenderSettings(width=8, height=8, jitter=False)
    ref = _render(volume, "reference", 64, "grid", lights, None, settings).xyz
    cpu = _render(volume, "cpu", 64, "grid", lights, None, settings).xyz
    assert np.abs(cpu - ref).max() < 0.005 * ref.max()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: _slab(1.0, 5.0), r"scattering_alpha must be in \[0, 4\]"),
    ],
)  # fmt: skip
def test_bad_spectral_scattering_is_one_clear_error(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_flags_and_scene_files_scatter_in_spectral_bins(tmp_path):
    """``--spectral-bins 16 --scattering-alpha 4 --sun …`` and ``[volume] scattering_alpha``
    render the Python volume's image; ``--fire-light`` and ``--environment FILE.exr`` render in
    bins."""
    from typer.testing import CliRunner

    from incandescent.cli import app
    from incandescent.io.images import read_exr, write_exr

    np.save(tmp_path / "gas.npy", synthetic.plume_temperature(16))
    common = ["--width", "10", "--height", "12", "--albedo", "0.5", "--spectral-bins", "16"]
    runner = CliRunner()
    flags = ["render", str(tmp_path / "gas.npy"), *common, "--scattering-alpha", "4", "--sun",
             "0,1,0.5,2e4"]  # fmt: skip
    result = runner.invoke(app, [*flags, "-o", str(tmp_path / "a.exr")])
    assert result.exit_code == 0, result.output
    (tmp_path / "s.toml").write_text(
        f'[volume]\npath = "{tmp_path / "gas.npy"}"\nscattering_alpha = 4.0\n'
        "[[light]]\ndirection = [0.0, 1.0, 0.5]\nilluminance_lux = 2e4\n"
    )
    result = runner.invoke(app, ["render", str(tmp_path / "s.toml"), *common, "-o",
                                 str(tmp_path / "b.exr")])  # fmt: skip
    assert result.exit_code == 0, result.output
    volume = inc.Volume.from_arrays(synthetic.plume_temperature(16))
    lit = volume.with_scattering(albedo=0.5, scattering_alpha=4.0)
    sun = DirectionalLight((0.0, 1.0, 0.5), 2e4)
    integrator = SingleScattering(lights=(sun,), spectral_bins=16)
    python = inc.render(lit, None, inc.RenderSettings(width=10, height=12), integrator=integrator)
    a, b = (read_exr(tmp_path / f"{n}.exr")[0][..., :3] for n in "ab")
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(a, python.rgb(), rtol=1e-6, atol=1e-9)
    fire = runner.invoke(app, [*flags, "--fire-light", "--spp", "1", "-o", str(tmp_path / "f.exr")])
    assert fire.exit_code == 0, fire.output
    assert (read_exr(tmp_path / "f.exr")[0][..., 1] > a[..., 1]).any()  # the fire lights it
    write_exr(tmp_path / "sky.exr", np.ones((4, 8, 3), np.float32))
    sky = runner.invoke(app, [*flags, "--environment", str(tmp_path / "sky.exr"), "--spp", "1",
                              "-o", str(tmp_path / "c.exr")])  # fmt: skip
    assert sky.exit_code == 0, sky.output
    assert (read_exr(tmp_path / "c.exr")[0][..., 1] > a[..., 1]).any()  # the map lights it
