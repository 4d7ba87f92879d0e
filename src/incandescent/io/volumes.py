"""Loading volume grids from files: ``.npy`` (a temperature grid) and ``.npz`` (named grids).

``.npz`` grid names: ``temperature`` (required unless another name is chosen), and optionally
``absorption`` (1/m), ``emission_scale`` and ``sodium_fraction`` (0..1, paper mode).
Arrays are read with ``allow_pickle=False``. Axis order
is x, y, z (``a[i, j, k]`` is the voxel at x=i, y=j, z=k).
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

SUFFIXES = (".npy", ".npz")
OPTIONAL_GRIDS = ("absorption", "emission_scale", "sodium_fraction")


@dataclass(frozen=True)
class LoadedGrids:
    """Raw grids read from a file, before validation and remapping."""

    path: Path
    temperature: NDArray
    absorption: NDArray | None = None
    emission_scale: NDArray | None = None
    sodium_fraction: NDArray | None = None


def _read(path: Path):
    try:
        return np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path}: not a readable {path.suffix} file ({error})") from None


def _npz_grid(data, path: Path, name: str, required: bool) -> NDArray | None:
    if name in data.files:
        try:
            return np.asarray(data[name])
        except (ValueError, OSError, zipfile.BadZipFile) as error:
            raise ValueError(f"{path}: grid {name!r} cannot be read ({error})") from None
    if required:
        raise ValueError(
            f"{path}: no grid named {name!r}; the file has: {', '.join(data.files) or 'nothing'}"
        )
    return None


def load_grids(path: str | Path, temperature_grid: str = "temperature") -> LoadedGrids:
    """Read the grids of a ``.npy`` or ``.npz`` file (errors name the file and the problem)."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(
            f"{path}: unsupported volume format {path.suffix!r}; expected .npy or .npz"
        )
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such volume file")
    data = _read(path)
    if isinstance(data, np.ndarray):
        return LoadedGrids(path, data)
    with data:
        temperature = _npz_grid(data, path, temperature_grid, required=True)
        assert temperature is not None  # required=True raised otherwise
        optional = {name: _npz_grid(data, path, name, required=False) for name in OPTIONAL_GRIDS}
    return LoadedGrids(path, temperature, **optional)
