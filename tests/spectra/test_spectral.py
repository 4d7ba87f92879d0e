"""Spectral mode: soot absorption κ_λ = κ·(550 nm/λ)^α marched in N bins (DESIGN.md §3)."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.camera import Camera
from incandescent.colorimetry import xyz_to_xy
from incandescent.renderer import EmissionAbsorption, Paper2011, RenderSettings, render
from incandescent.spectra import blackbody_xyz
from incandescent.spectra.bins import bin_xyz, make_bins
from incandescent.volume import Volume


def _random_volume(seed: int) -> Volume:
    rng = np.random.default_rng(seed)
    shape = (7, 8, 6)
    temp = rng.uniform(900.0, 3000.0, shape)
    kappa = rng.uniform(0.0, 8.0, shape) * (rng.random(shape) > 0.3)
    return Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.05)


CAMERA = Camera(eye=(0.5, 0.35, 0.6), target=(0, 0, 0), fov_deg=50.0)


def test_bins_partition_the_blackbody_table():
    bins = make_bins(12, 1.39)
    temps = np.array([800.0, 2000.0, 6500.0])
    np.testing.assert_allclose(bin_xyz(bins, temps).sum(axis=-2), blackbody_xyz(temps), rtol=1e-12)
    assert np.all(np.diff(bins.kappa_scale) < 0)  # soot absorbs more in the blue


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_grey_kappa_spectral_mode_equals_table_mode(backend):
    vol = _random_volume(1)
    s = RenderSettings(width=9, height=7)
    lut = render(vol, CAMERA, s, backend=backend).xyz
    flat = vol.with_soot_alpha(0.0)
    grey = render(flat, CAMERA, s, backend=backend, integrator=EmissionAbsorption(8)).xyz
    np.testing.assert_allclose(grey, lut, rtol=1e-3, atol=1e-6 * lut.max())


def test_n_bin_result_converges_to_the_1nm_reference(jit_backend):
    """Measured: max error / max 0.040, 0.018, 0.0075 for 2, 4, 8 bins (0.0021 for 16)."""
    vol = _random_volume(2).with_soot_alpha(1.39)
    s = RenderSettings(width=13, height=9)
    ref = render(vol, CAMERA, s, "reference", integrator=EmissionAbsorption(1)).xyz
    errors = []
    for n in (2, 4, 8):
        fast = render(vol, CAMERA, s, jit_backend, integrator=EmissionAbsorption(n)).xyz
        errors.append(np.abs(fast - ref).max() / ref.max())
    assert errors[-1] < 1e-2
    assert errors[2] < errors[1] < errors[0]
    assert errors[-1] < errors[0] / 4


def test_soot_makes_transmitted_light_redder(jit_backend):
    """A hot thin emitter seen through a cold soot layer: α > 0 removes more blue than red."""
    temp = np.full((2, 2, 40), 300.0)
    kappa = np.zeros_like(temp)
    temp[..., :20], kappa[..., :20] = 2500.0, 0.5  # back: hot, thin
    kappa[..., 20:] = 4.0  # front: cold soot (camera at +z)
    vol = Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.025)
    cam = Camera(eye=(0, 0, 3.0), target=(0, 0, 0), projection="orthographic", ortho_height_m=0.02)
    s, bins = RenderSettings(width=2, height=2), EmissionAbsorption(spectral_bins=8)
    grey = render(vol.with_soot_alpha(0.0), cam, s, jit_backend, integrator=bins).xyz[0, 0]
    soot = render(vol.with_soot_alpha(1.39), cam, s, jit_backend, integrator=bins).xyz[0, 0]
    assert xyz_to_xy(soot)[0] > xyz_to_xy(grey)[0] + 0.01  # redder (larger x)


def test_spectral_jit_backend_is_within_the_bin_error_of_the_reference(jit_backend):
    vol = _random_volume(3).with_soot_alpha(1.0)
    s = RenderSettings(width=11, height=9)
    ref = render(vol, CAMERA, s, "reference", integrator=EmissionAbsorption(1)).xyz
    fast = render(vol, CAMERA, s, jit_backend, integrator=EmissionAbsorption(8)).xyz
    assert np.abs(fast - ref).max() < 1e-2 * ref.max()


def test_spectral_settings_are_validated():
    with pytest.raises(ValueError, match="spectral_bins must be in 0..64"):
        EmissionAbsorption(spectral_bins=100)
    with pytest.raises(ValueError, match=r"soot_alpha must be in \[0, 4\]"):
        _random_volume(1).with_soot_alpha(5.0)
    with pytest.raises(TypeError):  # bins belong to emission–absorption, not to the paper's sums
        Paper2011(spectral_bins=4)  # type: ignore[call-arg]
