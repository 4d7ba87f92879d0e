"""The emission-model interface (``incandescent.emission``): a new model is one class, models
compose (species lines in spectral bins), and every model checks against its closed form on every
backend."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.camera import Camera
from incandescent.emission import BlackbodyGrey, Emission, EmissionModel
from incandescent.renderer import EmissionAbsorption, Paper2011, RenderSettings, render
from incandescent.scenes import plume_temperature
from incandescent.spectra import blackbody_xyz
from incandescent.spectra.lut import T_MAX_K, build_emission_lut
from incandescent.volume import Volume


class ConstantGlow(EmissionModel):
    """A toy model: a constant emission coefficient η = ``xyz_per_m`` per metre wherever the gas
    is at least 250 K (the tables' T_min), whatever κ. The whole of what adding a model takes."""

    name = "constant-glow"
    kind = "coefficient"

    def __init__(self, xyz_per_m) -> None:
        self.xyz = np.asarray(xyz_per_m, dtype=np.float64)
        constant = lambda t: np.zeros(np.shape(t) + (3,)) + self.xyz  # noqa: E731
        self.tables = (build_emission_lut(T_MAX_K, constant),)

    def add(self, kernel, bound, eta, band, position, values):
        return eta + kernel.lookup(bound[0][band], position)

    def reference_add(self, eta, temperature_K, values, inputs):
        return eta + self.xyz


def _face_on() -> Camera:
    return Camera(eye=(0.0, 0.0, 3.0), projection="orthographic", ortho_height_m=0.3)


@pytest.mark.parametrize("backend", ["reference", "jit"])
def test_a_toy_model_is_one_class(backend, jit_backend):
    """Uniform slab, thickness ℓ: L = B(T)(1 − e^{−κℓ}) + η(1 − e^{−κℓ})/κ (Kirchhoff plus a
    constant thin emitter, integrated exactly)."""
    backend = jit_backend if backend == "jit" else "reference"
    kappa, length_m, glow = 0.7, 1.0, np.array([1e4, 3e4, 2e4])
    slab = Volume.from_arrays(np.full((4, 4, 10), 2000.0), absorption=kappa, voxel_size_m=0.1)
    models = (BlackbodyGrey(), ConstantGlow(glow))
    image = render(slab, _face_on(), RenderSettings(width=5, height=5), backend, models=models)
    absorbed = -np.expm1(-kappa * length_m)
    expected = blackbody_xyz(2000.0) * absorbed + glow * absorbed / kappa
    np.testing.assert_allclose(image.xyz[2, 2], expected, rtol=2e-4)


def _lines_volume(n: int = 20) -> Volume:
    temp = plume_temperature(n)
    lithium = np.clip((temp - 300.0) / 1700.0, 0.0, 1.0) * 0.02
    return Volume.from_arrays(temp, absorption=1.5, species={"Na": 0.02, "Li": lithium})


def test_species_in_one_grey_bin_equal_the_table_mode(jit_backend):
    volume = _lines_volume()
    s = RenderSettings(width=24, height=20)
    grey = render(volume, None, s, jit_backend)
    flat = volume.with_soot_alpha(0.0)
    for bins in (1, 6):
        banded = render(flat, None, s, jit_backend, integrator=EmissionAbsorption(bins))
        np.testing.assert_allclose(banded.xyz, grey.xyz, rtol=1e-5, atol=1e-5 * grey.xyz.max())


def test_species_in_bins_converge_to_the_1nm_reference(jit_backend):
    """Soot α = 1.39 with lines: the bins' error against the 1 nm march falls as N grows."""
    volume = _lines_volume().with_soot_alpha(1.39)
    s = RenderSettings(width=24, height=20)
    exact = render(volume, None, s, "reference", integrator=EmissionAbsorption(4)).xyz  # 1 nm
    errors = []
    for bins in (2, 8, 32):
        image = render(volume, None, s, jit_backend, integrator=EmissionAbsorption(bins))
        errors.append(np.abs(image.xyz - exact).max() / exact.max())
    assert errors[0] > errors[1] > errors[2] and errors[2] < 2e-3, errors


def test_reference_lines_per_nm_equal_the_table_mode():
    """The 1 nm reference with grey soot (α = 0) sums the species spectra to species_xyz."""
    volume = _lines_volume(12)
    s = RenderSettings(width=12, height=10)
    grey = render(volume, None, s, "reference")
    flat = volume.with_soot_alpha(0.0)
    per_nm = render(flat, None, s, "reference", integrator=EmissionAbsorption(3))
    np.testing.assert_allclose(per_nm.xyz, grey.xyz, rtol=1e-9, atol=1e-9 * grey.xyz.max())


def test_the_integrators_pick_and_compose_their_models():
    volume = _lines_volume(8)
    assert [m.name for m in Emission().models(volume)] == ["blackbody", "lines"]
    assert [m.name for m in EmissionAbsorption().models(volume)] == ["blackbody", "lines"]
    banded = EmissionAbsorption(spectral_bins=5).models(volume)
    assert [m.name for m in banded] == ["blackbody-bins", "lines"]
    assert all(len(m.tables) == 5 * (1 if m.name != "lines" else 2) for m in banded)
    assert Paper2011().models(volume) == ()  # the paper's colour is its own, not models
