"""Input validation shared by the public API: clear errors that name the value and its origin."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _first_bad(values: NDArray, bad: NDArray) -> str:
    index = tuple(int(i) for i in np.argwhere(bad)[0])
    where = f" at index {index}" if values.ndim else ""
    value = values[index] if values.ndim else values
    return f"{np.asarray(value).item()!r}{where}"  # a plain Python number, not np.float64(...)


def real_array(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """Convert ``value`` to a float64 array, rejecting non-numeric dtypes with a TypeError."""
    arr = np.asarray(value)
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise TypeError(f"{name} must be a real number array; got dtype {arr.dtype}")
    if arr.dtype == np.bool_:
        raise TypeError(f"{name} must be a real number array; got dtype bool")
    return arr.astype(np.float64, copy=False)


def real_grid(value: ArrayLike, name: str) -> NDArray:
    """A real number array to be stored in float32: float32 input as it is (widening it first
    would only cost two passes), any other real dtype as float64 (:func:`real_array`)."""
    arr = np.asarray(value)
    return arr if arr.dtype == np.float32 else real_array(arr, name)


def finite(arr: NDArray, name: str) -> NDArray:
    """Reject NaN and infinity, naming the first offending value and its index."""
    found = nonfinite(arr)
    if found is not None:
        raise ValueError(f"{name} must be finite; got {found[1]}")
    return arr


def nonfinite(arr: NDArray) -> tuple[int, str] | None:
    """(how many values are NaN or ±inf, the first of them and its index), or None when every
    value is finite: the rule :func:`finite` enforces, for reports that only warn."""
    bad = ~np.isfinite(arr)
    if not bad.any():
        return None
    return int(np.count_nonzero(bad)), _first_bad(arr, bad)


def positive_temperature(value: ArrayLike, name: str = "temperature_K") -> NDArray[np.float64]:
    """Validate temperatures in kelvin: real, finite and strictly positive."""
    arr = finite(real_array(value, name), name)
    bad = arr <= 0
    if bad.any():
        raise ValueError(f"{name} must be > 0 K; got {_first_bad(arr, bad)} K")
    return arr


def positive_scalar(value: float, name: str) -> float:
    """Validate a strictly positive finite scalar."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number; got {type(value).__name__} {value!r}")
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a finite number > 0; got {value!r}")
    return v


def choice(value: str, name: str, valid: tuple[str, ...] | list[str]) -> str:
    """Validate that ``value`` is one of ``valid``, listing the choices otherwise."""
    if value not in valid:
        raise ValueError(f"unknown {name} {value!r}; expected one of: {', '.join(valid)}")
    return value


def finite_scalar(value: float, name: str) -> float:
    """Validate a finite real scalar (any sign)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number; got {type(value).__name__} {value!r}")
    if not np.isfinite(value):
        raise ValueError(f"{name} must be finite; got {value!r}")
    return float(value)


def nonnegative_scalar(value: float, name: str) -> float:
    """Validate a finite scalar ≥ 0."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number; got {type(value).__name__} {value!r}")
    if not np.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0; got {value!r}")
    return float(value)
