"""What a camera's channels see of a hot emitter: the signals and their ratio as functions of
temperature, from the same sensor model that makes the raw images (``sensor``).

A pixel looking at an emitter of temperature T and spectral emissivity ε_λ collects per second

    ė_c(T) = ∫ k_c(λ) ε_λ B_λ(T) dλ        (k_c: ``Sensor.weights``, B_λ: Planck's law)

Soot's emissivity follows Hottel & Broughton (1932, Ind. Eng. Chem. Anal. Ed. 4:166):
ε_λ = 1 − exp(−KL/λ^α), written here with the optical thickness at 550 nm, τ₅₅₀ = KL/0.55^α
(λ in µm): ε_λ = 1 − exp(−τ₅₅₀ (550 nm/λ)^α) — the volume's own κ_λ law (``Volume.soot_alpha``).
In the optically thin limit ε_λ ∝ (550 nm/λ)^α, so the ratio of two channels depends on T
alone: two-colour (ratio) pyrometry. A grey body (ε constant) is α = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.sensor import Sensor
from incandescent.sensor.spectra import grid_nm
from incandescent.spectra.planck import planck_radiance

#: The table's temperatures, K: every kelvin from 700 to 3500.
T_TABLE_K = np.arange(700.0, 3501.0, 1.0)


def emissivity(tau_550, alpha: float) -> NDArray[np.float64]:
    """ε_λ on the CIE grid for optical thicknesses τ₅₅₀ (any shape) → shape + (471,); τ₅₅₀ None:
    the optically thin shape (550 nm/λ)^α (unnormalised)."""
    law = (550.0 / grid_nm()) ** alpha
    if tau_550 is None:
        return law
    return -np.expm1(-np.asarray(tau_550, dtype=np.float64)[..., None] * law)


def channel_rates(sensor: Sensor, temperature_K, eps: NDArray) -> NDArray[np.float64]:
    """ė_c (e⁻/s) of each channel for temperatures (shape S) and emissivities (471,) or
    S + (471,) → S + (3,)."""
    temp = np.asarray(temperature_K, dtype=np.float64)
    radiance = planck_radiance(grid_nm(), np.maximum(temp, 1.0)[..., None]) * eps
    return radiance @ sensor.weights()


@dataclass(frozen=True, eq=False)
class RatioTable:
    """The red/green ratio of an optically thin emitter of spectral law ``alpha`` over
    :data:`T_TABLE_K`, and its inverse."""

    sensor: Sensor
    alpha: float
    temperature_K: NDArray[np.float64]
    ratio: NDArray[np.float64]

    @classmethod
    def of(cls, sensor: Sensor, alpha: float = 1.39) -> RatioTable:
        """The table for ``sensor`` and soot exponent ``alpha`` (1.39: Hottel & Broughton's
        visible value; 0: a grey body)."""
        rates = channel_rates(sensor, T_TABLE_K, emissivity(None, alpha))
        ratio = rates[:, 0] / rates[:, 1]
        if not (np.diff(ratio) < 0).all():
            raise ValueError("this sensor's red/green ratio is not monotonic in T; no ratio "
                             "pyrometry")  # fmt: skip
        return cls(sensor, float(alpha), T_TABLE_K, ratio)

    def temperature(self, ratio) -> NDArray[np.float64]:
        """T (K) of red/green ratios; NaN outside the table's range."""
        r = np.asarray(ratio, dtype=np.float64)
        inside = (r <= self.ratio[0]) & (r >= self.ratio[-1])
        t = np.interp(r, self.ratio[::-1], self.temperature_K[::-1])
        return np.where(inside, t, np.nan)

    def slope(self, temperature_K) -> NDArray[np.float64]:
        """d(ratio)/dT (1/K) at temperatures, from the table."""
        gradient = np.gradient(self.ratio, self.temperature_K)
        return np.interp(temperature_K, self.temperature_K, gradient)
