"""Reading volume files into named raw grids: ``.npy`` (one temperature grid), ``.npz`` (named
grids) and — through :mod:`incandescent.io.vdb` — OpenVDB ``.vdb`` / NanoVDB ``.nvdb``.

Standard ``.npz`` grid names: ``temperature``, ``absorption`` (1/m), ``emission_scale`` and
``sodium_fraction`` (0..1, paper mode); any other names can be chosen per role. Arrays are read
with ``allow_pickle=False``. Axis order is x, y, z (``a[i, j, k]`` is the voxel at x=i, y=j, z=k).
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

NUMPY_SUFFIXES = (".npy", ".npz")
VDB_SUFFIXES = (".vdb", ".nvdb")
SUFFIXES = NUMPY_SUFFIXES + VDB_SUFFIXES


@dataclass(frozen=True)
class GridSource:
    """A volume file's grids: their names, and a reader for the ones a render needs.

    ``origin_m`` and ``voxel_size_m`` come from the file where it stores a transform (VDB), else
    None. ``read(names)`` returns the named grids on one common box of voxels.
    """

    path: Path
    names: tuple[str, ...]
    read: Callable[[Iterable[str]], dict[str, NDArray]]
    origin_m: tuple[float, float, float] | None = None
    voxel_size_m: float | None = None


def _np_load(path: Path):
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path}: not a readable {path.suffix} file ({error})") from None


def _npz_reader(path: Path, data) -> Callable[[Iterable[str]], dict[str, NDArray]]:
    def read(names: Iterable[str]) -> dict[str, NDArray]:
        out = {}
        for name in names:
            try:
                out[name] = np.asarray(data[name])
            except KeyError:
                raise ValueError(
                    f"{path}: no grid named {name!r}; the file has: {', '.join(data.files)}"
                ) from None
            except (ValueError, OSError, zipfile.BadZipFile) as error:
                raise ValueError(f"{path}: grid {name!r} cannot be read ({error})") from None
        return out

    return read


def open_grids(path: str | Path) -> GridSource:
    """Open a volume file (errors name the file and the problem)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(
            f"{path}: unsupported volume format {path.suffix!r}; expected one of "
            f"{', '.join(SUFFIXES)} (or a .toml/.json scene file)"
        )
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such volume file")
    if suffix in VDB_SUFFIXES:
        from incandescent.io.vdb import open_vdb

        return open_vdb(path)
    data = _np_load(path)
    if isinstance(data, np.ndarray):
        return GridSource(path, ("temperature",), _npy_reader(path, data))
    return GridSource(path, tuple(data.files), _npz_reader(path, data))


def _npy_reader(path: Path, data: NDArray) -> Callable[[Iterable[str]], dict[str, NDArray]]:
    def read(names: Iterable[str]) -> dict[str, NDArray]:
        names = list(names)
        other = [n for n in names if n != "temperature"]
        if other:
            raise ValueError(f"{path}: a .npy file holds one grid (temperature), not {other[0]!r}")
        return {n: data for n in names}

    return read
