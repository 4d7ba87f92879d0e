"""Pyrometry of a raw file: read it (and its sensor), take its temperature map, write it.

The sensor comes from the raw file's JSON sidecar (every parameter ``photograph`` wrote) unless
one is given; a given one must agree with the file's Bayer pattern and levels, and, when it
states its size, with the file's.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from incandescent.io.images import write_exr
from incandescent.io.raw import RawImage, read_raw
from incandescent.pyrometry.inversion import TemperatureMap, temperature_map
from incandescent.pyrometry.table import RatioTable
from incandescent.sensor import Filter, Sensor

#: The sensor parameters a sidecar holds (``Sensor.parameters``) that build a Sensor.
_SENSOR_KEYS = ("sensitivity", "f_number", "lens_transmittance", "exposure_s", "pixel_pitch_um",
                "peak_qe", "gain_e_per_dn", "full_well_e", "read_noise_e", "dark_current_e_s",
                "black_level_dn", "bits", "pattern", "cos4")  # fmt: skip


def sensor_from_metadata(raw: RawImage, source: Path) -> Sensor:
    """The Sensor a raw file's sidecar describes; one line when it lacks one."""
    meta = raw.metadata
    missing = [k for k in _SENSOR_KEYS if k not in meta]
    if missing:
        raise ValueError(f"{source}: its sidecar does not describe the sensor (no "
                         f"{', '.join(missing[:3])}…); give --sensor")  # fmt: skip
    values = {k: meta[k] for k in _SENSOR_KEYS}
    values["cos4"] = str(values["cos4"]).lower() in ("true", "1")
    filters = json.loads(str(meta.get("filters", "[]")))
    return Sensor(**values, filters=tuple(Filter(**f) for f in filters))  # type: ignore[arg-type]


def check_agrees(raw: RawImage, sensor: Sensor, source: Path, shape=None) -> None:
    """One line when the raw file's pattern, levels or size are not the sensor's."""
    mine = (sensor.pattern, sensor.black_level_dn, sensor.white_level_dn)
    theirs = (raw.pattern, raw.black_level_dn, raw.white_level_dn)
    if mine != theirs:
        raise ValueError(f"{source}: pattern, black and white level {theirs} are not the "
                         f"sensor's {mine}")  # fmt: skip
    if shape is not None and tuple(raw.mosaic.shape) != tuple(shape):
        raise ValueError(f"{source}: {raw.mosaic.shape[1]}×{raw.mosaic.shape[0]} pixels; the "
                         f"sensor has {shape[1]}×{shape[0]}")  # fmt: skip


def calibration_from(path: Path, temperature_K: float, sensor: Sensor, shape=None) -> float:
    """The calibration factor from a raw image of a blackbody at ``temperature_K`` filling the
    view (``calibrate``), checked against the sensor as the measurement is."""
    from incandescent.pyrometry.inversion import calibrate

    raw = read_raw(path, expected_shape=shape)
    check_agrees(raw, sensor, path, shape)
    return calibrate(raw.mosaic, sensor, temperature_K)


def pyrometry_file(
    raw_path: Path,
    output: Path,
    sensor: Sensor | None = None,
    shape=None,
    alpha: float = 1.39,
    calibration: float | None = None,
    max_sigma_K: float = 50.0,
    overwrite: bool = False,
    blackbody: tuple[Path, float] | None = None,
):
    """Read ``raw_path``, map its temperature (``temperature_map``; calibrated by
    ``calibration``, or by ``blackbody``: a raw image of a blackbody and its K) and write
    ``output`` (.exr: RGB = T in K, channels T, sigma_T, tau_550, usable; NaN where unusable);
    (the map, the file written)."""
    from incandescent.io.atomic import check_output

    check_output(output, overwrite, (".exr",), "temperature map", inputs=[raw_path])
    raw = read_raw(raw_path, expected_shape=shape)
    sensor = sensor or sensor_from_metadata(raw, raw_path)
    check_agrees(raw, sensor, raw_path, shape)
    if blackbody is not None:
        calibration = calibration_from(blackbody[0], blackbody[1], sensor, shape)
    result = temperature_map(raw.mosaic, sensor, RatioTable.of(sensor, alpha), calibration,
                             max_sigma_K)  # fmt: skip
    return result, write_map(output, result, alpha, calibration, overwrite)


def write_map(path: Path, result: TemperatureMap, alpha: float, calibration, overwrite: bool):
    """The map as EXR: RGB all T (K) so viewers show it as grey, and its named channels."""
    temp = result.temperature_K.astype(np.float32)
    channels = {"T": temp, "sigma_T": result.sigma_K.astype(np.float32),
                "tau_550": result.tau_550.astype(np.float32),
                "usable": result.usable.astype(np.float32)}  # fmt: skip
    scale = "none (thin soot)" if calibration is None else f"{calibration:g}"
    meta = {
        "units": "T and sigma_T in K; tau_550 optical thickness at 550 nm",
        "pyrometry": f"two-colour red/green, soot alpha {alpha:g}",
        "calibration": scale,
    }
    return write_exr(path, np.repeat(temp[..., None], 3, axis=2), meta, overwrite, channels)
