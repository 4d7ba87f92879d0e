"""The paper2011 integrator in the renderers: the 2011 method's sums, against its own formulas."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

from incandescent.camera import Camera
from incandescent.imaging.pipeline import display_pixels
from incandescent.renderer import Paper2011, RenderSettings, render
from incandescent.spectra.paper2011 import paper_rgb
from incandescent.volume import Volume

FACE_ON = Camera(eye=(0, 0, 3.0), target=(0, 0, 0), projection="orthographic", ortho_height_m=0.2)


def _slab(temperature_K: float, n_z: int = 10, sodium=None) -> Volume:
    return Volume.from_arrays(
        np.full((4, 4, n_z), temperature_K),
        absorption=5.0,
        voxel_size_m=0.1,
        sodium_fraction=sodium,
    )


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize("temperature_K", [1000.0, 3000.0, 6500.0])
@pytest.mark.parametrize("step", [0.25, 0.5, 0.9])
def test_uniform_slab_sums_paper_colour_without_absorption(backend, temperature_K, step):
    gain = 1e-6
    s = RenderSettings(width=3, height=3, step_voxels=step)
    img = render(_slab(temperature_K), FACE_ON, s, backend=backend, integrator=Paper2011(gain=gain))
    expected = np.minimum(paper_rgb(temperature_K) * gain * 10.0, 255.0)  # 10 voxels of path
    np.testing.assert_allclose(img.display_rgb[1, 1], expected, rtol=2e-4, atol=1e-3)
    assert img.xyz is None  # display-referred: no absolute XYZ to disguise it as
    assert np.all(img.transmittance == 1.0)  # the paper ignores absorption


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_sums_are_capped_at_255(backend):
    s, paper = RenderSettings(width=3, height=3), Paper2011()
    rgb = render(_slab(6000.0, 40), FACE_ON, s, backend=backend, integrator=paper).display_rgb
    np.testing.assert_allclose(rgb.max(), 255.0, rtol=1e-5)
    image = render(_slab(6000.0, 40), FACE_ON, s, integrator=paper)
    assert np.asarray(display_pixels(image)).max() == 255


def test_samples_below_paper_threshold_do_not_contribute(jit_backend):
    cool = _slab(700.0)
    s = RenderSettings(width=3, height=3)
    assert render(cool, FACE_ON, s, jit_backend, integrator=Paper2011()).display_rgb.max() == 0.0
    lowered = render(cool, FACE_ON, s, jit_backend, integrator=Paper2011(min_K=600.0))
    assert lowered.display_rgb.max() > 0.0


def test_sodium_fraction_adds_the_590_nm_term(jit_backend):
    """At 6500 K (near white) sodium's 590 nm light pulls the colour toward orange: less blue."""
    s, paper = RenderSettings(width=3, height=3), Paper2011(gain=1e-8)
    plain = render(_slab(6500.0), FACE_ON, s, jit_backend, integrator=paper).display_rgb[1, 1]
    with_na = render(_slab(6500.0, sodium=1.0), FACE_ON, s, jit_backend, integrator=paper)
    sodium = with_na.display_rgb[1, 1]
    assert sodium[2] / sodium.max() < 0.95 * plain[2] / plain.max()
    np.testing.assert_allclose(sodium, paper_rgb(6500.0, 1.0) * 1e-8 * 10.0, rtol=2e-4)


@pytest.mark.parametrize("seed", [0, 3])
def test_paper_mode_cpu_matches_reference(jit_backend, seed):
    rng = np.random.default_rng(seed)
    temp = rng.uniform(500.0, 4000.0, (7, 8, 6))
    sodium = rng.uniform(0.0, 1.0, temp.shape)
    vol = Volume.from_arrays(temp, voxel_size_m=0.05, sodium_fraction=sodium)
    cam = Camera(eye=(0.5, 0.4, 0.6), target=(0, 0, 0), fov_deg=50.0)
    s, paper = RenderSettings(width=19, height=13, seed=seed), Paper2011(gain=2e-5)
    ref = render(vol, cam, s, backend="reference", integrator=paper).display_rgb
    fast = render(vol, cam, s, backend=jit_backend, integrator=paper).display_rgb
    assert 0 < ref.max() < 255  # uncapped, so the comparison sees the sums
    np.testing.assert_allclose(fast, ref, rtol=2e-4, atol=1e-4 * ref.max())
    unskipped = s.replace(skip_empty=False)
    skipped = render(vol, cam, unskipped, backend=jit_backend, integrator=paper).display_rgb
    np.testing.assert_allclose(skipped, fast, rtol=1e-5, atol=1e-6 * ref.max())


def test_paper_image_is_display_rgb_in_its_own_field(tmp_path):
    from incandescent.io.images import read_exr
    from incandescent.output import save_image

    img = render(_slab(3000.0), FACE_ON, RenderSettings(width=3, height=3), integrator=Paper2011())
    with pytest.raises(ValueError, match="display-referred RGB"):
        _ = img.luminance
    rgb, meta, _ = read_exr(save_image(img, tmp_path / "paper.exr"))
    np.testing.assert_array_equal(rgb, img.display_rgb)
    assert meta["units"].startswith("display-referred sRGB code values")
    assert meta["integrator"] == "paper2011" and meta["paper_exponent"] == "1.5"


def test_paper_settings_are_validated():
    with pytest.raises(ValueError, match="paper_exponent must be in"):
        Paper2011(exponent=float("nan"))
    with pytest.raises(ValueError, match="paper_gain"):
        Paper2011(gain=0.0)
    with pytest.raises(ValueError, match="the paper2011 integrator takes no emission models"):
        render(_slab(2000.0), FACE_ON, RenderSettings(width=3, height=3), models=(1,),
               integrator=Paper2011())  # fmt: skip
    with pytest.raises(ValueError, match=r"species 'Na' fraction must be in \[0, 1\]; got 1.5"):
        _slab(2000.0, sodium=np.full((4, 4, 10), 1.5))
