"""``incandescent bench``: named synthetic scenes on every available backend, side by side.

Method (DESIGN.md §6): every case is rendered once untimed (kernel compilation, caches), then the
cases are timed in interleaved rounds so that machine noise hits them alike; medians are reported.
``ms_per_frame`` is the march time (no start-up, no kernel compilation); ``total_ms`` is the whole
``render()`` call including host-side ray setup and macrocell construction. The NumPy reference is
run at 1/8 of the resolution, once (it is ~1000× slower); compare it by samples/s. Every scene is
seen by the default three-quarter camera framing its whole grid box.
"""

from __future__ import annotations

import platform
import statistics
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from incandescent._jit import drjit_module
from incandescent._parallel import workers
from incandescent._version import __version__
from incandescent.camera import default_camera
from incandescent.renderer import RenderSettings, render
from incandescent.renderer.backends import available_backends
from incandescent.scenes import SCENES


@dataclass(frozen=True)
class Case:
    name: str
    backend: str
    threads: int | None  # None: all
    skip_empty: bool
    resolution_divisor: int = 1
    #: each frame renders a new Volume, built by the scene outside the timing as a file reader or
    #: a simulation builds one (``Volume.from_arrays``: what validation and a κ made from T tell
    #: are known; device copies, macrocells and the other scans are redone): what every
    #: `incandescent render` and animation frame pays
    cold: bool = False


def _cases(backends: list[str], reference: bool, cold: bool = False) -> list[Case]:
    cases = []
    if cold:
        cases.append(
            Case("cpu, all threads, cold (a new volume each frame)", "cpu", None, True, cold=True)
        )
    if "cuda" in backends:
        cases.append(Case("cuda", "cuda", None, True))
    cases += [
        Case("cpu, all threads", "cpu", None, True),
        Case("cpu, 1 thread", "cpu", 1, True),
        Case("cpu, all threads, no skipping", "cpu", None, False),
    ]
    if reference:
        cases.append(Case("reference (NumPy float64)", "reference", None, False, 8))
    return cases


def _time_case(case: Case, volume, resolution: int, fresh=None) -> dict:
    """One timed render of ``volume`` (of ``fresh()``, built untimed, for a cold case)."""
    dr = drjit_module()
    all_threads = dr.thread_count()
    r = max(8, resolution // case.resolution_divisor)
    settings = RenderSettings(width=r, height=r, skip_empty=case.skip_empty)
    if case.threads:
        dr.set_thread_count(case.threads)
    if case.cold:
        volume = fresh()  # a new Volume: nothing from the renders before cached for it
    try:
        start = time.perf_counter()
        camera = default_camera(volume.bounds_m)  # the whole box, empty space included
        image = render(volume, camera, settings, backend=case.backend)
        total = time.perf_counter() - start
    finally:
        dr.set_thread_count(all_threads)
    meta = image.metadata
    return {
        "seconds": meta["seconds"],
        "total": total,
        "samples": meta["samples"],
        "device": meta["device"],
        "resolution": r,
    }


def _summarise(case: Case, runs: list[dict]) -> dict:
    seconds = statistics.median(r["seconds"] for r in runs)
    samples = runs[0]["samples"]
    return {
        "case": case.name,
        "backend": case.backend,
        "threads": case.threads or drjit_module().thread_count(),
        "skip_empty": case.skip_empty,
        "width": runs[0]["resolution"],
        "height": runs[0]["resolution"],
        "samples": samples,
        "ms_per_frame": seconds * 1e3,
        "total_ms": statistics.median(r["total"] for r in runs) * 1e3,
        "samples_per_s": samples / seconds if seconds > 0 else None,
        "repeats": len(runs),
        "device": runs[0]["device"],
    }


def _scene_report(
    name: str, size: int, resolution: int, repeat: int, reference: bool, progress, cold=False
) -> dict:
    scene = SCENES[name]
    label, volume = scene.label + " at {r}²", scene.build(size)
    cases = _cases(available_backends(), reference, cold)
    runs: dict[str, list[dict]] = {c.name: [] for c in cases}
    fresh = (lambda: scene.build(size)) if cold else None
    for case in cases:  # warm-up: compile kernels, fill caches
        _time_case(case, volume, resolution, fresh)
    for round_ in range(repeat):
        for case in cases:
            if case.backend == "reference" and round_ > 0:
                continue
            if progress is not None:
                progress.print(f"  {name}: round {round_ + 1}/{repeat}: {case.name}", style="dim")
            runs[case.name].append(_time_case(case, volume, resolution, fresh))
    results = [_summarise(c, runs[c.name]) for c in cases]
    return {
        "scene": name,
        "description": label.format(n=size, r=resolution),
        "results": results,
        "ratios": _ratios(results),
    }


def _ratios(results: list[dict]) -> dict:
    ms = {r["case"]: r["ms_per_frame"] for r in results}
    best = ms["cpu, all threads"]
    return {
        "threads_speedup": ms["cpu, 1 thread"] / best,
        "skipping_speedup": ms["cpu, all threads, no skipping"] / best,
    }


def git_commit() -> str:
    """The short commit hash of the checkout, or "unknown" (recorded with benchmark results)."""
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def cpu_description(cpuinfo: str | None = None) -> str:
    """The CPU the figures were measured on — model, family/model numbers, cores this process
    may use, widest SIMD — from ``/proc/cpuinfo`` (Linux), else the platform's processor name.
    Timings move with it: these VMs have been Zen 3 (AVX2) and Zen 4 (AVX-512) under one name."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text()
        except OSError:
            return platform.processor() or platform.machine()
    fields: dict[str, str] = {}
    for line in cpuinfo.splitlines():
        key, _, value = line.partition(":")
        fields.setdefault(key.strip(), value.strip())
    flags = set(fields.get("flags", "").split())
    simd = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
    name = fields.get("model name", platform.processor() or platform.machine())
    family = f"family {fields.get('cpu family', '?')} model {fields.get('model', '?')}"
    return f"{name} ({family}), {workers()} cores, {simd}"


def run(
    scene_names: list[str],
    size: int = 256,
    resolution: int = 512,
    repeat: int = 5,
    reference: bool = True,
    progress=None,
    cold: bool = False,
) -> dict:
    """Benchmark ``scene_names``; returns a JSON-able report. ``cold`` adds a case whose every
    frame renders a new Volume (timed next to the warm cases in the same rounds)."""
    unknown = [s for s in scene_names if s not in SCENES]
    if unknown:
        raise ValueError(f"unknown bench scene {unknown[0]!r}; expected: {', '.join(SCENES)}")
    if repeat < 1 or size < 8 or resolution < 8:
        raise ValueError("bench needs repeat >= 1, size >= 8 and resolution >= 8")
    dr = drjit_module()
    return {
        "incandescent": __version__,
        "drjit": dr.__version__,
        "python": platform.python_version(),
        "machine": platform.processor() or platform.machine(),
        "cpu": cpu_description(),
        "commit": git_commit(),
        "scenes": [
            _scene_report(s, size, resolution, repeat, reference, progress, cold)
            for s in scene_names
        ],
    }


def print_table(report: dict, console) -> None:
    """Render the report as rich tables."""
    from rich.table import Table

    for scene in report["scenes"]:
        table = Table(title=scene["description"])
        for col in ("case", "image", "samples", "ms/frame", "total ms", "Msamples/s"):
            table.add_column(col, justify="right" if col != "case" else "left")
        for r in scene["results"]:
            rate = r["samples_per_s"] or 0.0
            table.add_row(
                r["case"],
                f"{r['width']}²",
                f"{r['samples']:,}",
                f"{r['ms_per_frame']:.1f}",
                f"{r['total_ms']:.1f}",
                f"{rate / 1e6:.1f}",
            )
        console.print(table)
        ratios = scene["ratios"]
        console.print(
            f"all threads vs 1 thread: {ratios['threads_speedup']:.2f}×; "
            f"skipping vs none: {ratios['skipping_speedup']:.2f}×"
        )
