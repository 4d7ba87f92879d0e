"""HDF5 (``.h5``, ``.hdf5``, through h5py) and NetCDF (``.nc``, ``.nc4``, through xarray) volumes,
reordered into the renderer's x, y, z axes, with temperatures converted to kelvin.

Both readers are optional: ``pip install 'incandescent[science]'`` (h5py, xarray, h5netcdf). They
are imported only when a file is opened; a missing one is a ``ValueError`` with that hint.

Grids
-----
HDF5: every 3-D numeric (integer or float) dataset, named by its path (``"fields/temperature"``).
NetCDF: every data variable with 3 dimensions and a numeric type, named by the variable's name.
Values read as float32 (float64 for float64 and 32/64-bit integer data), C-contiguous, in x, y, z
order: ``a[i, j, k]`` is the voxel at x=i, y=j, z=k (DESIGN.md §4).

Axis order
----------
``axes`` names the axis of each stored array dimension, e.g. ``"zyx"``: the file's ``v[k, j, i]``
is the voxel at x=i, y=j, z=k (any permutation of x, y, z; case-insensitive).

- HDF5: the dataset attribute ``axes``, ``axis_order`` or ``dimension_labels`` (first found;
  a string ``"zyx"`` or a list ``["z", "y", "x"]``), searched on the dataset, then on its parent
  groups up to the root. Without one: the ``axes`` argument, else ``"xyz"`` (the ``.npy``
  convention).
- NetCDF: the variable's dimension names when they are ``x``, ``y`` and ``z`` (any order and
  case); else the CF ``axis`` attributes (``X``, ``Y``, ``Z``) of its dimensions' coordinate
  variables; else the ``axes`` argument; else reading that variable is an error (the dimension
  names are listed). Names such as ``lon``/``lat``/``height`` are not guessed.

An ``axes`` argument that contradicts the file's attribute or dimension names is an error, never
silently overridden either way.

Units
-----
A ``units`` attribute on the dataset (HDF5: or a parent group) / variable: kelvin (``K``,
``kelvin``, ``degK``) is kept; Celsius (``degC``, ``°C``, ``celsius``, ``degree_Celsius`` …) is
converted with T/K = t/°C + 273.15 and Fahrenheit (``degF``, ``°F``, ``fahrenheit`` …) with
T/K = (t/°F + 459.67)·5/9 (exact, by definition of the scales; see :func:`to_kelvin`). Other units
are left as they are. Every conversion is logged and listed in the source's ``notes``.

Placement
---------
``Grids.origin_m`` is the world position of the corner of voxel (0, 0, 0) in x, y, z order and
``Grids.voxel_size_m`` the voxel side (the renderer's voxels are cubes).

- HDF5: attributes ``voxel_size_m`` (a number, or three equal numbers) and ``origin_m`` (three
  numbers, x, y, z order whatever the array order), on the dataset or a parent group.
- NetCDF: the coordinate variables of the three dimensions. Each must be uniformly spaced
  (relative tolerance 1e-5) and the spacings must agree across axes, else reading is an error.
  A decreasing coordinate flips its axis so that the index grows with the coordinate. Coordinate
  ``units`` m, cm, mm or km are converted to metres; no ``units`` means metres; other units (e.g.
  degrees) give no placement (noted). origin = lowest centre − half a spacing.
  Dimensions without coordinate variables give no origin.

NetCDF-4 files (HDF5 inside) are read with the ``h5netcdf`` engine; NetCDF-3 "classic" files with
``netCDF4`` or ``scipy`` if one is installed, else the error says how to get or convert one.
CF decoding (``scale_factor``, ``add_offset``, ``_FillValue`` → NaN) is applied by xarray.
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from types import ModuleType
from typing import Any, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from incandescent.io.formats import HDF5_SUFFIXES, NETCDF_SUFFIXES, SCIENCE_SUFFIXES
from incandescent.io.grids import Grids, GridSource

__all__ = [
    "HDF5_SUFFIXES",
    "NETCDF_SUFFIXES",
    "SUFFIXES",
    "open_hdf5",
    "open_netcdf",
    "open_scientific",
    "to_kelvin",
]

log = logging.getLogger("incandescent")

SUFFIXES = SCIENCE_SUFFIXES
INSTALL_HINT = "pip install 'incandescent[science]'"
#: Attributes read as the axis order of an HDF5 dataset, first found wins.
AXES_ATTRIBUTES = ("axes", "axis_order", "dimension_labels")
VOXEL_SIZE_ATTRIBUTE = "voxel_size_m"
ORIGIN_ATTRIBUTE = "origin_m"
UNITS_ATTRIBUTE = "units"
#: Relative tolerance for uniform coordinate spacing and for agreeing voxel sizes / origins.
SPACING_RTOL = 1e-5

#: Temperature units → (shift, factor) with T/K = (value + shift)·factor, exact by definition of
#: the scales: 0 °C = 273.15 K; 0 °F = 459.67 °R (Rankine) and 1 °R = 1 °F = 5/9 K.
_KELVIN = (0.0, 1.0)
_CELSIUS = (273.15, 1.0)
_FAHRENHEIT = (459.67, 5.0 / 9.0)
TEMPERATURE_UNITS: dict[str, tuple[float, float]] = {
    **dict.fromkeys(("k", "kelvin", "kelvins", "degk", "deg_k", "degrees_k"), _KELVIN),
    **dict.fromkeys(
        ("degc", "deg_c", "celsius", "degree_celsius", "degrees_celsius", "degree_c", "degrees_c"),
        _CELSIUS,
    ),
    **dict.fromkeys(
        ("degf", "deg_f", "fahrenheit", "degree_fahrenheit", "degrees_fahrenheit", "degree_f"),
        _FAHRENHEIT,
    ),
}
#: Coordinate length units → metres.
LENGTH_UNITS = {
    **dict.fromkeys(("m", "meter", "metre", "meters", "metres"), 1.0),
    **dict.fromkeys(("km", "kilometer", "kilometre", "kilometers", "kilometres"), 1e3),
    **dict.fromkeys(("cm", "centimeter", "centimetre", "centimeters", "centimetres"), 1e-2),
    **dict.fromkeys(("mm", "millimeter", "millimetre", "millimeters", "millimetres"), 1e-3),
}


@dataclass(frozen=True)
class _Layout:
    """How one stored grid maps onto the renderer's arrays (found when the file is opened)."""

    axes: str  # axis letter of each stored dimension, e.g. "zyx"
    axes_from: str
    units: str | None = None
    voxel_size_m: float | None = None
    origin_m: tuple[float, float, float] | None = None
    flip: tuple[bool, bool, bool] = (False, False, False)  # per stored dimension
    placement_note: str | None = None
    problem: str | None = None  # reading the grid raises ValueError(problem)


# ------------------------------------------------------------------ entry points


def open_scientific(path: str | Path, axes: str | None = None) -> GridSource:
    """Open an HDF5 or NetCDF volume by its suffix (see :data:`SUFFIXES`)."""
    path = Path(path)
    if path.suffix.lower() in HDF5_SUFFIXES:
        return open_hdf5(path, axes)
    if path.suffix.lower() in NETCDF_SUFFIXES:
        return open_netcdf(path, axes)
    raise ValueError(f"{path}: not an HDF5 or NetCDF file name; expected {', '.join(SUFFIXES)}")


def open_hdf5(path: str | Path, axes: str | None = None) -> GridSource:
    """The 3-D numeric datasets of an HDF5 file, by path, read in x, y, z order and kelvin.

    Parameters
    ----------
    path : HDF5 file (``.h5``, ``.hdf5``).
    axes : axis of each stored dimension (``"zyx"`` …) for datasets without an axes attribute;
        default ``"xyz"``. Contradicting a dataset's attribute is an error when it is read.
    """
    path = _existing(path)
    axes = _checked_axes(axes, path, "the axes argument")
    h5py = _import("h5py", path)
    with _h5_file(h5py, path) as f:
        layouts = _h5_layouts(h5py, f, path, axes)
    return _source(path, layouts, lambda names: _h5_read(h5py, path, layouts, names))


def open_netcdf(path: str | Path, axes: str | None = None) -> GridSource:
    """The 3-D numeric variables of a NetCDF file, read in x, y, z order, kelvin and metres.

    Parameters
    ----------
    path : NetCDF file (``.nc``, ``.nc4``; NetCDF-4, or NetCDF-3 with netCDF4/scipy installed).
    axes : axis of each dimension (``"zyx"`` …) for variables whose dimensions are not named
        x, y, z. Contradicting the dimension names is an error when the variable is read.
    """
    path = _existing(path)
    axes = _checked_axes(axes, path, "the axes argument")
    xr = _import("xarray", path)
    engine = _netcdf_engine(path)
    with _nc_dataset(xr, path, engine) as ds:
        layouts = {name: _nc_layout(ds, name, axes) for name in _nc_grid_names(ds, path)}
    return _source(path, layouts, lambda names: _nc_read(xr, path, engine, layouts, names))


def to_kelvin(values: NDArray, units: str | None) -> tuple[NDArray, str | None]:
    """``values`` in kelvin when ``units`` is a temperature unit, and a note of what was done.

    Kelvin and unknown/non-temperature units return ``values`` unchanged; Celsius returns
    ``values + 273.15``, Fahrenheit ``(values + 459.67)·5/9`` (new arrays).
    """
    if units is None:
        return values, None
    values = np.asarray(values)
    values = values.astype(_float_dtype(values.dtype), copy=False)
    known = TEMPERATURE_UNITS.get(_unit_key(units))
    if known is None:
        return values, f"units {units!r} (not a temperature unit; values kept)"
    shift, factor = known
    if known == _KELVIN:
        return values, f"units {units!r} (kelvin)"
    converted = (values + values.dtype.type(shift)) * values.dtype.type(factor)
    rule = f"t + {shift:g}" if factor == 1.0 else f"(t + {shift:g})·{factor:.6g}"
    return converted, f"units {units!r} converted to K: T = {rule}"


# ------------------------------------------------------------------ shared


def _existing(path: str | Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such volume file")
    return path


def _import(module: str, path: Path) -> ModuleType:
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ValueError(
            f"{path}: reading {path.suffix} files needs the {module!r} package: {INSTALL_HINT}"
        ) from None


def _text(value: Any) -> str | None:
    """An attribute as text: str, bytes, or a sequence of them joined (``["z", "y", "x"]``)."""
    if isinstance(value, bytes | np.bytes_):
        return value.decode("utf-8", "replace")
    if isinstance(value, str):
        return value
    if isinstance(value, np.ndarray | list | tuple) and all(
        isinstance(v, str | bytes | np.str_ | np.bytes_) for v in np.ravel(value)
    ):
        return "".join(_text(v) or "" for v in np.ravel(value))
    return None


def _unit_key(units: str) -> str:
    return units.strip().lower().replace("°", "deg").replace("º", "deg").replace(" ", "_")


def _checked_axes(axes: Any, path: Path, where: str) -> str | None:
    return None if axes is None else _axes_letters(axes, path, where)


def _axes_letters(axes: Any, path: Path, where: str) -> str:
    text = _text(axes)
    letters = (text or "").replace(",", "").replace(" ", "").lower()
    if sorted(letters) != ["x", "y", "z"]:
        raise ValueError(
            f"{path}: {where} must be a permutation of 'xyz' (e.g. 'zyx'), got {axes!r}"
        )
    return letters


def _float_dtype(dtype: np.dtype) -> np.dtype:
    """float32 for float16/float32/small integers, float64 for float64 and 32/64-bit integers."""
    return np.result_type(dtype, np.float32)


def _to_xyz(values: NDArray, layout: _Layout) -> NDArray:
    """Stored array → renderer array: flip decreasing coordinates, reorder to x, y, z, float."""
    flips = tuple(slice(None, None, -1) if f else slice(None) for f in layout.flip)
    order = [layout.axes.index(axis) for axis in "xyz"]
    xyz = np.transpose(values[flips], order)
    return np.ascontiguousarray(xyz, dtype=_float_dtype(values.dtype))


def _prepared(path: Path, name: str, values: NDArray, layout: _Layout) -> NDArray:
    xyz = _to_xyz(values, layout)
    kelvin, note = to_kelvin(xyz, layout.units)
    if kelvin is not xyz:
        log.info("%s: grid %r: %s", path, name, note)
    return kelvin


def _note(layout: _Layout) -> str:
    if layout.problem:
        return f"unreadable: {layout.problem}"
    parts = [f"axes {layout.axes} ({layout.axes_from})"]
    parts.append(to_kelvin(np.zeros(0, np.float32), layout.units)[1] or "no units")
    flipped = [axis for axis, f in zip(layout.axes, layout.flip, strict=True) if f]
    if flipped:
        parts.append(f"decreasing coordinates: {', '.join(flipped)} flipped")
    if layout.placement_note:
        parts.append(layout.placement_note)
    elif layout.voxel_size_m is not None:
        parts.append(f"voxel {layout.voxel_size_m:g} m, corner {_fmt(layout.origin_m)}")
    return "; ".join(parts)


def _fmt(origin: tuple[float, ...] | None) -> str:
    return "unknown" if origin is None else "(" + ", ".join(f"{v:g}" for v in origin) + ") m"


def _source(
    path: Path, layouts: dict[str, _Layout], read: Callable[[Iterable[str]], Grids]
) -> GridSource:
    notes = {name: _note(layout) for name, layout in layouts.items()}
    return GridSource(path, tuple(layouts), read, notes)


class _Readable(Protocol):
    @property
    def problem(self) -> str | None: ...


_Entry = TypeVar("_Entry", bound=_Readable)


def _layout_for(path: Path, layouts: Mapping[str, _Entry], name: str) -> _Entry:
    """The entry of grid ``name`` (an error listing the names if none; its problem if any).
    Also the VTK reader's (``io.vtk``)."""
    if name not in layouts:
        raise ValueError(f"{path}: no grid named {name!r}; the file has: {', '.join(layouts)}")
    layout = layouts[name]
    if layout.problem:
        raise ValueError(f"{path}: grid {name!r}: {layout.problem}")
    return layout


def _grids(path: Path, arrays: dict[str, NDArray], layouts: Mapping[str, _Layout]) -> Grids:
    """The grids read, checked to share one box: shape, voxel size and origin."""
    shapes = {name: a.shape for name, a in arrays.items()}
    if len(set(shapes.values())) > 1:
        listed = ", ".join(f"{n} {s}" for n, s in shapes.items())
        raise ValueError(f"{path}: grids differ in shape (x, y, z order): {listed}")
    voxel = _agreed(path, "voxel size (m)", {n: layouts[n].voxel_size_m for n in arrays})
    origin = _agreed(path, "origin (m)", {n: layouts[n].origin_m for n in arrays})
    return Grids(arrays, origin, voxel)


def _agreed(path: Path, what: str, values: Mapping[str, Any]) -> Any:
    known = {n: v for n, v in values.items() if v is not None}
    if not known:
        return None
    first = next(iter(known.values()))
    if any(not np.allclose(v, first, rtol=SPACING_RTOL, atol=1e-12) for v in known.values()):
        listed = ", ".join(f"{n} {v}" for n, v in known.items())
        raise ValueError(f"{path}: grids differ in {what}: {listed}")
    return first


# ------------------------------------------------------------------ HDF5


@contextmanager
def _h5_file(h5py: ModuleType, path: Path) -> Iterator[Any]:
    if not h5py.is_hdf5(str(path)):
        raise ValueError(f"{path}: not an HDF5 file")
    try:
        f = h5py.File(path, "r")
    except OSError as error:
        raise ValueError(f"{path}: not a readable HDF5 file ({error})") from None
    with f:
        yield f


def _h5_layouts(h5py: ModuleType, f: Any, path: Path, axes: str | None) -> dict[str, _Layout]:
    datasets: dict[str, Any] = {}
    skipped: list[str] = []

    def visit(name: str, obj: Any) -> None:
        if isinstance(obj, h5py.Dataset):
            if obj.ndim == 3 and obj.dtype.kind in "iuf":
                datasets[name] = obj
            else:
                skipped.append(f"{name} ({obj.ndim}-D {obj.dtype})")

    try:
        f.visititems(visit)
    except (OSError, RuntimeError, KeyError) as error:
        raise ValueError(f"{path}: HDF5 file structure cannot be read ({error})") from None
    if not datasets:
        raise ValueError(
            f"{path}: no 3-D numeric dataset; the file has: {', '.join(skipped) or 'no datasets'}"
        )
    return {name: _h5_layout(path, ds, axes) for name, ds in datasets.items()}


def _h5_attribute(obj: Any, names: Sequence[str]) -> tuple[str, Any] | None:
    """The first of ``names`` found on ``obj``, then on its parent groups up to the root."""
    while True:
        for name in names:
            if name in obj.attrs:
                return name, obj.attrs[name]
        if obj.name in ("/", None):
            return None
        obj = obj.parent


def _h5_layout(path: Path, ds: Any, axes: str | None) -> _Layout:
    try:
        return _h5_layout_checked(path, ds, axes)
    except (OSError, RuntimeError, TypeError, KeyError) as error:  # unsupported or corrupt
        return _Layout("xyz", "unknown", problem=f"attributes cannot be read ({error})")
    except ValueError as error:
        return _Layout("xyz", "unknown", problem=str(error).removeprefix(f"{path}: "))


def _h5_layout_checked(path: Path, ds: Any, axes: str | None) -> _Layout:
    found = _h5_attribute(ds, AXES_ATTRIBUTES)
    if found is None:
        layout = _Layout(axes or "xyz", "the axes argument" if axes else "default")
    else:
        stored = _axes_letters(found[1], path, f"attribute {found[0]!r}")
        if axes is not None and axes != stored:
            raise ValueError(
                f"attribute {found[0]!r} says axes {stored!r} but the axes argument says "
                f"{axes!r}; drop the argument or fix the file"
            )
        layout = _Layout(stored, f"attribute {found[0]!r}")
    units = _h5_attribute(ds, (UNITS_ATTRIBUTE,))
    return replace(layout, units=None if units is None else _text(units[1]), **_h5_place(ds))


def _h5_place(ds: Any) -> dict[str, Any]:
    size = _h5_attribute(ds, (VOXEL_SIZE_ATTRIBUTE,))
    origin = _h5_attribute(ds, (ORIGIN_ATTRIBUTE,))
    out: dict[str, Any] = {}
    if size is not None:
        sizes = _numbers(size[1], VOXEL_SIZE_ATTRIBUTE)
        if sizes.size not in (1, 3) or not np.all(np.isfinite(sizes) & (sizes > 0)):
            raise ValueError(f"{VOXEL_SIZE_ATTRIBUTE} must be one or three positive numbers")
        if not np.allclose(sizes, sizes[0], rtol=SPACING_RTOL, atol=0.0):
            raise ValueError(f"voxels are not cubes ({VOXEL_SIZE_ATTRIBUTE} = {sizes.tolist()})")
        out["voxel_size_m"] = float(sizes[0])
    if origin is not None:
        corner = _numbers(origin[1], ORIGIN_ATTRIBUTE)
        if corner.size != 3 or not np.all(np.isfinite(corner)):
            raise ValueError(f"{ORIGIN_ATTRIBUTE} must be three finite numbers (x, y, z)")
        out["origin_m"] = (float(corner[0]), float(corner[1]), float(corner[2]))
    return out


def _numbers(value: Any, name: str) -> NDArray[np.float64]:
    try:
        return np.ravel(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError):
        raise ValueError(f"attribute {name!r} is not numeric: {value!r}") from None


def _h5_read(
    h5py: ModuleType, path: Path, layouts: Mapping[str, _Layout], names: Iterable[str]
) -> Grids:
    wanted = {name: _layout_for(path, layouts, name) for name in names}
    arrays = {}
    with _h5_file(h5py, path) as f:
        for name, layout in wanted.items():
            try:
                values = f[name][()]
            except (OSError, RuntimeError, KeyError, ValueError) as error:
                raise ValueError(f"{path}: grid {name!r} cannot be read ({error})") from None
            arrays[name] = _prepared(path, name, values, layout)
    return _grids(path, arrays, layouts)


# ------------------------------------------------------------------ NetCDF

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def _netcdf_engine(path: Path) -> str:
    """``h5netcdf`` for NetCDF-4 (HDF5 inside), ``netcdf4``/``scipy`` for NetCDF-3 classic."""
    with path.open("rb") as f:
        head = f.read(8)
    if head == _HDF5_SIGNATURE:
        _import("h5netcdf", path)
        with _h5_file(_import("h5py", path), path):  # a clean error for unopenable files
            return "h5netcdf"
    if head[:3] == b"CDF":
        for engine, module in (("netcdf4", "netCDF4"), ("scipy", "scipy")):
            if importlib.util.find_spec(module) is not None:
                return engine
        raise ValueError(
            f"{path}: a NetCDF-3 (classic) file; h5netcdf reads NetCDF-4 only. "
            "pip install netCDF4 (or scipy), or convert it: nccopy -k nc4 IN OUT"
        )
    raise ValueError(f"{path}: not a NetCDF file (no NetCDF-3 or HDF5 signature)")


@contextmanager
def _nc_dataset(xr: ModuleType, path: Path, engine: str) -> Iterator[Any]:
    try:
        ds = xr.open_dataset(path, engine=engine, decode_times=False, decode_timedelta=False)
    except (OSError, ValueError, RuntimeError, KeyError, TypeError) as error:
        raise ValueError(f"{path}: not a readable NetCDF file ({error})") from None
    with ds:
        yield ds


def _nc_grid_names(ds: Any, path: Path) -> list[str]:
    names = [n for n, v in ds.data_vars.items() if v.ndim == 3 and v.dtype.kind in "iuf"]
    if not names:
        others = ", ".join(f"{n} {v.dims}" for n, v in ds.data_vars.items())
        raise ValueError(
            f"{path}: no numeric variable with 3 dimensions; the file has: {others or 'none'}"
        )
    return [str(n) for n in names]


def _nc_layout(ds: Any, name: str, axes: str | None) -> _Layout:
    var = ds[name]
    dims = [str(d) for d in var.dims]
    units = _text(var.attrs.get(UNITS_ATTRIBUTE))
    named, named_from = _nc_named_axes(ds, dims)
    if named is not None:
        if axes is not None and axes != named:
            problem = (
                f"{named_from} say axes {named!r} (dimensions {tuple(dims)}) but the axes "
                f"argument says {axes!r}; drop the argument"
            )
            return _Layout(named, named_from, units, problem=problem)
        layout = _Layout(named, named_from, units)
    elif axes is not None:
        layout = _Layout(axes, f"the axes argument; dimensions {tuple(dims)}", units)
    else:
        problem = (
            f"dimensions {tuple(dims)} are not named x, y, z; give the axis of each, "
            "e.g. axes='zyx'"
        )
        return _Layout("xyz", "unknown", units, problem=problem)
    try:
        return replace(layout, **_nc_place(ds, dims, layout.axes))
    except ValueError as error:
        return replace(layout, problem=str(error))
    except (OSError, RuntimeError, KeyError, TypeError) as error:
        return replace(layout, problem=f"coordinates cannot be read ({error})")


def _nc_named_axes(ds: Any, dims: list[str]) -> tuple[str | None, str]:
    """The axis order the file states: dimension names x, y, z, else the CF ``axis`` attribute
    (``X``, ``Y``, ``Z``) of the dimensions' coordinate variables."""
    named = "".join(d.lower() for d in dims)
    if len(named) == 3 and sorted(named) == ["x", "y", "z"]:
        return named, "dimension names"
    cf = "".join((_text(ds[d].attrs.get("axis")) or "?") if d in ds.coords else "?" for d in dims)
    if len(cf) == 3 and sorted(cf.lower()) == ["x", "y", "z"]:
        return cf.lower(), "coordinate 'axis' attributes"
    return None, ""


def _nc_place(ds: Any, dims: list[str], axes: str) -> dict[str, Any]:
    """Voxel size, origin and flips from the coordinate variables of ``dims``."""
    coords: dict[str, tuple[NDArray, float]] = {}
    for dim in dims:
        if dim not in ds.coords:
            continue
        units = _text(ds[dim].attrs.get(UNITS_ATTRIBUTE)) or "m"
        factor = LENGTH_UNITS.get(_unit_key(units))
        if factor is None:
            note = f"coordinate {dim!r} in {units!r}, not a length: no placement"
            return {"placement_note": note}
        coords[dim] = (np.asarray(ds[dim].values, dtype=np.float64) * factor, factor)
    spacing = {dim: _spacing(dim, c) for dim, (c, _) in coords.items() if c.size > 1}
    flip = tuple(spacing.get(dim, 1.0) < 0 for dim in dims)
    sizes = {dim: abs(s) for dim, s in spacing.items()}
    if not sizes:
        return {"flip": flip}
    voxel = next(iter(sizes.values()))
    if not all(np.isclose(s, voxel, rtol=SPACING_RTOL, atol=0.0) for s in sizes.values()):
        listed = ", ".join(f"{d} {s:g} m" for d, s in sizes.items())
        raise ValueError(f"voxels are not cubes (coordinate spacing {listed}); resample the data")
    out: dict[str, Any] = {"flip": flip, "voxel_size_m": voxel}
    if len(coords) == 3:
        corner = {axes[i]: float(coords[d][0].min()) - voxel / 2 for i, d in enumerate(dims)}
        out["origin_m"] = (corner["x"], corner["y"], corner["z"])
    return out


def _spacing(dim: str, centres: NDArray) -> float:
    """The uniform signed spacing of a 1-D coordinate, or ValueError."""
    steps = np.diff(centres) if centres.ndim == 1 else np.zeros(1)
    if not np.all(np.isfinite(steps)) or steps[0] == 0:
        raise ValueError(f"coordinate {dim!r} is not a 1-D strictly monotonic coordinate")
    if not np.allclose(steps, steps[0], rtol=SPACING_RTOL, atol=0.0):
        raise ValueError(
            f"coordinate {dim!r} is not uniformly spaced (steps {steps.min():g} to "
            f"{steps.max():g} m); resample the data onto a uniform grid"
        )
    return float(steps[0])


def _nc_read(
    xr: ModuleType,
    path: Path,
    engine: str,
    layouts: Mapping[str, _Layout],
    names: Iterable[str],
) -> Grids:
    wanted = {name: _layout_for(path, layouts, name) for name in names}
    arrays = {}
    with _nc_dataset(xr, path, engine) as ds:
        for name, layout in wanted.items():
            try:
                values = np.asarray(ds[name].values)
            except (OSError, KeyError, ValueError, RuntimeError) as error:
                raise ValueError(f"{path}: grid {name!r} cannot be read ({error})") from None
            arrays[name] = _prepared(path, name, values, layout)
    return _grids(path, arrays, layouts)
