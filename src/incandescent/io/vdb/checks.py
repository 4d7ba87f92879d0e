"""Checks every VDB reader makes: the path, the grid names asked for, the values read; and the
one shape of a library's error."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from incandescent.io.formats import VDB_SUFFIXES

SUFFIXES = VDB_SUFFIXES
#: Default cap on the voxels of one dense box (512³ float32 = 512 MiB per grid).
MAX_DENSE_VOXELS = 512**3
#: Exceptions the library raises on malformed input (VDBError is a RuntimeError).
LIBRARY_ERRORS = (
    RuntimeError,
    OSError,
    ValueError,
    IndexError,
    TypeError,
    MemoryError,
    SystemError,
)

T = TypeVar("T")


def checked_path(path: str | Path) -> Path:
    """``path`` as a Path, refused unless it is an existing ``.vdb``/``.nvdb`` file."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(
            f"{path}: unsupported volume format {path.suffix!r}; expected .vdb or .nvdb"
        )
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such volume file")
    return path


def unique_names(path: Path, names: Sequence[str]) -> list[str]:
    """The grid names asked for (one name may come as a string): at least one, none twice."""
    if isinstance(names, str):
        names = [names]
    names = list(names)
    if not names:
        raise ValueError(f"{path}: no grid names given")
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: grid names repeat: {names}")
    return names


def pick(path: Path, grids: Mapping[str, T], name: str) -> T:
    """Grid ``name`` of ``grids``, or an error listing the grids the file has."""
    if name not in grids:
        available = ", ".join(repr(n) for n in grids) or "none"
        raise ValueError(f"{path}: no grid named {name!r}; the file has: {available}")
    return grids[name]


def library_error(path: Path, what: str, error: BaseException) -> ValueError:
    """A library's (or the OS's) error as a ValueError naming the file and what failed."""
    detail = str(error) or type(error).__name__
    return ValueError(f"{path}: {what} ({detail})")


def value_range(values: NDArray) -> tuple[float | None, float | None]:
    """(min, max) of the values, or (None, None) when there are none."""
    if values.size == 0:
        return None, None
    return float(values.min()), float(values.max())


def check_values(path: Path, name: str, values: NDArray) -> None:
    """Refuse grid ``name`` when it holds NaN or infinite values (saying how many)."""
    if not np.all(np.isfinite(values)):
        count = int(np.count_nonzero(~np.isfinite(values)))
        raise ValueError(f"{path}: grid {name!r} has {count} non-finite values (NaN or inf)")
