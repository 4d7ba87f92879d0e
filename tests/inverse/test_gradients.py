"""The float64 adjoint of emission–absorption (``inverse.gradients``) against central finite
differences of the float64 render, voxel by voxel: temperature and absorption, optically thin
and thick, a voxel behind an opaque wall (gradient ≈ 0) and an empty voxel beside the flame
(no step skipped: a κ there would emit)."""

from __future__ import annotations

import numpy as np
import pytest
from _backends import ALL_BACKENDS

import incandescent as inc
from incandescent.inverse import gradients
from incandescent.inverse.adjoint import gradients_on
from incandescent.inverse.gradients import forward, ray_ordered

SETTINGS = inc.RenderSettings(width=6, height=5, jitter=False, step_voxels=0.5,
                              min_transmittance=1e-12)  # fmt: skip
CAMERA = inc.Camera(eye=(0.05, 0.03, 0.25), target=(0.0, 0.0, 0.0), fov_deg=30.0)
WEIGHTS = np.random.default_rng(1).uniform(0.2, 1.0, (5, 6, 3))


def _blob(kappa_peak: float, n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    x = (np.indices((n, n, n)).transpose(1, 2, 3, 0) + 0.5) / n - 0.5
    r = np.linalg.norm(x, axis=-1)
    temp = 300.0 + 1600.0 * np.exp(-((r / 0.3) ** 2))
    kappa = kappa_peak * np.exp(-((r / 0.35) ** 2))
    return temp, kappa


def _loss(temp, kappa, sodium=None) -> float:
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    if sodium is not None:
        volume = volume.with_sodium(sodium)
    _, xyz, ray = forward(volume, CAMERA, SETTINGS)
    return float(np.sum(ray_ordered(WEIGHTS)[ray] * xyz))


def _finite_difference(temp, kappa, which: str, voxel, h: float) -> float:
    grids = {"T": temp, "kappa": kappa}
    up, down = (grids[which].copy() for _ in range(2))
    up[voxel] += h
    down[voxel] -= h
    if which == "T":
        return (_loss(up, kappa) - _loss(down, kappa)) / (2 * h)
    return (_loss(temp, up) - _loss(temp, down)) / (2 * h)


@pytest.mark.parametrize("kappa_peak", [5.0, 400.0])  # τ across the blob ≈ 0.03 and ≈ 2.5
@pytest.mark.parametrize(("which", "h"), [("T", 2.0**-4), ("kappa", 2.0**-12)])  # exact in float32
def test_the_adjoint_matches_finite_differences(kappa_peak, which, h):
    """Four voxels (the centre, off-centre, a corner of the flame, the far side): the adjoint
    within 1e-4 of the float64 central difference (or 1e-9 of the largest gradient where it
    is ~0)."""
    temp, kappa = _blob(kappa_peak)
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    result = gradients(volume, CAMERA, SETTINGS, WEIGHTS)
    grid = result.temperature_K if which == "T" else result.absorption_per_m
    assert result.loss == pytest.approx(_loss(temp, kappa), rel=1e-12)
    scale = np.abs(grid).max()
    for voxel in [(4, 4, 4), (3, 5, 4), (2, 2, 6), (5, 3, 1)]:
        fd = _finite_difference(temp, kappa, which, voxel, h)
        assert grid[voxel] == pytest.approx(fd, rel=1e-4, abs=1e-9 * scale), voxel


def test_a_voxel_behind_an_opaque_wall_has_no_gradient():
    """A wall of κ = 2e4/m (τ = 200 per voxel) between the camera and a hot voxel: its
    temperature's gradient is ~0 in both the adjoint and the finite difference, while the
    same voxel without the wall has a large one."""
    temp, kappa = _blob(50.0)
    walled = kappa.copy()
    walled[:, :, 6] = 2e4  # the camera looks from +z
    for grids, expect_zero in ((walled, True), (kappa, False)):
        volume = inc.Volume.from_arrays(temp, absorption=grids, voxel_size_m=0.01)
        grad = gradients(volume, CAMERA, SETTINGS, WEIGHTS).temperature_K[(4, 4, 3)]
        fd = _finite_difference(temp, grids, "T", (4, 4, 3), 2.0**-4)
        if expect_zero:
            assert abs(grad) < 1e-12 and abs(fd) < 1e-9
        else:
            assert grad == pytest.approx(fd, rel=1e-4) and abs(grad) > 1e-6


def test_an_empty_voxel_beside_the_flame_still_gets_its_absorption_gradient():
    """κ = 0 in a hot voxel: it emits and absorbs nothing, but raising κ there would make it
    emit and shade what lies behind, so its κ gradient is not zero (here negative: the shade
    wins) and matches the one-sided finite difference (κ ≥ 0)."""
    temp, kappa = _blob(50.0)
    kappa[3, 4, 5] = 0.0
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    grad = gradients(volume, CAMERA, SETTINGS, WEIGHTS).absorption_per_m[(3, 4, 5)]
    up = kappa.copy()
    up[3, 4, 5] = 2.0**-16
    one_sided = (_loss(temp, up) - _loss(temp, kappa)) / 2.0**-16
    assert abs(grad) > 1e-3 and grad == pytest.approx(one_sided, rel=1e-3)


def test_what_the_adjoint_does_not_cover_is_one_line():
    temp, kappa = _blob(5.0)
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    with pytest.raises(ValueError, match="without an emission scale"):
        gradients(volume.replace(emission_scale=np.ones(volume.shape, np.float32)), CAMERA,
                  SETTINGS, WEIGHTS)  # fmt: skip
    with pytest.raises(ValueError, match="without an emission scale"):
        gradients_on("cpu", volume.replace(emission_scale=np.ones(volume.shape, np.float32)),
                     CAMERA, SETTINGS, WEIGHTS)  # fmt: skip
    with pytest.raises(ValueError, match="supersample 2"):
        gradients(volume, CAMERA, SETTINGS.replace(supersample=2), WEIGHTS)


@pytest.mark.parametrize("backend", [b for b in ALL_BACKENDS if b.id != "reference"])
@pytest.mark.parametrize("kappa_peak", [5.0, 400.0])
def test_the_dr_jit_replay_adjoint_is_the_float64_one(backend, kappa_peak):
    """The Dr.Jit adjoint (one more march, scatter-adds, no tape) against the float64 one:
    within 1e-3 of the largest gradient everywhere (measured 6e-5 for T, 2.4e-6 for κ), and the
    central differences within 1e-2 at the voxels above."""
    temp, kappa = _blob(kappa_peak)
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    exact = gradients(volume, CAMERA, SETTINGS, WEIGHTS)
    device = gradients_on(backend, volume, CAMERA, SETTINGS, WEIGHTS)
    for name, which, h in (("temperature_K", "T", 2.0**-4), ("absorption_per_m", "kappa",
                                                             2.0**-12)):  # fmt: skip
        ours, truth = getattr(device, name), getattr(exact, name)
        assert np.abs(ours - truth).max() < 1e-3 * np.abs(truth).max()
        for voxel in [(4, 4, 4), (3, 5, 4), (2, 2, 6)]:
            fd = _finite_difference(temp, kappa, which, voxel, h)
            assert ours[voxel] == pytest.approx(fd, rel=1e-2, abs=1e-6 * np.abs(truth).max())


@pytest.mark.parametrize("backend", [b for b in ALL_BACKENDS if b.id != "reference"])
@pytest.mark.parametrize("lines", [False, True])
def test_empty_space_skipping_keeps_the_gradient_of_hot_empty_voxels(backend, lines):
    """κ = 0 (and no sodium) over the hot half x < 8 of a 16³ blob, macrocells of 2 voxels: a
    forward render skips most of that half (the adjoint with the forward's occupancy gets 0
    there, measured), but those voxels' κ gradient is the largest of all, and raising their
    sodium would make them emit too; counting hot voxels as occupied, the adjoint gives them the
    float64 adjoint's values."""
    temp, kappa = _blob(50.0, 16)
    kappa[:8] = 0.0
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.005)
    if lines:
        volume = volume.with_sodium(np.where(np.indices(kappa.shape)[0] < 8, 0.0, 0.1))
    settings = SETTINGS.replace(macrocell_voxels=2)
    exact = gradients(volume, CAMERA, settings, WEIGHTS)
    device = gradients_on(backend, volume, CAMERA, settings, WEIGHTS)
    pairs = [(device.absorption_per_m, exact.absorption_per_m)]
    if lines:
        pairs.append((device.species["Na"], exact.species["Na"]))
    for ours, truth in pairs:
        assert np.abs(truth[:6]).max() > 0.5 * np.abs(truth).max()  # hot, empty, it matters
        np.testing.assert_allclose(ours[:6], truth[:6], atol=1e-3 * np.abs(truth).max())


def _sodium(n: int = 8) -> np.ndarray:
    """A sodium fraction rising across the blob (0.02 to 0.3)."""
    i = np.indices((n, n, n))[0]
    return (0.02 + 0.28 * i / (n - 1)).astype(np.float32)


def _sodium_difference(values: dict, name: str, voxel, h: float) -> float:
    """The central difference of the loss in grid ``name`` (T, kappa or Na) at ``voxel``."""
    up, down = values[name].copy(), values[name].copy()
    up[voxel] += h
    down[voxel] -= h
    losses = [_loss(v["T"], v["kappa"], v["Na"]) for v in ({**values, name: g} for g in (up, down))]
    return (losses[0] - losses[1]) / (2 * h)


SODIUM_STEPS = (("T", 2.0**-4), ("kappa", 2.0**-12), ("Na", 2.0**-12))  # exact in float32


def _sodium_gradients(result) -> dict[str, np.ndarray]:
    return {"T": result.temperature_K, "kappa": result.absorption_per_m,
            "Na": result.species["Na"]}  # fmt: skip


@pytest.mark.parametrize("kappa_peak", [5.0, 400.0])
def test_the_adjoint_of_a_flame_with_sodium_lines_matches_finite_differences(kappa_peak):
    """With species lines (η = κS + f·Φ(T), weight (1 − e^{−κΔs})/κ): the gradients with
    respect to T, κ and the sodium fraction within 1e-4 of central differences, thin and
    thick."""
    temp, kappa = _blob(kappa_peak)
    values = {"T": temp, "kappa": kappa, "Na": _sodium()}
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    result = gradients(volume.with_sodium(values["Na"]), CAMERA, SETTINGS, WEIGHTS)
    assert result.loss == pytest.approx(_loss(temp, kappa, values["Na"]), rel=1e-12)
    grids = _sodium_gradients(result)
    for voxel in [(4, 4, 4), (2, 2, 6), (5, 3, 1)]:
        for name, h in SODIUM_STEPS:
            fd = _sodium_difference(values, name, voxel, h)
            scale = np.abs(grids[name]).max()
            assert grids[name][voxel] == pytest.approx(fd, rel=1e-4, abs=1e-9 * scale), (
                name,
                voxel,
            )


@pytest.mark.parametrize("backend", [b for b in ALL_BACKENDS if b.id != "reference"])
@pytest.mark.parametrize("kappa_peak", [5.0, 400.0])
def test_the_dr_jit_adjoint_of_a_flame_with_sodium_lines(backend, kappa_peak):
    """The Dr.Jit replay adjoint with lines (the weight form, its own dw/dκ series) against the
    float64 one: within 1e-3 of the largest gradient for T, κ and the sodium fraction (measured
    6e-5, 2.4e-6, 2.2e-6), and the central differences within 1e-2."""
    temp, kappa = _blob(kappa_peak)
    values = {"T": temp, "kappa": kappa, "Na": _sodium()}
    volume = inc.Volume.from_arrays(temp, absorption=kappa, voxel_size_m=0.01)
    volume = volume.with_sodium(values["Na"])
    exact = _sodium_gradients(gradients(volume, CAMERA, SETTINGS, WEIGHTS))
    device = gradients_on(backend, volume, CAMERA, SETTINGS, WEIGHTS)
    assert device.loss == pytest.approx(_loss(temp, kappa, values["Na"]), rel=1e-5)
    for name, h in SODIUM_STEPS:
        ours, truth = _sodium_gradients(device)[name], exact[name]
        scale = np.abs(truth).max()
        assert np.abs(ours - truth).max() < 1e-3 * scale, name
        for voxel in [(4, 4, 4), (2, 2, 6)]:
            fd = _sodium_difference(values, name, voxel, h)
            assert ours[voxel] == pytest.approx(fd, rel=1e-2, abs=1e-6 * scale), (name, voxel)
