"""A simulated fire's health per frame: one JSON record per frame in ``diagnostics.jsonl`` beside
the frames (``incandescent info FOLDER`` shows them).

Each record: the frame, its file, the simulated time (s), the solver steps it took and whether
the step cap (``max_steps_per_frame``) was hit, the largest CFL number of its steps (cells a
sample moved per step: Δt·(max|u| + S)/h) and the smallest and largest Δt (s); at the frame's
end the largest speed (m/s), the kinetic energy (J, at the air density the solver holds
constant), the volume hotter than ``HOT_K`` (m³: the flame is alive while it is > 0); the
pressure solves' most CG iterations and largest relative residual, the largest remaining
divergence |∇·u − D| (1/s), and the wall seconds (a measurement, never asserted).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from pathlib import Path

import numpy as np

from incandescent.io.atomic import OutputError, atomic_write
from incandescent.simulation.settings import air_density_kg_m3

DIAGNOSTICS = "diagnostics.jsonl"
#: Gas hotter than this (K) counts as flame in ``hot_volume_m3`` (the presets' ignition point:
#: the fuel itself is held at it, so only burning gas and hot products count).
HOT_K = 1000.0


def frame_record(solver, state, frame: int, path: Path, steps, seconds: float) -> dict:
    """The diagnostics of one frame (see the module docstring) from its state and step reports."""
    ops, s, h = solver.ops, solver.settings, solver.h
    faces = [ops.numpy(v.values) for v in state.velocity]
    speed = max(float(np.abs(u).max()) for u in faces) * h
    energy = 0.5 * air_density_kg_m3(s.t_air_K) * sum(float((u * u).sum()) for u in faces)
    hot = int((ops.numpy(state.temperature.values) > HOT_K).sum())
    return {
        "frame": frame,
        "file": path.name,
        "time_s": state.time_s,
        "steps": len(steps),
        "capped": any(r.cfl > s.cfl * (1.0 + 1e-9) for r in steps),
        "cfl_max": max(r.cfl for r in steps),
        "dt_min_s": min(r.dt_s for r in steps),
        "dt_max_s": max(r.dt_s for r in steps),
        "max_speed_m_s": speed,
        "kinetic_energy_J": energy * h**5,  # (cells/s)²·h² per face, times h³
        "hot_volume_m3": hot * h**3,
        "pressure_iterations_max": max(r.pressure_iterations for r in steps),
        "pressure_residual_max": max(r.pressure_residual for r in steps),
        "divergence_max_per_s": max(r.max_divergence for r in steps),
        "wall_s": seconds,
    }


def append(out_dir: Path, record: dict) -> None:
    """Add one frame's record to ``diagnostics.jsonl`` (non-finite numbers as null). A record
    that cannot be written (a full disk) is an ``OutputError`` naming the frame and the file,
    and leaves no partial line behind."""
    finite = lambda v: not (isinstance(v, float) and not math.isfinite(v))  # noqa: E731
    clean = {key: (value if finite(value) else None) for key, value in record.items()}
    path = out_dir / DIAGNOSTICS
    size = path.stat().st_size if path.is_file() else 0
    try:
        with open(path, "a", encoding="utf-8") as handle:
            handle.write(json.dumps(clean, allow_nan=False) + "\n")
    except OSError as error:
        if path.is_file():
            with contextlib.suppress(OSError):
                os.truncate(path, size)
        raise OutputError(
            f"frame {record.get('frame')}: cannot add its record to {path}: "
            f"{error.strerror or error} (the frame and its checkpoint are written)"
        ) from None


def keep_until(out_dir: Path, frame: int) -> None:
    """Drop the records after ``frame`` (a resumed run writes them again; a fresh one, frame 0,
    starts the file empty)."""
    path = out_dir / DIAGNOSTICS
    if not os.path.lexists(path):
        return
    kept = [r for r in read(path) if r["frame"] <= frame]
    text = "".join(json.dumps(r) + "\n" for r in kept)

    def write(tmp: Path) -> None:
        tmp.write_text(text, encoding="utf-8")

    atomic_write(path, write, overwrite=True)


def read(path: Path) -> list[dict]:
    """The records of a ``diagnostics.jsonl`` (or of the one in folder ``path``); a line that is
    not a record is one ``ValueError`` naming the file and line."""
    path = Path(path)
    if path.is_dir():
        path = path / DIAGNOSTICS
    records = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        try:
            record = json.loads(line)
        except json.JSONDecodeError as error:
            raise ValueError(f"{path}:{number}: not a JSON record ({error.msg})") from None
        if not isinstance(record, dict) or not isinstance(record.get("frame"), int):
            raise ValueError(f"{path}:{number}: expected a JSON object with an integer 'frame'")
        records.append(record)
    return records
