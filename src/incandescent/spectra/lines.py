"""Emission lines and bands of species in flames (sodium, lithium, strontium, copper, CH*, C2 …).

A *line table* lists, per species, lines (atomic, width 0) and bands (molecular, Gaussian FWHM):
wavelength in air (nm), relative intensity, upper-level energy E_u (eV) and a citation. The shipped
table is ``data/lines.csv`` (its header gives the provenance of every column); users may load their
own CSV or TOML table with the same columns.

Line model (local thermodynamic equilibrium, Boltzmann population of the upper level)::

    P_j(T) = I_j · exp(−E_j/k_B · (1/T − 1/T_ref)) = s_j · exp(−E_j / (k_B T)),
    s_j    = I_j · exp(E_j / (k_B T_ref)),

where I_j is the row's ``relative_intensity`` — its power relative to the species' other rows at
the reference temperature :data:`T_REF_K` = 2000 K, the temperature of the flames the molecular
intensities were read from — and s_j the temperature-independent strength.

Absolute scale (a documented convention, not physics). A line table has no absolute strength, so
each species is scaled such that, at fraction 1 and T = T_ref, its luminance equals that of a
blackbody at T_ref per unit optical depth::

    Y_species(T_ref) = Y_bb(T_ref) ≈ 4.64e5 cd/m²   (CIE 1931 2°, CODATA 2018)

The XYZ returned by :func:`species_xyz` therefore has the units of
:func:`incandescent.spectra.blackbody.blackbody_xyz` (the value the renderer multiplies by κ·Δs),
so a pure-sodium voxel at 2000 K is as bright as a blackbody voxel at 2000 K and only differs in
colour; away from T_ref the brightness follows the Boltzmann factors exactly (sodium at 1500 K is
exp(−2.10 eV/k·(1/1500 − 1/2000)) ≈ 0.017 of its 2000 K luminance; it saturates, instead of
growing like T⁴, as T → ∞). Line emission here is emission only: lines do not add absorption.

Deposit. A line of width 0 at λ_c between grid samples λ_i ≤ λ_c < λ_{i+1} (step h) puts
(1 − f)/h on λ_i and f/h on λ_{i+1}, f = (λ_c − λ_i)/h (linear interpolation of the CMFs), so the
rectangle-rule integral Σ S_i·h equals the line's power exactly. A band of FWHM w is the Gaussian
of σ = w / (2√(2 ln 2)) deposited the same way, i.e. integrated against the same hat functions
(closed form below), which is also integral preserving and tends to the line deposit as w → 0.

References
----------
NIST Atomic Spectra Database, v5 (Kramida, Ralchenko, Reader and NIST ASD Team).
W. Meyerriecks and K. L. Kosanke, "Color Values and Spectra of the Principal Emitters in Colored
Flames", J. Pyrotechnics 18 (2003) 1–22.
R. W. B. Pearse and A. G. Gaydon, *The Identification of Molecular Spectra*, 4th ed. (1976).
"""

from __future__ import annotations

import csv
import io
import math
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.constants import K_BOLTZMANN_EV, K_M
from incandescent.spectra.blackbody import blackbody_xyz
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.lut import T_MIN_K, EmissionLUT, build_emission_lut

#: Reference temperature of the relative intensities and of the absolute scale, K.
T_REF_K = 2000.0
#: Accepted wavelength range of table rows, nm (air).
WAVELENGTH_RANGE_NM = (300.0, 900.0)
#: Largest accepted upper-level energy, eV (above the ionisation energy of every flame species;
#: keeps the LUT's 1e-4 interpolation bound, see :func:`build_species_lut`).
MAX_UPPER_ENERGY_EV = 15.0

REQUIRED_COLUMNS = ("species", "wavelength_nm", "relative_intensity", "upper_energy_eV")
OPTIONAL_COLUMNS = ("width_nm", "source")
COLUMNS = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
_FWHM_TO_SIGMA = 1.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))
_SHIPPED = "lines.csv (shipped with incandescent)"


@dataclass(frozen=True)
class LineTable:
    """A validated line table; one entry per row, arrays of shape (n,).

    Attributes
    ----------
    origin: the file the table came from (for messages).
    species: species name of each row.
    wavelength_nm: wavelength in air, nm.
    relative_intensity: power relative to the species' other rows at :data:`T_REF_K`.
    upper_energy_eV: upper-level energy E_u, eV.
    width_nm: Gaussian FWHM in nm; 0 for a line.
    source: citation of each row ("" if the file gave none).
    """

    origin: str
    species: tuple[str, ...]
    wavelength_nm: NDArray[np.float64]
    relative_intensity: NDArray[np.float64]
    upper_energy_eV: NDArray[np.float64]
    width_nm: NDArray[np.float64]
    source: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.species)

    def rows_of(self, species: str) -> NDArray[np.intp]:
        """Row indices of ``species`` (ValueError listing the valid names if unknown)."""
        _validate.choice(species, "species", species_names(self))
        return np.flatnonzero(np.asarray(self.species) == species)


# --------------------------------------------------------------------------- loading


def load_lines(path: str | Path | None = None) -> LineTable:
    """Load and validate a line table: the shipped one (``path=None``), or a CSV/TOML file.

    CSV: a header row with the column names, ``#`` comment lines allowed. TOML: an array of tables
    ``[[lines]]``, each with the same keys. Columns: ``species``, ``wavelength_nm``,
    ``relative_intensity``, ``upper_energy_eV`` (required), ``width_nm`` (default 0) and ``source``
    (default ""); see :mod:`incandescent.spectra.lines` for their meaning.

    Raises
    ------
    ValueError
        Naming the file, the row and the column: missing or unknown columns, non-numeric or
        non-finite values, wavelength outside 300–900 nm, negative intensity, energy or width,
        energy above 15 eV, duplicate (species, wavelength) rows, an empty table.
    FileNotFoundError
        If ``path`` does not exist.
    """
    if path is None:
        text = resources.files("incandescent.spectra").joinpath("data/lines.csv").read_text("utf-8")
        return _table_from_records(_SHIPPED, _csv_records(text, _SHIPPED))
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".toml"):
        raise ValueError(f"{p}: unsupported line table format {p.suffix!r}; expected .csv or .toml")
    from incandescent.io.volumes import check_input_file

    check_input_file(p, "line table")
    try:
        text = p.read_text("utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(
            f"{p}: not a UTF-8 text line table (byte {error.start} is "
            f"{error.object[error.start]:#04x}); expected .csv or .toml text"
        ) from None
    records = _csv_records(text, str(p)) if suffix == ".csv" else _toml_records(text, str(p))
    return _table_from_records(str(p), records)


_Record = tuple[str, Mapping[str, Any]]  # (where, column -> raw value)


def _csv_records(text: str, name: str) -> list[_Record]:
    lines = [(n, s) for n, s in enumerate(text.splitlines(), 1) if s.strip() and s[0] != "#"]
    if not lines:
        raise ValueError(f"{name}: no header row (expected columns {', '.join(COLUMNS)})")
    rows = list(csv.reader(io.StringIO("\n".join(s for _, s in lines))))
    header = [h.strip() for h in rows[0]]
    _check_columns(header, name, f"header (line {lines[0][0]})")
    records: list[_Record] = []
    for (line_no, _), cells in zip(lines[1:], rows[1:], strict=True):
        where = f"{name} line {line_no}"
        if len(cells) != len(header):
            raise ValueError(f"{where}: {len(cells)} cells; the header has {len(header)} columns")
        records.append((where, dict(zip(header, (c.strip() for c in cells), strict=True))))
    return records


def _toml_records(text: str, name: str) -> list[_Record]:
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{name}: not valid TOML: {exc}") from None
    extra = sorted(set(doc) - {"lines"})
    if extra:
        raise ValueError(f"{name}: unknown top-level key(s) {extra}; expected only [[lines]]")
    entries = doc.get("lines")
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise ValueError(f"{name}: expected an array of tables [[lines]]")
    records: list[_Record] = []
    for i, entry in enumerate(entries):
        where = f"{name} lines[{i}]"
        _check_columns(list(entry), name, where)
        records.append((where, entry))
    return records


def _check_columns(columns: Sequence[str], name: str, where: str) -> None:
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    unknown = [c for c in columns if c not in COLUMNS]
    dupes = sorted({c for c in columns if list(columns).count(c) > 1})
    if missing:
        raise ValueError(f"{name} {where}: missing column(s) {missing}")
    if unknown:
        raise ValueError(f"{name} {where}: unknown column(s) {unknown}; expected {list(COLUMNS)}")
    if dupes:
        raise ValueError(f"{name} {where}: repeated column(s) {dupes}")


def _table_from_records(origin: str, records: list[_Record]) -> LineTable:
    if not records:
        raise ValueError(f"{origin}: the table has no rows")
    parsed = [_parse_row(where, rec) for where, rec in records]
    seen: dict[tuple[str, float], str] = {}
    for (where, _), row in zip(records, parsed, strict=True):
        key = (row[0], row[1])
        if key in seen:
            raise ValueError(
                f"{where}: duplicate row for species {key[0]!r} at {key[1]:g} nm "
                f"(first given at {seen[key].removeprefix(origin).strip()})"
            )
        seen[key] = where

    def column(i: int) -> NDArray[np.float64]:
        arr = np.array([r[i] for r in parsed], dtype=np.float64)
        arr.setflags(write=False)
        return arr

    return LineTable(
        origin=origin,
        species=tuple(r[0] for r in parsed),
        wavelength_nm=column(1),
        relative_intensity=column(2),
        upper_energy_eV=column(3),
        width_nm=column(4),
        source=tuple(r[5] for r in parsed),
    )


def _parse_row(where: str, rec: Mapping[str, Any]) -> tuple[str, float, float, float, float, str]:
    species = rec["species"]
    if not isinstance(species, str) or not species.strip():
        raise ValueError(f"{where}, column 'species': must be a non-empty name; got {species!r}")
    where = f"{where} (species {species.strip()!r})"
    lo, hi = WAVELENGTH_RANGE_NM
    wavelength = _number(rec, "wavelength_nm", where)
    if not lo <= wavelength <= hi:
        raise ValueError(
            f"{where}, column 'wavelength_nm': must be within {lo:g}–{hi:g} nm; got {wavelength:g}"
        )
    intensity = _number(rec, "relative_intensity", where)
    energy = _number(rec, "upper_energy_eV", where)
    width = _number(rec, "width_nm", where, default=0.0)
    for col, value in (("relative_intensity", intensity), ("upper_energy_eV", energy)):
        if value < 0:
            raise ValueError(f"{where}, column {col!r}: must be >= 0; got {value:g}")
    if energy > MAX_UPPER_ENERGY_EV:
        raise ValueError(
            f"{where}, column 'upper_energy_eV': must be <= {MAX_UPPER_ENERGY_EV:g} eV; "
            f"got {energy:g}"
        )
    if width < 0:
        raise ValueError(f"{where}, column 'width_nm': must be >= 0 (0 = a line); got {width:g}")
    source = rec.get("source", "")
    if not isinstance(source, str):
        raise ValueError(f"{where}, column 'source': must be text; got {source!r}")
    return species.strip(), wavelength, intensity, energy, width, source.strip()


def _number(rec: Mapping[str, Any], col: str, where: str, default: float | None = None) -> float:
    raw = rec.get(col, "")
    if raw == "" and default is not None:
        return default
    if raw == "":
        raise ValueError(f"{where}, column {col!r}: missing value")
    if isinstance(raw, bool) or not isinstance(raw, (str, int, float)):
        raise ValueError(f"{where}, column {col!r}: must be a number; got {raw!r}")
    try:
        value = float(raw)
    except ValueError:
        raise ValueError(f"{where}, column {col!r}: must be a number; got {raw!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{where}, column {col!r}: must be finite; got {raw!r}")
    return value


# --------------------------------------------------------------------------- spectra


def species_names(table: LineTable) -> tuple[str, ...]:
    """Species of ``table`` in order of first appearance."""
    return tuple(dict.fromkeys(table.species))


def line_profiles(
    wavelength_nm: ArrayLike, centre_nm: ArrayLike, fwhm_nm: ArrayLike
) -> NDArray[np.float64]:
    """Per-nm deposit of unit-power lines onto a uniform wavelength grid.

    Parameters
    ----------
    wavelength_nm: (M,) uniform ascending grid, nm (step h).
    centre_nm: (L,) line or band centres, nm.
    fwhm_nm: (L,) Gaussian FWHM, nm; 0 for a line.

    Returns
    -------
    (L, M) array in 1/nm; each row sums to 1/h (Σ P·h = 1) when the line lies at least
    h + 8σ inside the grid.

    Notes
    -----
    Row j is P_ij = (1/h) ∫ G_j(λ) φ_i(λ) dλ with the hat functions φ_i of the grid (the basis of
    linear interpolation). Writing φ_i as a second difference of ramps,
    h·φ_i(λ) = (λ−λ_i+h)₊ − 2(λ−λ_i)₊ + (λ−λ_i−h)₊, and E[(X−a)₊] = (μ−a)Φ(z) + σφ(z),
    z = (μ−a)/σ for X ~ N(μ, σ²), gives a closed form that reduces to (μ−a)₊ for σ = 0.
    """
    grid = _uniform_grid(wavelength_nm)
    h = float(grid[1] - grid[0])
    mu = np.asarray(centre_nm, dtype=np.float64).reshape(-1, 1)
    sigma = np.asarray(fwhm_nm, dtype=np.float64).reshape(-1, 1) * _FWHM_TO_SIGMA
    sigma = np.broadcast_to(sigma, mu.shape)
    d = mu - grid[None, :]
    near = np.abs(d) < h + 8.0 * sigma
    out = np.zeros(np.broadcast_shapes(d.shape, sigma.shape))
    dn, sn = d[near], np.broadcast_to(sigma, d.shape)[near]
    ramp = _ramp_mean(dn + h, sn) - 2.0 * _ramp_mean(dn, sn) + _ramp_mean(dn - h, sn)
    out[near] = np.maximum(ramp, 0.0) / (h * h)
    return out


_erf = np.vectorize(math.erf, otypes=[np.float64])


def _ramp_mean(m: NDArray, sigma: NDArray) -> NDArray:
    """E[(X)₊] for X ~ N(m, σ²); (m)₊ where σ = 0."""
    s = np.where(sigma > 0, sigma, 1.0)
    z = m / s
    gauss = m * 0.5 * (1.0 + _erf(z / math.sqrt(2.0))) + s * np.exp(-0.5 * z * z) / math.sqrt(
        2.0 * math.pi
    )
    return np.where(sigma > 0, gauss, np.maximum(m, 0.0))


def _uniform_grid(wavelength_nm: ArrayLike) -> NDArray[np.float64]:
    grid = _validate.finite(_validate.real_array(wavelength_nm, "wavelength_nm"), "wavelength_nm")
    if grid.ndim != 1 or grid.size < 2:
        raise ValueError(
            f"wavelength_nm must be a 1-D grid of >= 2 samples; got shape {grid.shape}"
        )
    step = np.diff(grid)
    if step[0] <= 0 or not np.allclose(step, step[0], rtol=1e-9, atol=0.0):
        raise ValueError("wavelength_nm must be uniformly spaced and ascending")
    return grid


def _power(table: LineTable, rows: NDArray[np.intp], temp_K: NDArray) -> NDArray[np.float64]:
    """P_j(T) = I_j exp(−E_j/k (1/T − 1/T_ref)), shape temp_K.shape + (rows,)."""
    energy = table.upper_energy_eV[rows] / K_BOLTZMANN_EV
    inv = 1.0 / temp_K[..., None] - 1.0 / T_REF_K
    return table.relative_intensity[rows] * np.exp(-energy * inv)


def _line_xyz(table: LineTable, rows: NDArray[np.intp], observer: str) -> NDArray[np.float64]:
    """K_m ∫ P̂_j x̄ȳz̄ dλ of each row's unit-power profile, (rows, 3)."""
    cmf = cmfs(observer)
    prof = line_profiles(cmf.wavelength_nm, table.wavelength_nm[rows], table.width_nm[rows])
    return K_M * cmf.step_nm * (prof @ cmf.xyz_bar)


def _scale(table: LineTable, rows: NDArray[np.intp], species: str, observer: str) -> float:
    """Factor making Y_species(T_ref) = Y_bb(T_ref) (see module doc)."""
    y_ref = float(table.relative_intensity[rows] @ _line_xyz(table, rows, observer)[:, 1])
    if not y_ref > 0:
        raise ValueError(
            f"species {species!r} of {table.origin} has no visible emission at {T_REF_K:g} K "
            "(all lines outside 360–830 nm or of zero intensity); cannot normalise it"
        )
    return float(blackbody_xyz(T_REF_K, observer)[1]) / y_ref


def species_spectrum(
    table: LineTable,
    species: str,
    temperature_K: ArrayLike,
    wavelength_nm: ArrayLike,
    observer: str = "cie1931_2",
) -> NDArray[np.float64]:
    """Spectral emission of ``species`` at fraction 1, per unit optical depth.

    Parameters
    ----------
    table: a :class:`LineTable` (:func:`load_lines`).
    species: one of :func:`species_names`.
    temperature_K: temperatures in K (> 0), any shape.
    wavelength_nm: (M,) uniform ascending grid in nm (e.g. the CMF grid, or spectral bins).
    observer: observer whose luminance fixes the absolute scale (module doc).

    Returns
    -------
    Array ``temperature_K.shape + (M,)`` in W·sr⁻¹·m⁻²·nm⁻¹, lines deposited integral-preserving
    (module doc). On the CMF grid, K_m Σ S·x̄ȳz̄·h equals :func:`species_xyz`.
    """
    rows = table.rows_of(species)
    temp = _validate.positive_temperature(temperature_K)
    prof = line_profiles(wavelength_nm, table.wavelength_nm[rows], table.width_nm[rows])
    scale = _scale(table, rows, species, observer)
    return scale * (_power(table, rows, temp) @ prof)


def species_xyz(
    table: LineTable, species: str, temperature_K: ArrayLike, observer: str = "cie1931_2"
) -> NDArray[np.float64]:
    """Absolute XYZ emitted by ``species`` at fraction 1, per unit optical depth.

    Same units as :func:`~incandescent.spectra.blackbody.blackbody_xyz` (Y in cd/m²), normalised
    so that Y_species(T_ref = 2000 K) = Y_bb(2000 K) ≈ 4.64e5 cd/m²; the temperature dependence is
    Σ_j s_j exp(−E_j/(k_B T)) exactly (module doc).

    Parameters
    ----------
    table: a :class:`LineTable`.
    species: one of :func:`species_names`.
    temperature_K: temperatures in K (> 0), any shape.
    observer: ``"cie1931_2"`` (default) or ``"cie1964_10"``.

    Returns
    -------
    Array ``temperature_K.shape + (3,)``.

    Examples
    --------
    >>> table = load_lines()
    >>> xyz = species_xyz(table, "Na", 2000.0)
    >>> f"{xyz[1]:.3e}"
    '4.638e+05'
    """
    rows = table.rows_of(species)
    temp = _validate.positive_temperature(temperature_K)
    scale = _scale(table, rows, species, observer)
    return scale * (_power(table, rows, temp) @ _line_xyz(table, rows, observer))


def build_species_lut(
    table: LineTable,
    species: str,
    t_max_K: float,
    observer: str = "cie1931_2",
    t_min_K: float = T_MIN_K,
) -> EmissionLUT:
    """T ↦ XYZ table of ``species`` (:func:`species_xyz`), sampled like the blackbody table.

    Built by :func:`~incandescent.spectra.lut.build_emission_lut`, uniform in w = 1/T with
    Δw ≈ 0.015 / max(t_max_K, 1e5 K). Each line is exp(−a·w) with a = E_u/k_B, whose linear
    interpolation error is ≤ (a·Δw)²/8 relative: 1.5e-5 at E_u = 6.2 eV (Cu I 521.8 nm) and
    ≤ 1e-4 up to E_u = 16 eV, above :data:`MAX_UPPER_ENERGY_EV`. A sum of such terms keeps the
    largest term's relative bound. Below ``t_min_K`` the table gives 0.
    """
    table.rows_of(species)  # validate before tabulating
    fn: Callable[[NDArray], NDArray] = lambda t: species_xyz(table, species, t, observer)  # noqa: E731
    return build_emission_lut(t_max_K, fn, t_min_K)
