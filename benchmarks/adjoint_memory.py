"""Memory and time of a gradient against a forward render (issue 30): a 128³ flame at 256², each
measured in its own process (peak resident memory, VmHWM, includes Dr.Jit's JIT and the
arrays), forward render vs forward + replay adjoint (``inverse.gradients_on``).

    python benchmarks/adjoint_memory.py [--size 128] [--pixels 256] [--out results.json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

CHILD = """
import sys, time, numpy as np, incandescent as inc
from incandescent.inverse import gradients_on
n, px, mode = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
x = (np.indices((n, n, n), dtype=np.float32).transpose(1, 2, 3, 0) + 0.5) / n - 0.5
r = np.linalg.norm(x - np.float32([0.05, -0.1, 0.0]), axis=-1)
temp = 300 + 1600 * np.exp(-(r / 0.25) ** 2)
kappa = 20 * np.exp(-(np.linalg.norm(x, axis=-1) / 0.4) ** 2)
volume = inc.Volume.from_arrays(temp.astype(np.float32), absorption=kappa.astype(np.float32),
                                voxel_size_m=1.0 / n)
camera = inc.Camera(eye=(0.0, 0.2, 2.5), target=(0.0, 0.0, 0.0), fov_deg=30.0)
settings = inc.RenderSettings(width=px, height=px, jitter=False)
inc.render(volume, camera, settings, "cpu")  # compile once
start = time.perf_counter()
if mode == "forward":
    inc.render(volume, camera, settings, "cpu")
else:
    gradients_on("cpu", volume, camera, settings, np.ones((px, px, 3)))
seconds = time.perf_counter() - start
peak = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM"))
print(seconds, peak)
"""


def measure(mode: str, size: int, pixels: int) -> tuple[float, float]:
    """(seconds, peak resident memory in MiB) of one ``mode`` run in a fresh process."""
    out = subprocess.run([sys.executable, "-c", CHILD, str(size), str(pixels), mode],
                         check=True, capture_output=True, text=True).stdout.split()  # fmt: skip
    return float(out[0]), int(out[1]) / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--pixels", type=int, default=256)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    rows = {mode: measure(mode, args.size, args.pixels) for mode in ("forward", "gradient")}
    result = {
        "size": args.size, "pixels": args.pixels, "when": time.strftime("%Y-%m-%d %H:%M"),
        "forward_s": rows["forward"][0], "forward_peak_MiB": rows["forward"][1],
        "gradient_s": rows["gradient"][0], "gradient_peak_MiB": rows["gradient"][1],
        "memory_ratio": rows["gradient"][1] / rows["forward"][1],
    }  # fmt: skip
    print(json.dumps(result, indent=2))
    if args.out:
        args.out.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
