"""The 2011 paper's emission model (Zonenberg & Forrest 2011, §4), a *display* model.

Per sample at or above ``paper_min_K`` the colour of ``spectra.paper2011.paper_rgb``
(chromaticity of the 19-sample Planck sums plus the 590 nm sodium term, through the constant
sRGB matrix, clamped, normalised, × T^exponent) times ``paper_gain`` per voxel of path is added
along the ray, with no absorption. The image is display-referred RGB capped at 255
(``HDRImage.display_rgb``), not absolute XYZ. The kernel reads the paper's sums from tables on
the common 1/T spacing; the reference evaluates them exactly.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from incandescent.emission.base import Bands, EmissionModel
from incandescent.spectra.lut import T_MAX_K, EmissionLUT, build_emission_lut, cached_tables
from incandescent.spectra.paper2011 import (
    PAPER_XYZ_TO_RGB,
    paper_rgb,
    paper_sodium_xyz,
    paper_spectrum_xyz,
)

#: The image's values are the paper's display RGB sums, capped here.
PAPER_CAP = 255.0


@functools.lru_cache(maxsize=2)
def paper_lut(kind: str) -> EmissionLUT:
    """The paper's 19-sample sums ("spectrum") or its 590 nm sodium term ("sodium") vs T."""
    fn = paper_sodium_xyz if kind == "sodium" else paper_spectrum_xyz
    return cached_tables(f"paper2011 {kind} {T_MAX_K}", lambda: [build_emission_lut(T_MAX_K, fn)])[
        0
    ]


class Paper2011(EmissionModel):
    """The paper's colour model summed along the ray (``settings.paper_*``; sodium from the
    volume's ``sodium_fraction``)."""

    name = "paper2011"
    kind = "display"

    def __init__(self, settings, sodium: bool) -> None:
        self.min_K, self.exponent = settings.paper_min_K, settings.paper_exponent
        self.gain = settings.paper_gain
        self.bands = Bands()
        self.tables = (paper_lut("spectrum"),) + ((paper_lut("sodium"),) if sodium else ())

    @property
    def occupancy_key(self) -> str:
        return f"{self.name} >= {self.min_K!r} K"

    def occupancy(self, volume) -> NDArray[np.float32]:
        """Voxels at or above ``min_K`` (the paper ignores absorption)."""
        return (volume.temperature_K >= np.float32(self.min_K)).astype(np.float32)

    # --- kernel -----------------------------------------------------------------------------
    def bind(self, kernel):
        vol = kernel.volume
        sodium = None
        if len(self.tables) > 1 and vol.sodium_fraction is not None:
            sodium = kernel.grid(("sodium",), vol.sodium_fraction)
        matrix = [[float(v) for v in row] for row in PAPER_XYZ_TO_RGB]
        gain_per_m = np.float32(self.gain / vol.voxel_size_m)
        return [kernel.table(t) for t in self.tables], sodium, matrix, gain_per_m

    def sample(self, kernel, bound, corners) -> list:
        return []  # the sodium fraction is read inside the branch, where a sample contributes

    def interacts(self, kernel, temp):
        """Traced: where a sample contributes (and first emits): T ≥ paper_min_K."""
        return temp >= np.float32(self.min_K)

    def colour(self, kernel, bound, temp, c):
        """Traced: the paper's voxel colour at T (and the sodium fraction at corners c)."""
        dr, m = kernel.dr, kernel.m
        tables, sodium, matrix, _ = bound
        position = kernel.lut_position(temp)
        xyz = kernel.lookup(tables[0], position)
        if sodium is not None:
            fraction = dr.clip(kernel.trilinear(sodium, c), 0.0, 1.0)
            xyz = dr.fma(kernel.lookup(tables[1], position), fraction, xyz)
        chroma = xyz / (xyz[0] + xyz[1] + xyz[2])
        rgb = m.Array3f(
            *(dr.maximum(sum(row[i] * chroma[i] for i in range(3)), 0.0) for row in matrix)
        )
        peak = dr.maximum(dr.maximum(rgb[0], rgb[1]), rgb[2])
        rgb = rgb * (dr.power(temp, float(self.exponent)) / peak)
        return dr.select(temp >= kernel.lut_t_min, rgb, 0.0)

    def accumulate(self, kernel, bound, tr, L, temp, c, ds_m):
        """Traced: add colour × gain per voxel of path; no absorption (Tr stays 1)."""
        rgb = self.colour(kernel, bound, temp, c)
        if kernel.scale is not None:
            rgb = rgb * kernel.trilinear(kernel.scale, c)
        return tr, kernel.dr.fma(rgb, ds_m * bound[3], L)

    def add(self, kernel, bound, eta, band, position, values):
        raise TypeError("the paper's model replaces transport; the kernel calls accumulate()")

    # --- reference --------------------------------------------------------------------------
    def reference_step(self, inputs, trilinear, r, p, ds_m, rgb) -> NDArray[np.bool_]:
        """Float64: add paper_rgb(T, sodium)·gain per voxel of path where T ≥ paper_min_K, in
        place; returns the mask of rays whose sample contributed."""
        vol = inputs.volume
        temp = trilinear(vol.temperature_K, p)
        hot = temp >= np.float32(self.min_K)
        if not hot.any():
            return hot
        sodium = 0.0 if vol.sodium_fraction is None else trilinear(vol.sodium_fraction, p[hot])
        colour = paper_rgb(temp[hot], np.clip(sodium, 0.0, 1.0), self.exponent)
        if vol.emission_scale is not None:
            colour = colour * trilinear(vol.emission_scale, p[hot])[:, None]
        rgb[r[hot]] += colour * (self.gain * ds_m[hot] / vol.voxel_size_m)[:, None]
        return hot

    def reference_add(self, eta, temperature_K, values, inputs):
        raise TypeError("the paper's model replaces transport; the reference uses reference_step")
