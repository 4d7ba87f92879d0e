"""The Monte Carlo lights and paths in spectral bins (``integrators.spectral_monte_carlo``): the
fire's own light, uniform skies and multiple scattering per band, σ_s,λ = σ_s·(550/λ)^β
beside soot's κ_λ. Grey laws in bins give the grey render (the same samples); a white furnace
whose σ_s varies 28× across the bins conserves energy in each; a thin slab under a blackbody sky
scatters each bin's light as the closed form; the float64 reference (every nanometre) and
Dr.Jit (bins) walk the same paths."""

from __future__ import annotations

import numpy as np
import pytest
from test_multiple_scattering import _ball

import incandescent as inc
from incandescent.renderer.integrators import MultipleScattering, SingleScattering
from incandescent.renderer.integrators.spectral_monte_carlo import map_bins, map_coefficients
from incandescent.renderer.integrators.spectral_scattering import light_bins, spectral_scale
from incandescent.renderer.lights import (
    DirectionalLight,
    EmissionLight,
    EnvironmentLight,
    EnvironmentMap,
)
from incandescent.scenes import synthetic
from incandescent.spectra.bins import make_bins

SKY = EnvironmentLight(50.0, 8000.0)
#: A coloured lat-long sky: blue above, orange below, a bright patch (RGB × 40 cd/m²).
_RGB = np.zeros((8, 16, 3), np.float32) + np.linspace([0.2, 0.4, 1.0], [1.0, 0.5, 0.1], 8)[:, None]
_RGB[2, 5] = (8.0, 6.0, 2.0)
MAP = EnvironmentMap(_RGB, 40.0)
LIGHTS = (EmissionLight(), SKY, MAP, DirectionalLight((0.3, 1.0, 0.2), 1000.0))
SMALL = inc.RenderSettings(width=5, height=5, jitter=False)


def _plume(soot_alpha: float, beta: float, n: int = 8) -> inc.Volume:
    """A hot, sooty, scattering plume (its own light is most of what it scatters)."""
    volume = inc.Volume.from_arrays(synthetic.plume_temperature(n), absorption=3.0)
    return volume.with_soot_alpha(soot_alpha).with_scattering(6.0, phase_g=0.2,
                                                               scattering_alpha=beta)  # fmt: skip


def _integrators(bins: int):
    """Single scattering and four orders of the fire, a uniform sky, a map and a sun (marched
    shadows)."""
    common = {"lights": LIGHTS, "spp": 2, "spectral_bins": bins, "shadows": "march"}
    return SingleScattering(**common), MultipleScattering(**common, max_bounces=4)


@pytest.mark.parametrize("order", [0, 1], ids=["single", "multiple"])
def test_grey_laws_in_bins_are_the_grey_render(order):
    """α = β = 0 in 8 bins draws the grey render's samples and sums to its image: within 1e-5
    of the brightest pixel (measured 2.3e-7 single, 3.5e-7 four orders)."""
    grey = inc.render(_plume(0, 0), None, SMALL, "cpu", integrator=_integrators(0)[order]).xyz
    bins = inc.render(_plume(0, 0), None, SMALL, "cpu", integrator=_integrators(8)[order]).xyz
    assert np.abs(bins - grey).max() < 1e-5 * grey.max()


@pytest.mark.parametrize("order", [0, 1], ids=["single", "multiple"])
def test_the_reference_and_dr_jit_walk_the_same_spectral_paths(jit_backend, order):
    """Soot α = 1.2, σ_s ∝ λ^−2: Dr.Jit in 64 bins against the float64 reference at every
    nanometre with the same samples, within 0.2 % of the brightest pixel — the bins' own error
    (measured 1.3e-4 single, 5.0e-4 four orders)."""
    volume = _plume(1.2, 2.0, 6)
    ref = inc.render(volume, None, SMALL, "reference", integrator=_integrators(64)[order]).xyz
    jit = inc.render(volume, None, SMALL, jit_backend, integrator=_integrators(64)[order]).xyz
    assert np.abs(jit - ref).max() < 2e-3 * ref.max()


def _sky_bins(sky, bins) -> np.ndarray:
    """A uniform sky's or a uniform map's XYZ radiance per bin, (N, 3)."""
    if isinstance(sky, EnvironmentLight):
        return light_bins(sky, bins, "cie1931_2")
    coefficients = map_coefficients(sky.xyz()[0, 0], "cie1931_2")[0]
    return np.einsum("c,bci->bi", coefficients, map_bins(bins, "cie1931_2"))


@pytest.mark.parametrize(
    "sky",
    [
        EnvironmentLight(100.0),
        EnvironmentMap(np.full((4, 8, 3), (0.5, 1.0, 2.0), np.float32), 60.0),
    ],
    ids=["sky", "map"],
)
def test_a_white_furnace_conserves_energy_in_every_bin(jit_backend, sky):
    """Albedo 1, σ_s ∝ λ^−4 (Rayleigh: 28× from the first bin to the last) under a uniform flat
    sky, or a uniform blue map (its pixels' three flat spectra), of L₀: in each bin b the gas
    gives L₀,b(1 − Tr_b), Tr_b the camera ray's transmittance in that bin (an
    emission–absorption render of κ = σ_s,b) — in X, Y and Z over the image to 1 % at 256 paths
    (measured 1.0009, 0.9989, 1.0019 under the sky; 0.9997, 0.9980, 0.9996 under the map;
    mixing the bands per vertex instead of per path was 8 % dark in Z)."""
    bins = make_bins(8, 0.0)
    camera = inc.Camera(eye=(0.0, 0.05, 0.5), target=(0.0, 0.0, 0.0), fov_deg=25.0)
    settings = inc.RenderSettings(width=12, height=12)
    ball = _ball(100.0, 0.6)
    furnace = MultipleScattering(lights=(sky,), spp=256, max_bounces=1024, spectral_bins=8)
    image = inc.render(ball.replace(scattering_alpha=4.0), camera, settings, jit_backend,
                       integrator=furnace)  # fmt: skip
    expected = np.zeros(3)
    sky_bins = _sky_bins(sky, bins)
    for scale, xyz in zip(spectral_scale(bins.centre_nm, 4.0), sky_bins, strict=True):
        absorbing = inc.Volume.from_arrays(np.full(ball.shape, 300.0), voxel_size_m=0.01,
                                           absorption=ball.scattering_per_m * scale)  # fmt: skip
        tr = inc.render(absorbing, camera, settings, jit_backend).transmittance
        expected += xyz * (1.0 - tr).sum()
    total = image.xyz.reshape(-1, 3).sum(axis=0)
    np.testing.assert_allclose(total, expected, rtol=0.01)


def test_a_thin_slab_scatters_each_bins_sky():
    """A cold, thin slab (optical depth ≤ 4e-3 across its box in every bin) under an 8000 K
    sky, σ_s ∝ λ^−4: each bin scatters σ_s,b·T·L_sky,b toward the camera (the sky's light
    arrives unattenuated to first order), so the image is Σ_b of that to the slab's optical
    depth (measured 0.99971, 0.99978, 0.99957 in X, Y, Z); grey scattering (β = 0) is 54 % short
    in Z."""
    sigma, thickness, beta = 1e-3, 0.2, 4.0
    cold = inc.Volume.from_arrays(np.zeros((40, 4, 10)), absorption=0.0, voxel_size_m=0.02)
    camera = inc.Camera(eye=(0.0, 0.0, 3.0), projection="orthographic", ortho_height_m=0.02)
    settings = inc.RenderSettings(width=1, height=1, jitter=False, step_voxels=0.25)
    bins = make_bins(16, 0.0)
    per_bin = light_bins(SKY, bins, "cie1931_2") * spectral_scale(bins.centre_nm, beta)[:, None]
    expected = per_bin.sum(axis=0) * sigma * thickness
    images = []
    for b in (beta, 0.0):
        slab = cold.with_scattering(sigma, scattering_alpha=b)
        lit = SingleScattering(lights=(SKY,), spp=64, spectral_bins=16)
        images.append(inc.render(slab, camera, settings, "cpu", integrator=lit).xyz[0, 0])
    np.testing.assert_allclose(images[0], expected, rtol=1e-3)
    assert images[1][2] < 0.6 * expected[2]
