"""Reading .npy/.npz volume files: real files, corrupt and truncated ones (bounded fuzz)."""

from __future__ import annotations

import io

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from incandescent.api import load_volume
from incandescent.io.volumes import open_grids


def _npz_bytes() -> bytes:
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer, temperature=np.full((3, 4, 5), 1500.0), absorption=np.ones((3, 4, 5))
    )
    return buffer.getvalue()


def test_npz_round_trip_with_named_grids(tmp_path):
    path = tmp_path / "v.npz"
    path.write_bytes(_npz_bytes())
    source = open_grids(path)
    assert set(source.names) == {"temperature", "absorption"}
    vol = load_volume(path)
    assert vol.shape == (3, 4, 5) and vol.absorption_source == "grid ('absorption')"


def test_npz_with_declared_axes_is_transposed(tmp_path):
    temp = np.arange(24, dtype=float).reshape(2, 3, 4) + 300.0
    np.savez(tmp_path / "zyx.npz", temperature=np.transpose(temp, (2, 1, 0)))
    grids = open_grids(tmp_path / "zyx.npz", axes="zyx").read(["temperature"])
    np.testing.assert_array_equal(grids.arrays["temperature"], temp)
    with pytest.raises(ValueError, match="permutation of xyz"):
        open_grids(tmp_path / "zyx.npz", axes="xxz")


def test_pickled_object_arrays_are_refused(tmp_path):
    path = tmp_path / "obj.npy"
    np.save(path, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError, match="obj.npy: holds dtype object.*never unpickled"):
        load_volume(path)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_corrupted_npz_files_raise_only_value_error(tmp_path, data):
    raw = bytearray(_npz_bytes())
    if data.draw(st.booleans()):
        raw = raw[: data.draw(st.integers(0, len(raw) - 1))]  # truncated
    else:
        for _ in range(data.draw(st.integers(1, 8))):
            raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    path = tmp_path / "fuzz.npz"
    path.write_bytes(bytes(raw))
    try:
        load_volume(path)
    except ValueError as error:  # anything else (zlib.error, KeyError, ...) fails the test
        message = str(error)
    else:
        return
    assert "fuzz.npz" in message
