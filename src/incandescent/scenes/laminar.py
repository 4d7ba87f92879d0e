"""An axisymmetric sooty laminar diffusion flame for the pyrometry demos and tests.

Shaped and sized after the ethylene/air coflow flame of Santoro, Semerjian & Dobbins (1983,
Combust. Flame 51:203; fuel tube 11.1 mm, visible height 88 mm) and its later measurements
(Santoro et al. 1987, Combust. Sci. Technol. 53:89): a thin reaction sheet near 1950 K whose
radius shrinks with height as a Burke–Schumann flame's does, soot in an annulus just inside it
peaking near 9 ppm at mid-height, and a cool fuel core. The field is a smooth analytic
stand-in with these magnitudes, not the measured data. Soot's absorption is Rayleigh's
κ₅₅₀ = 6π E(m) f_v / λ with E(m) = 0.26 (the value Santoro's group used), its spectral law
α = 1 (κ_λ ∝ 1/λ, ``Volume.soot_alpha``).
"""

from __future__ import annotations

import numpy as np

from incandescent.volume import Volume

#: Peak temperature of the reaction sheet, K; the air and fuel around it, K.
SHEET_K, AMBIENT_K = 1950.0, 300.0
#: Peak soot volume fraction (Santoro et al. 1983: ~8–10 ppm).
PEAK_FV = 9e-6
#: Soot's absorption function E(m) and its wavelength law.
E_M, SOOT_ALPHA = 0.26, 1.0
#: The flame's base radius (the fuel tube's 5.55 mm) and visible height, m.
BASE_RADIUS_M, HEIGHT_M = 5.55e-3, 0.088


def sheet_radius_m(z_m):
    """The reaction sheet's radius at height z: R₀·√(1 − z/H) (Burke–Schumann-like), 0 above."""
    return BASE_RADIUS_M * np.sqrt(np.clip(1.0 - np.asarray(z_m) / HEIGHT_M, 0.0, 1.0))


def fields(r_m, z_m) -> tuple[np.ndarray, np.ndarray]:
    """(T in K, soot volume fraction) at radii r and heights z (broadcast)."""
    rf = sheet_radius_m(z_m)
    height = np.clip(np.asarray(z_m) / HEIGHT_M, 0.0, 1.0)
    sheet = np.exp(-(((r_m - rf) / 1.6e-3) ** 2))
    core = np.exp(-((r_m / np.maximum(rf, 1e-4)) ** 2)) * (1.0 - height)
    temp = AMBIENT_K + (SHEET_K - AMBIENT_K) * sheet * (1.0 - 0.35 * core) * (1 - height**6)
    soot_band = np.exp(-(((r_m - 0.75 * rf) / 1.0e-3) ** 2))
    fv = PEAK_FV * soot_band * np.sin(np.pi * height) ** 2
    return temp, fv


def laminar_flame(voxel_m: float = 4e-4, width_m: float = 0.016) -> Volume:
    """The flame in a box ``width_m`` wide (x, z) and the flame's height tall (y, up), the axis
    on the box's centre line; κ₅₅₀ = 6π E(m) f_v / 550 nm."""
    n = int(round(width_m / voxel_m)) | 1  # odd: a voxel column on the axis
    ny = int(round(HEIGHT_M / voxel_m))
    x = (np.arange(n) - n // 2) * voxel_m
    y = (np.arange(ny) + 0.5) * voxel_m
    r = np.hypot(x[:, None, None], x[None, None, :])
    temp, fv = fields(r, y[None, :, None])
    kappa = 6.0 * np.pi * E_M * fv / 550e-9
    corner = -(n // 2 + 0.5) * voxel_m
    volume = Volume.from_arrays(temp.astype(np.float32), absorption=kappa.astype(np.float32),
                                voxel_size_m=voxel_m, origin_m=(corner, 0.0, corner))  # fmt: skip
    return volume.with_soot_alpha(SOOT_ALPHA)
