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


def test_two_phases_blend_by_triangles_that_vanish_at_their_resets():
    """Phase k resets every 12 frames at frames ≡ 6k (mod 12); its weight is 0 there and 1 half
    a period later, so one phase always carries the detail."""
    from incandescent.simulation.upres import PERIOD_FRAMES, phases

    assert PERIOD_FRAMES == 12
    assert phases(24) == [(24, 0.0), (18, 1.0)]
    assert phases(27) == [(24, 0.5), (18, 0.5)]
    assert phases(5)[1] == (-6, pytest.approx(1 / 6))  # 11 frames since, 1 before its reset
    for frame in range(-12, 40):
        weights = [w for _, w in phases(frame)]
        assert max(weights) >= 0.5 and min(weights) >= 0.0
        assert all(frame - 12 < reset <= frame for reset, _ in phases(frame))


def test_advected_coordinates_follow_a_uniform_flow():
    """Texture coordinates carried 3 frames by 0.4 cells a frame along x and 0.25 along z are
    x − 1.2 and z − 0.75 cells (exact for a linear field) away from the edge they enter from."""
    from incandescent.simulation.upres import advected

    shape, h, dt = (12, 6, 10), 0.02, 1 / 24
    velocity = np.zeros(shape + (3,), np.float32)
    velocity[..., 0], velocity[..., 2] = 0.4 * h / dt, 0.25 * h / dt
    coords = advected([velocity] * 3, h, dt)
    x, y, z = np.meshgrid(*[np.arange(n, dtype=float) for n in shape], indexing="ij")
    inner = (slice(4, None), slice(None), slice(3, None))
    np.testing.assert_allclose(coords[..., 0][inner], (x - 1.2)[inner], atol=1e-5)
    np.testing.assert_allclose(coords[..., 1], y, atol=1e-9)
    np.testing.assert_allclose(coords[..., 2][inner], (z - 0.75)[inner], atol=1e-5)
    with pytest.raises(ValueError, match="at least one velocity"):
        advected([], h, dt)


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    return float(np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b)))


def test_the_detail_travels_with_the_gas_and_keeps_its_strength():
    """A uniform flow of one coarse cell a frame along x: the advected noise of frame 16 is that
    of frame 15 moved two fine cells downstream (correlation > 0.9 against < 0.3 in place); the
    fixed noise stays in place instead. Over a period the blended noise keeps its unit RMS
    (0.8–1.2: two independent noises, normalised by √(w₀² + w₁²))."""
    from incandescent.simulation.upres import advected_noise, curl_noise

    shape, h, dt, factor = (16, 8, 8), 0.02, 1 / 24, 2
    velocity = np.zeros(shape + (3,), np.float32)
    velocity[..., 0] = h / dt
    noise = {f: advected_noise(f, shape, lambda _: velocity, h, factor, dt)[0] for f in (15, 16)}
    before, after = noise[15][8:26], noise[16][10:28]  # fine cells, away from the inflow edge
    assert _correlation(after, before) > 0.9
    assert _correlation(noise[16][8:26], before) < 0.3
    fixed = curl_noise(tuple(2 * n for n in shape), 0, factor, 0)
    assert _correlation(fixed[10:28], fixed[8:26]) < 0.3  # fixed noise does not move
    for frame in range(12, 24):
        field = advected_noise(frame, shape, lambda _: velocity, h, factor, dt)[0]
        assert 0.8 < float(np.sqrt(np.mean(np.sum(field**2, axis=-1)))) < 1.2, frame


def test_a_frame_of_a_sequence_takes_its_detail_from_the_frames_before_it(tmp_path):
    """Up-resolving the last of four simulated torch frames reads the velocities of those before
    it: its detail differs from the same file alone; with its predecessor missing (a gap) it
    gets the lone file's fixed noise exactly."""
    import shutil

    from incandescent import api
    from incandescent.config import VolumeSection
    from incandescent.simulation import preset, simulate

    frames = [r.path for r in simulate(preset("torch"), 16, 4, tmp_path / "fire")]
    last = frames[-1]
    alone = tmp_path / "alone" / last.name
    alone.parent.mkdir()
    shutil.copy(last, alone)

    def fine(path):
        section = VolumeSection(path=path, upres=2)
        return api.volume_from_section(section, api.Remap(), layout="dense").temperature_K

    in_sequence, by_itself = fine(last), fine(alone)
    assert not np.array_equal(in_sequence, by_itself)
    assert _correlation(in_sequence, by_itself) > 0.9  # the same frame, other detail
    frames[-2].unlink()
    np.testing.assert_array_equal(fine(last), by_itself)
