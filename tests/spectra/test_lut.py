"""Emission LUT (T ↦ XYZ of B(T), uniform in 1/T): interpolation error, extension, range, errors."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.spectra import EmissionLUT, blackbody_xyz, build_emission_lut
from incandescent.spectra.lut import T_MAX_K, T_MIN_K, table_size

MAX_RELATIVE_ERROR = 1e-4


@pytest.fixture(scope="module")
def lut() -> EmissionLUT:
    return build_emission_lut()


def _max_relative_error(table: EmissionLUT, temperature_K: np.ndarray) -> np.ndarray:
    """Per channel max |lookup / exact − 1|."""
    return np.abs(table.lookup(temperature_K) / blackbody_xyz(temperature_K) - 1.0).max(axis=0)


def test_default_range(lut):
    assert lut.t_min_K == T_MIN_K == 250.0
    assert lut.t_max_K == T_MAX_K == 100_000.0
    assert lut.values.shape == (lut.size, 3)
    assert not lut.values.flags.writeable


def test_table_endpoints_are_exact(lut):
    np.testing.assert_allclose(lut.values[0], blackbody_xyz(lut.t_max_K), rtol=1e-12)
    np.testing.assert_allclose(lut.values[-1], blackbody_xyz(lut.t_min_K), rtol=1e-12)
    np.testing.assert_allclose(lut.lookup(lut.t_min_K), blackbody_xyz(lut.t_min_K), rtol=1e-9)


def test_interpolation_error_260K_to_100000K(lut):
    temps = np.geomspace(260.0, 100_000.0, 20_000)
    assert (_max_relative_error(lut, temps) <= MAX_RELATIVE_ERROR).all()


def test_interpolation_error_between_nodes_near_hot_end(lut):
    """Midpoints between table entries are where linear interpolation errs most."""
    w_nodes = lut.w_min + np.arange(0, 200) / lut.inv_dw
    temps = 1.0 / (w_nodes + 0.5 / lut.inv_dw)
    assert (_max_relative_error(lut, temps) <= MAX_RELATIVE_ERROR).all()


def test_extension_above_100000K():
    lut = build_emission_lut(t_max_K=3e5)
    assert lut.t_max_K == 3e5
    temps = np.concatenate(
        [np.geomspace(260.0, 3e5, 6_000), [1.0 / (1.0 / 3e5 + 0.5 / lut.inv_dw)]]
    )
    assert (_max_relative_error(lut, temps) <= MAX_RELATIVE_ERROR).all()


def test_t_max_below_default_is_raised_to_default():
    cheap = build_emission_lut(t_max_K=5_000.0, xyz_of_temperature=lambda t: np.stack([t] * 3, -1))
    assert cheap.t_max_K == T_MAX_K


def test_lower_t_min_keeps_accuracy():
    """The table size follows the whole 1/T span, not only T_max."""
    lut = build_emission_lut(t_min_K=100.0)
    assert lut.size == table_size(T_MAX_K, 100.0) > table_size(T_MAX_K)
    temps = np.concatenate([np.geomspace(100.0, 1e5, 4_000), [1.0 / (1e-5 + 0.5 / lut.inv_dw)]])
    assert (_max_relative_error(lut, temps) <= MAX_RELATIVE_ERROR).all()


def test_zero_below_t_min(lut):
    cold = np.array([1e-3, 1.0, 100.0, 249.0, np.nextafter(250.0, 0.0)])
    assert (lut.lookup(cold) == 0.0).all()
    assert lut.lookup(0.0).tolist() == [0.0, 0.0, 0.0]
    assert (lut.lookup(250.0) > 0).all()


def test_clamped_above_t_max(lut):
    np.testing.assert_array_equal(lut.lookup(1e6), lut.values[0])
    np.testing.assert_array_equal(lut.lookup([2e5, 1e7]), lut.values[[0, 0]])


def test_luminance_monotonic_in_temperature(lut):
    temps = np.concatenate([[0.0, 100.0], np.geomspace(250.0, 1e5, 50_000), [2e5]])
    y = lut.lookup(temps)[:, 1]
    assert (np.diff(y) >= 0).all()
    hot = temps[2:-1]
    assert (np.diff(lut.lookup(hot)[:, 1]) > 0).all()


def test_lookup_shapes(lut):
    assert lut.lookup(2000.0).shape == (3,)
    assert lut.lookup(np.full((2, 5), 2000.0)).shape == (2, 5, 3)


def test_custom_tabulated_function():
    """Any T ↦ XYZ function can be tabulated (the renderer passes observer/constants this way)."""
    lut = build_emission_lut(xyz_of_temperature=lambda t: blackbody_xyz(t, "cie1964_10", "cie"))
    temps = np.geomspace(500.0, 50_000.0, 500)
    exact = blackbody_xyz(temps, "cie1964_10", "cie")
    np.testing.assert_allclose(lut.lookup(temps), exact, rtol=MAX_RELATIVE_ERROR)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"t_max_K": float("nan")}, ValueError, r"t_max_K must be a finite number > 0; got nan"),
        ({"t_max_K": -1.0}, ValueError, r"t_max_K must be a finite number > 0; got -1\.0"),
        ({"t_max_K": "1e5"}, TypeError, r"t_max_K must be a number; got str '1e5'"),
        ({"t_min_K": 0.0}, ValueError, r"t_min_K must be a finite number > 0; got 0\.0"),
        ({"t_min_K": True}, TypeError, r"t_min_K must be a number; got bool True"),
        ({"t_min_K": 2e5}, ValueError, r"t_min_K must be < t_max_K = 100000 K; got 200000\.0"),
    ],
)
def test_bad_arguments_raise(kwargs, error, match):
    with pytest.raises(error, match=match):
        build_emission_lut(**kwargs)


def test_tables_are_cached_on_disk_and_a_bad_cache_is_rebuilt(tmp_path, monkeypatch):
    from incandescent.spectra import lut as lut_module

    monkeypatch.setenv(lut_module.CACHE_ENV, str(tmp_path))
    calls = []

    def build():
        calls.append(1)
        return [build_emission_lut(xyz_of_temperature=lambda t: np.stack([t, 2 * t, 3 * t], -1))]

    first = lut_module.cached_tables("test ramp", build)
    second = lut_module.cached_tables("test ramp", build)
    assert len(calls) == 1  # the second came from disk
    np.testing.assert_array_equal(second[0].values, first[0].values)
    assert (second[0].t_min_K, second[0].t_max_K) == (first[0].t_min_K, first[0].t_max_K)
    for path in tmp_path.glob("*.npz"):
        path.write_bytes(b"not a table")  # corrupt: rebuilt, not an error
    third = lut_module.cached_tables("test ramp", build)
    assert len(calls) == 2 and np.array_equal(third[0].values, first[0].values)
    monkeypatch.setenv(lut_module.CACHE_ENV, "/proc/no-such-place")  # unwritable: still works
    assert lut_module.cached_tables("test ramp", build)[0].size == first[0].size
