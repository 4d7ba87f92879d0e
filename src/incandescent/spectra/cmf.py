"""CIE colour matching functions, 360–830 nm at 1 nm.

Data come from colour-science's tabulations of CIE 015:2018 (``colour.MSDS_CMFS``):
the CIE 1931 2° and CIE 1964 10° standard observers. Loaded lazily and cached, because importing
colour-science costs about half a second.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from incandescent import _validate

OBSERVERS = {
    "cie1931_2": "CIE 1931 2 Degree Standard Observer",
    "cie1964_10": "CIE 1964 10 Degree Standard Observer",
}


@dataclass(frozen=True)
class ColourMatchingFunctions:
    """Tabulated x̄ȳz̄ of one observer.

    Attributes
    ----------
    observer: key of :data:`OBSERVERS`.
    wavelength_nm: (N,) wavelengths in nm, 1 nm apart.
    xyz_bar: (N, 3) dimensionless colour matching functions.
    """

    observer: str
    wavelength_nm: NDArray[np.float64]
    xyz_bar: NDArray[np.float64]

    @property
    def step_nm(self) -> float:
        return float(self.wavelength_nm[1] - self.wavelength_nm[0])


def import_colour():
    """Import colour-science without its warnings about optional SciPy/Matplotlib features."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
    return colour


@functools.cache
def cmfs(observer: str = "cie1931_2") -> ColourMatchingFunctions:
    """Colour matching functions of ``observer`` (``"cie1931_2"`` default, or ``"cie1964_10"``)."""
    _validate.choice(observer, "observer", tuple(OBSERVERS))
    data = import_colour().MSDS_CMFS[OBSERVERS[observer]]
    wavelength = np.asarray(data.wavelengths, dtype=np.float64)
    values = np.asarray(data.values, dtype=np.float64)
    keep = (wavelength >= 360) & (wavelength <= 830)
    wavelength, values = wavelength[keep], values[keep]  # boolean indexing copies: freeze after
    wavelength.setflags(write=False)
    values.setflags(write=False)
    return ColourMatchingFunctions(observer, wavelength, values)
