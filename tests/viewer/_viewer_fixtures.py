"""Shared helpers of the viewer's tests: small test volumes, a served viewer, PNG decoding, and
``incandescent render`` run in-process (the independent reference every view is checked
against)."""

from __future__ import annotations

import base64
import io
import shlex
from pathlib import Path

import numpy as np
from PIL import Image
from typer.testing import CliRunner

from incandescent import viewer
from incandescent.cli import app
from incandescent.cli.flags import command_line

#: Voxels per side of the test volumes (even: the blob's peak is the 8 central voxels).
SIDE = 24
#: The viewer's image size in the tests (odd: a centre pixel whose ray crosses the centre).
WIDTH, HEIGHT = 81, 61


def blob(path: Path, peak_K: float = 2000.0, squash: float = 1.0) -> Path:
    """A hot ellipsoid centred in a SIDE³ grid, 1000 K at its rim and ``peak_K`` at its centre,
    longer along x (so that orbiting changes the image); ``squash`` < 1 flattens it in y."""
    x = np.linspace(-1.0, 1.0, SIDE)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    r2 = (X / 0.95) ** 2 + (Y / (0.6 * squash)) ** 2 + (Z / 0.5) ** 2
    temperature = np.where(r2 < 1.0, 1000.0 + (peak_K - 1000.0) * (1.0 - r2), 0.0)
    np.savez(path, temperature=temperature.astype(np.float32))
    return path


def serve(given: str | Path, base: dict | None = None) -> viewer.Server:
    """``incandescent view`` of ``given`` on a free port, in a thread, at the tests' size."""
    base = {"render": {"width": WIDTH, "height": HEIGHT}} | (base or {})
    return viewer.serve(str(given), base, "cpu", command_line=command_line).start()


def decode_png(data: bytes | str) -> np.ndarray:
    """PNG bytes, or a ``data:image/png;base64,…`` URL, as an (H, W, 3) uint8 array."""
    if isinstance(data, str):
        data = base64.b64decode(data.split(",", 1)[1] if data.startswith("data:") else data)
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def run_render(command: str, output: Path) -> Path:
    """A viewer's "copy command" run as typed (``-o`` made ``output``), in-process."""
    words = shlex.split(command)
    assert words[:2] == ["incandescent", "render"], command
    at = words.index("-o")
    words[at + 1] = str(output)
    result = CliRunner().invoke(app, [*words[1:], "--backend", "cpu"])
    assert result.exit_code == 0, result.output
    return output


def render_png(source: Path, output: Path, *flags: str) -> np.ndarray:
    """``incandescent render SOURCE -o OUTPUT FLAGS`` at the tests' size, its pixels."""
    args = ["render", str(source), "-o", str(output), "--backend", "cpu",
            "--width", str(WIDTH), "--height", str(HEIGHT), *flags]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    return decode_png(output.read_bytes())


def camera_flags(camera: dict) -> list[str]:
    """``--eye``/``--target``/``--fov`` of a camera the page reports (floats exactly)."""
    vector = lambda v: ",".join(repr(float(c)) for c in v)  # noqa: E731
    return ["--eye", vector(camera["eye"]), "--target", vector(camera["target"]),
            "--fov", repr(float(camera["fov_deg"]))]  # fmt: skip
