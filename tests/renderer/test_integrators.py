"""Integrators are plugins (``incandescent.renderer.integrators``): a new transport is one class
and one registry line — no backend file changes — and it renders on the float64 reference and
on Dr.Jit; the built-in ones are reachable from scene dicts, and the old ``[render]`` keys and
flags keep working."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.api import volume_from_section
from incandescent.camera import Camera
from incandescent.config import scene_from_dict
from incandescent.emission import Emission
from incandescent.renderer import EmissionAbsorption, Paper2011, RenderSettings, render
from incandescent.renderer.backends.common import trilinear
from incandescent.renderer.integrators import (
    INTEGRATORS,
    Integrator,
    Reference,
    Traced,
    integrator_from_dict,
    register,
)
from incandescent.volume import Volume


class OpticalDepth(Integrator):
    """A toy transport: the optical depth τ = ∫κ ds along the ray in all three channels, and
    Tr = e^{−τ} (what an X-ray image of the absorption shows). The whole of what adding an
    integrator takes: host parameters, a traced step and a float64 step."""

    name = "optical_depth"

    def models(self, volume) -> tuple:
        return ()

    def traced(self, kernel) -> Traced:
        return _TracedDepth(kernel)

    def reference(self, inputs) -> Reference:
        return _ReferenceDepth(inputs)


class _TracedDepth(Traced):
    def interacts(self, kappa, temp, sampled):
        absorbs = kappa > 0.0
        return absorbs, absorbs

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        x = kappa * ds_m
        return tr * self.kernel.dr.exp(-x), L + x


class _ReferenceDepth(Reference):
    def step(self, segment, xyz, tr):
        kappa = trilinear(self.inputs.volume.absorption_per_m, segment.p)
        x = kappa * segment.ds_m
        xyz[segment.r] += x[:, None]
        tr[segment.r] *= np.exp(-x)
        return kappa > 0


@pytest.fixture
def optical_depth():
    register(OpticalDepth)
    yield OpticalDepth
    INTEGRATORS.pop(OpticalDepth.name)


FACE_ON = Camera(eye=(0.0, 0.0, 3.0), projection="orthographic", ortho_height_m=0.3)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize("step", [0.3, 0.5, 1.0])
def test_a_toy_integrator_is_one_class_on_every_backend(optical_depth, backend, step):
    """Uniform slab of thickness ℓ: τ = κℓ exactly for any step (the segments tile the ray)."""
    kappa, length_m = 0.7, 1.0
    slab = Volume.from_arrays(np.full((4, 4, 10), 2000.0), absorption=kappa, voxel_size_m=0.1)
    settings = RenderSettings(width=5, height=5, step_voxels=step)
    image = render(slab, FACE_ON, settings, backend, integrator=integrator_from_dict(
        {"type": "optical_depth"}))  # fmt: skip
    np.testing.assert_allclose(image.xyz[2, 2], kappa * length_m, rtol=1e-5)
    np.testing.assert_allclose(image.transmittance[2, 2], np.exp(-kappa * length_m), rtol=1e-5)
    assert image.metadata["integrator"] == "optical_depth"


def test_the_toy_integrator_on_dr_jit_matches_the_reference(optical_depth, jit_backend):
    rng = np.random.default_rng(4)
    temp = rng.uniform(0.0, 3000.0, (9, 7, 8))
    vol = Volume.from_arrays(temp, absorption=rng.uniform(0.0, 3.0, temp.shape) * (temp > 900))
    cam = Camera(eye=(0.9, 0.5, 1.1), target=(0.0, 0.0, 0.0), fov_deg=45.0)
    settings = RenderSettings(width=17, height=13)
    ref = render(vol, cam, settings, "reference", integrator=OpticalDepth())
    fast = render(vol, cam, settings, jit_backend, integrator=OpticalDepth())
    assert ref.xyz.max() > 0.1  # the rays cross absorbing gas
    np.testing.assert_allclose(fast.xyz, ref.xyz, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(fast.transmittance, ref.transmittance, rtol=1e-4, atol=1e-6)
    skipped = render(vol, cam, settings.replace(skip_empty=False), jit_backend,
                     integrator=OpticalDepth())  # fmt: skip
    np.testing.assert_allclose(skipped.xyz, fast.xyz, rtol=1e-5, atol=1e-7)


def test_a_registered_integrator_is_chosen_by_a_scene_file(optical_depth, tmp_path):
    np.save(tmp_path / "gas.npy", np.full((4, 4, 4), 1500.0))
    scene = scene_from_dict(
        {"volume": {"path": str(tmp_path / "gas.npy")}, "integrator": {"type": "optical_depth"}}
    )
    assert isinstance(scene.render_integrator(), OpticalDepth)


def test_integrator_dicts_build_the_built_in_integrators_and_name_bad_keys():
    assert integrator_from_dict({}) == EmissionAbsorption()
    bins = integrator_from_dict({"type": "emission_absorption", "spectral_bins": 4})
    assert bins == EmissionAbsorption(spectral_bins=4)
    emission = Emission(observer="cie1964_10")
    assert integrator_from_dict({}, emission=emission).emission == emission
    paper = integrator_from_dict({"type": "paper2011", "exponent": 2.0}, emission=emission)
    assert paper == Paper2011(exponent=2.0)  # the paper's colour takes no emission models
    with pytest.raises(ValueError, match="unknown integrator 'volpath'; expected one of"):
        integrator_from_dict({"type": "volpath"})
    with pytest.raises(ValueError, match="integrator 'paper2011' has no parameter 'spectral_bins'"):
        integrator_from_dict({"type": "paper2011", "spectral_bins": 4})
    with pytest.raises(TypeError, match="must subclass incandescent Integrator"):
        register(dict)  # type: ignore[arg-type]


def _scene(tmp_path, **sections):
    np.save(tmp_path / "gas.npy", np.full((4, 4, 4), 1500.0))
    return scene_from_dict({"volume": {"path": str(tmp_path / "gas.npy")}, **sections})


def test_the_old_render_keys_are_read_into_their_sections(tmp_path):
    """Scene files written before the integrators keep working, with one FutureWarning per key."""
    old = {"brightness": "paper", "paper_exponent": 2.0, "paper_min_K": 900.0, "width": 8}
    with pytest.warns(FutureWarning, match="render.brightness is now integrator.type"):
        scene = _scene(tmp_path, render=old)
    assert scene.render_integrator() == Paper2011(exponent=2.0, min_K=900.0)
    assert scene.render_settings().width == 8
    keys = {"spectral_bins": 4, "soot_alpha": 1.39, "observer": "cie1964_10", "constants": "cie"}
    with pytest.warns(FutureWarning):
        scene = _scene(tmp_path, render=keys)
    assert scene.render_integrator() == EmissionAbsorption(4, Emission("cie1964_10", "cie"))
    assert scene.volume.soot_alpha == 1.39


def test_an_old_key_and_its_new_spelling_together_are_refused(tmp_path):
    with pytest.raises(ValueError, match="render.brightness and integrator.type both given"):
        _scene(tmp_path, render={"brightness": "paper"}, integrator={"type": "paper2011"})


def test_new_sections_render_what_the_old_keys_rendered(tmp_path):
    """The same scene through ``[render] brightness = "paper"`` and ``[integrator]``: same bits."""
    temp = np.linspace(500.0, 3500.0, 6 * 5 * 4).reshape(6, 5, 4)
    np.save(tmp_path / "gas.npy", temp)
    images = []
    for sections in (
        {"render": {"width": 9, "height": 7, "brightness": "paper", "paper_gain": 1e-5}},
        {"render": {"width": 9, "height": 7}, "integrator": {"type": "paper2011", "gain": 1e-5}},
    ):
        old = "brightness" in sections["render"]
        with pytest.warns(FutureWarning) if old else contextlib.nullcontext():
            scene = scene_from_dict({"volume": {"path": str(tmp_path / "gas.npy")}, **sections})
        volume = volume_from_section(scene.volume, scene.remap())
        images.append(render(volume, None, scene.render_settings(), "cpu",
                             integrator=scene.render_integrator()))  # fmt: skip
    np.testing.assert_array_equal(images[0].display_rgb, images[1].display_rgb)


def test_render_settings_hold_no_transport_mode():
    """Film and sampling only: no brightness law, no paper or spectral or emission keys."""
    fields = set(RenderSettings.__dataclass_fields__)
    modes = {"brightness", "paper_exponent", "paper_gain", "paper_min_K", "spectral_bins",
             "soot_alpha", "line_table", "observer", "constants"}  # fmt: skip
    assert fields & modes == set()


def test_old_scene_keys_and_flags_render_the_same_bits_through_the_cli(tmp_path):
    """``[render] brightness = "paper"`` (one warning line) and ``--brightness paper --sodium``
    give the pixels of ``[integrator] type = "paper2011"`` and ``species.Na``."""
    from typer.testing import CliRunner

    from incandescent.cli import app
    from incandescent.io.images import read_exr

    np.save(tmp_path / "gas.npy", np.linspace(500.0, 3500.0, 6 * 5 * 4).reshape(6, 5, 4))
    head = f'[volume]\npath = "{tmp_path / "gas.npy"}"\n'
    size = "[render]\nwidth = 9\nheight = 7\n"
    old = head + size + 'brightness = "paper"\npaper_exponent = 2.0\n'
    new = head + size + '[integrator]\ntype = "paper2011"\nexponent = 2.0\n'
    runner, pixels = CliRunner(), {}
    for name, text in (("old", old), ("new", new)):
        (tmp_path / f"{name}.toml").write_text(text)
        result = runner.invoke(app, ["render", str(tmp_path / f"{name}.toml"), "-o",
                                     str(tmp_path / f"{name}.exr")])  # fmt: skip
        assert result.exit_code == 0, result.output
        warned = [line for line in result.output.splitlines() if line.startswith("warning:")]
        assert len(warned) == (name == "old")
        pixels[name] = read_exr(tmp_path / f"{name}.exr")[0]
    np.testing.assert_array_equal(pixels["old"], pixels["new"])
    args = ["render", str(tmp_path / "gas.npy"), "--width", "9", "--height", "7"]
    for name, flags in (
        ("flags", ["--brightness", "paper", "--sodium", "0.5"]),
        ("sections", ["--integrator", "paper2011", "--species", "Na=0.5"]),
    ):
        result = runner.invoke(app, args + flags + ["-o", str(tmp_path / f"{name}.exr")])
        assert result.exit_code == 0, result.output
        pixels[name] = read_exr(tmp_path / f"{name}.exr")[0]
    np.testing.assert_array_equal(pixels["flags"], pixels["sections"])
    assert not np.array_equal(pixels["flags"], pixels["new"])  # the sodium term is in
