"""Tabulated T ↦ XYZ emission per unit absorption, the table the renderer samples.

For grey absorption κ the wavelength integral commutes with transport (Kirchhoff: emission is
κ·B_λ(T)), so a 1-D table of XYZ(B(T)) is exact up to its interpolation error.

Sampling. The table is uniform in *inverse* temperature w = 1/T. Blackbody XYZ behaves like
exp(−a·w) at low T (Wien, a = c2/λ ≤ 3.8e4 K) and like 1/w at high T (Rayleigh–Jeans), and linear
interpolation in w is accurate at both ends: the relative error is about (a·Δw)²/8 at low T and
(Δw·T)²/4 at high T. The spacing is set so that (Δw·T_max)²/4 ≤ 1e-4, i.e. Δw ≤ 0.02 / T_max;
we use 0.015 / T_max for margin, which gives about 1e-4 at most on
[T_min, T_max] (measured in ``tests/spectra/test_lut.py``).
Below T_min the renderer emits nothing (at 250 K the visible luminance is ~1e-37 cd/m²); above
T_max the table is extended when built for a volume (:func:`build_emission_lut` ``t_max_K``).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.spectra.blackbody import blackbody_xyz

T_MIN_K = 250.0
T_MAX_K = 100_000.0
MIN_ENTRIES = 4096


@dataclass(frozen=True)
class EmissionLUT:
    """XYZ emission per unit absorption, tabulated uniformly in w = 1/T.

    Attributes
    ----------
    t_min_K, t_max_K: table range in K; entry 0 is at T_max, entry N−1 at T_min.
    values: (N, 3) float64, XYZ of B(T) (Y in cd/m²) at w_i = 1/T_max + i·Δw.
    """

    t_min_K: float
    t_max_K: float
    values: NDArray[np.float64]

    @property
    def size(self) -> int:
        return int(self.values.shape[0])

    @property
    def w_min(self) -> float:
        """Smallest tabulated inverse temperature 1/T_max in 1/K."""
        return 1.0 / self.t_max_K

    @property
    def inv_dw(self) -> float:
        """Entries per unit of inverse temperature (1/Δw), in K."""
        return (self.size - 1) / (1.0 / self.t_min_K - self.w_min)

    def lookup(self, temperature_K: ArrayLike) -> NDArray[np.float64]:
        """Linear interpolation in 1/T, exactly as the kernels do; 0 below T_min; clamped above."""
        temp = np.asarray(temperature_K, dtype=np.float64)
        f = (1.0 / np.maximum(temp, 1e-30) - self.w_min) * self.inv_dw
        f = np.clip(f, 0.0, self.size - 1)
        i0 = np.minimum(np.floor(f).astype(np.int64), self.size - 2)
        frac = (f - i0)[..., None]
        out = self.values[i0] * (1.0 - frac) + self.values[i0 + 1] * frac
        return np.where((temp >= self.t_min_K)[..., None], out, 0.0)


def table_size(t_max_K: float, t_min_K: float = T_MIN_K) -> int:
    """Entries for ≤ 1e-4 relative interpolation error on [t_min_K, t_max_K] (see module doc).

    The spacing Δw = 0.015 / t_max_K is fixed by the hot end, so the count grows with the
    inverse-temperature span 1/t_min_K − 1/t_max_K.
    """
    span = 1.0 / t_min_K - 1.0 / t_max_K
    return max(MIN_ENTRIES, int(np.ceil(span * t_max_K / 0.015)) + 1)


def build_emission_luts(
    t_max_K: float, xyz_of_temperature: Callable[[NDArray], NDArray], count: int
) -> list[EmissionLUT]:
    """``count`` tables at once from ``xyz_of_temperature(T)`` of shape T.shape + (count, 3)
    (e.g. the XYZ of every spectral bin), evaluated in blocks of temperatures; table b is what
    :func:`build_emission_lut` gives for ``lambda t: xyz_of_temperature(t)[..., b, :]``."""
    t_max = max(_validate.positive_scalar(t_max_K, "t_max_K"), T_MAX_K)
    w = np.linspace(1.0 / t_max, 1.0 / T_MIN_K, table_size(t_max, T_MIN_K))
    temps = 1.0 / w
    values = np.empty((w.size, count, 3))
    for start in range(0, w.size, 2048):
        values[start : start + 2048] = xyz_of_temperature(temps[start : start + 2048])
    tables = []
    for b in range(count):
        column = np.ascontiguousarray(values[:, b, :])
        column.setflags(write=False)
        tables.append(EmissionLUT(T_MIN_K, t_max, column))
    return tables


def build_emission_lut(
    t_max_K: float = T_MAX_K,
    xyz_of_temperature: Callable[[NDArray], NDArray] | None = None,
    t_min_K: float = T_MIN_K,
) -> EmissionLUT:
    """Tabulate ``xyz_of_temperature`` (default :func:`blackbody_xyz`) over [t_min_K, t_max_K].

    ``t_max_K`` is raised to at least 100 000 K; pass a volume's hottest temperature to extend it.
    """
    t_max = max(_validate.positive_scalar(t_max_K, "t_max_K"), T_MAX_K)
    t_min = _validate.positive_scalar(t_min_K, "t_min_K")
    if t_min >= t_max:
        raise ValueError(f"t_min_K must be < t_max_K = {t_max:g} K; got {t_min_K!r}")
    n = table_size(t_max, t_min)
    w = np.linspace(1.0 / t_max, 1.0 / t_min, n)
    fn = xyz_of_temperature or blackbody_xyz
    values = np.asarray(fn(1.0 / w), dtype=np.float64)
    values.setflags(write=False)
    return EmissionLUT(t_min, t_max, values)


# --- the on-disk cache of tables -----------------------------------------------------------------

#: Where built tables are kept between processes (like Dr.Jit's kernel cache): the folder
#: ``$INCANDESCENT_CACHE_DIR``, else ``$XDG_CACHE_HOME/incandescent/tables``, else
#: ``~/.cache/incandescent/tables``.
CACHE_ENV = "INCANDESCENT_CACHE_DIR"


def cache_dir() -> Path:
    given = os.environ.get(CACHE_ENV)
    if given:
        return Path(given)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "incandescent" / "tables"


def cached_tables(key: str, build: Callable[[], list[EmissionLUT]]) -> list[EmissionLUT]:
    """The tables ``build()`` makes, kept on disk under ``key`` (which must name everything the
    values depend on; the package version is added). Best effort: an unreadable, foreign or
    unwritable cache only means the tables are built again, never a failed render."""
    from incandescent._version import __version__

    digest = hashlib.sha256(f"{__version__}\n{key}".encode()).hexdigest()[:24]
    path = cache_dir() / f"{digest}.npz"
    try:
        with np.load(path, allow_pickle=False) as data:
            ranges, values = data["ranges"], data["values"]
        pairs = zip(ranges, values, strict=True)
        tables = [_frozen_lut(t_min, t_max, v) for (t_min, t_max), v in pairs]
        if tables and all(t.size == table_size(t.t_max_K, t.t_min_K) for t in tables):
            return tables
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        pass
    tables = build()
    _store(path, tables)
    return tables


def _frozen_lut(t_min_K: float, t_max_K: float, values: NDArray) -> EmissionLUT:
    values = np.array(values, dtype=np.float64)
    values.setflags(write=False)
    return EmissionLUT(float(t_min_K), float(t_max_K), values)


def _store(path: Path, tables: list[EmissionLUT]) -> None:
    """Write the cache file atomically (a temporary file renamed); errors are ignored."""
    ranges = np.array([(t.t_min_K, t.t_max_K) for t in tables], dtype=np.float64)
    values = np.stack([t.values for t in tables])
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as handle:
            np.savez(handle, ranges=ranges, values=values)
        os.replace(tmp, path)
    except OSError:
        with contextlib.suppress(OSError):
            tmp.unlink()
