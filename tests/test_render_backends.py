"""Backend parity (cpu and cuda vs the float64 reference), empty-space skipping, selection."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent import scenes
from incandescent.camera import Camera
from incandescent.render import RenderSettings, render
from incandescent.render.backends import BackendUnavailable, available_backends, resolve_backend
from incandescent.render.backends.jit import cuda_problem
from incandescent.volume import Volume, build_macrocells


def _random_volume(seed: int, shape=(7, 9, 6)) -> Volume:
    rng = np.random.default_rng(seed)
    temp = rng.uniform(600.0, 3200.0, shape)
    kappa = rng.uniform(0.0, 6.0, shape) * (rng.random(shape) > 0.3)
    scale = rng.uniform(0.5, 2.0, shape)
    return Volume.from_arrays(
        temp,
        absorption=kappa,
        emission_scale=scale,
        voxel_size_m=0.05,
        origin_m=(-0.2, -0.1, -0.15),
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jit_backend_matches_reference(jit_backend, seed):
    vol = _random_volume(seed)
    cam = Camera(eye=(0.7, 0.5, 0.9), target=(0.0, 0.1, 0.0), fov_deg=45.0)
    s = RenderSettings(width=23, height=17, supersample=2, step_voxels=0.37, seed=seed)
    ref = render(vol, cam, s, backend="reference")
    fast = render(vol, cam, s, backend=jit_backend)
    assert ref.xyz.max() > 0
    np.testing.assert_allclose(fast.xyz, ref.xyz, rtol=1e-4, atol=1e-6 * ref.xyz.max())
    np.testing.assert_allclose(fast.transmittance, ref.transmittance, rtol=1e-4, atol=1e-6)
    assert fast.metadata["samples"] <= ref.metadata["samples"]
    assert fast.metadata["backend"] == jit_backend


def test_skipping_leaves_image_unchanged_and_saves_samples(jit_backend):
    vol = scenes.sparse_flame(48, flame_fraction=0.3)
    s = RenderSettings(width=40, height=32, macrocell_voxels=8)
    dense = render(vol, settings=s.replace(skip_empty=False), backend=jit_backend)
    skipped = render(vol, settings=s, backend=jit_backend)
    assert dense.xyz.max() > 0
    np.testing.assert_allclose(skipped.xyz, dense.xyz, rtol=1e-5, atol=1e-7 * dense.xyz.max())
    np.testing.assert_allclose(skipped.transmittance, dense.transmittance, rtol=1e-6, atol=1e-7)
    assert skipped.metadata["samples"] < dense.metadata["samples"] / 3


@pytest.mark.parametrize("cell", [1, 3, 8, 16])
def test_skipping_is_exact_for_any_macrocell_size(cell):
    vol = _random_volume(5, shape=(12, 10, 14))
    s = RenderSettings(width=15, height=11, macrocell_voxels=cell)
    dense = render(vol, settings=s.replace(skip_empty=False), backend="cpu")
    skipped = render(vol, settings=s, backend="cpu")
    np.testing.assert_allclose(skipped.xyz, dense.xyz, rtol=1e-5, atol=1e-7 * dense.xyz.max())


def test_macrocells_include_a_one_voxel_border():
    kappa = np.zeros((16, 16, 16), dtype=np.float32)
    kappa[8, 3, 3] = 1.0  # first voxel of cell x=1; cell x=0 must see it through its border
    cells = build_macrocells(kappa, 8)
    assert cells.shape == (2, 2, 2)
    assert cells.max_absorption[0, 0, 0] == 1.0
    assert cells.max_absorption[1, 0, 0] == 1.0
    assert cells.max_absorption[0, 1, 0] == 0.0


def test_renders_are_reproducible_and_seeded(jit_backend):
    vol = scenes.plume(24)
    s = RenderSettings(width=16, height=16)
    a, b = (render(vol, settings=s, backend=jit_backend).xyz for _ in range(2))
    np.testing.assert_array_equal(a, b)
    c = render(vol, settings=s.replace(seed=7), backend=jit_backend).xyz
    assert not np.array_equal(a, c)
    np.testing.assert_allclose(c.sum(), a.sum(), rtol=0.05)


def test_backend_selection_explicit_env_and_errors(monkeypatch):
    assert resolve_backend("reference") == "reference"
    monkeypatch.setenv("INCANDESCENT_BACKEND", "reference")
    assert resolve_backend("auto") == "reference"
    assert resolve_backend(None) == "reference"
    assert resolve_backend("cpu") == "cpu"  # explicit beats the environment
    monkeypatch.setenv("INCANDESCENT_BACKEND", "gpu")
    with pytest.raises(ValueError, match="environment INCANDESCENT_BACKEND 'gpu'"):
        resolve_backend("auto")
    monkeypatch.delenv("INCANDESCENT_BACKEND")
    with pytest.raises(ValueError, match="unknown backend 'vulkan'; expected one of"):
        resolve_backend("vulkan")
    assert resolve_backend("auto") == available_backends()[0]


@pytest.mark.skipif(cuda_problem() is None, reason="a GPU is present")
def test_cuda_unavailable_is_a_clear_error():
    with pytest.raises(BackendUnavailable, match="backend 'cuda' is unavailable: no NVIDIA GPU"):
        resolve_backend("cuda")
    assert "cuda" not in available_backends()


class _FakeDrJit:
    """Stands in for drjit to exercise the libLLVM checks without the real library state."""

    class JitBackend:
        LLVM, CUDA = "llvm", "cuda"

    def __init__(self, has_llvm: bool, version=(19, 1, 7)):
        self._has_llvm, self._version = has_llvm, version

        class detail:  # noqa: N801 - mirrors drjit.detail
            @staticmethod
            def llvm_version():
                return version

        self.detail = detail

    def has_backend(self, backend):
        return self._has_llvm if backend == "llvm" else False


@pytest.mark.parametrize(
    ("fake", "expected"),
    [
        (_FakeDrJit(False), "Dr.Jit found no libLLVM; the CPU backend needs a shared libLLVM"),
        (_FakeDrJit(True, (15, 0, 6)), "Dr.Jit loaded libLLVM 15.0.6; the CPU backend needs"),
        (_FakeDrJit(True, (19, 1, 7)), None),
    ],
)
def test_llvm_check_names_what_to_install(monkeypatch, fake, expected):
    from incandescent.render.backends import jit

    monkeypatch.setattr(jit, "drjit_module", lambda: fake)
    problem = jit.llvm_problem.__wrapped__()
    if expected is None:
        assert problem is None
    else:
        assert problem.startswith(expected)
        assert "apt-get install libllvm19" in problem and "brew install llvm" in problem
