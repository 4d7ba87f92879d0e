"""Motion blur from a velocity grid: κ and T sampled at x − v(x)·t, t in the shutter."""

from __future__ import annotations

import numpy as np
import pytest

from incandescent.camera import Camera
from incandescent.renderer import RenderSettings, render
from incandescent.volume import Volume

N = 40
SPEED_M_S = 12.0  # along x; a voxel is 1/40 m, so a quarter frame at 24 fps moves 5 voxels
CAMERA = Camera(eye=(0.0, 0.0, 2.0), target=(0.0, 0.0, 0.0), fov_deg=35.0)
BASE = RenderSettings(width=40, height=40, step_voxels=0.25, jitter=False)


def _blob(velocity=(SPEED_M_S, 0.0, 0.0), n: int = N) -> Volume:
    """A Gaussian hot blob left of centre, the whole grid moving at ``velocity`` (m/s)."""
    x, y, z = np.meshgrid(*(np.arange(n) + 0.5,) * 3, indexing="ij")
    peak = 1800.0 * np.exp(-((x - 14) ** 2 + (y - 20) ** 2 + (z - 20) ** 2) / (2 * 3.0**2))
    velocity_grid = np.broadcast_to(np.asarray(velocity, dtype=np.float32), (n, n, n, 3))
    return Volume.from_arrays(np.where(peak > 400, peak, 0.0), velocity_m_s=velocity_grid)


def _moved(volume: Volume, t_s: float) -> Volume:
    """The same grids translated by v·t: the blob where it is at time t."""
    x, y, z = volume.origin_m
    return volume.replace(origin_m=(x + SPEED_M_S * t_s, y, z))


def test_no_motion_renders_exactly_the_unblurred_image(jit_backend):
    volume = _blob()
    sharp = render(volume, CAMERA, BASE.replace(supersample=2), backend=jit_backend)
    closed = BASE.replace(supersample=2, shutter=(0.0, 0.0))
    still = _blob(velocity=(0.0, 0.0, 0.0))
    for image in (
        render(volume, CAMERA, closed, backend=jit_backend),  # a closed shutter at the instant
        render(still, CAMERA, closed.replace(shutter=(-0.5, 0.5)), backend=jit_backend),  # v = 0
    ):
        np.testing.assert_array_equal(image.xyz, sharp.xyz)
        assert image.metadata["samples"] == sharp.metadata["samples"]


def test_an_instant_shutter_shows_the_gas_where_it_is_then(jit_backend):
    """Backward advection by v·t equals the grid moved by v·t (same samples along each ray)."""
    volume = _blob()
    for frames in (0.125, -0.25):
        instant = BASE.replace(shutter=(frames, frames))
        moved = render(_moved(volume, frames / 24.0), CAMERA, BASE, backend=jit_backend)
        image = render(volume, CAMERA, instant, backend=jit_backend)
        np.testing.assert_allclose(image.xyz, moved.xyz, rtol=1e-5, atol=1e-6 * moved.xyz.max())


def test_blur_converges_to_the_average_of_the_gas_along_its_path(jit_backend):
    """The blurred image against the mean of 32 renders of the moved blob, at the same rays per
    pixel: the error is time-sampling noise and falls as 1/√(rays per pixel) = 1/N."""
    volume, shutter = _blob(), (0.0, 0.25)
    times = (np.arange(32) + 0.5) / 32 * (shutter[1] - shutter[0]) / 24.0
    errors = {}
    for n in (2, 8):
        settings = BASE.replace(supersample=n)
        mean = np.mean(
            [render(_moved(volume, t), CAMERA, settings, backend=jit_backend).xyz for t in times],
            axis=0,
        )
        blurred = render(volume, CAMERA, settings.replace(shutter=shutter), backend=jit_backend)
        errors[n] = np.linalg.norm(blurred.xyz - mean) / np.linalg.norm(mean)
    sharp = render(volume, CAMERA, BASE.replace(supersample=8), backend=jit_backend)
    assert np.linalg.norm(sharp.xyz - mean) / np.linalg.norm(mean) > 0.5  # blur is visible
    assert errors[8] < 0.08
    assert errors[2] / errors[8] > 2.5  # 4 expected from 1/N


def test_skipping_with_blur_gives_the_image_without_skipping(jit_backend):
    volume = _blob(velocity=(SPEED_M_S, -4.0, 7.0), n=96)  # moves ≤ 12 voxels: 2 rings of cells
    settings = BASE.replace(supersample=2, shutter=(-0.25, 0.25), jitter=True)
    skipped = render(volume, CAMERA, settings, backend=jit_backend)
    full = render(volume, CAMERA, settings.replace(skip_empty=False), backend=jit_backend)
    assert skipped.metadata["samples"] < full.metadata["samples"]
    np.testing.assert_array_equal(skipped.xyz, full.xyz)
    np.testing.assert_array_equal(skipped.transmittance, full.transmittance)


def test_the_sparse_layout_blurs_as_the_dense_one(jit_backend):
    """The sparse volume keeps the velocity of every leaf a blurred sample can read (the blur's
    reach in leaves, plus one): the same image and samples as the dense layout."""
    volume = _blob(velocity=(SPEED_M_S, -4.0, 7.0), n=96)
    settings = BASE.replace(supersample=2, shutter=(-0.25, 0.25), jitter=True)
    dense = render(volume, CAMERA, settings.replace(layout="dense"), backend=jit_backend)
    sparse = render(volume, CAMERA, settings.replace(layout="sparse"), backend=jit_backend)
    assert sparse.metadata["layout"] == "sparse" and dense.xyz.max() > 0
    assert sparse.metadata["samples"] == dense.metadata["samples"]
    np.testing.assert_array_equal(sparse.xyz, dense.xyz)
    np.testing.assert_array_equal(sparse.depth_m, dense.depth_m)


@pytest.mark.parametrize(
    ("still", "changes", "backend", "message"),
    [
        (False, {"shutter": (0.5, 0.1)}, "cpu", "open <= close"),
        (False, {"shutter": (-2.0, 0.0)}, "cpu", "-1 <= open"),
        (False, {"fps": 0.0}, "cpu", "fps"),
        (True, {"shutter": (0.0, 0.5)}, "cpu", "no velocity grid"),
        (False, {"shutter": (0.0, 0.5)}, "reference", "cpu and cuda backends"),
    ],
    ids=["reversed", "too early", "fps", "no velocity", "reference"],
)
def test_what_cannot_blur_is_a_clear_error(still, changes, backend, message):
    volume = _blob().with_velocity(None) if still else _blob()
    with pytest.raises(ValueError, match=message):
        render(volume, CAMERA, BASE.replace(**changes), backend=backend)


def test_a_velocity_grid_must_be_a_vector_per_voxel():
    with pytest.raises(ValueError, match=r"velocity grid has shape \(4, 4, 4\); expected"):
        Volume.from_arrays(np.full((4, 4, 4), 1500.0), velocity_m_s=np.zeros((4, 4, 4)))
    with pytest.raises(ValueError, match="velocity .m/s. must be finite"):
        Volume.from_arrays(np.full((2, 2, 2), 1500.0), velocity_m_s=np.full((2, 2, 2, 3), np.nan))


def test_the_command_line_blurs_along_a_velocity_grid_in_either_unit(tmp_path):
    """``render --shutter`` reads the file's velocity grid; 1 voxel/frame at 24 fps is
    voxel·24 m/s, or a velocity scale of voxel·24: the three spellings give one image."""
    from typer.testing import CliRunner

    from incandescent.cli import app
    from incandescent.io.images import read_exr

    volume = _blob()
    voxel = volume.voxel_size_m
    per_frame = np.zeros((N, N, N, 3), dtype=np.float32)
    per_frame[..., 0] = 2.0  # voxels per frame
    temp = volume.temperature_K
    np.savez(tmp_path / "frames.npz", temperature=temp, velocity=per_frame)
    np.savez(tmp_path / "metres.npz", temperature=temp, vel=per_frame * np.float32(voxel * 24.0))
    common = ["--width", "24", "--height", "24", "--supersample", "2", "--fps", "24"]
    runs = {
        "still": ["render", tmp_path / "frames.npz", *common],
        "frames": [
            "render",
            tmp_path / "frames.npz",
            *common,
            "--shutter",
            "-0.5:0.5",
            "--velocity-units",
            "voxels/frame",
        ],  # fmt: skip
        "metres": ["render", tmp_path / "metres.npz", *common, "--shutter", "-0.5:0.5"],
        "scaled": [
            "render",
            tmp_path / "frames.npz",
            *common,
            "--shutter",
            "-0.5:0.5",
            "--velocity-scale",
            repr(voxel * 24.0),
        ],  # fmt: skip
    }
    images = {}
    for name, args in runs.items():
        out = tmp_path / f"{name}.exr"
        result = CliRunner().invoke(app, [str(a) for a in args] + ["-o", str(out)])
        assert result.exit_code == 0, result.output
        images[name] = read_exr(out)[0]
    np.testing.assert_allclose(images["frames"], images["metres"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(images["scaled"], images["metres"], rtol=1e-5, atol=1e-6)
    assert np.abs(images["frames"] - images["still"]).max() > 0.1 * images["still"].max()
    bad = CliRunner().invoke(app, [str(a) for a in runs["still"]] + ["--shutter", "0.5", "-o",
                                   str(tmp_path / "x.exr")])  # fmt: skip
    assert bad.exit_code == 2 and "--shutter must be OPEN:CLOSE" in bad.output


def test_animate_blurs_each_frame_at_the_video_frame_rate(tmp_path):
    from PIL import Image
    from typer.testing import CliRunner

    from incandescent.cli import app

    volume = _blob()
    for i in (1, 2):
        np.savez(tmp_path / f"f_{i:04d}.npz", temperature=volume.temperature_K,
                 velocity=volume.velocity_m_s)  # fmt: skip
    frames = {}
    for name, extra in (("sharp", []), ("blur", ["--shutter", "-0.5:0.5", "--fps", "12"])):
        out = tmp_path / name
        args = ["animate", str(tmp_path / "f_####.npz"), "-o", str(out), "--width", "24",
                "--height", "24", *extra]  # fmt: skip
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 0, result.output
        with Image.open(sorted(out.glob("*.png"))[0]) as image:
            frames[name] = np.asarray(image, dtype=np.float64)
    assert np.abs(frames["blur"] - frames["sharp"]).max() > 20  # of 255: visibly streaked
