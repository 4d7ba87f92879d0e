"""The renderer against the hand-written CPU marchers of shared/reference/cpu-limit, side by side.

Writes the limit study's input (``params.txt``, ``temp.f32``, ``kappa.f32``, ``lut.f32``) from the
graded-κ plume (``scenes.soot_plume``) seen by `incandescent render`'s default camera, builds
``ref_march.cpp`` (scalar C++, no skipping) and ``limit_avx2.cpp`` (AVX2 + macrocells, variant
``simdskip``) with ``g++ -O3 -march=native -fopenmp``, then times in interleaved rounds:

* ``ref`` and ``limit``: each program's own figure (median of 5 frames after a warm-up);
* ``warm``: ``render()`` of the same Volume again (march time, and the whole call);
* ``cold``: ``render()`` of a new Volume, built untimed by ``soot_plume`` as a file reader builds
  one (``Volume.from_arrays``): what each ``incandescent render`` and each frame of a sequence pays;
  warm and cold are each the median of 5 frames, alternating, after an untimed render, as the C++
  programs time themselves (a single frame right after a C++ program ran measured ~10 % slower);
* ``cli``: one ``incandescent render`` of the plume saved as ``.npz`` (wall time, and its march from
  ``--stats``) next to ``incandescent version`` (wall time): the command around the march.

Usage: ``python benchmarks/cpu_limit.py REFERENCE_DIR OUT.json [--size 192] [--rounds 5]``.
Run it on a quiet machine: under load every figure grows and the ratios move.
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

from incandescent.api import camera_from
from incandescent.benchmark import cpu_description, git_commit
from incandescent.emission import Emission
from incandescent.renderer import RenderSettings, render
from incandescent.renderer.rays import ray_spec
from incandescent.scenes import soot_plume

RESOLUTION = 512
LUT_ROWS = 1024


def write_input(volume, camera, folder: Path, step: float) -> None:
    """The limit study's input format (README of cpu-limit): voxel-unit camera, [z][y][x] grids."""
    settings = RenderSettings(width=RESOLUTION, height=RESOLUTION, step_voxels=step)
    spec = ray_spec(camera, volume, settings)
    eye = (np.asarray(spec.eye) - np.asarray(spec.origin_m)) / spec.voxel_size_m
    lines = [
        f"{volume.shape[0]} {RESOLUTION} {RESOLUTION} {spec.half_height} {step} "
        f"{LUT_ROWS} {volume.max_temperature_K}"
    ]
    lines += [" ".join(f"{c:.9g}" for c in v) for v in (eye, spec.forward, spec.right, spec.up)]
    (folder / "params.txt").write_text("\n".join(lines) + "\n")
    kappa_per_voxel = volume.absorption_per_m * np.float32(volume.voxel_size_m)
    for name, grid in (("temp", volume.temperature_K), ("kappa", kappa_per_voxel)):
        np.ascontiguousarray(grid.transpose(2, 1, 0), dtype="<f4").tofile(folder / f"{name}.f32")
    lut = Emission().models(volume)[0].tables[0]
    temps = np.linspace(0.0, volume.max_temperature_K, LUT_ROWS)
    lut.lookup(temps).astype("<f4").tofile(folder / "lut.f32")


def build(source: Path, out: Path) -> Path:
    cmd = ["g++", "-std=c++17", "-O3", "-march=native", "-fopenmp", str(source), "-o", str(out)]
    subprocess.run(cmd, check=True)
    return out


def run_program(args: list[str]) -> dict:
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def time_frames(volume, camera, settings, size: int, frames: int = 5) -> tuple[tuple, tuple]:
    """(warm, cold) medians of (march s, whole render() s) over ``frames`` alternating renders
    after an untimed one: warm renders ``volume`` again, cold a new ``soot_plume(size)`` built
    untimed."""
    time_render(volume, camera, settings)
    warm, cold = [], []
    for _ in range(frames):
        warm.append(time_render(volume, camera, settings))
        cold.append(time_render(soot_plume(size), camera, settings))

    def medians(runs: list) -> tuple[float, float]:
        return statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)

    return medians(warm), medians(cold)


def time_render(volume, camera, settings) -> tuple[float, float]:
    """(march s, whole render() s) of one frame of ``volume``."""
    began = time.perf_counter()
    image = render(volume, camera, settings, backend="cpu")
    return image.metadata["seconds"], time.perf_counter() - began


def time_cli(npz: Path, folder: Path) -> tuple[float, float, float]:
    """(wall s of `incandescent render`, its march s, wall s of `incandescent version`)."""
    exe = str(Path(sys.executable).with_name("incandescent"))
    began = time.perf_counter()
    subprocess.run(
        [
            exe,
            "render",
            str(npz),
            "-o",
            str(folder / "cli.exr"),
            "--overwrite",
            "--stats",
            str(folder / "cli.json"),
            "--width",
            str(RESOLUTION),
            "--height",
            str(RESOLUTION),
        ],
        check=True,
        capture_output=True,
    )
    wall = time.perf_counter() - began
    march = json.loads((folder / "cli.json").read_text())["seconds"]
    began = time.perf_counter()
    subprocess.run([exe, "version"], check=True, capture_output=True)
    return wall, march, time.perf_counter() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reference", type=Path, help="shared/reference/cpu-limit")
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=192)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--step", type=float, default=0.5)
    a = parser.parse_args()
    volume = soot_plume(a.size)
    camera = camera_from(volume)  # what `incandescent render` frames: the gas
    settings = RenderSettings(width=RESOLUTION, height=RESOLUTION, step_voxels=a.step)
    runs: dict[str, list] = {k: [] for k in ("ref", "limit", "warm", "cold", "cli")}
    samples = render(volume, camera, settings, backend="cpu").metadata["samples"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_input(volume, camera, folder, a.step)
        np.savez(
            folder / "plume.npz",
            temperature=volume.temperature_K,
            absorption=volume.absorption_per_m,
        )
        ref = build(a.reference / "ref_march.cpp", folder / "ref_march")
        limit = build(a.reference / "limit_avx2.cpp", folder / "limit_avx2")
        for r in range(a.rounds):
            print(f"round {r + 1}/{a.rounds}", file=sys.stderr)
            runs["ref"].append(run_program([str(ref), tmp]))
            runs["limit"].append(run_program([str(limit), tmp, "simdskip"]))
            warm, cold = time_frames(volume, camera, settings, a.size)
            runs["warm"].append(warm)
            runs["cold"].append(cold)
            runs["cli"].append(time_cli(folder / "plume.npz", folder))
    report = summarise(runs, a)
    report["samples"]["renderer"] = samples
    a.out.write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report["ratios"], indent=2))


def summarise(runs: dict, a) -> dict:
    med = statistics.median
    ref = med(r["seconds"] for r in runs["ref"])
    limit = med(r["seconds"] for r in runs["limit"])
    warm, warm_total = (med(r[i] for r in runs["warm"]) for i in (0, 1))
    cold, cold_total = (med(r[i] for r in runs["cold"]) for i in (0, 1))
    cli_wall, cli_march, version = (med(r[i] for r in runs["cli"]) for i in range(3))
    return {
        "scene": f"soot_plume({a.size}) at {RESOLUTION}², step {a.step}, the CLI's default camera",
        "cpu": cpu_description(),
        "commit": git_commit(),
        "rounds": a.rounds,
        "seconds": {
            "ref_march": ref,
            "limit_simdskip": limit,
            "warm_march": warm,
            "warm_render": warm_total,
            "cold_march": cold,
            "cold_render": cold_total,
            "cli_wall": cli_wall,
            "cli_march": cli_march,
            "version_wall": version,
        },
        "samples": {
            "ref_march": runs["ref"][0]["samples"],
            "limit_simdskip": runs["limit"][0]["samples"],
        },
        "ratios": {
            "cli_march_over_ref": cli_march / ref,
            "warm_march_over_limit": warm / limit,
            "cold_render_over_warm_render": cold_total / warm_total,
            "cold_march_over_warm_march": cold / warm,
            "cli_wall_minus_march_over_version": (cli_wall - cli_march) / version,
        },
        "runs": runs,
    }


if __name__ == "__main__":
    main()
