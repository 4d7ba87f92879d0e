"""Radial temperature of an axisymmetric flame: the inverse Abel transform of each channel's
line-of-sight signal (PyAbel's BASEX, Dribinski et al. 2002, Rev. Sci. Instrum. 73:2634, with
its Tikhonov regularisation), then the two-colour ratio of the local emission.

An optically thin flame's pixel signal is the line integral of the local emission
κ_λ B_λ(T) through each channel; inverted, the ratio of the red and green local emissions is
the thin-soot ratio of the local T (``table``). Self-absorption is neglected: the flame must be
thin in the channels (τ ≲ 0.3), as it must for any Abel-based pyrometry.
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
    min_fraction: float = 0.05,
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
