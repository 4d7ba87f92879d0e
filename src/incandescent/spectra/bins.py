"""Spectral bins for wavelength-dependent absorption (soot), DESIGN.md §3.

With grey κ the wavelength integral commutes with transport and one T ↦ XYZ table is exact. With
spectral κ_λ (soot: κ_λ ∝ λ^−α) it does not, so the march carries one transmittance per bin. The
CIE range 360–830 nm (1 nm samples) is split into N contiguous bins; bin b gets the table

    XYZ_b(T) = K_m Σ_{λ_i ∈ b} B_λ(λ_i, T) · x̄ȳz̄(λ_i) · Δλ,

so Σ_b XYZ_b(T) = blackbody_xyz(T) exactly (grey κ reproduces the LUT mode), and one absorption
scale per bin, (λ_ref / λ_b)^α at the bin's Y-weighted mean wavelength λ_b (for α = 0: 1).
As N → 471 the bins become the reference marcher's 1 nm samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent.constants import K_M, planck_constants
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.lut import EmissionLUT, build_emission_luts
from incandescent.spectra.planck import NM_TO_M, _planck_m

#: Reference wavelength at which the volume's κ is given in spectral mode, nm.
REFERENCE_NM = 550.0


@dataclass(frozen=True)
class SpectralBins:
    """N bins over the CMF grid: which 1 nm samples each holds, and its absorption scale."""

    edges: NDArray[np.int64]  # sample index boundaries, (N + 1,)
    centre_nm: NDArray[np.float64]  # Y-weighted mean wavelength of each bin
    kappa_scale: NDArray[np.float64]  # (λ_ref / λ_b)^α

    @property
    def count(self) -> int:
        return int(self.centre_nm.size)


def make_bins(n: int, alpha: float, observer: str = "cie1931_2") -> SpectralBins:
    """``n`` bins of (nearly) equal width over 360–830 nm for soot exponent ``alpha``."""
    cmf = cmfs(observer)
    size = cmf.wavelength_nm.size
    if not 1 <= n <= size:
        raise ValueError(f"spectral_bins must be in 1..{size}; got {n}")
    edges = np.round(np.linspace(0, size, n + 1)).astype(np.int64)
    y = cmf.xyz_bar[:, 1] + 1e-12
    spans = list(zip(edges[:-1], edges[1:], strict=True))
    centre = np.array([np.average(cmf.wavelength_nm[a:b], weights=y[a:b]) for a, b in spans])
    return SpectralBins(edges, centre, (REFERENCE_NM / centre) ** alpha)


def bin_xyz(
    bins: SpectralBins,
    temperature_K: NDArray,
    observer: str = "cie1931_2",
    constants: str = "codata2018",
) -> NDArray[np.float64]:
    """XYZ of B(T) in each bin, shape T.shape + (N, 3); sums over bins to blackbody_xyz."""
    cmf = cmfs(observer)
    temp = np.asarray(temperature_K, dtype=np.float64)
    lam_m = cmf.wavelength_nm * NM_TO_M
    radiance = _planck_m(lam_m, temp[..., None], planck_constants(constants)) * NM_TO_M
    per_sample = K_M * cmf.step_nm * radiance[..., :, None] * cmf.xyz_bar  # (..., 471, 3)
    return np.stack(
        [
            per_sample[..., a:b, :].sum(axis=-2)
            for a, b in zip(bins.edges[:-1], bins.edges[1:], strict=True)
        ],
        axis=-2,
    )


def bin_luts(
    bins: SpectralBins,
    t_max_K: float,
    observer: str = "cie1931_2",
    constants: str = "codata2018",
) -> list[EmissionLUT]:
    """One 1/T-uniform table per bin (same spacing as the blackbody table)."""
    return build_emission_luts(t_max_K, lambda t: bin_xyz(bins, t, observer, constants), bins.count)
