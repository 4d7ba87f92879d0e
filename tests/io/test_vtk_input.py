"""VTK / ParaView / OpenFOAM input (io.vtk) against VTK itself: a real OpenFOAM case
(tests/data/openfoam_fire, made by Debian's OpenFOAM: tests/data/make_openfoam_fire.sh) rendered
as the same field probed by VTK's own vtkProbeFilter here; .vti of an array read exactly as the
array; point/cell data of .vtu meshes against analytic fields; .pvd and OpenFOAM time series as
animate frames; temperature units; bad input."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

vtk_np = pytest.importorskip("vtkmodules.util.numpy_support")
from vtkmodules.vtkCommonCore import vtkDataArray, vtkPoints, vtkStringArray  # noqa: E402
from vtkmodules.vtkCommonDataModel import (  # noqa: E402
    VTK_HEXAHEDRON,
    vtkCompositeDataSet,
    vtkImageData,
    vtkUnstructuredGrid,
)
from vtkmodules.vtkFiltersCore import vtkProbeFilter  # noqa: E402
from vtkmodules.vtkIOGeometry import vtkOpenFOAMReader  # noqa: E402
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLUnstructuredGridWriter  # noqa: E402

from incandescent import Camera, RenderSettings, render  # noqa: E402
from incandescent.animation import expand_sequence  # noqa: E402
from incandescent.cli import app  # noqa: E402
from incandescent.config.assemble import volume_from_section  # noqa: E402
from incandescent.config.schema import VolumeSection  # noqa: E402
from incandescent.io.volumes import open_grids  # noqa: E402
from incandescent.io.vtk import voxel_grid  # noqa: E402
from incandescent.volume import Remap  # noqa: E402

CASE = Path(__file__).parents[1] / "data" / "openfoam_fire"
SETTINGS = RenderSettings(width=40, height=56, jitter=False)
runner = CliRunner()


def _vtk_array(name: str, values: np.ndarray):
    array = vtk_np.numpy_to_vtk(np.ascontiguousarray(values), deep=True)
    array.SetName(name)
    return array


def _flat(xyz: np.ndarray) -> np.ndarray:
    """(nx, ny, nz[, c]) → VTK's order, x varying fastest."""
    return xyz.transpose((2, 1, 0) + tuple(range(3, xyz.ndim))).reshape((-1,) + xyz.shape[3:])


def write_vti(path: Path, cells: dict, spacing=0.1, origin=(0.0, 0.0, 0.0), points=None) -> Path:
    """An image whose cell arrays are ``cells`` (x, y, z arrays), point arrays ``points``."""
    shape = next(iter((cells or points).values())).shape[:3]
    image = vtkImageData()
    image.SetDimensions(*(n + 1 for n in shape) if cells else shape)
    image.SetSpacing(*np.broadcast_to(spacing, 3))
    image.SetOrigin(*origin)
    for name, values in cells.items():
        image.GetCellData().AddArray(_vtk_array(name, _flat(values)))
    for name, values in (points or {}).items():
        image.GetPointData().AddArray(_vtk_array(name, _flat(values)))
    writer = vtkXMLImageDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(image)
    assert writer.Write() == 1
    return path


def hex_mesh(xs, ys, zs) -> vtkUnstructuredGrid:
    """An unstructured grid of hexahedra on the (non-uniform) lines ``xs``, ``ys``, ``zs``."""
    grid, points = vtkUnstructuredGrid(), vtkPoints()
    nx, ny, nz = len(xs), len(ys), len(zs)
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                points.InsertNextPoint(xs[i], ys[j], zs[k])
    grid.SetPoints(points)

    def pid(i, j, k):
        return i + nx * (j + ny * k)

    for k in range(nz - 1):
        for j in range(ny - 1):
            for i in range(nx - 1):
                ids = [pid(i, j, k), pid(i + 1, j, k), pid(i + 1, j + 1, k), pid(i, j + 1, k),
                       pid(i, j, k + 1), pid(i + 1, j, k + 1), pid(i + 1, j + 1, k + 1),
                       pid(i, j + 1, k + 1)]  # fmt: skip
                grid.InsertNextCell(VTK_HEXAHEDRON, 8, ids)
    return grid


def write_vtu(path: Path, grid) -> Path:
    writer = vtkXMLUnstructuredGridWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(grid)
    assert writer.Write() == 1
    return path


def linear(x, y, z):
    """An analytic temperature field, K: linear, so linear interpolation reproduces it."""
    return 900.0 + 400.0 * x + 250.0 * y - 120.0 * z


XS, YS, ZS = (
    np.array([0, 0.1, 0.35, 0.5, 1.0]),
    np.array([0, 0.4, 0.5, 1.2]),
    np.array([0, 0.3, 0.8]),
)


def _image(section: VolumeSection, camera: Camera) -> np.ndarray:
    volume = volume_from_section(section, Remap())
    return render(volume, camera, SETTINGS, backend="cpu").xyz


# ------------------------------------------------------------------ OpenFOAM (the must-show)


def _probe_by_vtk(case: Path, time: float, resolution: int):
    """The T field of ``case`` at ``time`` probed by VTK's own filter at the voxel centres the
    module documents: N voxels along the longest side, the grid centred on the bounds."""
    reader = vtkOpenFOAMReader()
    reader.SetFileName(str(case / "system" / "controlDict"))
    reader.UpdateInformation()
    reader.SetTimeValue(time)
    reader.Update()
    mesh = reader.GetOutput().GetBlock(0)
    assert reader.GetOutput().GetMetaData(0).Get(vtkCompositeDataSet.NAME()) == "internalMesh"
    bounds = np.array(mesh.GetBounds())
    low, high = bounds[0::2], bounds[1::2]
    side = (high - low).max() / resolution
    shape = np.ceil((high - low) / side - 1e-6).astype(int)
    corner = (low + high) / 2 - shape * side / 2
    grid = vtkImageData()
    grid.SetDimensions(*shape)
    grid.SetSpacing(side, side, side)
    grid.SetOrigin(*(corner + side / 2))
    probe = vtkProbeFilter()
    probe.SetInputData(grid)
    probe.SetSourceData(mesh)
    probe.Update()
    out = probe.GetOutput().GetPointData()
    values = vtk_np.vtk_to_numpy(out.GetArray("T")).astype(np.float32)  # point data: first "T"
    values[vtk_np.vtk_to_numpy(out.GetArray("vtkValidPointMask")) == 0] = 0
    t_xyz = values.reshape(shape[::-1]).transpose(2, 1, 0)
    return np.ascontiguousarray(t_xyz), tuple(corner), float(side)


@pytest.mark.parametrize("time", [0.1, 0.4])
def test_openfoam_render_equals_vtk_probe_filter_npy(tmp_path, time):
    expected, corner, side = _probe_by_vtk(CASE, time, resolution=40)
    assert expected.max() > 1000.0  # a hot case: the images below are not black
    npy = tmp_path / "probed.npy"
    np.save(npy, expected)
    folder = CASE / f"{time:g}"
    ours = open_grids(folder, resolution=40).read(["T"])
    np.testing.assert_array_equal(ours.arrays["T"], expected)
    camera = Camera(eye=(3.5, 2.5, 4.0), target=(1.0, 1.2, 1.0), fov_deg=45.0)
    case_image = _image(VolumeSection(path=folder, resolution=40), camera)
    npy_image = _image(VolumeSection(path=npy, voxel_size_m=side, origin_m=corner), camera)
    assert case_image[..., 1].max() > 0
    np.testing.assert_array_equal(case_image, npy_image)


def test_openfoam_case_reads_latest_time_in_kelvin_from_its_dimensions():
    source = open_grids(CASE, resolution=24)
    assert source.names == ("T", "U")
    assert "time 0.4" in source.notes["T"] and "units 'K' from its metadata" in source.notes["T"]
    grids = source.read(["T", "U"])
    assert grids.arrays["U"].shape == grids.arrays["T"].shape + (3,)
    expected, _, _ = _probe_by_vtk(CASE, 0.4, 24)
    np.testing.assert_array_equal(grids.arrays["T"], expected)


def test_openfoam_up_axis_is_against_gravity(tmp_path):
    case = shutil.copytree(CASE, tmp_path / "z_up")
    (case / "constant" / "g").write_text(
        (CASE / "constant" / "g").read_text().replace("(0 -9.81 0)", "(0 0 -9.81)")
    )
    given = volume_from_section(VolumeSection(path=case, resolution=20, up_axis="z"), Remap())
    found = volume_from_section(VolumeSection(path=case, resolution=20), Remap())
    as_is = volume_from_section(VolumeSection(path=CASE, resolution=20), Remap())
    assert (
        found.temperature_K.shape == given.temperature_K.shape == (14, 14, 20)
    )  # z up: (x, z, −y)
    np.testing.assert_array_equal(found.temperature_K, given.temperature_K)
    assert as_is.temperature_K.shape == (14, 20, 14)  # −y gravity: y is up already


def test_openfoam_time_folders_are_the_animation_frames():
    assert [p.name for p in expand_sequence(str(CASE))] == ["0", "0.1", "0.2", "0.3", "0.4"]
    assert expand_sequence(str(CASE / "case.foam"))[-1] == CASE / "0.4"


def test_openfoam_case_without_time_folders_is_a_one_line_error(tmp_path):
    case = tmp_path / "empty_case"
    for part in ("system", "constant"):
        shutil.copytree(CASE / part, case / part)
    result = runner.invoke(app, ["render", str(case), "-o", str(tmp_path / "out.png")])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    (line,) = [t for t in result.output.splitlines() if t.startswith("error:")]
    assert str(case) in line and "no time folders" in line


# ------------------------------------------------------------------ image data, as it is


def test_vti_cell_data_renders_exactly_as_the_array(tmp_path):
    rng = np.random.default_rng(3)
    i, j, k = np.meshgrid(*(np.arange(n) for n in (9, 12, 7)), indexing="ij")
    blob = 1800.0 * np.exp(-((i - 4) ** 2 + (j - 5) ** 2 / 2 + (k - 3) ** 2) / 6.0)
    temperature = (blob + rng.uniform(0, 50, blob.shape)).astype(np.float32)
    vti = write_vti(tmp_path / "t.vti", {"temperature": temperature}, 0.05, (0.2, -0.1, 0.3))
    grids = open_grids(vti).read(["temperature"])
    np.testing.assert_array_equal(grids.arrays["temperature"], temperature)
    assert grids.voxel_size_m == pytest.approx(0.05) and grids.origin_m == (0.2, -0.1, 0.3)
    npy = tmp_path / "t.npy"
    np.save(npy, temperature)
    camera = Camera(eye=(1.2, 0.6, 1.5), target=(0.42, 0.2, 0.48))
    image = _image(VolumeSection(path=vti), camera)
    assert image[..., 1].max() > 0
    same = _image(VolumeSection(path=npy, voxel_size_m=0.05, origin_m=(0.2, -0.1, 0.3)), camera)
    np.testing.assert_array_equal(image, same)


def test_vti_point_data_values_are_voxel_centres(tmp_path):
    values = np.arange(2 * 3 * 4, dtype=np.float32).reshape(2, 3, 4)
    vti = write_vti(tmp_path / "p.vti", {}, 0.5, (1.0, 2.0, 3.0), points={"T": values})
    grids = open_grids(vti).read(["T"])
    np.testing.assert_array_equal(grids.arrays["T"], values)
    assert grids.origin_m == (0.75, 1.75, 2.75)


# ------------------------------------------------------------------ meshes, resampled


def test_voxel_grid_follows_the_documented_rule():
    shape, origin, side = voxel_grid((0, 2, 0, 3, 0, 1), cells=100, resolution=10)
    assert side == pytest.approx(0.3) and shape == (7, 10, 4)
    np.testing.assert_allclose(origin, (1 - 1.05, 0.0, 0.5 - 0.6))
    # default: two voxels per mean cell edge (V/cells)^(1/3), within 64 … 256
    assert voxel_grid((0, 1, 0, 1, 0, 1), cells=50**3)[0] == (100, 100, 100)
    assert voxel_grid((0, 1, 0, 1, 0, 1), cells=8)[0] == (64, 64, 64)
    assert voxel_grid((0, 1, 0, 1, 0, 1), cells=10**9)[0] == (256, 256, 256)


def _as_format(tmp_path: Path, mesh, suffix: str) -> Path:
    """``mesh`` (hexahedra on XS, YS, ZS, with its point data) as a .vtu, .vts or .vtr file."""
    from vtkmodules.vtkCommonDataModel import vtkRectilinearGrid, vtkStructuredGrid
    from vtkmodules.vtkIOXML import vtkXMLRectilinearGridWriter, vtkXMLStructuredGridWriter

    if suffix == ".vtu":
        return write_vtu(tmp_path / "lin.vtu", mesh)
    if suffix == ".vts":
        grid, writer = vtkStructuredGrid(), vtkXMLStructuredGridWriter()
        grid.SetPoints(mesh.GetPoints())
    else:
        grid, writer = vtkRectilinearGrid(), vtkXMLRectilinearGridWriter()
        grid.SetXCoordinates(_vtk_array("x", XS))
        grid.SetYCoordinates(_vtk_array("y", YS))
        grid.SetZCoordinates(_vtk_array("z", ZS))
    grid.SetDimensions(len(XS), len(YS), len(ZS))
    grid.GetPointData().ShallowCopy(mesh.GetPointData())
    writer.SetFileName(str(tmp_path / f"lin{suffix}"))
    writer.SetInputData(grid)
    assert writer.Write() == 1
    return tmp_path / f"lin{suffix}"


@pytest.mark.parametrize("suffix", [".vtu", ".vts", ".vtr"])
def test_point_data_linear_field_is_reproduced_exactly(tmp_path, suffix):
    mesh = hex_mesh(XS, YS, ZS)
    pts = vtk_np.vtk_to_numpy(mesh.GetPoints().GetData())
    mesh.GetPointData().AddArray(_vtk_array("T", linear(*pts.T)))
    source = open_grids(_as_format(tmp_path, mesh, suffix), resolution=30)
    grids = source.read(["T"])
    shape, origin, side = voxel_grid(mesh.GetBounds(), mesh.GetNumberOfCells(), 30)
    centres = [origin[a] + (np.arange(shape[a]) + 0.5) * side for a in range(3)]
    x, y, z = np.meshgrid(*centres, indexing="ij")
    inside = (x >= 0) & (x <= 1) & (y >= 0) & (y <= 1.2) & (z >= 0) & (z <= 0.8)
    assert inside.sum() > 0.9 * inside.size and "interpolated in each cell" in source.notes["T"]
    np.testing.assert_allclose(grids.arrays["T"][inside], linear(x, y, z)[inside], rtol=1e-6)
    assert np.all(grids.arrays["T"][~inside] == 0)  # outside the mesh: vacuum


def test_legacy_vtk_and_image_vti_read_like_their_xml_and_array(tmp_path):
    from vtkmodules.vtkIOLegacy import vtkStructuredPointsWriter, vtkUnstructuredGridWriter

    mesh = hex_mesh(XS, YS, ZS)
    pts = vtk_np.vtk_to_numpy(mesh.GetPoints().GetData())
    mesh.GetPointData().AddArray(_vtk_array("T", linear(*pts.T)))
    legacy = tmp_path / "lin.vtk"
    writer = vtkUnstructuredGridWriter()
    writer.SetFileName(str(legacy))
    writer.SetInputData(mesh)
    writer.SetFileTypeToBinary()
    assert writer.Write() == 1
    xml = open_grids(write_vtu(tmp_path / "lin.vtu", mesh), resolution=20).read(["T"])
    np.testing.assert_array_equal(open_grids(legacy, resolution=20).read(["T"]).arrays["T"],
                                  xml.arrays["T"])  # fmt: skip
    values = np.arange(60, dtype=np.float32).reshape(3, 4, 5)
    image = vtkImageData()
    image.SetDimensions(4, 5, 6)
    image.SetSpacing(0.2, 0.2, 0.2)
    image.GetCellData().SetScalars(_vtk_array("temperature", _flat(values)))
    points = vtkStructuredPointsWriter()
    points.SetFileName(str(tmp_path / "img.vtk"))
    points.SetInputData(image)
    assert points.Write() == 1
    read = open_grids(tmp_path / "img.vtk").read(["temperature"])
    np.testing.assert_array_equal(read.arrays["temperature"], values)
    assert read.voxel_size_m == pytest.approx(0.2)


def test_vtu_cell_data_is_constant_over_each_cell(tmp_path):
    mesh = hex_mesh(XS, YS, ZS)
    cx, cy, cz = (np.convolve(c, [0.5, 0.5], "valid") for c in (XS, YS, ZS))
    centre = np.meshgrid(cx, cy, cz, indexing="ij")
    mesh.GetCellData().AddArray(_vtk_array("T", _flat(linear(*centre))))
    grids = open_grids(write_vtu(tmp_path / "cells.vtu", mesh), resolution=25).read(["T"])
    shape, origin, side = voxel_grid(mesh.GetBounds(), mesh.GetNumberOfCells(), 25)
    at = [origin[a] + (np.arange(shape[a]) + 0.5) * side for a in range(3)]
    cell = [
        np.searchsorted(lines, c, side="right") - 1
        for lines, c in zip((XS, YS, ZS), at, strict=True)
    ]
    ok = [
        (c >= 0) & (c < len(lines) - 1) & (np.abs(a[:, None] - lines).min(axis=1) > 1e-9)
        for c, a, lines in zip(cell, at, (XS, YS, ZS), strict=True)
    ]  # centres on a face between two cells may take either cell's value: left out
    ix, iy, iz = np.meshgrid(*(c[o] for c, o in zip(cell, ok, strict=True)), indexing="ij")
    values = grids.arrays["T"][np.ix_(*ok)]
    np.testing.assert_allclose(values, linear(cx[ix], cy[iy], cz[iz]), rtol=1e-6)


# ------------------------------------------------------------------ series


def test_pvd_series_in_time_order_renders_as_animate_frames(tmp_path):
    names = []
    for step, (_t, x0) in enumerate([(2.0, 0.7), (0.0, 0.3), (1.0, 0.5)]):
        i = np.arange(10)[:, None, None] * 0.1 + 0.05
        hot = (1700.0 * np.exp(-((i - x0) ** 2) / 0.01) * np.ones((10, 6, 6))).astype(np.float32)
        names.append(write_vti(tmp_path / f"f{step}.vti", {"temperature": hot}).name)
    pvd = tmp_path / "run.pvd"
    entries = "".join(
        f'<DataSet timestep="{t}" part="0" file="{n}"/>'
        for t, n in zip((2, 0, 1), names, strict=True)
    )
    pvd.write_text(f'<VTKFile type="Collection"><Collection>{entries}</Collection></VTKFile>')
    assert [p.name for p in expand_sequence(str(pvd))] == ["f1.vti", "f2.vti", "f0.vti"]
    out = tmp_path / "frames"
    result = runner.invoke(app, ["animate", str(pvd), "-o", str(out), "--width", "48",
                                 "--height", "32", "--backend", "cpu"])  # fmt: skip
    assert result.exit_code == 0, result.output
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == 3
    from PIL import Image

    columns = [np.asarray(Image.open(f), dtype=float).sum(axis=(0, 2)) for f in frames]
    centroid = [float((c * np.arange(c.size)).sum() / c.sum()) for c in columns]
    steps = np.diff(centroid)  # the hot slab moves along +x over time: across the image, in order
    assert np.all(np.abs(steps) > 0.5) and steps[0] * steps[1] > 0, centroid


# ------------------------------------------------------------------ units


@pytest.mark.parametrize(
    ("name", "kelvin"),
    [("T [K]", 1000.0), ("T_degC", 1273.15), ("temperature (°F)", (1000 + 459.67) * 5 / 9),
     ("T_C", 1273.15), ("heat", 1000.0)],
)  # fmt: skip
def test_temperature_units_from_the_name(tmp_path, name, kelvin):
    vti = write_vti(tmp_path / "u.vti", {name: np.full((2, 2, 2), 1000.0, np.float32)})
    values = open_grids(vti).read([name]).arrays[name]
    np.testing.assert_allclose(values, kelvin, rtol=1e-6)


def _with_field_units(path: Path, name: str, units: str) -> Path:
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    image = reader.GetOutput()
    label = vtkStringArray()
    label.SetName(f"{name}_units")
    label.InsertNextValue(units)
    image.GetFieldData().AddArray(label)
    writer = vtkXMLImageDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(image)
    writer.Write()
    return path


def test_temperature_units_from_metadata_and_ambiguous_units(tmp_path):
    vti = write_vti(tmp_path / "m.vti", {"T": np.full((2, 2, 2), 20.0, np.float32)})
    values = open_grids(_with_field_units(vti, "T", "degC")).read(["T"]).arrays["T"]
    np.testing.assert_allclose(values, 293.15, rtol=1e-6)
    clash = write_vti(tmp_path / "c.vti", {"T [K]": np.full((2, 2, 2), 20.0, np.float32)})
    source = open_grids(_with_field_units(clash, "T [K]", "degC"))
    with pytest.raises(ValueError, match=r"c\.vti: grid 'T \[K\]': ambiguous units: its name"):
        source.read(["T [K]"])
    assert vtkDataArray.UNITS_LABEL() is not None  # the info key the reader also honours


# ------------------------------------------------------------------ presets and bad input


def test_openfoam_preset_soot_volume_fraction_to_absorption(tmp_path):
    temperature = np.full((3, 3, 3), 1500.0, np.float32)
    soot = np.full((3, 3, 3), 1e-6, np.float32)
    vti = write_vti(tmp_path / "s.vti", {"T": temperature, "soot": soot})
    volume = volume_from_section(VolumeSection(path=vti, preset="openfoam"), Remap())
    kappa = 6 * np.pi * 0.26 * 1e-6 / 550e-9  # Rayleigh-limit soot absorption, 1/m
    np.testing.assert_allclose(volume.absorption_per_m, kappa, rtol=1e-5)
    np.testing.assert_allclose(volume.temperature_K, 1500.0)
    mass = write_vti(tmp_path / "y.vti", {"T": temperature, "Ysoot": soot})
    volume = volume_from_section(VolumeSection(path=mass, preset="openfoam"), Remap())
    rho = 101325.0 * 0.02897 / (8.314462618 * 1500.0)  # ideal gas, kg/m³
    np.testing.assert_allclose(volume.absorption_per_m, kappa * rho / 1800.0, rtol=1e-5)


def test_vtk_file_without_temperature_lists_its_fields(tmp_path):
    mesh = hex_mesh(XS, YS, ZS)
    mesh.GetPointData().AddArray(_vtk_array("p", np.zeros(mesh.GetNumberOfPoints())))
    mesh.GetCellData().AddArray(_vtk_array("U", np.zeros((mesh.GetNumberOfCells(), 3))))
    vtu = write_vtu(tmp_path / "cold.vtu", mesh)
    result = runner.invoke(app, ["render", str(vtu), "-o", str(tmp_path / "o.png")])
    assert result.exit_code == 2 and "Traceback" not in result.output
    (line,) = [t for t in result.output.splitlines() if t.startswith("error:")]
    assert "cold.vtu" in line and "no temperature grid" in line and "the file has: p, U" in line


@pytest.mark.parametrize("suffix", [".vtu", ".vti", ".vtk"])
def test_corrupt_vtk_file_is_one_line_naming_it(tmp_path, capfd, suffix):
    bad = tmp_path / f"bad{suffix}"
    good = write_vtu(tmp_path / "good.vtu", hex_mesh(XS, YS, ZS)).read_bytes()
    bad.write_bytes(good[: len(good) // 3] if suffix == ".vtu" else b"# vtk DataFile\nnot vtk")
    with pytest.raises(ValueError, match=rf"bad\{suffix}: not a"):
        open_grids(bad)
    assert "ERR" not in capfd.readouterr().err  # VTK's log stays off the terminal


def test_pvd_naming_a_missing_file_is_an_error(tmp_path):
    pvd = tmp_path / "gone.pvd"
    pvd.write_text('<VTKFile type="Collection"><Collection><DataSet timestep="0" file="x.vtu"/>'
                   "</Collection></VTKFile>")  # fmt: skip
    with pytest.raises(FileNotFoundError, match=r"gone\.pvd: its DataSet file .*x\.vtu"):
        open_grids(pvd)
