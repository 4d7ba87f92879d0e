"""Raw Bayer mosaic → temperature: superpixels, the ratio, its uncertainty and masks, soot's
optical thickness from an absolutely calibrated signal, and calibration against a blackbody.

Each 2×2 Bayer cell becomes one superpixel, its three channels estimated at the cell's centre
(:func:`superpixels`). Electrons are (DN − black)·gain − dark·t; their
variance is the shot noise (the electrons themselves), the read noise and the quantisation
(gain²/12) — the sensor's own noise model (EMVA 1288 §2), so the uncertainty of T follows by
propagation: σ_r/r = √(σ_R²/R² + σ_G²/G²), σ_T = σ_r / |dr/dT|.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.pyrometry.table import RatioTable, channel_rates, emissivity
from incandescent.sensor import PATTERNS, Sensor

#: Largest σ_T (K) of a usable pixel by default.
MAX_SIGMA_K = 50.0
#: Optical thicknesses at 550 nm the calibrated solution searches (log-spaced).
TAU_GRID = np.geomspace(1e-4, 30.0, 121)


@dataclass(frozen=True, eq=False)
class Superpixels:
    """Net electrons per channel (H/2, W/2, 3), their variance, and the saturated cells."""

    electrons: NDArray[np.float64]
    variance: NDArray[np.float64]
    saturated: NDArray[np.bool_]


def superpixels(mosaic: NDArray, sensor: Sensor) -> Superpixels:
    """The mosaic's 2×2 cells as (R, G, B) net electrons with variances, every channel estimated
    at the cell's centre; a cell is saturated when any of its pixels reached the white level or
    the full well.

    A Bayer cell's own R, G and B pixels sit at different places: in a flame's steep edges
    their plain ratio is biased by hundreds of kelvin. So each channel is bilinearly demosaiced
    to every pixel (the classic kernels: [1 2 1; 2 4 2; 1 2 1]/4 on the red and blue sites,
    [0 1 0; 1 4 1; 0 1 0]/4 on the green) and averaged over the cell — one linear filter per
    channel, applied here as its 4×4 weights on the mosaic so that the variance is exactly
    Σ wᵢ² σᵢ² (edges mirrored, which keeps the Bayer phase)."""
    dn = np.asarray(mosaic, dtype=np.float64)
    height, width = dn.shape
    gross = (dn - sensor.black_level_dn) * sensor.gain_e_per_dn
    net = gross - sensor.dark_current_e_s * sensor.exposure_s
    var = np.maximum(gross, 0.0) + sensor.read_noise_e**2 + sensor.gain_e_per_dn**2 / 12.0
    full = (dn >= sensor.white_level_dn) | (gross >= sensor.full_well_e - sensor.gain_e_per_dn)
    electrons, variance = _resampled(net, var, np.asarray(PATTERNS[sensor.pattern]).reshape(2, 2))
    saturated = np.asarray(full.reshape(height // 2, 2, width // 2, 2).any(axis=(1, 3)))
    return Superpixels(electrons, variance, saturated)


#: Bilinear demosaicing's kernels on a channel's own sites: red and blue, green.
_KERNEL_RB = np.array([[1.0, 2.0, 1.0], [2.0, 4.0, 2.0], [1.0, 2.0, 1.0]]) / 4.0
_KERNEL_G = np.array([[0.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 0.0]]) / 4.0


def _cell_weights(cell: NDArray, channel: int) -> NDArray:
    """The weights (4×4, offsets −1…2 from the cell's top-left pixel) of the mosaic's pixels in
    channel ``channel``'s demosaiced value averaged over the cell."""
    kernel = _KERNEL_G if channel == 1 else _KERNEL_RB
    out = np.zeros((4, 4))
    for u in range(2):
        for v in range(2):
            out[u : u + 3, v : v + 3] += kernel / 4.0
    mask = np.array([[cell[oy % 2, ox % 2] == channel for ox in range(-1, 3)]
                     for oy in range(-1, 3)])  # fmt: skip
    return out * mask


def _resampled(net: NDArray, var: NDArray, cell: NDArray) -> tuple[NDArray, NDArray]:
    """Each channel's cell value (:func:`_cell_weights`) and its variance, (H/2, W/2, 3)."""
    height, width = net.shape
    padded_net, padded_var = np.pad(net, 2, mode="reflect"), np.pad(var, 2, mode="reflect")
    total = np.zeros((height // 2, width // 2, 3))
    total_var = np.zeros_like(total)
    for c in range(3):
        weights = _cell_weights(cell, c)
        for (iy, ix), w in np.ndenumerate(weights):
            if w == 0.0:
                continue
            rows = slice(1 + iy, 1 + iy + height, 2)
            cols = slice(1 + ix, 1 + ix + width, 2)
            total[..., c] += w * padded_net[rows, cols]
            total_var[..., c] += w * w * padded_var[rows, cols]
    return total, total_var


@dataclass(frozen=True, eq=False)
class TemperatureMap:
    """Per superpixel: T (K, NaN where unusable), σ_T (K), τ₅₅₀ (NaN without calibration) and
    the masks (saturated; too little signal for ``max_sigma_K``)."""

    temperature_K: NDArray[np.float64]
    sigma_K: NDArray[np.float64]
    tau_550: NDArray[np.float64]
    saturated: NDArray[np.bool_]
    low_signal: NDArray[np.bool_]

    @property
    def usable(self) -> NDArray[np.bool_]:
        return ~self.saturated & ~self.low_signal


def temperature_map(
    mosaic: NDArray,
    sensor: Sensor,
    table: RatioTable,
    calibration: float | None = None,
    max_sigma_K: float = MAX_SIGMA_K,
) -> TemperatureMap:
    """Two-colour T of every superpixel from its red/green ratio (the optically thin law of
    ``table``); with a ``calibration`` (measured / modelled signal, :func:`calibrate`) also soot's
    τ₅₅₀ and T from the thick law that fits both the ratio and the absolute green signal."""
    cells = superpixels(mosaic, sensor)
    red, green = cells.electrons[..., 0], cells.electrons[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = red / green
        rel = np.sqrt(cells.variance[..., 0] / red**2 + cells.variance[..., 1] / green**2)
    temp = table.temperature(ratio)
    tau = np.full(temp.shape, np.nan)
    if calibration is not None:
        rate = green / (sensor.exposure_s * calibration)
        temp, tau = thick_solution(ratio, rate, sensor, table.alpha)
    with np.errstate(invalid="ignore"):
        sigma = np.abs(rel * ratio / table.slope(np.nan_to_num(temp, nan=1500.0)))
    low = ~((red > 0) & (green > 0) & np.isfinite(temp) & (sigma <= max_sigma_K))
    unusable = low | cells.saturated
    return TemperatureMap(np.where(unusable, np.nan, temp), sigma, np.where(unusable, np.nan, tau),
                          cells.saturated, low)  # fmt: skip


def thick_solution(ratio, green_rate, sensor: Sensor, alpha: float):
    """(T, τ₅₅₀) per pixel such that soot of optical thickness τ₅₅₀ at T gives both the red/
    green ``ratio`` and the green signal ``green_rate`` (e⁻/s): for each τ of
    :data:`TAU_GRID` the T its ratio implies, then τ where that T's green signal crosses the
    measured one (linear interpolation; NaN outside the grid)."""
    temps = np.arange(700.0, 3501.0, 2.0)
    eps = emissivity(TAU_GRID, alpha)  # (τ, λ): one τ at a time keeps the table (T, λ) small
    rates = np.stack([channel_rates(sensor, temps, e) for e in eps], axis=1)  # (T, τ, 3)
    table_ratio = rates[..., 0] / rates[..., 1]  # (T, τ), falling with T
    r = np.asarray(ratio, dtype=np.float64).ravel()
    g = np.asarray(green_rate, dtype=np.float64).ravel()
    columns = range(TAU_GRID.size)
    falling = table_ratio[::-1]
    t_of_tau = np.stack(
        [np.interp(r, falling[:, j], temps[::-1], left=np.nan, right=np.nan) for j in columns],
        axis=1,
    )
    g_of_tau = np.stack([np.interp(t_of_tau[:, j], temps, rates[:, j, 1])
                         for j in range(TAU_GRID.size)], axis=1)  # fmt: skip
    return _crossing(t_of_tau, g_of_tau, g, np.shape(ratio))


def _crossing(t_of_tau, g_of_tau, g, shape):
    """Interpolate T and log τ where g_of_tau first passes g along each row."""
    above = g_of_tau >= g[:, None]
    first = np.argmax(above, axis=1)
    found = above.any(axis=1) & (first > 0)
    j = np.clip(first, 1, TAU_GRID.size - 1)
    rows = np.arange(len(g))
    g0, g1 = g_of_tau[rows, j - 1], g_of_tau[rows, j]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.clip((g - g0) / (g1 - g0), 0.0, 1.0)
    log_tau = np.log(TAU_GRID)
    tau = np.exp(log_tau[j - 1] + w * (log_tau[j] - log_tau[j - 1]))
    temp = t_of_tau[rows, j - 1] + w * (t_of_tau[rows, j] - t_of_tau[rows, j - 1])
    return (np.where(found, temp, np.nan).reshape(shape),
            np.where(found, tau, np.nan).reshape(shape))  # fmt: skip


def calibrate(
    mosaic: NDArray, sensor: Sensor, temperature_K: float, emissivity_value: float = 1.0
) -> float:
    """Measured / modelled green signal of a blackbody (or grey body of ``emissivity_value``)
    at ``temperature_K`` filling the view: the factor :func:`temperature_map` divides signals by,
    fixing what the model does not know absolutely (quantum efficiency, lens, aperture)."""
    cells = superpixels(mosaic, sensor)
    usable = ~cells.saturated & (cells.electrons[..., 1] > 0)
    if not usable.any():
        raise ValueError("calibration image: no unsaturated pixel with signal")
    measured = float(np.median(cells.electrons[..., 1][usable])) / sensor.exposure_s
    eps = np.full(emissivity(None, 0.0).shape, float(emissivity_value))
    modelled = float(channel_rates(sensor, temperature_K, eps)[1])
    return measured / modelled
