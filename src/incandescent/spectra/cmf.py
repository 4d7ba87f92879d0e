"""CIE colour matching functions, 360–830 nm at 1 nm.

The CIE 1931 2° and CIE 1964 10° standard observers of CIE 015:2018, shipped as package data
(``spectra/data/cmf_*.csv``, written from colour-science's tabulations by
``scripts/cie_tables.py`` and compared with colour-science in ``tests/spectra/test_cmf_data.py``),
so the render path never imports colour-science (its import pulls in matplotlib and pandas: ~0.9 s).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

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


#: Folder of the shipped tables.
DATA = Path(__file__).with_name("data")


#: Observers registered at run time (a camera's channels: ``camera.sensor``), by name.
_REGISTERED: dict[str, ColourMatchingFunctions] = {}


def register_observer(prefix: str, weights: NDArray) -> str:
    """Register three weighting functions on the CIE grid (360–830 nm, 1 nm; (471, 3)) as an
    observer and return its name, ``prefix`` + a SHA-256 of the weights: the renderer then
    integrates K_m Σ L_λ w(λ) Δλ per channel instead of XYZ (tables cached on disk by name, so
    the name is the weights')."""
    import hashlib

    grid = _cie(next(iter(OBSERVERS))).wavelength_nm
    values = np.ascontiguousarray(weights, dtype=np.float64)
    if values.shape != (grid.size, 3) or not np.isfinite(values).all() or (values < 0).any():
        raise ValueError(f"observer weights must be finite, >= 0, shape ({grid.size}, 3)")
    name = f"{prefix}-{hashlib.sha256(values.tobytes()).hexdigest()[:16]}"
    values.setflags(write=False)
    _REGISTERED[name] = ColourMatchingFunctions(name, grid, values)
    return name


def cmfs(observer: str = "cie1931_2") -> ColourMatchingFunctions:
    """Colour matching functions of ``observer`` (``"cie1931_2"`` default, or ``"cie1964_10"``,
    or a name :func:`register_observer` returned)."""
    if observer in _REGISTERED:
        return _REGISTERED[observer]
    return _cie(observer)


@functools.cache
def _cie(observer: str) -> ColourMatchingFunctions:
    _validate.choice(observer, "observer", tuple(OBSERVERS))
    rows = np.loadtxt(DATA / f"cmf_{observer}.csv", delimiter=",", dtype=np.float64)
    wavelength, values = rows[:, 0].copy(), np.ascontiguousarray(rows[:, 1:])
    wavelength.setflags(write=False)
    values.setflags(write=False)
    return ColourMatchingFunctions(observer, wavelength, values)
