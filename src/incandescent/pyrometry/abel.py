"""Radial temperature of an axisymmetric flame: the inverse Abel transform of each channel's
line-of-sight signal (PyAbel's BASEX, Dribinski et al. 2002, Rev. Sci. Instrum. 73:2634, with
its Tikhonov regularisation), then the two-colour ratio of the local emission.

An optically thin flame's pixel signal is the line integral of the local emission
κ_λ B_λ(T) through each channel; inverted, the ratio of the red and green local emissions is
the thin-soot ratio of the local T (``table``). A sooty flame is not thin: light from the far
side of the soot ring crosses the near side, green more than red (κ_λ ∝ λ^−α), which reddens
the ratio. With an absolute calibration, :func:`self_absorption_corrected` iterates: invert,
take the local κ₅₅₀ from the green emission and T, project each channel forward with and
without that absorption along every chord, scale the measured projections by the ratio and
invert again (the correction of e.g. Snelling et al.'s emission tomography, at one effective
wavelength per channel).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.pyrometry.inversion import Superpixels
from incandescent.pyrometry.table import RatioTable

#: BASEX's regularisation by default (Tikhonov, in its basis' units).
DEFAULT_REG = 10.0


@dataclass(frozen=True, eq=False)
class RadialField:
    """Per image row and radius from the axis: the local emission per channel (e⁻ s⁻¹... per m
    of path, up to the sensor's constant) and T (K, NaN where the green emission is below
    ``min_fraction`` of its peak)."""

    emission: NDArray[np.float64]
    temperature_K: NDArray[np.float64]
    radius_m: NDArray[np.float64]
    #: soot's absorption at 550 nm (1/m) where T is known, with an absolute calibration
    kappa_550_per_m: NDArray[np.float64] | None = None

    def soot_volume_fraction(self, e_m: float = 0.26) -> NDArray[np.float64]:
        """f_v = κ₅₅₀ λ / (6π E(m)) at λ = 550 nm (Rayleigh absorption by small soot; E(m) 0.26
        as Santoro's group used, 0.35–0.4 in later work): the inversion's soot."""
        if self.kappa_550_per_m is None:
            raise ValueError("the soot volume fraction needs a calibrated inversion")
        return self.kappa_550_per_m * 550e-9 / (6.0 * np.pi * e_m)


def half_image(image: NDArray) -> NDArray:
    """The mean of the right and the mirrored left half of rows centred on the axis (an odd
    number of columns, the middle one on the axis): (rows, (n + 1)/2)."""
    n = image.shape[1]
    if n % 2 == 0:
        raise ValueError(f"an Abel inversion needs the axis on a column: an odd width; got {n}")
    centre = n // 2
    return 0.5 * (image[:, centre:] + image[:, centre::-1])


def radial_temperature(
    cells: Superpixels,
    table: RatioTable,
    pixel_m: float,
    reg: float = DEFAULT_REG,
    min_fraction: float = 0.1,
) -> RadialField:
    """Invert each channel's superpixel signals (axis vertical, on the middle column) and take
    the red/green ratio of the local emission where the green's is ≥ ``min_fraction`` of its
    peak."""
    import abel

    emission = np.stack(
        [abel.basex.basex_transform(half_image(cells.electrons[..., c]), sigma=1.0, reg=reg,
                                    basis_dir=None, dr=pixel_m, verbose=False)
         for c in range(3)], axis=-1)  # fmt: skip
    green = emission[..., 1]
    strong = green >= min_fraction * green.max()
    with np.errstate(divide="ignore", invalid="ignore"):
        temp = table.temperature(emission[..., 0] / green)
    radius = np.arange(emission.shape[1], dtype=np.float64) * pixel_m
    return RadialField(emission, np.where(strong, temp, np.nan), radius)


def _chords(radius_m: NDArray, pixel_m: float) -> tuple[NDArray, NDArray]:
    """(r at each chord sample, its length in m): chords at the radii's offsets y_j, sampled at
    half a pixel from the far side (−) to the camera's side (+), shape (n_y, n_s)."""
    top = radius_m[-1] + pixel_m
    s = np.arange(-top + pixel_m / 4, top, pixel_m / 2)
    r = np.hypot(radius_m[:, None], s[None, :])
    return r, np.full(s.shape, pixel_m / 2)


def _project(emission: NDArray, kappa: NDArray, radius_m: NDArray, pixel_m: float):
    """Per row: each offset's chord integral of ``emission`` (rows, n_r) without and with the
    attenuation by ``kappa`` (rows, n_r; 1/m) between the sample and the camera."""
    r, ds = _chords(radius_m, pixel_m)
    e = np.stack([np.interp(r, radius_m, row, right=0.0) for row in emission])  # (rows, y, s)
    k = np.stack([np.interp(r, radius_m, row, right=0.0) for row in kappa])
    to_camera = np.cumsum((k * ds)[..., ::-1], axis=-1)[..., ::-1] - k * ds / 2
    return (e * ds).sum(-1), (e * np.exp(-to_camera) * ds).sum(-1)


def effective_wavelengths_nm(sensor, temperature_K: float = 1800.0) -> NDArray[np.float64]:
    """Each channel's mean wavelength weighted by its signal from a blackbody at
    ``temperature_K`` (nm): where its light is absorbed."""
    from incandescent.sensor.spectra import grid_nm
    from incandescent.spectra.planck import planck_radiance

    weights = sensor.weights() * planck_radiance(grid_nm(), temperature_K)[:, None]
    return (grid_nm()[:, None] * weights).sum(axis=0) / weights.sum(axis=0)


def self_absorption_corrected(
    cells: Superpixels,
    table: RatioTable,
    pixel_m: float,
    sensor,
    calibration: float = 1.0,
    reg: float = DEFAULT_REG,
    iterations: int = 8,
    min_fraction: float = 0.1,
) -> RadialField:
    """:func:`radial_temperature` with the flame's self-absorption corrected (see the module):
    κ₅₅₀(r) = e_G(r) / (t·c·ė_G(T(r))) per unit κ₅₅₀, each channel attenuated by
    κ₅₅₀ (550 nm/λ_c)^α at its :func:`effective_wavelengths_nm`."""
    from incandescent.pyrometry.table import channel_rates, emissivity

    measured = cells.electrons
    scale = (550.0 / effective_wavelengths_nm(sensor)) ** table.alpha
    per_kappa = sensor.exposure_s * calibration
    field = radial_temperature(cells, table, pixel_m, reg, min_fraction)

    def soot(field: RadialField) -> NDArray:
        temp = np.nan_to_num(field.temperature_K, nan=0.0)
        green_unit = channel_rates(sensor, np.maximum(temp, 300.0), emissivity(None, table.alpha))
        kappa = np.where(temp > 0, field.emission[..., 1] / (per_kappa * green_unit[..., 1]), 0.0)
        return np.maximum(kappa, 0.0)

    for _ in range(iterations):
        kappa = soot(field)
        corrected = np.empty_like(measured)
        for c in range(3):
            thin, absorbed = _project(field.emission[..., c], kappa * scale[c], field.radius_m,
                                      pixel_m)  # fmt: skip
            gain = np.where(absorbed > 0, thin / np.maximum(absorbed, 1e-300), 1.0)
            corrected[..., c] = _unfolded(half_image(measured[..., c]) * gain)
        field = radial_temperature(Superpixels(corrected, cells.variance, cells.saturated),
                                   table, pixel_m, reg, min_fraction)  # fmt: skip
    kappa = np.where(np.isfinite(field.temperature_K), soot(field), np.nan)
    return RadialField(field.emission, field.temperature_K, field.radius_m, kappa)


def _unfolded(half: NDArray) -> NDArray:
    """A half image (axis in column 0) back to a symmetric full one (odd width)."""
    return np.concatenate([half[:, :0:-1], half], axis=1)
