"""VTK, ParaView and OpenFOAM inputs, read through VTK itself (the ``vtk`` wheel, extra "vtk").

Files and folders
-----------------
- ``.vti`` (image data), ``.vtu`` (unstructured), ``.vts`` (structured), ``.vtr`` (rectilinear):
  VTK's XML readers; ``.vtk``: its legacy reader (``vtkDataSetReader``, any dataset type).
- ``.pvd``: a ParaView collection of those files, one per time step (``<DataSet timestep=…
  file=…>``). ``render`` reads the last time step; ``animate`` renders every step in time order
  (:func:`sequence_frames`). One part per time step (multi-part collections are refused). The
  ``vtk`` wheel has no ``.pvd`` reader (ParaView's ``vtkPVDReader`` is not in it), so the
  collection's small XML is read here; each of its files through VTK.
- OpenFOAM: a case folder (it has ``system/controlDict``), a ``.foam``/``.OpenFOAM`` file in one
  (what ParaView opens), or one of its time folders (``case/0.4``), read by
  ``vtkOpenFOAMReader`` (reconstructed cases: the ``internalMesh`` region; decomposed
  ``processor*`` folders are not read: run ``reconstructPar``). A case renders its latest time;
  ``animate`` renders each time folder. Up is against the case's gravity (``constant/g`` along −y
  or −z: :func:`openfoam_up_axis`, which ``config.assemble`` applies unless an up axis is given).

Grids
-----
Every numeric point or cell array with 1 component (a scalar grid) or 3 (a vector grid, e.g.
``U``), by its name. A name held both as point and as cell data is read from the point data on
meshes (interpolated) and from the cell data on images (read as they are).

Voxels
------
*Image data read as it is*: a ``.vti`` (or legacy structured points) with cubic spacing, no
rotation and no ``resolution`` asked: a cell field is the voxel grid itself (cell (i, j, k) is voxel
(i, j, k); the box corner is the image origin); a point field's points are voxel centres (the
corner half a spacing before the origin). So a ``.vti`` of a NumPy array renders exactly as the
array does.

*Everything else is resampled* by VTK's ``vtkProbeFilter`` at the centres of a voxel grid over the
dataset's bounds: ``N`` voxels of side ``h = L / N`` along the longest side ``L`` of the bounds
(``resolution``; default about two voxels per mean cell edge, ``(V_box / cells)^(1/3) / 2``,
within 64 … 256), ``ceil(L_i / h)`` along the others, the grid centred on the bounds. Interpolation
is VTK's: point data by the cell's own interpolation functions (linear on tetrahedra, trilinear on
hexahedra, …), cell data constant over each cell. Voxel centres outside every cell are 0 (vacuum:
0 K) — and counted in the grid's note. Coordinates are read as metres (OpenFOAM's SI).

Temperature units
-----------------
From the field's name (``T [K]``, ``T_degC``, ``temperature (°F)``, ``T_C`` …; single letters K, C,
F only after a temperature-like stem: T, temp…, temperature…) and from metadata: the array's VTK
``UNITS_LABEL`` information key, a field-data string array ``NAME_units``, or — OpenFOAM — the
field file's ``dimensions [0 0 0 1 0 0 0]`` (temperature, which OpenFOAM keeps in kelvin). Celsius
and Fahrenheit are converted to kelvin exactly (:func:`incandescent.io.scientific.to_kelvin`).
When the name and the metadata disagree the grid is ambiguous: reading it is an error naming
both. A field with no unit anywhere is read as it is (kelvin for a temperature, as a ``.npy``).

Errors name the file: unreadable or corrupt files (VTK's own message, never its log on the
terminal), an OpenFOAM case without time folders, a dataset without cells or arrays.
"""

from __future__ import annotations

import contextlib
import gzip
import importlib
import logging
import math
import re
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.budget import Limits
from incandescent.io.formats import OPENFOAM_SUFFIXES, PVD_SUFFIXES, VTK_SUFFIXES
from incandescent.io.grids import Grids, GridSource
from incandescent.io.scientific import TEMPERATURE_UNITS, _layout_for, to_kelvin

__all__ = ["is_openfoam", "open_vtk", "openfoam_up_axis", "sequence_frames", "voxel_grid"]

log = logging.getLogger("incandescent")

INSTALL_HINT = "pip install 'incandescent[vtk]'"
#: Default resampling: voxels per mean cell edge, and the bounds on voxels along the longest side.
VOXELS_PER_CELL = 2.0
DEFAULT_RESOLUTION_RANGE = (64, 256)
#: Relative tolerance for cubic image spacing.
SPACING_RTOL = 1e-5
#: Peak bytes per voxel of probing one scalar grid (float64 point arrays, mask, our copy).
PROBE_BYTES_PER_VOXEL = 24
CONTROL_DICT = Path("system") / "controlDict"
#: Single-letter units after a temperature-like stem.
_LETTER_UNITS = {"k": "K", "c": "degC", "f": "degF"}
_UNIT_WORDS = "|".join(sorted({re.escape(k) for k in TEMPERATURE_UNITS} | {"°c", "°f"}, key=len))
_NAME_UNITS = re.compile(
    rf"^(?P<stem>.+?)\s*(?:[\[(]\s*(?P<bracketed>{_UNIT_WORDS}|k|c|f)\s*[\])]|"
    rf"[_\s\-](?P<suffix>{_UNIT_WORDS}|k|c|f))$",
    re.IGNORECASE,
)
_TEMPERATURE_STEM = re.compile(r"^(t|temp.*|temperature.*|t_.*)$", re.IGNORECASE)


# ------------------------------------------------------------------ public


def is_openfoam(path: str | Path) -> bool:
    """Is ``path`` an OpenFOAM case folder, a ``.foam`` file in one, or a case's time folder?"""
    try:
        _case_and_time(Path(path))
    except ValueError:
        return False
    return True


def sequence_frames(path: str | Path) -> list[Path] | None:
    """The frames ``animate`` renders from one path: a ``.pvd``'s files in time order, or an
    OpenFOAM case's time folders; None for any other path (not a series)."""
    path = Path(path)
    if path.suffix.lower() in PVD_SUFFIXES and path.is_file():
        return [file for _, file in _pvd_datasets(path)]
    if (path.is_dir() or path.suffix.lower() in OPENFOAM_SUFFIXES) and is_openfoam(path):
        case, time = _case_and_time(path)
        if time is None:
            return [case / name for name, _ in _foam_times(case)]
    return None


_FOAM_GRAVITY = re.compile(r"value\s*\(\s*(\S+)\s+(\S+)\s+(\S+)\s*\)")


def openfoam_up_axis(path: str | Path) -> str | None:
    """ "y" or "z" when ``path`` is an OpenFOAM case whose ``constant/g`` points along −y or −z
    (up is against gravity); None for anything else (no case, no g, another direction)."""
    try:
        case, _ = _case_and_time(Path(path))
        text = (case / "constant" / "g").read_text(errors="replace")
    except (ValueError, OSError):
        return None
    found = _FOAM_GRAVITY.search(text)
    try:
        g = np.array([float(v) for v in found.groups()]) if found else np.zeros(3)
    except ValueError:
        return None
    axis = int(np.argmax(np.abs(g)))
    along = g[axis] < 0 and np.allclose(np.delete(g, axis), 0.0)
    return {1: "y", 2: "z"}.get(axis) if along else None


def voxel_grid(
    bounds: tuple[float, ...], cells: int, resolution: int | None = None
) -> tuple[tuple[int, int, int], tuple[float, float, float], float]:
    """(shape, corner origin in m, voxel side in m) of the grid a dataset is resampled onto.

    ``bounds``: (x0, x1, y0, y1, z0, z1) in m; ``cells``: the dataset's cells; ``resolution``:
    voxels along the longest side (default: see the module docstring). The grid is centred on
    the bounds."""
    low, high = np.asarray(bounds[0::2], float), np.asarray(bounds[1::2], float)
    lengths = high - low
    longest = float(lengths.max())
    if not np.all(np.isfinite(lengths)) or longest <= 0:
        raise ValueError(f"the dataset has no extent (bounds {tuple(bounds)})")
    n = resolution if resolution is not None else _default_resolution(lengths, cells)
    side = longest / n
    shape = tuple(int(max(1, math.ceil(length / side - 1e-6))) for length in lengths)
    origin = (low + high) / 2 - np.asarray(shape) * side / 2
    return shape, (float(origin[0]), float(origin[1]), float(origin[2])), side  # type: ignore[return-value]


def _default_resolution(lengths: NDArray, cells: int) -> int:
    """About :data:`VOXELS_PER_CELL` voxels per mean cell edge along the longest side, within
    :data:`DEFAULT_RESOLUTION_RANGE`."""
    longest = float(lengths.max())
    box = float(np.prod(np.maximum(lengths, longest * 1e-6)))
    edge = (box / max(cells, 1)) ** (1.0 / 3.0)
    low, high = DEFAULT_RESOLUTION_RANGE
    return int(np.clip(math.ceil(VOXELS_PER_CELL * longest / edge), low, high))


def open_vtk(
    path: str | Path, resolution: int | None = None, limits: Limits | None = None
) -> GridSource:
    """A VTK file, ParaView ``.pvd`` or OpenFOAM case as named grids on a voxel grid.

    Parameters
    ----------
    path : ``.vti .vtk .vtu .vts .vtr .pvd``, an OpenFOAM case folder, ``.foam`` file or time
        folder.
    resolution : voxels along the longest side of a resampled dataset (default: chosen from the
        cell count); asking for one resamples image data too.
    limits : the resampled grids' memory is checked against them before probing.
    """
    path = Path(path)
    if resolution is not None and (isinstance(resolution, bool) or resolution < 1):
        raise ValueError(
            f"{path}: resolution must be a positive number of voxels, got {resolution}"
        )
    dataset, units, what = _load(path)
    fields = _fields(path, dataset, units)
    if not fields:
        raise ValueError(
            f"{path}: {what} holds no numeric point or cell array with 1 or 3 components"
        )
    image = resolution is None and _plain_image(dataset)
    sampler = _ImageSampler(path, dataset) if image else _Resampler(path, dataset, resolution)
    notes = {name: f"{what}; {f.note}; {sampler.note(f)}" for name, f in fields.items()}
    limits = limits or Limits()

    def read(names: Iterable[str]) -> Grids:
        chosen = [_layout_for(path, fields, name) for name in names]
        listed = ", ".join(f.name for f in chosen)
        limits.check_memory(sampler.bytes(chosen), f"reading {listed} from {path}")
        with _vtk_errors(path, "cannot be resampled"):
            grids = sampler.sample(chosen)
        arrays = {f.name: _in_kelvin(path, f, grids.arrays[f.name]) for f in chosen}
        return Grids(arrays, grids.origin_m, grids.voxel_size_m)

    return GridSource(path, tuple(fields), read, notes)


# ------------------------------------------------------------------ loading


def _vtk(module: str, path: Path) -> Any:
    try:
        return importlib.import_module(f"vtkmodules.{module}")
    except ImportError:
        raise ValueError(
            f"{path}: reading VTK, ParaView or OpenFOAM input needs VTK: {INSTALL_HINT}"
        ) from None


@contextlib.contextmanager
def _vtk_errors(path: Path, doing: str) -> Iterator[None]:
    """VTK's error messages collected (never on the terminal); the first one raised with the
    file's name after the block."""
    core = _vtk("vtkCommonCore", path)
    window, previous = core.vtkStringOutputWindow(), core.vtkOutputWindow.GetInstance()
    verbosity = core.vtkLogger.GetCurrentVerbosityCutoff()
    core.vtkOutputWindow.SetInstance(window)
    core.vtkLogger.SetStderrVerbosity(core.vtkLogger.VERBOSITY_OFF)
    try:
        yield
    finally:
        core.vtkOutputWindow.SetInstance(previous)
        core.vtkLogger.SetStderrVerbosity(verbosity)
    message = _first_error(window.GetOutput())
    if message:
        raise ValueError(f"{path}: {doing} (VTK: {message})")


def _first_error(text: str) -> str | None:
    for block in text.split("ERROR:")[1:]:
        lines = [line.strip() for line in block.strip().splitlines() if line.strip()]
        if len(lines) >= 2:
            return lines[1].split("): ", 1)[-1]
    return None


_XML_READERS = {
    ".vti": "vtkXMLImageDataReader",
    ".vtu": "vtkXMLUnstructuredGridReader",
    ".vts": "vtkXMLStructuredGridReader",
    ".vtr": "vtkXMLRectilinearGridReader",
}


def _load(path: Path) -> tuple[Any, dict[str, str], str]:
    """(dataset, units from the files beside the data, what it is) of one input."""
    suffix = path.suffix.lower()
    if suffix in PVD_SUFFIXES:
        steps = _pvd_datasets(path)
        time, file = steps[-1]
        log.info("%s: time step %g (the last of %d) from %s", path, time, len(steps), file.name)
        dataset, units, what = _load(file)
        return dataset, units, f"{what} (time {time:g} of {path.name})"
    if suffix in VTK_SUFFIXES:
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such VTK file")
        return _read_file(path), {}, f"VTK {suffix} file"
    return _read_openfoam(path)


def _read_file(path: Path) -> Any:
    suffix = path.suffix.lower()
    if suffix == ".vtk":
        reader = _vtk("vtkIOLegacy", path).vtkDataSetReader()
    else:
        reader = getattr(_vtk("vtkIOXML", path), _XML_READERS[suffix])()
        if not reader.CanReadFile(str(path)):
            raise ValueError(f"{path}: not a VTK XML {suffix} file (VTK's reader refuses it)")
    reader.SetFileName(str(path))
    if suffix == ".vtk":
        reader.ReadAllScalarsOn()  # every scalar array, not only the file's default one
    with _vtk_errors(path, f"not a readable {suffix} file"):
        reader.Update()
    dataset = reader.GetOutput()
    if dataset is None or dataset.GetNumberOfPoints() == 0:
        raise ValueError(f"{path}: not a readable {suffix} file (VTK read no points)")
    return dataset


def _read_openfoam(path: Path) -> tuple[Any, dict[str, str], str]:
    case, time = _case_and_time(path)
    times = _foam_times(case)
    if time is None:
        time = times[-1][1]
        log.info("%s: OpenFOAM time %g (the latest of %d)", case, time, len(times))
    reader = _vtk("vtkIOGeometry", path).vtkOpenFOAMReader()
    reader.SetFileName(str(case / CONTROL_DICT))
    with _vtk_errors(path, "not a readable OpenFOAM case"):
        reader.UpdateInformation()
        reader.EnableAllCellArrays()
        reader.SetTimeValue(time)
        reader.Update()
    mesh = _internal_mesh(path, reader.GetOutput())
    folder = next(name for name, t in times if t == time)
    units = _foam_units(case / folder)
    return mesh, units, f"OpenFOAM case {case.name}, time {folder}"


def _internal_mesh(path: Path, output: Any) -> Any:
    """The ``internalMesh`` block of the reader's multiblock output."""
    from vtkmodules.vtkCommonDataModel import vtkCompositeDataSet

    for index in range(output.GetNumberOfBlocks() if output is not None else 0):
        block = output.GetBlock(index)
        name = output.GetMetaData(index).Get(vtkCompositeDataSet.NAME())
        if name == "internalMesh" and block is not None and block.GetNumberOfCells() > 0:
            return block
    raise ValueError(f"{path}: the OpenFOAM case has no cells (no internalMesh; run blockMesh?)")


def _case_and_time(path: Path) -> tuple[Path, float | None]:
    """(case folder, the time folder's time or None) of an OpenFOAM path, or ValueError."""
    if path.suffix.lower() in OPENFOAM_SUFFIXES:
        path = path.parent
    if (path / CONTROL_DICT).is_file():
        return path, None
    time = _time_of(path.name)
    if time is not None and (path.parent / CONTROL_DICT).is_file() and path.is_dir():
        return path.parent, time
    raise ValueError(
        f"{path}: not an OpenFOAM case (no {CONTROL_DICT}) nor one of its time folders"
    )


def _time_of(name: str) -> float | None:
    try:
        time = float(name)
    except ValueError:
        return None
    return time if math.isfinite(time) else None


def _foam_times(case: Path) -> list[tuple[str, float]]:
    """The case's time folders (name, time), in time order; none is an error."""
    times = [
        (p.name, t) for p in case.iterdir() if p.is_dir() and (t := _time_of(p.name)) is not None
    ]
    if not times:
        decomposed = any(p.name.startswith("processor") for p in case.iterdir())
        hint = "; it is decomposed: run reconstructPar" if decomposed else "; run the solver first"
        raise ValueError(f"{case}: an OpenFOAM case with no time folders (0, 0.1, …){hint}")
    return sorted(times, key=lambda item: item[1])


_FOAM_DIMENSIONS = re.compile(rb"dimensions\s*\[([^\]]*)\]")


def _foam_units(folder: Path) -> dict[str, str]:
    """Fields of a time folder whose ``dimensions`` are temperature, [0 0 0 1 0 0 0]: kelvin."""
    units = {}
    for file in folder.iterdir():
        if not file.is_file():
            continue
        opener: Any = gzip.open if file.suffix == ".gz" else open
        try:
            with opener(file, "rb") as handle:
                head = handle.read(4096)
        except (OSError, EOFError):
            continue
        found = _FOAM_DIMENSIONS.search(head)
        if found and found.group(1).split() == [b"0", b"0", b"0", b"1", b"0", b"0", b"0"]:
            units[file.name.removesuffix(".gz")] = "K"
    return units


def _pvd_datasets(path: Path) -> list[tuple[float, Path]]:
    """(time step, file) of a ``.pvd`` collection, in time order."""
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError) as error:
        raise ValueError(f"{path}: not a readable .pvd collection ({error})") from None
    steps: dict[float, Path] = {}
    for item in root.iter("DataSet"):
        time, file = _pvd_entry(path, item.attrib)
        if time in steps:
            raise ValueError(
                f"{path}: several datasets (parts) at time step {time:g}; one per step is read"
            )
        steps[time] = file
    if root.tag != "VTKFile" or not steps:
        raise ValueError(f"{path}: not a ParaView collection (no <VTKFile><Collection><DataSet …>)")
    return sorted(steps.items())


def _pvd_entry(path: Path, attrib: dict[str, str]) -> tuple[float, Path]:
    try:
        time = float(attrib.get("timestep", "0"))
    except ValueError:
        raise ValueError(
            f"{path}: DataSet timestep {attrib.get('timestep')!r} is not a number"
        ) from None
    name = attrib.get("file")
    if not name:
        raise ValueError(f"{path}: a DataSet without a file attribute")
    file = path.parent / name
    if file.suffix.lower() not in VTK_SUFFIXES:
        raise ValueError(f"{path}: DataSet file {name!r} is not one of {', '.join(VTK_SUFFIXES)}")
    if not file.is_file():
        raise FileNotFoundError(f"{path}: its DataSet file {file} does not exist")
    return time, file


# ------------------------------------------------------------------ fields and units


@dataclass(frozen=True)
class _Field:
    name: str
    association: str  # "point" | "cell"
    components: int
    units: str | None  # the unit the values are in, after name and metadata agreed
    note: str
    problem: str | None = None


def _fields(path: Path, dataset: Any, file_units: dict[str, str]) -> dict[str, _Field]:
    """The readable arrays by name (point data first on meshes, cell data first on images)."""
    image = dataset.IsA("vtkImageData")
    order = ("cell", "point") if image else ("point", "cell")
    fields: dict[str, _Field] = {}
    for association in order:
        data = dataset.GetCellData() if association == "cell" else dataset.GetPointData()
        for index in range(data.GetNumberOfArrays()):
            array = data.GetArray(index)  # None for string arrays
            if array is None or array.GetNumberOfComponents() not in (1, 3) or not array.GetName():
                continue
            name = array.GetName()
            if name not in fields:
                meta = file_units.get(name) or _array_units(dataset, array)
                fields[name] = _field_units(name, association, array.GetNumberOfComponents(), meta)
    return fields


def _array_units(dataset: Any, array: Any) -> str | None:
    """The array's ``UNITS_LABEL`` information key, or a field-data string array NAME_units."""
    from vtkmodules.vtkCommonCore import vtkDataArray

    info = array.GetInformation()
    if info is not None and info.Has(vtkDataArray.UNITS_LABEL()):
        return str(info.Get(vtkDataArray.UNITS_LABEL()))
    extra = dataset.GetFieldData().GetAbstractArray(f"{array.GetName()}_units")
    if extra is not None and extra.GetNumberOfValues() > 0:
        return str(extra.GetVariantValue(0).ToString())
    return None


def _name_units(name: str) -> str | None:
    """The temperature unit a field's name states (``T [K]``, ``T_degC``), or None."""
    found = _NAME_UNITS.match(name.strip())
    if found is None:
        return None
    unit = found.group("bracketed") or found.group("suffix")
    if unit.lower() in _LETTER_UNITS:
        return _LETTER_UNITS[unit.lower()] if _TEMPERATURE_STEM.match(found.group("stem")) else None
    return unit


def _scale(units: str | None) -> tuple[float, float] | None:
    return None if units is None else TEMPERATURE_UNITS.get(_unit_key(units))


def _unit_key(units: str) -> str:
    return units.strip().lower().replace("°", "deg").replace("º", "deg").replace(" ", "_")


def _field_units(name: str, association: str, components: int, meta: str | None) -> _Field:
    named = _name_units(name)
    where = f"{association} data, {components} component{'s' if components > 1 else ''}"
    if named and meta and _scale(named) != _scale(meta):
        problem = (
            f"ambiguous units: its name says {named!r} but its metadata says {meta!r}; "
            "fix the file or rename the array"
        )
        return _Field(name, association, components, None, where, problem)
    units = named or meta
    said = f"units {units!r} from its {'name' if named else 'metadata'}" if units else "no units"
    return _Field(name, association, components, units, f"{where}; {said}")


def _in_kelvin(path: Path, field: _Field, values: NDArray) -> NDArray:
    kelvin, note = to_kelvin(values, field.units) if _scale(field.units) else (values, None)
    if note and kelvin is not values:
        log.info("%s: field %r: %s", path, field.name, note)
    return np.ascontiguousarray(kelvin, dtype=np.result_type(kelvin.dtype, np.float32))


# ------------------------------------------------------------------ voxels


def _plain_image(dataset: Any) -> bool:
    """Image data whose voxels are ours as they are: cubic spacing, no rotation."""
    if not dataset.IsA("vtkImageData"):
        return False
    spacing = np.asarray(dataset.GetSpacing(), float)
    matrix = dataset.GetDirectionMatrix()
    identity = matrix is None or matrix.IsIdentity()
    return bool(
        identity and spacing[0] > 0 and np.allclose(spacing, spacing[0], rtol=SPACING_RTOL, atol=0)
    )


def _to_xyz(flat: NDArray, shape: tuple[int, ...], components: int) -> NDArray:
    """A VTK array's values (x varies fastest) as an (nx, ny, nz[, 3]) C-ordered array."""
    values = np.asarray(flat).reshape(
        tuple(reversed(shape)) + ((components,) if components > 1 else ())
    )
    order = (2, 1, 0, 3) if components > 1 else (2, 1, 0)
    return np.ascontiguousarray(np.transpose(values, order))


class _ImageSampler:
    """Image data as it is: cells are voxels (point fields: points are voxel centres)."""

    def __init__(self, path: Path, image: Any) -> None:
        self.path, self.image = path, image
        self.side = float(image.GetSpacing()[0])
        self.points = tuple(int(n) for n in image.GetDimensions())

    def note(self, field: _Field) -> str:
        return f"image data read as it is ({field.association} values are voxels, {self.side:g} m)"

    def bytes(self, fields: list[_Field]) -> float:
        return float(np.prod(self.points)) * sum(8 * f.components for f in fields)

    def sample(self, fields: list[_Field]) -> Grids:
        kinds = {f.association for f in fields}
        if len(kinds) > 1:
            listed = ", ".join(f"{f.name} ({f.association})" for f in fields)
            raise ValueError(
                f"{self.path}: point and cell fields of an image have different voxels: {listed}; "
                "read them apart, or resample with a resolution"
            )
        cells = tuple(max(1, n - 1) for n in self.points)
        shape = cells if kinds == {"cell"} else self.points
        shift = self.side / 2 if kinds == {"point"} else 0.0  # point values sit at voxel centres
        origin = tuple(float(o) - shift for o in self.image.GetOrigin())
        out = {}
        for f in fields:
            data = (
                self.image.GetCellData() if f.association == "cell" else self.image.GetPointData()
            )
            out[f.name] = _to_xyz(_numpy(data.GetArray(f.name)), shape, f.components)
        return Grids(out, origin, self.side)  # type: ignore[arg-type]


class _Resampler:
    """A dataset probed at the centres of a voxel grid over its bounds (``vtkProbeFilter``)."""

    def __init__(self, path: Path, dataset: Any, resolution: int | None) -> None:
        self.path, self.dataset = path, dataset
        try:
            self.shape, self.origin, self.side = voxel_grid(
                dataset.GetBounds(), dataset.GetNumberOfCells(), resolution
            )
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None

    def note(self, field: _Field) -> str:
        how = "interpolated in each cell" if field.association == "point" else "constant per cell"
        shape = "×".join(map(str, self.shape))
        return f"resampled by vtkProbeFilter onto {shape} voxels of {self.side:.4g} m ({how})"

    def bytes(self, fields: list[_Field]) -> float:
        return float(np.prod(self.shape)) * (
            PROBE_BYTES_PER_VOXEL + sum(12 * f.components for f in fields)
        )

    def sample(self, fields: list[_Field]) -> Grids:
        probed = self._probe(fields)
        inside = _numpy(probed.GetPointData().GetArray("vtkValidPointMask")).astype(bool)
        outside = int(inside.size - inside.sum())
        if outside:
            log.info(
                "%s: %d of %d voxel centres outside the mesh are 0 (vacuum)",
                self.path,
                outside,
                inside.size,
            )
        out = {}
        for f in fields:
            values = _numpy(probed.GetPointData().GetArray(f.name)).copy()
            values[~inside] = 0
            out[f.name] = _to_xyz(values, self.shape, f.components)
        return Grids(out, self.origin, self.side)

    def _probe(self, fields: list[_Field]) -> Any:
        from vtkmodules.vtkCommonDataModel import vtkImageData
        from vtkmodules.vtkFiltersCore import vtkProbeFilter

        grid = vtkImageData()
        grid.SetDimensions(*self.shape)
        grid.SetSpacing(self.side, self.side, self.side)
        grid.SetOrigin(*(o + self.side / 2 for o in self.origin))  # voxel centres
        probe = vtkProbeFilter()
        probe.SetInputData(grid)
        probe.SetSourceData(_only(self.dataset, fields))
        probe.Update()
        return probe.GetOutput()


def _numpy(array: Any) -> NDArray:
    from vtkmodules.util.numpy_support import vtk_to_numpy

    return vtk_to_numpy(array)


def _only(dataset: Any, fields: list[_Field]) -> Any:
    """A shallow copy of ``dataset`` holding just ``fields`` (so names do not collide)."""
    copy = dataset.NewInstance()
    copy.ShallowCopy(dataset)
    for association in ("point", "cell"):
        data = copy.GetPointData() if association == "point" else copy.GetCellData()
        keep = {f.name for f in fields if f.association == association}
        for name in [data.GetArrayName(i) for i in range(data.GetNumberOfArrays())]:
            if name not in keep:
                data.RemoveArray(name)
    return copy
