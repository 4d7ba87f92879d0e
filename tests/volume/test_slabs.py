"""Host passes split into slabs on threads (``_parallel``) give the serial results exactly."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from incandescent import _parallel as slabs
from incandescent.volume import Volume, build_macrocells
from incandescent.volume import scan as scan_module


@pytest.fixture
def three_threads(monkeypatch):
    """Every grid split into 3 slabs on threads, however small."""
    monkeypatch.setattr(slabs, "MIN_PARALLEL_VOXELS", 0)
    monkeypatch.setattr(slabs, "workers", lambda: 3)


@pytest.mark.parametrize(("n", "parts", "align"), [(17, 3, 8), (256, 2, 8), (5, 4, 1), (7, 3, 8)])
def test_bounds_cover_the_axis_in_aligned_slabs(n, parts, align):
    ranges = slabs.bounds(n, parts, align)
    assert ranges[0][0] == 0 and ranges[-1][1] == n
    assert all(hi == lo for (_, hi), (lo, _) in zip(ranges, ranges[1:], strict=False))
    assert all(lo % align == 0 and hi > lo for lo, hi in ranges)
    assert len(ranges) == min(parts, -(-n // align))


def _brute_macrocells(kappa: np.ndarray, s: int) -> np.ndarray:
    """Cell c: max over voxels c·s − 1 … (c + 1)·s on each axis, clamped to the grid."""
    cells = [-(-n // s) for n in kappa.shape]
    out = np.zeros(cells, dtype=np.float32)
    for c in np.ndindex(*cells):
        box = tuple(slice(max(i * s - 1, 0), (i + 1) * s + 1) for i in c)
        out[c] = kappa[box].max()
    return out


@pytest.mark.parametrize("shape", [(17, 9, 23), (24, 8, 8), (3, 5, 4), (1, 12, 7)])
@pytest.mark.parametrize("s", [8, 4, 3, 1])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_macrocells_in_slabs_are_the_definition(three_threads, shape, s, dtype):
    rng = np.random.default_rng(sum(shape) + s)
    kappa = np.where(rng.random(shape) > 0.85, rng.random(shape), 0.0).astype(dtype)
    cells = build_macrocells(kappa, s).max_absorption
    assert cells.dtype == np.float32
    np.testing.assert_array_equal(cells, _brute_macrocells(kappa, s))


@pytest.mark.parametrize("kappa_values", [(0.0, 2.5), (0.0, 2.5, 1.0), (0.0,), (3.0,)])
def test_volume_scans_in_slabs(three_threads, kappa_values):
    """The hottest voxel and the two-valued κ test read slab by slab: the whole-grid answers."""
    rng = np.random.default_rng(len(kappa_values))
    kappa = rng.choice(np.array(kappa_values, dtype=np.float32), size=(11, 6, 7))
    temperature = rng.uniform(300, 2500, size=(11, 6, 7)).astype(np.float32)
    volume = Volume.from_arrays(temperature, kappa.copy())
    volume = volume.replace(medium=None)  # nothing known from construction: scanned
    assert volume.max_temperature_K == float(temperature.max())
    positive = np.unique(kappa[kappa > 0])
    expected = float(positive[0]) if positive.size == 1 else None
    assert volume.two_valued_absorption_per_m == expected


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_positive_range_is_the_masked_minimum_and_the_maximum(monkeypatch, dtype):
    """The scan over float32 bits in chunks (a chunk smaller than the grid here) equals
    min(where > 0) and max, with zeros, −0, subnormals and no positive value at all."""
    monkeypatch.setattr(scan_module, "SCAN_CHUNK", 7)
    rng = np.random.default_rng(3)
    values = np.where(rng.random(50) > 0.5, rng.uniform(0.1, 9.0, 50), 0.0).astype(dtype)
    values[[3, 11]] = -0.0
    values[20] = np.finfo(dtype).smallest_subnormal * 3
    expected = (float(values.min(where=values > 0, initial=np.inf)), float(values.max()))
    assert scan_module.positive_range(values) == expected
    assert scan_module.positive_range(np.zeros(9, dtype)) == (np.inf, 0.0)
    assert scan_module.positive_range(np.full(9, -0.0, dtype)) == (np.inf, 0.0)


def test_two_valued_scan_stops_at_a_graded_chunk(monkeypatch):
    """A second positive κ ends the scan (and tells the other slabs); one κ₀ scans everything."""
    monkeypatch.setattr(scan_module, "SCAN_CHUNK", 4)
    graded, two = threading.Event(), threading.Event()
    values = np.array([0, 2, 0, 3] + [0, 0, 0, 0.5] * 3, dtype=np.float32)
    assert scan_module.positive_range(values, graded) == (2.0, 3.0)  # the first chunk's
    assert graded.is_set()
    assert scan_module.positive_range(np.tile(values[:3], 5), two) == (2.0, 2.0)
    assert not two.is_set()
    assert scan_module.positive_range(values, two) == (2.0, 3.0) and two.is_set()


def test_kappa_two_valued_in_each_slab_but_not_across_them_is_graded(three_threads):
    kappa = np.zeros((12, 4, 4), dtype=np.float32)
    temperature = np.full(kappa.shape, 1500.0)
    kappa[:4, 0, 0], kappa[8:, 1, 1] = 2.5, 1.0  # one κ in the first slab, another in the last
    graded = Volume.from_arrays(temperature, kappa).replace(medium=None)  # nothing known, scanned
    assert graded.two_valued_absorption_per_m is None
    kappa[8:, 1, 1] = 2.5
    two_valued = Volume.from_arrays(temperature, kappa).replace(medium=None)
    assert two_valued.two_valued_absorption_per_m == 2.5


@pytest.mark.parametrize("where", ["random", "none", "corner", "one"])
def test_content_bounds_in_slabs_are_the_box_of_the_absorbing_voxels(three_threads, where):
    """The box from per-layer and across-layer maxima equals the box of the voxels with κ > 0
    (from their indices), −0 counting as no absorption; the whole box when none absorb."""
    rng = np.random.default_rng(len(where))
    shape = (13, 6, 9)
    kappa = np.zeros(shape, dtype=np.float32)
    if where == "random":
        kappa[2:11, 1:4, 3:9] = rng.uniform(0.0, 2.0, (9, 3, 6)) * (rng.random((9, 3, 6)) > 0.7)
        kappa[0, 0, 0] = -0.0
    elif where == "corner":
        kappa[-1, -1, -1] = 1.0
    elif where == "one":
        kappa[6, 2, 4] = 3e-30
    volume = Volume.from_arrays(np.full(shape, 1500.0), kappa, voxel_size_m=0.5, origin_m=(1, 2, 3))
    lo, hi = volume.content_bounds_m
    absorbing = np.argwhere(kappa > 0)
    if absorbing.size == 0:
        expected = volume.bounds_m
    else:
        origin = np.array([1.0, 2.0, 3.0])
        first, last = absorbing.min(axis=0), absorbing.max(axis=0)
        expected = (origin + first * 0.5, origin + (last + 1) * 0.5)
    np.testing.assert_array_equal(lo, expected[0])
    np.testing.assert_array_equal(hi, expected[1])
