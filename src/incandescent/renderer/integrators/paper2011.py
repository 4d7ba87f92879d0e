"""The 2011 paper's method (Zonenberg & Forrest 2011, §4) as an integrator: a display-referred
transport, not emission–absorption.

Per sample at or above ``min_K`` the colour of ``spectra.paper2011.paper_rgb``
(chromaticity of the 19-sample Planck sums plus the 590 nm sodium term, through the constant
sRGB matrix, clamped, normalised, × T^exponent) times ``gain`` per voxel of path is added
along the ray, with no absorption. The image is display-referred RGB capped at 255
(``HDRImage.display_rgb``), not absolute XYZ. The kernel reads the paper's sums from tables on
the common 1/T spacing; the reference evaluates them exactly. The sodium fraction is the
volume's species ``Na`` (grid name ``sodium_fraction`` in files).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent import _validate
from incandescent.renderer.backends.common import trilinear
from incandescent.renderer.integrators.base import Integrator, Reference, Segment, Traced
from incandescent.spectra.lut import T_MAX_K, EmissionLUT, build_emission_lut, cached_tables
from incandescent.spectra.paper2011 import (
    PAPER_XYZ_TO_RGB,
    paper_rgb,
    paper_sodium_xyz,
    paper_spectrum_xyz,
)

#: The image's values are the paper's display RGB sums, capped here.
PAPER_CAP = 255.0
#: Default gain per voxel of path: 32 voxels of 3000 K gas sum to 255 (our choice; the paper
#: does not give its scale).
PAPER_GAIN = 255.0 / (32.0 * 3000.0**1.5)
#: Default threshold: samples below it do not contribute (the paper mentions a threshold without
#: its value; 800 K is about the Draper point, where a visible glow begins).
PAPER_MIN_K = 800.0
#: The species whose fraction is the paper's sodium term.
SODIUM = "Na"


@functools.lru_cache(maxsize=2)
def paper_lut(kind: str) -> EmissionLUT:
    """The paper's 19-sample sums ("spectrum") or its 590 nm sodium term ("sodium") vs T."""
    fn = paper_sodium_xyz if kind == "sodium" else paper_spectrum_xyz
    return cached_tables(f"paper2011 {kind} {T_MAX_K}", lambda: [build_emission_lut(T_MAX_K, fn)])[
        0
    ]


@dataclass(frozen=True)
class Paper2011(Integrator):
    """The paper's colour model summed along the ray with no absorption: brightness ∝
    T^``exponent``, ``gain`` per voxel of path, samples below ``min_K`` do not contribute; the
    image is display RGB capped at 255 (``HDRImage.display_rgb``)."""

    exponent: float = 1.5
    gain: float = PAPER_GAIN
    min_K: float = PAPER_MIN_K

    name = "paper2011"
    display_referred = True

    def __post_init__(self) -> None:
        for key in ("exponent", "gain", "min_K"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise ValueError(f"paper_{key} must be a number; got {value!r}")
            object.__setattr__(self, key, float(value))
        _validate.positive_scalar(self.gain, "paper_gain")
        _validate.positive_scalar(self.min_K, "paper_min_K")
        if not np.isfinite(self.exponent) or not 0 <= self.exponent <= 8:
            raise ValueError(f"paper_exponent must be in [0, 8]; got {self.exponent!r}")

    # --- host -------------------------------------------------------------------------------
    def models(self, volume) -> tuple:
        return ()  # the paper's colour is its own (``spectra.paper2011``), not emission models

    def check_models(self, models) -> tuple:
        if models:
            raise ValueError("the paper2011 integrator takes no emission models")
        return ()

    def first_table(self, models):
        return paper_lut("spectrum")

    def occupancy(self, models) -> tuple[str, Callable | None]:
        """Voxels at or above ``min_K`` (the paper ignores absorption)."""

        def grid(volume) -> NDArray[np.float32]:
            return (volume.temperature_K >= np.float32(self.min_K)).astype(np.float32)

        return f"{self.name} >= {self.min_K!r} K", grid

    def sparse_problem(self, models) -> str | None:
        return f"the {self.name} integrator is not emission–absorption"

    def film(self, values):
        """Display-referred RGB: the paper's sums, capped at :data:`PAPER_CAP`."""
        return None, np.minimum(values, PAPER_CAP).astype(np.float32)

    def metadata(self) -> dict[str, object]:
        return {
            "integrator": self.name,
            "brightness": "paper",
            "paper_exponent": self.exponent,
            "paper_gain": self.gain,
            "paper_min_K": self.min_K,
        }

    def traced(self, kernel) -> Traced:
        return _Traced(kernel, self)

    def reference(self, inputs) -> Reference:
        return _Reference(inputs, self)


class _Traced(Traced):
    """The paper's sums in the kernel: its tables, the sodium grid, the matrix and the gain."""

    def __init__(self, kernel, paper: Paper2011) -> None:
        super().__init__(kernel)
        self.paper = paper
        vol = kernel.volume
        sodium = vol.species.get(SODIUM)
        self.tables = [kernel.table(paper_lut("spectrum"))]
        self.sodium = None
        if sodium is not None:
            self.tables.append(kernel.table(paper_lut("sodium")))
            self.sodium = kernel.grid(("species", SODIUM), sodium)
        self.matrix = [[float(v) for v in row] for row in PAPER_XYZ_TO_RGB]
        self.gain_per_m = np.float32(paper.gain / vol.voxel_size_m)

    def interacts(self, kappa, temp, sampled):
        """Where a sample contributes (and first emits): T ≥ min_K."""
        hot = temp >= np.float32(self.paper.min_K)
        return hot, hot

    def colour(self, temp, c):
        """The paper's voxel colour at T (and the sodium fraction at corners c)."""
        K = self.kernel
        dr, m = K.dr, K.m
        position = K.lut_position(temp)
        xyz = K.lookup(self.tables[0], position)
        if self.sodium is not None:
            fraction = dr.clip(K.trilinear(self.sodium, c), 0.0, 1.0)
            xyz = dr.fma(K.lookup(self.tables[1], position), fraction, xyz)
        chroma = xyz / (xyz[0] + xyz[1] + xyz[2])
        rgb = m.Array3f(
            *(dr.maximum(sum(row[i] * chroma[i] for i in range(3)), 0.0) for row in self.matrix)
        )
        peak = dr.maximum(dr.maximum(rgb[0], rgb[1]), rgb[2])
        rgb = rgb * (dr.power(temp, float(self.paper.exponent)) / peak)
        return dr.select(temp >= K.lut_t_min, rgb, 0.0)

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        """Add colour × gain per voxel of path; no absorption (Tr stays 1)."""
        K = self.kernel
        rgb = self.colour(temp, c)
        if K.scale is not None:
            rgb = rgb * K.trilinear(K.scale, c)
        return tr, K.dr.fma(rgb, ds_m * self.gain_per_m, L)


class _Reference(Reference):
    """The paper's sums in float64, exact (``spectra.paper2011.paper_rgb``)."""

    def __init__(self, inputs, paper: Paper2011) -> None:
        super().__init__(inputs)
        self.paper = paper

    def step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        """Add paper_rgb(T, sodium)·gain per voxel of path where T ≥ min_K."""
        vol, paper = self.inputs.volume, self.paper
        r, p, ds_m = segment.r, segment.p, segment.ds_m
        temp = trilinear(vol.temperature_K, p)
        hot = temp >= np.float32(paper.min_K)
        if not hot.any():
            return hot
        grid = vol.species.get(SODIUM)
        sodium = 0.0 if grid is None else trilinear(grid, p[hot])
        colour = paper_rgb(temp[hot], np.clip(sodium, 0.0, 1.0), paper.exponent)
        if vol.emission_scale is not None:
            colour = colour * trilinear(vol.emission_scale, p[hot])[:, None]
        xyz[r[hot]] += colour * (paper.gain * ds_m[hot] / vol.voxel_size_m)[:, None]
        return hot
