"""Two-colour pyrometry of raw camera images: the ratio table from the sensor model
(``table``), per-pixel T, σ_T, masks and soot's optical thickness (``inversion``), and the
radial T of axisymmetric flames by PyAbel's inverse Abel transform (``abel``)."""

from incandescent.pyrometry.inversion import (
    Superpixels,
    TemperatureMap,
    calibrate,
    superpixels,
    temperature_map,
)
from incandescent.pyrometry.table import RatioTable

__all__ = [
    "RatioTable",
    "Superpixels",
    "TemperatureMap",
    "calibrate",
    "superpixels",
    "temperature_map",
]
