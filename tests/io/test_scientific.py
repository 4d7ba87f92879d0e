"""HDF5 and NetCDF input (io.scientific): real files written with h5py / xarray and read back —
values, axis reordering, unit conversion, placement from attributes and coordinates, errors."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from incandescent.io import scientific
from incandescent.io.scientific import open_hdf5, open_netcdf, open_scientific, to_kelvin
from incandescent.io.volumes import GridSource

SHAPE = (4, 5, 6)  # x, y, z: all different, so a wrong transposition cannot pass


def xyz_field(dtype=np.float32) -> np.ndarray:
    """A field whose value tells its voxel: i + 10 j + 100 k at x=i, y=j, z=k."""
    i, j, k = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    return (i + 10 * j + 100 * k).astype(dtype)


def stored(a: np.ndarray, axes: str) -> np.ndarray:
    """``a`` (x, y, z) laid out with ``axes`` naming each stored dimension."""
    return np.transpose(a, ["xyz".index(c) for c in axes])


@pytest.fixture
def h5py():
    return pytest.importorskip("h5py")


@pytest.fixture
def xr():
    pytest.importorskip("h5netcdf")
    return pytest.importorskip("xarray")


def write_h5(h5py, path, datasets: dict, root_attrs: dict | None = None):
    with h5py.File(path, "w") as f:
        f.attrs.update(root_attrs or {})
        for name, (data, attrs) in datasets.items():
            f.create_dataset(name, data=data).attrs.update(attrs)
    return path


# ------------------------------------------------------------------ HDF5


def test_hdf5_lists_3d_numeric_datasets_by_path_and_reads_xyz_values(h5py, tmp_path):
    path = write_h5(
        h5py,
        tmp_path / "run.h5",
        {
            "fields/temperature": (xyz_field(), {}),
            "fields/density": (xyz_field(np.float64), {}),
            "slice": (np.zeros((3, 3)), {}),
            "labels": (np.zeros((2, 2, 2), dtype=bool), {}),
        },
    )
    source = open_hdf5(path)
    assert isinstance(source, GridSource)
    assert source.names == ("fields/density", "fields/temperature")
    grids = source.read(["fields/temperature", "fields/density"])
    t, rho = grids.arrays["fields/temperature"], grids.arrays["fields/density"]
    np.testing.assert_array_equal(t, xyz_field())
    assert (t.dtype, rho.dtype) == (np.float32, np.float64)
    assert grids.origin_m is None and grids.voxel_size_m is None
    assert source.notes["fields/temperature"].startswith("axes xyz (default)")


@pytest.mark.parametrize(
    ("where", "name", "value"),
    [
        ("dataset", "axes", "zyx"),
        ("dataset", "dimension_labels", [b"z", b"y", b"x"]),
        ("dataset", "axis_order", "Z,Y,X"),
        ("root", "axes", "zyx"),
    ],
)
def test_hdf5_axes_attribute_reorders_into_xyz(h5py, tmp_path, where, name, value):
    attrs = {name: value}
    path = write_h5(
        h5py,
        tmp_path / "zyx.hdf5",
        {"temperature": (stored(xyz_field(), "zyx"), attrs if where == "dataset" else {})},
        attrs if where == "root" else None,
    )
    source = open_hdf5(path)
    values = source.read(["temperature"]).arrays["temperature"]
    np.testing.assert_array_equal(values, xyz_field())
    assert values.flags.c_contiguous
    assert f"axes zyx (attribute {name!r})" in source.notes["temperature"]


@pytest.mark.parametrize("axes", ["zyx", "yzx", "xzy"])
def test_hdf5_axes_argument_declares_the_order(h5py, tmp_path, axes):
    path = write_h5(h5py, tmp_path / "a.h5", {"t": (stored(xyz_field(), axes), {})})
    np.testing.assert_array_equal(open_hdf5(path, axes).read(["t"]).arrays["t"], xyz_field())


def test_hdf5_axes_argument_contradicting_the_attribute_is_an_error(h5py, tmp_path):
    path = write_h5(h5py, tmp_path / "a.h5", {"t": (xyz_field(), {"axes": "xyz"})})
    source = open_hdf5(path, axes="zyx")
    assert "unreadable" in source.notes["t"]
    with pytest.raises(ValueError, match=r"a\.h5: grid 't': attribute 'axes' says axes 'xyz'"):
        source.read(["t"])
    assert open_hdf5(path, axes="xyz").read(["t"]).arrays["t"].shape == SHAPE


@pytest.mark.parametrize(
    ("units", "kelvin"),
    [
        ("K", 300.0),
        ("kelvin", 300.0),
        ("degC", 300.0 + 273.15),
        ("°C", 300.0 + 273.15),
        ("degree_Celsius", 300.0 + 273.15),
        ("degF", (300.0 + 459.67) * 5 / 9),
        ("kg/m^3", 300.0),
    ],
)
def test_hdf5_units_attribute_converts_temperature_to_kelvin(h5py, tmp_path, units, kelvin):
    data = np.full(SHAPE, 300, dtype=np.int16)
    path = write_h5(h5py, tmp_path / "t.h5", {"t": (data, {"units": units})})
    source = open_hdf5(path)
    values = source.read(["t"]).arrays["t"]
    assert values.dtype == np.float32
    np.testing.assert_allclose(values, kelvin, rtol=1e-6)
    assert f"units {units!r}" in source.notes["t"]
    assert ("converted to K" in source.notes["t"]) == (kelvin != 300.0)


def test_hdf5_placement_attributes_on_a_group(h5py, tmp_path):
    path = tmp_path / "placed.h5"
    with h5py.File(path, "w") as f:
        group = f.create_group("frame_0010")
        group.attrs.update({"voxel_size_m": 0.25, "origin_m": [1.0, -2.0, 0.5]})
        group.create_dataset("temperature", data=xyz_field())
        group.create_dataset("absorption", data=xyz_field())
    grids = open_hdf5(path).read(["frame_0010/temperature", "frame_0010/absorption"])
    assert grids.voxel_size_m == 0.25 and grids.origin_m == (1.0, -2.0, 0.5)


@pytest.mark.parametrize(
    ("attrs", "message"),
    [
        ({"voxel_size_m": [0.1, 0.2, 0.1]}, "voxels are not cubes"),
        ({"voxel_size_m": -1.0}, "voxel_size_m must be one or three positive numbers"),
        ({"origin_m": [0.0, 1.0]}, "origin_m must be three finite numbers"),
        ({"voxel_size_m": "small"}, "attribute 'voxel_size_m' is not numeric"),
        ({"axes": "xy"}, "attribute 'axes' must be a permutation of 'xyz'"),
    ],
)
def test_hdf5_bad_attributes_are_errors_naming_file_grid_and_attribute(
    h5py, tmp_path, attrs, message
):
    path = write_h5(h5py, tmp_path / "bad.h5", {"t": (xyz_field(), attrs)})
    with pytest.raises(ValueError, match=rf"bad\.h5: grid 't': {message}"):
        open_hdf5(path).read(["t"])


def test_hdf5_errors_name_the_file_and_the_problem(h5py, tmp_path):
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    with pytest.raises(ValueError, match=r"notes\.h5: not an HDF5 file"):
        open_hdf5(text)
    with pytest.raises(FileNotFoundError, match=r"missing\.h5: no such volume file"):
        open_hdf5(tmp_path / "missing.h5")
    flat = write_h5(h5py, tmp_path / "flat.h5", {"image": (np.zeros((2, 3)), {})})
    with pytest.raises(ValueError, match=r"flat\.h5: no 3-D numeric dataset; .*image \(2-D"):
        open_hdf5(flat)
    good = write_h5(h5py, tmp_path / "g.h5", {"a/t": (xyz_field(), {}), "b": (np.ones(SHAPE), {})})
    with pytest.raises(ValueError, match=r"g\.h5: no grid named 'heat'; the file has: a/t, b"):
        open_hdf5(good).read(["heat"])
    with pytest.raises(ValueError, match=r"g\.h5: the axes argument must be a permutation"):
        open_hdf5(good, axes="xyy")


def test_hdf5_grids_of_different_shapes_cannot_be_read_together(h5py, tmp_path):
    path = write_h5(
        h5py, tmp_path / "m.h5", {"t": (xyz_field(), {}), "k": (np.ones((2, 2, 2)), {})}
    )
    with pytest.raises(ValueError, match=r"m\.h5: grids differ in shape .*t \(4, 5, 6\)"):
        open_hdf5(path).read(["t", "k"])


def test_truncated_hdf5_is_a_clear_error(h5py, tmp_path):
    path = write_h5(h5py, tmp_path / "full.h5", {"t": (np.ones((16, 16, 16)), {})})
    cut = tmp_path / "cut.h5"
    cut.write_bytes(path.read_bytes()[:3000])
    with pytest.raises(ValueError, match=r"cut\.h5: "):
        open_hdf5(cut).read(["t"])


def test_missing_library_says_how_to_install(monkeypatch, tmp_path):
    path = tmp_path / "x.h5"
    path.write_bytes(b"\x89HDF\r\n\x1a\n")
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(ValueError, match=r"x\.h5: .*'h5py'.*pip install 'incandescent\[science\]'"):
        open_hdf5(path)


# ------------------------------------------------------------------ NetCDF


def write_nc(xr, path, data: np.ndarray, dims=("z", "y", "x"), coords=None, attrs=None):
    """One variable ``temperature`` (and a 1-D ``time``) written as NetCDF-4."""
    variables = {"temperature": (dims, data, attrs or {}), "time": (("t",), np.arange(3.0))}
    xr.Dataset(variables, coords=coords or {}).to_netcdf(path, engine="h5netcdf")
    return path


def centres(first: float, step: float, n: int) -> np.ndarray:
    return first + step * np.arange(n)


def test_netcdf_reads_zyx_variable_into_xyz_with_placement_from_coordinates(xr, tmp_path):
    coords = {
        "x": ("x", centres(1.0, 0.1, SHAPE[0]), {"units": "m"}),
        "y": ("y", centres(-2.0, 0.1, SHAPE[1])),
        "z": ("z", centres(0.5, 0.1, SHAPE[2])),
    }
    path = write_nc(xr, tmp_path / "run.nc", stored(xyz_field(), "zyx"), coords=coords)
    source = open_netcdf(path)
    assert source.names == ("temperature",)
    grids = source.read(["temperature"])
    np.testing.assert_array_equal(grids.arrays["temperature"], xyz_field())
    assert grids.voxel_size_m == pytest.approx(0.1)
    np.testing.assert_allclose(grids.origin_m, (0.95, -2.05, 0.45))
    assert source.notes["temperature"].startswith("axes zyx (dimension names)")


def test_netcdf_decreasing_coordinate_flips_its_axis(xr, tmp_path):
    coords = {
        "x": ("x", centres(1.0, 0.5, SHAPE[0])),
        "y": ("y", centres(3.0, -0.5, SHAPE[1])),  # 3.0, 2.5, ... 1.0
        "z": ("z", centres(0.0, 0.5, SHAPE[2])),
    }
    data = stored(xyz_field(), "xyz")[:, ::-1, :]
    path = write_nc(xr, tmp_path / "down.nc", data, dims=("x", "y", "z"), coords=coords)
    source = open_netcdf(path)
    grids = source.read(["temperature"])
    np.testing.assert_array_equal(grids.arrays["temperature"], xyz_field())
    np.testing.assert_allclose(grids.origin_m, (0.75, 0.75, -0.25))
    assert "decreasing coordinates: y flipped" in source.notes["temperature"]


def test_netcdf_units_celsius_and_centimetre_coordinates(xr, tmp_path):
    coords = {
        d: (d, centres(0.0, 2.0, n), {"units": "cm"}) for d, n in zip("xyz", SHAPE, strict=True)
    }
    data = np.full(SHAPE, 25.0, dtype=np.float32)
    path = write_nc(
        xr, tmp_path / "c.nc", data, dims=("x", "y", "z"), coords=coords, attrs={"units": "°C"}
    )
    source = open_netcdf(path)
    grids = source.read(["temperature"])
    np.testing.assert_allclose(grids.arrays["temperature"], 298.15, rtol=1e-7)
    assert grids.voxel_size_m == pytest.approx(0.02)
    np.testing.assert_allclose(grids.origin_m, (-0.01,) * 3)
    assert "converted to K" in source.notes["temperature"]


def test_netcdf_without_coordinates_has_no_placement_and_non_length_coordinates_are_noted(
    xr, tmp_path
):
    bare = write_nc(xr, tmp_path / "bare.nc", xyz_field(), dims=("x", "y", "z"))
    grids = open_netcdf(bare).read(["temperature"])
    assert grids.origin_m is None and grids.voxel_size_m is None
    coords = {"lon": ("lon", centres(0.0, 1.0, SHAPE[0]), {"units": "degrees_east"})}
    geo = write_nc(xr, tmp_path / "geo.nc", xyz_field(), dims=("lon", "lat", "z"), coords=coords)
    source = open_netcdf(geo, axes="xyz")
    assert "not a length: no placement" in source.notes["temperature"]
    grids = source.read(["temperature"])
    np.testing.assert_array_equal(grids.arrays["temperature"], xyz_field())
    assert grids.voxel_size_m is None


def test_netcdf_dimension_names_other_than_xyz_need_the_axes_argument(xr, tmp_path):
    path = write_nc(xr, tmp_path / "h.nc", stored(xyz_field(), "zyx"), dims=("h", "b", "a"))
    with pytest.raises(
        ValueError, match=r"h\.nc: grid 'temperature': dimensions \('h', 'b', 'a'\)"
    ):
        open_netcdf(path).read(["temperature"])
    values = open_netcdf(path, axes="zyx").read(["temperature"]).arrays["temperature"]
    np.testing.assert_array_equal(values, xyz_field())


def test_netcdf_cf_axis_attributes_name_the_axes(xr, tmp_path):
    coords = {
        "height": ("height", centres(0.0, 2.0, SHAPE[2]), {"axis": "Z", "units": "km"}),
        "north": ("north", centres(0.0, 2.0, SHAPE[1]), {"axis": "Y", "units": "km"}),
        "east": ("east", centres(0.0, 2.0, SHAPE[0]), {"axis": "X", "units": "km"}),
    }
    data = stored(xyz_field(), "zyx")
    path = write_nc(xr, tmp_path / "cf.nc", data, dims=("height", "north", "east"), coords=coords)
    source = open_netcdf(path)
    grids = source.read(["temperature"])
    np.testing.assert_array_equal(grids.arrays["temperature"], xyz_field())
    assert grids.voxel_size_m == pytest.approx(2000.0)
    assert "axes zyx (coordinate 'axis' attributes)" in source.notes["temperature"]


@pytest.mark.parametrize(
    ("coords", "message"),
    [
        ({"x": ("x", [0.0, 0.1, 0.2, 0.4])}, r"coordinate 'x' is not uniformly spaced"),
        (
            {"x": ("x", centres(0.0, 0.1, 4)), "y": ("y", centres(0.0, 0.2, 5))},
            r"voxels are not cubes \(coordinate spacing x 0\.1 m, y 0\.2 m\)",
        ),
    ],
)
def test_netcdf_non_uniform_or_non_cubic_coordinates_are_errors(xr, tmp_path, coords, message):
    path = write_nc(xr, tmp_path / "bad.nc", xyz_field(), dims=("x", "y", "z"), coords=coords)
    with pytest.raises(ValueError, match=rf"bad\.nc: grid 'temperature': {message}"):
        open_netcdf(path).read(["temperature"])


def test_netcdf_errors_name_the_file_and_the_problem(xr, tmp_path):
    path = write_nc(xr, tmp_path / "ok.nc", xyz_field(), dims=("x", "y", "z"))
    with pytest.raises(
        ValueError, match=r"ok\.nc: no grid named 'heat'; the file has: temperature"
    ):
        open_netcdf(path).read(["heat"])
    with pytest.raises(
        ValueError, match=r"ok\.nc: grid 'temperature': dimension names say axes 'xyz'"
    ):
        open_netcdf(path, axes="zyx").read(["temperature"])
    flat = tmp_path / "flat.nc"
    xr.Dataset({"image": (("y", "x"), np.zeros((2, 3)))}).to_netcdf(flat, engine="h5netcdf")
    with pytest.raises(ValueError, match=r"flat\.nc: no numeric variable with 3 dim.*image"):
        open_netcdf(flat)
    junk = tmp_path / "junk.nc"
    junk.write_text("hello")
    with pytest.raises(ValueError, match=r"junk\.nc: not a NetCDF file"):
        open_netcdf(junk)


def test_netcdf3_without_a_classic_reader_says_what_to_do(tmp_path, monkeypatch):
    path = tmp_path / "classic.nc"
    path.write_bytes(b"CDF\x01" + bytes(28))
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda m: None if m in ("netCDF4", "scipy") else real(m)
    )
    monkeypatch.setitem(sys.modules, "xarray", object())  # the engine check comes first
    with pytest.raises(ValueError, match=r"classic\.nc: a NetCDF-3 .*pip install netCDF4"):
        open_netcdf(path)


def test_open_scientific_dispatches_on_suffix(h5py, xr, tmp_path):
    h5 = write_h5(h5py, tmp_path / "a.hdf5", {"t": (xyz_field(), {})})
    nc = write_nc(xr, tmp_path / "a.nc", xyz_field(), dims=("x", "y", "z"))
    assert open_scientific(h5).names == ("t",)
    assert open_scientific(nc).names == ("temperature",)
    with pytest.raises(ValueError, match=r"a\.npz: not an HDF5 or NetCDF file name"):
        open_scientific(tmp_path / "a.npz")


def test_to_kelvin_keeps_kelvin_arrays_and_converts_integers_to_float():
    values = np.array([0, 100], dtype=np.int32)
    converted, note = to_kelvin(values, "Celsius")
    np.testing.assert_allclose(converted, [273.15, 373.15])
    assert converted.dtype == np.float64 and "converted to K" in (note or "")
    kelvin = np.ones(3, np.float32)
    assert to_kelvin(kelvin, "K")[0] is kelvin
    assert to_kelvin(kelvin, None) == (kelvin, None)
    assert set(scientific.TEMPERATURE_UNITS.values()) == {
        (0.0, 1.0),
        (273.15, 1.0),
        (459.67, 5 / 9),
    }


# ------------------------------------------------------------------ bounded fuzz


@pytest.fixture(scope="module")
def valid_files(tmp_path_factory):
    h5py = pytest.importorskip("h5py")
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    folder = tmp_path_factory.mktemp("fuzz")
    h5 = folder / "valid.h5"
    with h5py.File(h5, "w") as f:
        group = f.create_group("fields")
        group.attrs.update({"voxel_size_m": 0.1, "origin_m": [0.0, 0.0, 0.0]})
        group.create_dataset("t", data=xyz_field(), compression="gzip").attrs.update(
            {"units": "degC", "axes": "zyx"}
        )
    coords = {
        d: (d, centres(0.0, 0.1, n), {"units": "m"}) for d, n in zip("xyz", SHAPE, strict=True)
    }
    nc = write_nc(xr, folder / "valid.nc", xyz_field(), dims=("x", "y", "z"), coords=coords)
    return {".h5": (h5.read_bytes(), open_hdf5), ".nc": (nc.read_bytes(), open_netcdf)}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(suffix=st.sampled_from([".h5", ".nc"]), data=st.data())
def test_corrupted_files_read_or_raise_value_error(valid_files, tmp_path_factory, suffix, data):
    raw, opener = valid_files[suffix]
    flips = data.draw(
        st.lists(st.tuples(st.integers(0, len(raw) - 1), st.integers(0, 255)), max_size=8)
    )
    cut = data.draw(st.integers(8, len(raw)))
    corrupted = bytearray(raw)
    for at, byte in flips:
        corrupted[at] = byte
    path = tmp_path_factory.getbasetemp() / f"fuzzed{suffix}"
    path.write_bytes(bytes(corrupted[:cut]))
    message = None
    try:
        source = opener(path)
        source.read(source.names)
    except ValueError as error:
        message = str(error)
    assert message is None or message.startswith(f"{path}: ")
