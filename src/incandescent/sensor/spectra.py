"""Spectral curves of a camera: its channels' sensitivities and the filters in front of it.

Curves are tabulated (wavelength in nm, strictly increasing; values finite and >= 0) and
resampled linearly onto the CIE grid the renderer integrates on (360–830 nm, 1 nm; zero
outside the table). Shipped: the Nikon D5100's red, green and blue sensitivities measured at
the UK National Physical Laboratory (Darrodi et al. 2015, JOSA A 32:381, through
colour-science), each peaking at 1 — the one Bayer camera of colour-science's measured set
(its other, a Sigma SD Merrill, is a Foveon stack, not a mosaic). Users give their own as CSV.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from incandescent import _validate
from incandescent.spectra.cmf import cmfs

#: Folder of the shipped curves.
DATA = Path(__file__).resolve().parents[1] / "camera" / "data"
#: Shipped responses by name → file.
SHIPPED = {"nikon_d5100": "nikon_d5100_npl.csv"}


def grid_nm() -> NDArray[np.float64]:
    """The wavelengths the renderer integrates on: the CIE functions' 360–830 nm, 1 nm."""
    return cmfs().wavelength_nm


def _checked_table(wavelength_nm, values, where: str, columns: int) -> tuple[NDArray, NDArray]:
    """(λ, values) as float64, λ strictly increasing, values finite and >= 0: else one line
    naming the row."""
    lam = np.asarray(wavelength_nm, dtype=np.float64)
    val = np.asarray(values, dtype=np.float64).reshape(len(lam), columns)
    if lam.ndim != 1 or lam.size < 2 or not np.isfinite(lam).all():
        raise ValueError(f"{where}: expected at least two finite wavelengths in nm")
    step = np.flatnonzero(np.diff(lam) <= 0)
    if step.size:
        i = int(step[0]) + 1
        raise ValueError(f"{where}: wavelengths must increase; row {i + 1} has {lam[i]:g} nm "
                         f"after {lam[i - 1]:g} nm")  # fmt: skip
    bad = np.flatnonzero(~np.isfinite(val).all(axis=1) | (val < 0).any(axis=1))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{where}: values must be finite and >= 0; row {i + 1} "
                         f"({lam[i]:g} nm) has {val[i].tolist()}")  # fmt: skip
    return lam, val


def read_curve_csv(path, columns: int) -> tuple[NDArray, NDArray]:
    """A CSV of ``wavelength_nm`` and ``columns`` value columns (``#`` comments and one header
    line allowed) → (λ, values (N, columns)), checked as :func:`_checked_table` checks."""
    path = Path(path)
    try:
        lines = [x for x in path.read_text().splitlines() if x.strip() and not x.startswith("#")]
        if lines and not _is_number(lines[0].split(",")[0]):
            lines = lines[1:]  # the header
        rows = np.atleast_2d(np.loadtxt(lines, delimiter=",", ndmin=2))
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not a CSV of wavelength_nm and {columns} column(s): "
                         f"{str(error).splitlines()[0]}") from None  # fmt: skip
    if rows.shape[1] != columns + 1:
        raise ValueError(f"{path}: expected wavelength_nm and {columns} column(s); got "
                         f"{rows.shape[1]} columns")  # fmt: skip
    return _checked_table(rows[:, 0], rows[:, 1:], str(path), columns)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


@dataclass(frozen=True, eq=False)
class Curves:
    """Tabulated curves (one or more columns) on their own wavelengths, with where they came
    from; :meth:`on_grid` resamples them onto the renderer's grid."""

    wavelength_nm: NDArray[np.float64]
    values: NDArray[np.float64]
    source: str

    def on_grid(self) -> NDArray[np.float64]:
        """Linear interpolation onto :func:`grid_nm` (0 outside the table), (471, columns)."""
        grid = grid_nm()
        return np.stack([np.interp(grid, self.wavelength_nm, column, left=0.0, right=0.0)
                         for column in self.values.T], axis=1)  # fmt: skip


def response(name_or_path) -> Curves:
    """A camera's red, green and blue sensitivities: a shipped name (``nikon_d5100``) or a CSV
    (wavelength_nm, red, green, blue)."""
    text = str(name_or_path)
    path = DATA / SHIPPED[text] if text in SHIPPED else Path(text)
    if text not in SHIPPED and not path.is_file():
        raise ValueError(f"sensitivity {text!r}: neither a shipped camera ("
                         f"{', '.join(SHIPPED)}) nor a CSV file")  # fmt: skip
    lam, values = read_curve_csv(path, 3)
    return Curves(lam, values, text)


@dataclass(frozen=True)
class Filter:
    """A filter in front of the sensor: ``kind`` "nd" (optical density ``density``: T = 10^−d),
    "bandpass" (a Gaussian of ``centre_nm`` and full width at half maximum ``width_nm``, peak
    ``peak``), "ir_cut" (1 below ``edge_nm``, 0 above, a linear edge ``width_nm`` wide), or
    "csv" (``path``: wavelength_nm, transmittance)."""

    kind: str
    density: float = 0.0
    centre_nm: float = 550.0
    width_nm: float = 10.0
    peak: float = 1.0
    edge_nm: float = 680.0
    path: str | None = None

    def __post_init__(self) -> None:
        _validate.choice(self.kind, "filter kind", ("nd", "bandpass", "ir_cut", "csv"))
        if self.kind == "csv" and self.path is None:
            raise ValueError("a csv filter needs path (wavelength_nm, transmittance)")
        for name in ("density", "centre_nm", "width_nm", "peak", "edge_nm"):
            _validate.finite_scalar(getattr(self, name), f"filter {name}")
        if self.density < 0 or not 0 <= self.peak <= 1 or self.width_nm <= 0:
            raise ValueError(f"a filter needs density >= 0, 0 <= peak <= 1, width_nm > 0; got "
                             f"{self.density!r}, {self.peak!r}, {self.width_nm!r}")  # fmt: skip

    def transmittance(self) -> NDArray[np.float64]:
        """Its transmittance on :func:`grid_nm` (471,)."""
        lam = grid_nm()
        if self.kind == "nd":
            return np.full(lam.shape, 10.0**-self.density)
        if self.kind == "bandpass":
            sigma = self.width_nm / (2.0 * np.sqrt(2.0 * np.log(2.0)))
            return self.peak * np.exp(-0.5 * ((lam - self.centre_nm) / sigma) ** 2)
        if self.kind == "ir_cut":
            return np.clip((self.edge_nm + 0.5 * self.width_nm - lam) / self.width_nm, 0.0, 1.0)
        curve = Curves(*read_curve_csv(self.path, 1), str(self.path))
        if (curve.values > 1).any():
            raise ValueError(f"{self.path}: a transmittance is at most 1")
        return curve.on_grid()[:, 0]
