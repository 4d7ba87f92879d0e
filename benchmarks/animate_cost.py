"""An animation frame against a warm one: what each new volume of a sequence still costs.

* ``animate``: ``incandescent animate`` (in this process, so that the frames can be timed) of a
  sequence of graded-κ plumes (``.npz``, a different seed per frame) to a PNG folder; a frame's
  time is the interval between two frame writes, so it holds the frame's read (on the read-ahead
  thread), its new volume's layout and macrocells, the march, the display encoding and the PNG;
* ``warm``: the first file's volume rendered again and again with the same camera and settings,
  each frame encoded and written the same way: the march, display encoding and PNG alone.

Rounds alternate the two; medians. Usage:
``python benchmarks/animate_cost.py OUT.json [--size 192] [--frames 12] [--rounds 3]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from incandescent.animation import sequence as animation_sequence
from incandescent.api import camera_from, load_volume
from incandescent.benchmark import cpu_description, git_commit
from incandescent.imaging import DisplaySettings
from incandescent.imaging.pipeline import display_pixels
from incandescent.io.images import write_png
from incandescent.renderer import RenderSettings, render
from incandescent.scenes import plume_temperature

RESOLUTION = 512


def sequence(folder: Path, frames: int, size: int) -> str:
    """``frames`` graded-κ plumes (κ from 0 at 500 K to 2 1/m at 2000 K), one seed each."""
    for i in range(frames):
        temperature = plume_temperature(size, 2000.0, seed=1 + i)
        soot = (np.clip((temperature - 500.0) / 1500.0, 0.0, 1.0) * 2.0).astype(np.float32)
        np.savez(folder / f"f_{i:04d}.npz", temperature=temperature, absorption=soot)
    return str(folder / "f_####.npz")


def animate_frames(pattern: str, out: Path) -> list[float]:
    """Seconds between consecutive frame writes of one ``incandescent animate``."""
    from incandescent.cli import app

    stamps: list[float] = []
    real_write = animation_sequence.write_png

    def timed_write(*args, **kwargs):
        result = real_write(*args, **kwargs)
        stamps.append(time.perf_counter())
        return result

    animation_sequence.write_png = timed_write
    argv = ["animate", pattern, "-o", str(out), "--width", str(RESOLUTION),
            "--height", str(RESOLUTION), "--overwrite"]  # fmt: skip
    try:
        app(argv, standalone_mode=False)
    finally:
        animation_sequence.write_png = real_write
    return [b - a for a, b in zip(stamps, stamps[1:], strict=False)]


def warm_frames(first: str, out: Path, frames: int) -> list[float]:
    """Seconds per frame of one volume rendered again, encoded and written like a frame."""
    volume = load_volume(first)
    camera = camera_from(volume, frame_content=False)  # what animate frames: the whole box
    settings = RenderSettings(width=RESOLUTION, height=RESOLUTION)
    display = DisplaySettings(exposure_ev=0.0, auto_exposure=False)
    render(volume, camera, settings, backend="cpu")
    seconds = []
    for _ in range(frames):
        began = time.perf_counter()
        image = render(volume, camera, settings, backend="cpu")
        write_png(out, display_pixels(image, display), overwrite=True)
        seconds.append(time.perf_counter() - began)
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=192)
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--rounds", type=int, default=3)
    a = parser.parse_args()
    runs: dict[str, list[float]] = {"animate": [], "warm": []}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        pattern = sequence(folder, a.frames, a.size)
        for r in range(a.rounds):
            print(f"round {r + 1}/{a.rounds}", file=sys.stderr)
            runs["animate"].append(statistics.median(animate_frames(pattern, folder / "frames")))
            first = str(folder / "f_0000.npz")
            runs["warm"].append(statistics.median(warm_frames(first, folder / "w.png", a.frames)))
    animate, warm = (statistics.median(runs[k]) for k in ("animate", "warm"))
    report = {
        "scene": f"{a.frames} graded-κ plumes {a.size}³ (.npz) at {RESOLUTION}², PNG frames",
        "cpu": cpu_description(),
        "commit": git_commit(),
        "rounds": a.rounds,
        "seconds_per_frame": {"animate": animate, "warm": warm},
        "animate_over_warm": animate / warm,
        "runs": runs,
    }
    a.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps({k: report[k] for k in ("seconds_per_frame", "animate_over_warm")}))


if __name__ == "__main__":
    main()
