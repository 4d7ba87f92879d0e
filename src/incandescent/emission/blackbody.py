"""Blackbody emission of the absorbing gas, grey or in spectral bins (``DESIGN.md`` §3).

Kirchhoff: a gas in local thermodynamic equilibrium emits κ_λ·B_λ(T). With grey κ the
wavelength integral commutes with transport and one table XYZ(B(T)) is exact
(:class:`BlackbodyGrey`); with soot κ_λ = κ·(λ_ref/λ)^α it does not, and the march carries one
transmittance per bin with per-bin tables that sum to the grey one (:class:`BlackbodyBins`,
:mod:`incandescent.spectra.bins`).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from incandescent.emission.base import Bands, EmissionModel
from incandescent.spectra.bins import bin_luts, make_bins
from incandescent.spectra.blackbody import blackbody_xyz
from incandescent.spectra.lut import T_MAX_K, EmissionLUT, build_emission_lut, cached_tables


@functools.lru_cache(maxsize=16)
def blackbody_lut(observer: str, constants: str) -> EmissionLUT:
    """The T ↦ XYZ(B(T)) table (Y in cd/m²), T_min … T_MAX_K (kept on disk between runs)."""

    def build():
        return [build_emission_lut(T_MAX_K, lambda t: blackbody_xyz(t, observer, constants))]

    return cached_tables(f"blackbody {observer} {constants} {T_MAX_K}", build)[0]


@functools.lru_cache(maxsize=8)
def _bins_and_tables(n: int, alpha: float, observer: str, constants: str):
    bins = make_bins(n, alpha, observer)  # the tables depend on the bin edges (n), not on α

    def build():
        return bin_luts(bins, T_MAX_K, observer, constants)

    key = f"blackbody bins {n} {observer} {constants} {T_MAX_K}"
    return bins, tuple(cached_tables(key, build))


class BlackbodyGrey(EmissionModel):
    """Planck emission through the CIE observer in one grey band: S = XYZ(B(T))."""

    name = "blackbody"
    kind = "source"

    def __init__(self, observer: str = "cie1931_2", constants: str = "codata2018") -> None:
        self.observer, self.constants = observer, constants
        self.bands = Bands()
        self.tables = (blackbody_lut(observer, constants),)

    def add(self, kernel, bound, eta, band, position, values):
        term = kernel.lookup(bound[0][band], position)
        return term if eta is None else eta + term

    def reference_add(self, eta, temperature_K, values, inputs) -> NDArray:
        term = blackbody_xyz(temperature_K, self.observer, self.constants)
        return term if eta is None else eta + term

    def reference_spectrum_add(self, eta, temperature_K, values, wavelength_nm, inputs):
        from incandescent.constants import planck_constants
        from incandescent.spectra.planck import NM_TO_M, _planck_m

        lam_m = wavelength_nm * NM_TO_M
        temp = np.maximum(temperature_K, 1.0)[:, None]
        term = _planck_m(lam_m, temp, planck_constants(self.constants)) * NM_TO_M
        return term if eta is None else eta + term


class BlackbodyBins(BlackbodyGrey):
    """Planck emission in ``n`` spectral bins for soot absorption κ_λ = κ·(550 nm/λ)^α: bin b's
    table is K_m Σ_{λ∈b} B_λ x̄ȳz̄ Δλ, and its transport scales κ by (550 nm/λ_b)^α."""

    name = "blackbody-bins"

    def __init__(
        self, n: int, alpha: float, observer: str = "cie1931_2", constants: str = "codata2018"
    ) -> None:
        super().__init__(observer, constants)
        bins, tables = _bins_and_tables(n, float(alpha), observer, constants)
        self.bands, self.tables = Bands(bins), tables
