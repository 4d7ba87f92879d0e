"""Up-resolving a simulated frame (wavelet turbulence after Kim et al. 2008): exact trilinear
up-sampling where the flow is smooth, divergence-free band-limited noise, detail added at the
new scales only, and the render path (``volume.upres``, ``--upres``)."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.simulation.upres import (
    band_wavenumber,
    check_factor,
    curl_noise,
    upres_fields,
    upsample,
)


def _shear_flow(shape, rng) -> np.ndarray:
    """A velocity (m/s) with fine-scale structure: random cell values, up to 3 m/s."""
    return (rng.random(shape + (3,)) * 3.0).astype(np.float32)


def _blob(shape) -> np.ndarray:
    x, y, z = np.meshgrid(*[np.arange(n) - n / 2 for n in shape], indexing="ij")
    return (300.0 + 1500.0 * np.exp(-(x**2 + y**2 + z**2) / 20.0)).astype(np.float32)


def test_a_smooth_flow_gives_the_trilinear_up_sampling_exactly():
    """A uniform velocity has no unresolved band (e_t = 0): no displacement, so the result is
    the trilinear up-sampling itself, bit for bit."""
    shape = (12, 16, 12)
    velocity = np.broadcast_to(np.array([0.5, 2.0, -1.0], np.float32), shape + (3,)).copy()
    out = upres_fields({"T": _blob(shape)}, velocity, 0.05, 2, 1 / 24)
    np.testing.assert_array_equal(out["T"], upsample(_blob(shape), 2))
    assert out["T"].shape == (24, 32, 24)


def test_upsampling_keeps_a_linear_field_and_the_cell_means():
    """Trilinear on cell centres: a linear field stays linear (inside), and each coarse cell's
    2×2×2 fine children average to it (inside: the centres sit at ±¼ cell)."""
    x = np.arange(8, dtype=np.float32)
    field = np.broadcast_to(3.0 * x[:, None, None] + 1.0, (8, 8, 8)).copy()
    fine = upsample(field, 2)
    centres = (np.arange(16) + 0.5) / 2 - 0.5
    np.testing.assert_allclose(fine[2:-2, 4, 4], 3.0 * centres[2:-2] + 1.0, rtol=1e-6)
    means = fine.reshape(8, 2, 8, 2, 8, 2).mean(axis=(1, 3, 5))
    np.testing.assert_allclose(means[1:-1], field[1:-1], rtol=1e-6)


def test_the_noise_is_divergence_free_and_band_limited():
    """The curl of a potential is divergence-free: k·F(u) = 0 to rounding; and its power lies in
    the octave's band (k_c·2^i..2^(i+1), k_c = π/factor per fine cell)."""
    shape, factor = (32, 32, 32), 2
    u = curl_noise(shape, 0, factor, seed=3)
    k = np.meshgrid(*[np.fft.fftfreq(n) * 2 * np.pi for n in shape], indexing="ij")
    spectra = [np.fft.fftn(u[..., a]) for a in range(3)]
    divergence = sum(k[a] * spectra[a] for a in range(3))
    power = sum(np.abs(s) ** 2 for s in spectra)
    magnitude = np.sqrt(sum(q * q for q in k))
    assert np.abs(divergence).max() < 1e-9 * np.sqrt(power.max()) * np.pi
    inside = (magnitude >= np.pi / factor) & (magnitude < 2 * np.pi / factor)
    assert power[inside].sum() == pytest.approx(power.sum(), rel=1e-9)
    assert np.sqrt(np.mean(np.sum(u**2, axis=-1))) == pytest.approx(1.0, rel=1e-9)
    assert band_wavenumber(0, factor) == pytest.approx(0.75 * np.pi)


def test_turbulence_adds_detail_at_the_new_scales_only():
    """With an unresolved band: the fields' power above the coarse Nyquist grows (measured 4× on
    a campfire frame; here > 1.5× of the plain up-sampling's), while the 2×2×2 means stay within
    10 % of the coarse field's excess (the detail moves gas by at most an eddy's radius); the
    same seed gives the same detail, another seed other detail."""
    rng = np.random.default_rng(0)
    shape = (16, 16, 16)
    blob, velocity = _blob(shape), _shear_flow(shape, rng)
    out = upres_fields({"T": blob}, velocity, 0.05, 2, 1 / 24)["T"]
    plain = upsample(blob, 2)

    def high(field):
        spectrum = np.abs(np.fft.fftn(field - field.mean())) ** 2
        k = np.meshgrid(*[np.fft.fftfreq(n) for n in field.shape], indexing="ij")
        return spectrum[np.sqrt(sum(q * q for q in k)) > 0.25].sum()

    assert high(out) > 1.5 * high(plain)
    means = out.reshape(16, 2, 16, 2, 16, 2).mean(axis=(1, 3, 5))
    assert np.abs(means - blob).mean() < 0.1 * np.abs(blob - 300.0).mean()
    again = upres_fields({"T": blob}, velocity, 0.05, 2, 1 / 24)["T"]
    np.testing.assert_array_equal(again, out)
    other = upres_fields({"T": blob}, velocity, 0.05, 2, 1 / 24, seed=1)["T"]
    assert not np.array_equal(other, out)


@pytest.mark.parametrize("bad", [1, 5, 2.0, True, "2"])
def test_a_bad_factor_is_one_line(bad):
    with pytest.raises(ValueError, match=r"upres must be one of 2, 3, 4; got"):
        check_factor(bad)


def test_render_up_resolves_a_simulated_frame(tmp_path):
    """``--upres 2`` on a simulated frame: a volume on a grid twice as fine (half the voxel,
    same box); a frame without a velocity grid is refused in one line naming it."""
    from typer.testing import CliRunner

    from incandescent import api
    from incandescent.cli import app
    from incandescent.config import VolumeSection
    from incandescent.simulation import preset, simulate

    frame = simulate(preset("torch"), 16, 2, tmp_path / "fire")[-1].path
    coarse = api.volume_from_section(VolumeSection(path=frame), api.Remap(), layout="dense")
    fine = api.volume_from_section(VolumeSection(path=frame, upres=2), api.Remap(), layout="dense")
    assert fine.temperature_K.shape == tuple(2 * n for n in coarse.temperature_K.shape)
    assert fine.voxel_size_m == pytest.approx(coarse.voxel_size_m / 2)
    np.testing.assert_allclose(fine.bounds_m, coarse.bounds_m, atol=1e-9)
    plain = tmp_path / "plain.npy"
    np.save(plain, np.full((8, 8, 8), 1500.0, np.float32))
    result = CliRunner().invoke(app, ["render", str(plain), "-o", str(tmp_path / "p.png"),
                                      "--upres", "2"])  # fmt: skip
    assert result.exit_code == 2 and "up-resolving needs a velocity grid" in result.output
    assert "Traceback" not in result.output


def test_up_resolving_is_refused_before_work_over_the_memory_budget(tmp_path):
    """4× a 16-cell frame is 64× its voxels: with a 1 MiB budget, refused in one line."""
    from incandescent import api
    from incandescent.budget import BudgetError, Limits
    from incandescent.config import VolumeSection
    from incandescent.simulation import preset, simulate

    frame = simulate(preset("torch"), 16, 1, tmp_path / "fire")[-1].path
    with pytest.raises(BudgetError, match=r"up-resolving 4× .* needs about"):
        api.volume_from_section(
            VolumeSection(path=frame, upres=4), api.Remap(), Limits(max_memory_bytes=2**20)
        )
