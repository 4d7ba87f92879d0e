"""Serial vs Dask: frames per minute of a 60-frame sequence, and the per-task overhead.

* throughput: a 60-frame sequence of 96³ plumes (``.npy`` files), 320×240, rendered by
  ``incandescent animate`` in-process and with ``--workers 2``, in alternating rounds (each run
  renders every frame: ``--overwrite``); frames per minute of the whole command;
* overhead: the same with a tiny 8³ volume at 8×8 pixels, where a frame's render is negligible:
  what remains per frame is the task's cost (scheduler round trip, reading, Dr.Jit's kernel
  cache hit, PNG write), serial and distributed.

Usage: ``python benchmarks/cluster_cost.py OUT.json [--rounds 2] [--frames 60]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from incandescent.scenes import plume_temperature


def sequence(folder: Path, frames: int, size: int) -> str:
    base = plume_temperature(size)
    for i in range(frames):
        np.save(folder / f"f_{i:04d}.npy", np.roll(base, i, axis=1))
    return str(folder / "f_####.npy")


def run(pattern: str, out: Path, width: int, height: int, workers: int | None) -> float:
    exe = str(Path(sys.executable).with_name("incandescent"))
    args = [exe, "animate", pattern, "-o", str(out), "--width", str(width),
            "--height", str(height), "--overwrite"]  # fmt: skip
    if workers:
        args += ["--workers", str(workers)]
    began = time.perf_counter()
    subprocess.run(args, check=True, capture_output=True)
    return time.perf_counter() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--frames", type=int, default=60)
    a = parser.parse_args()
    report = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in ("big", "tiny"):
            (folder / name).mkdir()
        cases = {
            "throughput": (sequence(folder / "big", a.frames, 96), 320, 240),
            "overhead": (sequence(folder / "tiny", a.frames, 8), 8, 8),
        }
        for name, (pattern, width, height) in cases.items():
            times: dict[str, list[float]] = {"serial": [], "workers 2": []}
            for _ in range(a.rounds):
                times["serial"].append(run(pattern, folder / f"{name}_s", width, height, None))
                times["workers 2"].append(run(pattern, folder / f"{name}_d", width, height, 2))
            report[name] = {
                k: {
                    "seconds": statistics.median(v),
                    "frames_per_minute": 60.0 * a.frames / statistics.median(v),
                    "ms_per_frame": 1e3 * statistics.median(v) / a.frames,
                    "runs": v,
                }
                for k, v in times.items()
            }
    a.out.write_text(json.dumps({"frames": a.frames, "cases": report}, indent=2) + "\n")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
