"""A camera's sensor: its channels' spectral sensitivities, filters, optics and electronics
(``model``: radiance → electrons → raw DN; ``spectra``: the curves)."""

from incandescent.sensor.model import PATTERNS, Sensor
from incandescent.sensor.spectra import SHIPPED, Filter, response

__all__ = ["PATTERNS", "SHIPPED", "Filter", "Sensor", "response"]
