"""Species line emission in the renderers: η = κB(T) + Σ f_s E_s(T), E_s = species_xyz · 1/m."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.camera import Camera
from incandescent.colorimetry import xyz_to_xy
from incandescent.renderer import RenderSettings, render
from incandescent.spectra import blackbody_xyz
from incandescent.spectra.lines import load_lines, species_xyz
from incandescent.volume import Volume

FACE_ON = Camera(eye=(0, 0, 3.0), target=(0, 0, 0), projection="orthographic", ortho_height_m=0.2)
TABLE = load_lines()


def _slab(temperature_K: float, kappa: float, species: dict) -> Volume:
    shape = (4, 4, 10)  # 1 m thick along z
    return Volume.from_arrays(
        np.full(shape, temperature_K), absorption=kappa, voxel_size_m=0.1, species=species
    )


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_clean_flame_lines_integrate_to_fraction_times_path(backend):
    """κ = 0: L = f·E_s(T)·ℓ exactly (optically thin lines, no continuum)."""
    vol = _slab(2200.0, 0.0, {"Na": 0.3})
    img = render(vol, FACE_ON, RenderSettings(width=3, height=3), backend=backend)
    expected = 0.3 * species_xyz(TABLE, "Na", 2200.0) * 1.0
    np.testing.assert_allclose(img.xyz[1, 1], expected, rtol=2e-4)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_lines_and_soot_together_follow_the_slab_solution(backend):
    """L = (κB + fE)(1 − e^{−κℓ})/κ for a uniform slab."""
    kappa, f, t = 1.5, 0.2, 1900.0
    vol = _slab(t, kappa, {"Li": f})
    img = render(vol, FACE_ON, RenderSettings(width=3, height=3), backend=backend)
    eta = kappa * blackbody_xyz(t) + f * species_xyz(TABLE, "Li", t)
    np.testing.assert_allclose(img.xyz[1, 1], eta * -np.expm1(-kappa) / kappa, rtol=5e-4)


def test_pure_sodium_renders_the_d_line_chromaticity(jit_backend):
    img = render(
        _slab(2000.0, 0.0, {"Na": 1.0}),
        FACE_ON,
        RenderSettings(width=3, height=3),
        backend=jit_backend,
    )
    np.testing.assert_allclose(xyz_to_xy(img.xyz[1, 1]), [0.570, 0.429], atol=2e-3)


def test_species_cpu_matches_reference_and_skipping_is_exact(jit_backend):
    rng = np.random.default_rng(4)
    shape = (8, 7, 9)
    temp = rng.uniform(900.0, 3000.0, shape)
    kappa = rng.uniform(0.0, 3.0, shape) * (rng.random(shape) > 0.5)
    species = {"Na": rng.uniform(0, 0.5, shape) * (rng.random(shape) > 0.6), "Sr": 0.1}
    vol = Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.05, species=species)
    cam = Camera(eye=(0.6, 0.4, 0.7), target=(0, 0, 0), fov_deg=45.0)
    s = RenderSettings(width=17, height=13)
    ref = render(vol, cam, s, backend="reference").xyz
    fast = render(vol, cam, s, backend=jit_backend).xyz
    np.testing.assert_allclose(fast, ref, rtol=2e-4, atol=1e-6 * ref.max())
    dense = render(vol, cam, s.replace(skip_empty=False), backend=jit_backend).xyz
    np.testing.assert_allclose(fast, dense, rtol=1e-5, atol=1e-7 * ref.max())


def test_species_only_cells_are_not_skipped(jit_backend):
    """A sodium cloud with κ = 0 everywhere must not be skipped as empty space."""
    temp = np.full((16, 16, 16), 2000.0)
    sodium = np.zeros_like(temp)
    sodium[6:10, 6:10, 6:10] = 1.0
    vol = Volume.from_arrays(temp, absorption=0.0, species={"Na": sodium})
    s = RenderSettings(width=8, height=8, macrocell_voxels=4)
    skipped = render(vol, settings=s, backend=jit_backend)
    dense = render(vol, settings=s.replace(skip_empty=False), backend=jit_backend)
    assert skipped.xyz.max() > 0
    np.testing.assert_allclose(skipped.xyz, dense.xyz, rtol=1e-5, atol=1e-7 * dense.xyz.max())


def test_unknown_species_is_a_clear_error(jit_backend):
    vol = _slab(2000.0, 1.0, {"Unobtainium": 0.5})
    with pytest.raises(ValueError, match="species 'Unobtainium', which the line table"):
        render(vol, FACE_ON, RenderSettings(width=2, height=2), backend=jit_backend)
