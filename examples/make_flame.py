"""Write examples/flame.npz: a small synthetic candle-like flame for examples/flame.toml.

The grid ``temperature`` is *normalised* (0 = ambient, 1 = hottest), as many simulation tools
store it; the scene maps it to kelvin with ``volume.temperature.range``. Axis order x, y, z
(+y up), shape (24, 40, 24), float32 in 1/255 steps, about 15 KB compressed. Deterministic:
rerunning gives the same file.

    python examples/make_flame.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

SHAPE = (24, 40, 24)


def flame_field(shape: tuple[int, int, int] = SHAPE) -> np.ndarray:
    """A teardrop of normalised temperature: hottest low on the axis, narrowing and cooling
    upwards, with a seeded flicker so the example is not perfectly smooth; values in 1/255 steps."""
    nx, ny, nz = shape
    x = (np.arange(nx) + 0.5) / nx - 0.5
    y = (np.arange(ny) + 0.5) / ny
    z = (np.arange(nz) + 0.5) / nz - 0.5
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    radius = 0.32 * np.sqrt(np.clip(Y, 0.0, None)) * (1.0 - Y) + 0.03
    core = np.exp(-(X**2 + Z**2) / (2.0 * radius**2))
    height = np.exp(-(((Y - 0.35) / 0.4) ** 2))
    rng = np.random.default_rng(7)
    flicker = 1.0 + 0.08 * rng.standard_normal(shape)
    field = np.clip(core * height * flicker, 0.0, 1.0)
    return (np.round(field * 255.0) / 255.0).astype(np.float32)  # 8-bit steps: compresses well


def main(path: Path = Path(__file__).with_name("flame.npz")) -> Path:
    np.savez_compressed(path, temperature=flame_field())
    return path


if __name__ == "__main__":
    print(f"wrote {main()}")
