"""The camera model (``sensor``, ``photograph``): a blackbody filling the view gives the DN of a
direct integral of Planck × sensitivity × optics × exposure; flat frames have Poisson + read
noise; the sensor saturates at its full well and bit depth; raw files read back through LibRaw;
bad curves and exposures are one line."""

from __future__ import annotations

import numpy as np
import pytest

import incandescent as inc
from incandescent.io.raw import read_raw, write_raw
from incandescent.photograph import photograph
from incandescent.sensor import Filter, Sensor
from incandescent.sensor.spectra import grid_nm
from incandescent.spectra.planck import planck_radiance

H_J_S, C_M_S = 6.62607015e-34, 299792458.0


def _blackbody(temperature_K: float) -> tuple[inc.Volume, inc.Camera, inc.RenderSettings]:
    """An opaque cube (τ = 40 per voxel) at ``temperature_K`` filling a narrow camera's view."""
    cube = inc.Volume.from_arrays(np.full((8, 8, 8), temperature_K), absorption=4000.0,
                                  voxel_size_m=0.01)  # fmt: skip
    camera = inc.Camera(eye=(0.0, 0.0, 0.045), target=(0.0, 0.0, 0.0), fov_deg=20.0)
    return cube, camera, inc.RenderSettings(width=24, height=24, jitter=False)


def _direct_electrons(sensor: Sensor, temperature_K: float) -> np.ndarray:
    """The camera equation by hand: t·∫ B_λ(T) · π τ F/(4N²) · p² · λ/(hc) · QE_c(λ) dλ."""
    lam = grid_nm()
    optics = np.pi * sensor.lens_transmittance / (4 * sensor.f_number**2)
    photons = lam * 1e-9 / (H_J_S * C_M_S) * (sensor.pixel_pitch_um * 1e-6) ** 2
    through = np.prod([f.transmittance() for f in sensor.filters], axis=0) if sensor.filters \
        else 1.0  # fmt: skip
    qe = sensor.peak_qe * sensor.curves.on_grid()
    per_nm = planck_radiance(lam, temperature_K)[:, None] * (optics * photons * through)[:, None]
    return sensor.exposure_s * ((per_nm * qe).sum(axis=0) + sensor.dark_current_e_s)


@pytest.mark.parametrize("backend", ["reference", "cpu"])
@pytest.mark.parametrize(("temperature_K", "exposure_s"), [(1500.0, 2e-3), (2000.0, 5e-5)])
def test_a_blackbody_gives_the_dn_of_the_direct_integral(backend, temperature_K, exposure_s):
    """Noise off: each channel's mean electrons equal the camera equation's integral to 1e-4
    (measured 5e-8 float64, 1.3e-6 Dr.Jit), and the DN are them / gain + black, rounded."""
    sensor = Sensor(exposure_s=exposure_s, filters=(Filter("ir_cut", edge_nm=700.0),))
    cube, camera, settings = _blackbody(temperature_K)
    shot = photograph(cube, camera, settings, sensor, backend, noise=False, spectral_bins=8)
    expected = _direct_electrons(sensor, temperature_K)
    np.testing.assert_allclose(shot.electrons[12, 12], expected, rtol=1e-4)
    channel = sensor.channel_map(24, 24)
    dn = np.floor(expected[channel] / sensor.gain_e_per_dn + 0.5) + sensor.black_level_dn
    centre = slice(8, 16)  # cos⁴ is off: every pixel sees the same radiance
    np.testing.assert_array_equal(shot.mosaic[centre, centre], dn[centre, centre])


def test_flat_frames_have_poisson_and_read_noise():
    """A flat field of 5000 e⁻ mean: DN mean (e/gain + black) and variance (e + σ_read²)/gain²
    (+1/12 quantisation) over 200 000 pixels within 1 %."""
    sensor = Sensor(gain_e_per_dn=1.5, read_noise_e=12.0, dark_current_e_s=0.0)
    electrons = np.full((400, 500, 3), 5000.0)
    dn = sensor.mosaic(electrons, seed=4).astype(np.float64)
    assert dn.mean() == pytest.approx(5000.0 / 1.5 + sensor.black_level_dn, rel=1e-3)
    assert dn.var() == pytest.approx((5000.0 + 144.0) / 1.5**2 + 1 / 12, rel=0.01)


def test_the_sensor_saturates_at_its_full_well_and_its_bit_depth():
    """Electrons beyond the full well read as the full well's DN; a gain that would exceed the
    bit depth clips at the white level 2^bits − 1."""
    well = Sensor(full_well_e=20000.0, gain_e_per_dn=2.0, black_level_dn=100)
    over = well.mosaic(np.full((4, 4, 3), 1e6), noise=False)
    assert (over == 10000 + 100).all()
    deep = Sensor(full_well_e=60000.0, gain_e_per_dn=1.0, bits=12, black_level_dn=64)
    assert (deep.mosaic(np.full((4, 4, 3), 5e4), noise=False) == 4095).all()


def test_libraw_reads_the_photograph_s_dng_back_exactly(tmp_path):
    """The exposure's mosaic written as DNG reads back through rawpy (LibRaw) bit for bit, with
    the sensor's pattern, black and white levels; the sidecar holds every sensor parameter."""
    sensor = Sensor(exposure_s=2e-3, pattern="GRBG")
    cube, camera, settings = _blackbody(1500.0)
    shot = photograph(cube, camera, settings, sensor, "cpu", seed=7)
    path = write_raw(tmp_path / "bb.dng", shot.raw())
    back = read_raw(path, expected_shape=(24, 24))
    np.testing.assert_array_equal(back.mosaic, shot.mosaic)
    assert (back.pattern, back.black_level_dn, back.white_level_dn) == ("GRBG", 600, 16383)
    assert back.metadata["f_number"] == 8.0 and back.metadata["full_well_e"] == 30000.0


def test_an_exposure_that_saturates_everything_names_one_that_would_not():
    sensor = Sensor(exposure_s=1.0)
    cube, camera, settings = _blackbody(2000.0)
    with pytest.raises(ValueError, match=r"exposure 1 s saturates every pixel .* try exposure "):
        photograph(cube, camera, settings, sensor, "cpu")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("wavelength_nm,r,g,b\n400,1,1,1\n390,1,1,1\n", "wavelengths must increase; row 2"),
        ("400,1,1,1\n410,1,-0.2,1\n", r"values must be finite and >= 0; row 2 \(410 nm\)"),
        ("400,1,1\n410,1,1\n", "expected wavelength_nm and 3 column"),
    ],
)
def test_bad_sensitivity_curves_are_one_line_naming_the_row(tmp_path, text, message):
    path = tmp_path / "curve.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        Sensor(sensitivity=str(path))


@pytest.mark.parametrize("method", ["Menon2007", "bilinear"])
def test_demosaicing_gives_each_channel_everywhere(method):
    """A mosaic of three smooth ramps (one per channel, noise off): the demosaiced image's
    channels are the ramps within 1 % away from the borders."""
    from incandescent.photograph import demosaic

    sensor = Sensor(pattern="BGGR")
    y, x = np.mgrid[0:64, 0:64].astype(float)
    planes = np.stack([2000 + 20 * x, 3000 + 15 * y, 1000 + 10 * (x + y)], axis=-1)
    mosaic = sensor.mosaic(planes, noise=False)
    from incandescent.io.raw import RawImage

    raw = RawImage(mosaic, "BGGR", sensor.black_level_dn, sensor.white_level_dn, sensor.bits)
    rgb = demosaic(raw, method) * sensor.gain_e_per_dn
    inner = (slice(4, -4), slice(4, -4))
    np.testing.assert_allclose(rgb[inner], planes[inner], rtol=0.01)
    with pytest.raises(ValueError, match="unknown demosaicing 'fancy'"):
        demosaic(raw, "fancy")
