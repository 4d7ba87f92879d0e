"""Validation of the grids a :class:`~incandescent.volume.grid.Volume` is built from: shapes,
finite values, kelvin after the remap and below the tables' ceiling, voxel size and placement,
the default absorption, fraction and velocity grids. Errors name the value, the voxel and the
origin (``source``)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent._parallel import map_slabs
from incandescent.volume.remap import Remap
from incandescent.volume.scan import SCAN_CHUNK

#: Voxels at or above this temperature absorb under the default absorption, K.
DEFAULT_ABSORPTION_MIN_K = 500.0


#: Default optical depth across the largest side of the box.
DEFAULT_OPTICAL_DEPTH = 1.0


#: Hottest temperature a volume may hold, K: the top of the emission tables
#: (``incandescent.spectra.lut.T_MAX_K``), so a table never grows with the input. Gas this hot is
#: a plasma far outside the blackbody-gas model; hotter voxels are nearly always a wrong remap.
T_CEILING_K = 100_000.0


def _temperature(
    value: ArrayLike, remap: Remap, source: str, adopt: bool = False
) -> tuple[NDArray, float | None]:
    """(kelvin per voxel, hottest voxel K or None), validated: finite, ≥ 0 unless a cutoff removes
    it, below T_CEILING_K. The array is new and writable, or with ``adopt`` the input itself when
    it can be handed over (see :func:`_handed_over`). float32 input without offset or scale stays
    float32 — (raw − 0)·1 in float64, rounded back, is raw exactly — and is checked in one
    chunked pass (its min and max); anything else is remapped in float64."""
    arr = np.asarray(value)
    if arr.dtype != np.float32 or remap.offset != 0 or remap.scale != 1:
        temp = _remapped_temperature(_grid(value, source)[0], remap, source)
        _check_ceiling(temp, remap, source)
        return temp, None
    _check_shape(arr, source)
    low, high = _finite_range(arr, source)
    if low < 0:
        _remapped_temperature(arr, remap, source, copy=False)  # names the voxel unless a cutoff
    if high > T_CEILING_K:
        _check_ceiling(arr, remap, source)  # raises, naming the voxel
    return (arr if adopt and _handed_over(arr) else arr.copy()), high


def _check_shape(arr: NDArray, name: str) -> None:
    if arr.ndim != 3:
        raise ValueError(f"{name} must be a 3-D grid (nx, ny, nz); got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty: shape {arr.shape}")


def _handed_over(arr: NDArray) -> bool:
    """Can ``arr`` become a Volume's grid as it is? float32, C-ordered, writable, and owning its
    memory or the whole-array reshape of an array that does (what ``np.load`` returns) — not a
    view into something else (a file mapping, a library's buffer, a larger array)."""
    flags, base = arr.flags, arr.base
    whole = base is None or (
        isinstance(base, np.ndarray) and base.base is None and base.nbytes == arr.nbytes
    )
    return arr.dtype == np.float32 and flags.c_contiguous and flags.writeable and whole


def _value_range(values: NDArray) -> tuple[float, float]:
    """(min, max) of a 3-D grid, NaN if it holds a NaN: one pass over cache-sized runs of x-layers
    on every core, without the grid-sized boolean temporaries of ``isfinite``/``< 0`` masks (each
    a fresh allocation: the page faults cost more than the comparisons)."""
    layers = max(1, SCAN_CHUNK // max(1, values[0].size))

    def slab(lo: int, hi: int) -> tuple[float, float]:
        low, high = np.inf, -np.inf
        for a in range(lo, hi, layers):
            chunk = values[a : min(a + layers, hi)]
            c_low, c_high = float(chunk.min()), float(chunk.max())
            if np.isnan(c_low) or np.isnan(c_high):
                return np.nan, np.nan
            low, high = min(low, c_low), max(high, c_high)
        return low, high

    ranges = map_slabs(slab, values.shape[0], values.size)
    if any(np.isnan(r[0]) for r in ranges):
        return np.nan, np.nan
    return min(r[0] for r in ranges), max(r[1] for r in ranges)


def _finite_range(arr: NDArray, name: str) -> tuple[float, float]:
    """(min, max) of a grid that must be finite; NaN or ±inf raises, naming the first."""
    low, high = _value_range(arr)
    if not (np.isfinite(low) and np.isfinite(high)):
        _validate.finite(arr, name)  # raises with the offending value and its index
    return low, high


def _grid(
    value: ArrayLike, name: str, like: tuple[int, ...] | None = None
) -> tuple[NDArray, float]:
    """A finite 3-D grid (``_validate.real_grid``: float32 as it is) of shape ``like`` when
    given, and its minimum."""
    arr = _validate.real_grid(value, name)
    _check_shape(arr, name)
    if like is not None and arr.shape != like:
        raise ValueError(f"{name} grid has shape {arr.shape}; expected the temperature's {like}")
    low, _ = _finite_range(arr, name)
    return arr, low


def _remapped_temperature(
    raw: NDArray, remap: Remap, source: str, copy: bool = True
) -> NDArray[np.float64]:
    temp = np.array(remap.apply(raw), dtype=np.float64) if copy else raw
    negative = temp < 0
    if remap.cutoff_K <= 0 and negative.any():
        index = tuple(int(i) for i in np.argwhere(negative)[0])
        raise ValueError(
            f"{source}: temperature {temp[index]:g} K at voxel {index} is negative after remap "
            f"(offset={remap.offset:g}, scale={remap.scale:g}); kelvin must be >= 0 — "
            "fix the remap or set a cutoff"
        )
    return temp


def _check_ceiling(temp: NDArray, remap: Remap, source: str) -> None:
    """Refuse voxels hotter than T_CEILING_K, naming the first and the remap that made it."""
    hot = temp > T_CEILING_K
    if hot.any():
        index = tuple(int(i) for i in np.argwhere(hot)[0])
        raise ValueError(
            f"{source}: temperature {temp[index]:.4g} K at voxel {index} is above the "
            f"{T_CEILING_K:g} K ceiling of the emission tables (remap offset={remap.offset:g}, "
            f"scale={remap.scale:g}); if the field is not in kelvin, map it with --scale, "
            "--temperature-range or a --preset"
        )


#: Voxel sides a Volume accepts, m: a nanometre to a thousand kilometres.
VOXEL_SIZE_RANGE_M = (1e-9, 1e6)


def _voxel_size(voxel_size_m: float | None, shape: tuple[int, ...]) -> float:
    if voxel_size_m is None:
        return 1.0 / max(shape)
    size = _validate.positive_scalar(voxel_size_m, "voxel_size_m")
    low, high = VOXEL_SIZE_RANGE_M
    if not low <= size <= high:
        raise ValueError(f"voxel_size_m must be in [{low:g}, {high:g}] m; got {voxel_size_m!r}")
    return size


def _origin(origin_m: ArrayLike | None, shape: tuple[int, ...], voxel: float) -> tuple:
    if origin_m is None:
        return tuple(-0.5 * n * voxel for n in shape)
    origin = _validate.finite(_validate.real_array(origin_m, "origin_m"), "origin_m")
    if origin.shape != (3,):
        raise ValueError(f"origin_m must be 3 numbers (x, y, z) in m; got shape {origin.shape}")
    return tuple(float(v) for v in origin)


def _absorption(
    value, temp: NDArray, side_m: float, source: str, adopt: bool = False
) -> tuple[NDArray, str, float | None]:
    """(κ per voxel in 1/m, how it was given, κ₀ when it was made as κ₀ or 0 per voxel). κ is a
    new writable float32 array (values rounded once from float64), or with ``adopt`` the given
    grid itself when it can be handed over; the default is scaled to the box's largest side
    ``side_m``."""
    if value is None:
        kappa = np.float32(DEFAULT_OPTICAL_DEPTH / side_m)
        grid = np.where(temp >= DEFAULT_ABSORPTION_MIN_K, kappa, np.float32(0.0))
        how = f"default: {kappa:g} 1/m where T >= {DEFAULT_ABSORPTION_MIN_K:g} K"
        return grid, how, float(kappa)
    if np.ndim(value) == 0:
        kappa = np.float32(_nonnegative_scalar(value, "absorption (1/m)"))
        return np.full(temp.shape, kappa), f"constant {kappa:g} 1/m", float(kappa)
    return _checked_grid(value, temp.shape, "absorption", source, adopt), "grid", None


def _optional_grid(value, shape, name: str, source: str) -> NDArray[np.float32] | None:
    if value is None:
        return None
    if np.ndim(value) == 0:
        return _f32(np.full(shape, _nonnegative_scalar(value, name)))
    return _f32(_checked_grid(value, shape, name, source))


def _checked_grid(value, shape, name: str, source: str, adopt: bool = False) -> NDArray[np.float32]:
    """A non-negative finite grid of ``shape`` as a new writable float32 array (or with ``adopt``
    the input itself, see :func:`_handed_over`)."""
    arr, low = _grid(value, f"{source}: {name}", shape)
    if low < 0:
        index = tuple(int(i) for i in np.argwhere(arr < 0)[0])
        raise ValueError(f"{source}: {name} must be >= 0; got {arr[index]:g} at voxel {index}")
    if adopt and _handed_over(arr):
        return arr
    return np.array(arr, dtype=np.float32)


def _velocity(value, shape, source: str) -> NDArray[np.float32] | None:
    """A finite (nx, ny, nz, 3) velocity grid in m/s as float32, or None."""
    if value is None:
        return None
    arr = _validate.real_grid(value, f"{source}: velocity")
    if arr.shape != tuple(shape) + (3,):
        raise ValueError(
            f"{source}: velocity grid has shape {arr.shape}; expected {tuple(shape) + (3,)} "
            "(a 3-vector in m/s per voxel)"
        )
    return _f32(np.array(_validate.finite(arr, f"{source}: velocity (m/s)"), dtype=np.float32))


#: The species whose fraction a ``sodium_fraction`` grid gives (the 2011 paper's sodium term).
SODIUM = "Na"


def check_phase_g(g, shape: tuple[int, ...] | None = None, source: str = "volume"):
    """The Henyey–Greenstein asymmetry g: a number with −1 < g < 1, or (with the volume's
    ``shape``) a float32 grid of such numbers, one per voxel."""
    if isinstance(g, bool) or (np.ndim(g) == 0 and not isinstance(g, (int, float, np.number))):
        raise ValueError(f"phase_g must be a number in (-1, 1) or a grid; got {g!r}")
    if np.ndim(g) == 0:
        if not np.isfinite(float(g)) or not -1.0 < g < 1.0:
            raise ValueError(f"phase_g must be in (-1, 1) (|g| = 1 is a delta, not a phase "
                             f"function); got {g!r}")  # fmt: skip
        return float(g)
    if shape is None:
        raise ValueError("a phase_g grid needs the volume's shape")
    arr, low = _grid(g, f"{source}: phase_g", tuple(shape))
    high = float(np.max(arr))
    if not (-1.0 < low and high < 1.0):
        bad = low if low <= -1.0 else high
        index = tuple(int(i) for i in np.argwhere(arr == bad)[0])
        raise ValueError(f"{source}: phase_g must be in (-1, 1); got {bad:g} at voxel {index}")
    return _f32(np.array(arr, dtype=np.float32))


def scattering_grid(value, albedo, kappa: NDArray, shape, source: str):
    """σ_s (1/m) as a float32 grid from a constant or grid ``value``, or from the albedo α:
    σ_s = α/(1 − α)·κ; None when neither is given. Both given, α outside [0, 1), σ_s < 0 or not
    finite: one error naming the value."""
    if value is not None and albedo is not None:
        raise ValueError(f"{source}: give scattering (1/m) or albedo, not both")
    if albedo is not None:
        a = _validate.finite_scalar(albedo, "albedo")
        if not 0.0 <= a < 1.0:
            raise ValueError(f"{source}: albedo must be in [0, 1) (1: no absorption, give "
                             f"scattering in 1/m instead); got {albedo!r}")  # fmt: skip
        return _f32(np.asarray(kappa, np.float64) * (a / (1.0 - a)))
    if value is None:
        return None
    return _optional_grid(value, shape, "scattering_per_m", source)


def check_soot_alpha(alpha, name: str = "soot_alpha") -> float:
    """A spectral exponent (soot's α of κ_λ = κ·(550 nm/λ)^α, or the scattering's β of
    σ_s,λ = σ_s·(550 nm/λ)^β), a number in [0, 4] (4: Rayleigh's λ^−4)."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.number)):
        raise ValueError(f"{name} must be a number in [0, 4]; got {alpha!r}")
    if not np.isfinite(float(alpha)) or not 0 <= alpha <= 4:
        raise ValueError(f"{name} must be in [0, 4]; got {alpha!r}")
    return float(alpha)


def _with_sodium(species, sodium_fraction, source: str) -> dict:
    """The species fractions with ``sodium_fraction`` (if given) as species ``Na``."""
    out = dict(species or {})
    if sodium_fraction is None:
        return out
    if SODIUM in out:
        raise ValueError(
            f"{source}: sodium_fraction is the fraction of species {SODIUM!r}, also given; "
            "give one of them"
        )
    out[SODIUM] = sodium_fraction
    return out


def _fraction_grid(value, shape, name: str, source: str):
    """A fraction grid in [0, 1] (constant or grid), or None."""
    grid = _optional_grid(value, shape, name, source)
    if grid is not None and grid.max() > 1.0:
        index = tuple(int(i) for i in np.argwhere(grid > 1.0)[0])
        got = f"{grid[index]:g} at voxel {index}"
        raise ValueError(f"{source}: {name} must be in [0, 1]; got {got}")
    return grid


def _nonnegative_scalar(value, name: str) -> float:
    if value == 0:
        return 0.0
    return _validate.positive_scalar(value, name)


def _f32(arr: NDArray) -> NDArray[np.float32]:
    out = np.ascontiguousarray(arr, dtype=np.float32)
    out.setflags(write=False)
    return out
