"""``render --sensor`` writes a raw exposure LibRaw reads; ``pyrometry`` maps it back to the
temperature the Python API finds; a raw file of another size than its sensor, a sensor CSV out
of order and an exposure that saturates every pixel are one line each."""

from __future__ import annotations

import re

import numpy as np
import pytest
from typer.testing import CliRunner

from incandescent.cli import app
from incandescent.io.images import read_exr
from incandescent.io.raw import read_raw
from incandescent.pyrometry import RatioTable, temperature_map

RUNNER = CliRunner()


def _blackbody_npz(path, temperature_K=1500.0):
    np.savez(path, temperature=np.full((8, 8, 8), temperature_K, dtype=np.float32),
             absorption=np.full((8, 8, 8), 4000.0, dtype=np.float32))  # fmt: skip
    return path


def _one_line_error(result, pattern: str) -> None:
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), result.output
    assert re.search(pattern, lines[0]), lines[0]


CAMERA = ["--eye", "0,0,0.3", "--target", "0,0,0", "--fov", "10", "--width", "32", "--height",
          "32"]  # fmt: skip


def test_render_with_a_sensor_writes_a_dng_that_pyrometry_maps_back(tmp_path):
    """A 1500 K blackbody exposed 4 ms through the shipped Nikon D5100: rawpy reads the DNG, and
    ``pyrometry`` (α = 0, sensor from the sidecar) writes the T the Python API computes from
    the same mosaic, within 50 K of 1500 K everywhere usable."""
    volume = _blackbody_npz(tmp_path / "bb.npz")
    raw = tmp_path / "bb.dng"
    result = RUNNER.invoke(app, ["render", str(volume), *CAMERA, "--sensor", "nikon_d5100",
                                 "--exposure-time", "4e-3", "-o", str(raw)])  # fmt: skip
    assert result.exit_code == 0, result.output
    import rawpy

    with rawpy.imread(str(raw)) as image:
        mosaic = image.raw_image_visible.copy()
    back = read_raw(raw)
    np.testing.assert_array_equal(back.mosaic, mosaic)
    out = tmp_path / "t.exr"
    result = RUNNER.invoke(app, ["pyrometry", str(raw), "--alpha", "0", "-o", str(out)])
    assert result.exit_code == 0, result.output
    _, meta, channels = read_exr(out)
    from incandescent.pyrometry.files import sensor_from_metadata

    sensor = sensor_from_metadata(back, raw)
    python = temperature_map(back.mosaic, sensor, RatioTable.of(sensor, 0.0))
    np.testing.assert_allclose(channels["T"], python.temperature_K, rtol=1e-6)
    usable = channels["usable"] > 0
    assert usable.mean() > 0.5 and np.abs(channels["T"][usable] - 1500.0).max() < 50.0


def test_a_raw_file_of_another_size_than_its_sensor_is_one_line(tmp_path):
    volume = _blackbody_npz(tmp_path / "bb.npz")
    raw = tmp_path / "bb.npy"
    result = RUNNER.invoke(app, ["render", str(volume), *CAMERA, "--sensor", "nikon_d5100",
                                 "--exposure-time", "4e-3", "-o", str(raw)])  # fmt: skip
    assert result.exit_code == 0, result.output
    (tmp_path / "cam.toml").write_text("[sensor]\nwidth_px = 64\nheight_px = 48\n"
                                       "exposure_s = 4e-3\n")  # fmt: skip
    result = RUNNER.invoke(app, ["pyrometry", str(raw), "--sensor", str(tmp_path / "cam.toml"),
                                 "-o", str(tmp_path / "t.exr")])  # fmt: skip
    _one_line_error(result, r"32×32|\(32, 32\).*\(48, 64\)|48, 64")
    assert not (tmp_path / "t.exr").exists()


@pytest.mark.parametrize(
    ("setup", "pattern"),
    [
        ("csv", r"wavelengths must increase; row 3 has 400 nm after 410 nm"),
        ("saturate", r"exposure 1 s saturates every pixel .* try exposure"),
    ],
)
def test_bad_sensors_and_exposures_are_one_line(tmp_path, setup, pattern):
    volume = _blackbody_npz(tmp_path / "bb.npz", 2000.0)
    sensor = "nikon_d5100"
    if setup == "csv":
        (tmp_path / "curve.csv").write_text("wavelength_nm,r,g,b\n400,1,1,1\n410,1,1,1\n"
                                            "400,1,1,1\n")  # fmt: skip
        (tmp_path / "cam.toml").write_text(f'[sensor]\nsensitivity = "{tmp_path / "curve.csv"}"\n')
        sensor = str(tmp_path / "cam.toml")
    exposure = "1" if setup == "saturate" else "1e-4"
    result = RUNNER.invoke(app, ["render", str(volume), *CAMERA, "--sensor", sensor,
                                 "--exposure-time", exposure, "-o",
                                 str(tmp_path / "x.dng")])  # fmt: skip
    _one_line_error(result, pattern)
    assert not (tmp_path / "x.dng").exists()


def test_a_blackbody_raw_file_calibrates_the_map(tmp_path):
    """``--blackbody BB.dng --blackbody-k 1500``: the calibration is the blackbody's measured /
    modelled signal (1 for our own camera, to its noise), recorded in the EXR, and soot's τ₅₅₀
    comes out (> 1 for a blackbody: optically thick); one flag without the other is one
    line."""
    volume = _blackbody_npz(tmp_path / "bb.npz")
    raw = tmp_path / "bb.dng"
    result = RUNNER.invoke(app, ["render", str(volume), *CAMERA, "--sensor", "nikon_d5100",
                                 "--exposure-time", "4e-3", "-o", str(raw)])  # fmt: skip
    assert result.exit_code == 0, result.output
    out = tmp_path / "t.exr"
    result = RUNNER.invoke(app, ["pyrometry", str(raw), "--alpha", "0", "--blackbody", str(raw),
                                 "--blackbody-k", "1500", "-o", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    _, meta, channels = read_exr(out)
    assert float(meta["calibration"]) == pytest.approx(1.0, abs=0.01)
    usable = channels["usable"] > 0
    assert np.nanmedian(channels["tau_550"][usable]) > 1.0  # thick; noise blurs how thick
    bad = RUNNER.invoke(app, ["pyrometry", str(raw), "--blackbody", str(raw), "-o",
                              str(tmp_path / "u.exr")])  # fmt: skip
    _one_line_error(bad, "--blackbody FILE and --blackbody-k K go together")
