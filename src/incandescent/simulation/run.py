"""Running a fire: frames written as volumes, a checkpoint after each, resume after interruption.

``simulate(settings, resolution, frames, out_dir)`` advances the solver frame by frame (sub-steps
that keep the CFL number; ``max_steps_per_frame`` a reported safety limit), writes
``fire_####.npz`` (or ``.vdb``, written by OpenVDB) with temperature (K), absorption (1/m, from
soot), the CH and C₂ fractions of the reaction zone and the velocity (m/s), each atomically, then
``checkpoint.npz`` (every field of the solver's state, the settings, the frame format and the
frame). A fresh run writes checkpoint frame 0 before its first frame, so every frame in the folder
is accounted for by a checkpoint. A second run with the same settings, resolution and format
continues after the last checkpointed frame; other settings or another format are refused unless
``overwrite``, and so is any existing frame file this run did not write (all of them without a
checkpoint). A frame that goes non-finite is not written: the error names it and the settings keys
that likely drove it. Each frame's diagnostics (speed, CFL, energy, hot volume, pressure solves,
steps) go to ``diagnostics.jsonl`` (``diagnostics``)."""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from incandescent.io.atomic import OutputError, atomic_write, check_output
from incandescent.simulation import diagnostics
from incandescent.simulation.frames import frame_fields
from incandescent.simulation.settings import FireSettings, likely_unstable
from incandescent.simulation.solver import FireSolver, FireState, StepReport
from incandescent.volume import Volume

CHECKPOINT = "checkpoint.npz"
FRAME_FORMATS = (".npz", ".vdb")


@dataclass(frozen=True)
class FrameReport:
    """One written frame: its path, the solver steps it took and their reports, wall seconds,
    and its diagnostics record (``diagnostics.frame_record``, also in ``diagnostics.jsonl``)."""

    frame: int
    path: Path
    steps: list[StepReport]
    seconds: float
    record: dict = field(default_factory=dict)


def frame_path(out_dir: Path, frame: int, suffix: str = ".npz") -> Path:
    return out_dir / f"fire_{frame:04d}{suffix}"


def frame_volume(solver: FireSolver, state: FireState) -> Volume:
    """The state as a Volume: the domain's floor centred under the origin, +y up."""
    return _volume(solver, frame_fields(solver, state))


def _volume(solver: FireSolver, f: dict[str, np.ndarray]) -> Volume:
    nx, _, nz = solver.shape
    origin = (-0.5 * nx * solver.h, 0.0, -0.5 * nz * solver.h)
    return Volume.from_arrays(
        f["temperature_K"],
        absorption=f["absorption_per_m"],
        voxel_size_m=solver.h,
        origin_m=origin,
        source="fire simulation",
        species={"CH": f["CH"], "C2": f["C2"]},
        absorption_source="soot × soot_kappa_per_m",
        temperature_source="simulated (K)",
        velocity_m_s=f["velocity_m_s"],
    )


class SimulationDiverged(ValueError):
    """The solver's fields went non-finite; the message names the frame and the likely keys."""


def _identity(settings: FireSettings, resolution: int) -> str:
    return json.dumps({"settings": settings.model_dump(mode="json"), "resolution": resolution})


def advance_frame(solver: FireSolver, state: FireState) -> tuple[FireState, list[StepReport]]:
    """Steps to the next frame, each with its CFL number in its report: the rest of the frame
    in the fewest equal steps that keep Δt·(max|u| + S)/h ≤ ``cfl`` (the speed measured before
    each step). ``max_steps_per_frame`` is a safety limit: its last step takes whatever of the
    frame is left, over the CFL number — reported (``StepReport.cfl``, the frame's diagnostics
    record ``capped``), never silent."""
    s = solver.settings
    remaining, reports = 1.0 / s.fps, list[StepReport]()
    while remaining > 1e-12 * (1.0 / s.fps):
        speed = max(solver.ops.max_abs(v.values) for v in state.velocity)
        speed += s.flame_speed_m_s / solver.h  # cells/s
        dt = _sub_step(remaining, speed, s.cfl, s.max_steps_per_frame - len(reports))
        state, report = solver.step(state, dt)
        reports.append(replace(report, cfl=dt * speed))
        remaining -= dt
    return state, reports


def _sub_step(remaining_s: float, speed_cells_s: float, cfl: float, steps_left: int) -> float:
    """Δt (s): ``remaining_s`` split into the fewest equal steps of at most ``cfl`` cells at
    ``speed_cells_s``; all of it when one step is left under the cap (and the cap's share of it
    when the speed is no longer finite: the frame's fields then fail its finiteness check)."""
    if steps_left <= 1:
        return remaining_s
    if not math.isfinite(speed_cells_s):  # gone non-finite: the cap's steps, then the run's check
        return remaining_s / steps_left
    needed = math.ceil(remaining_s * speed_cells_s / cfl * (1.0 - 1e-12))
    return remaining_s / max(needed, 1)


def simulate(
    settings: FireSettings,
    resolution: int,
    frames: int,
    out_dir: str | Path,
    backend: str = "cpu",
    suffix: str = ".npz",
    overwrite: bool = False,
    on_frame: Callable[[FrameReport], None] | None = None,
    limits=None,
) -> list[FrameReport]:
    """Simulate ``frames`` frames into ``out_dir`` (see the module docstring); ``on_frame`` is
    called after each frame is written (progress, rendering); ``limits`` (``budget.Limits``)
    bound the memory, checked first. Returns this run's frames.

    Everything is checked before any work: the grid, the memory, the checkpoint (this run's:
    same settings, resolution and frame format) and every frame file to write — one that exists
    and that no checkpoint of this run accounts for is refused unless ``overwrite``. A run that
    fails before its first frame leaves the folder as it found it (a folder it made, removed)."""
    if suffix not in FRAME_FORMATS:
        raise ValueError(f"frame format must be one of {FRAME_FORMATS}; got {suffix!r}")
    if isinstance(frames, bool) or not isinstance(frames, int) or not 1 <= frames <= MAX_FRAMES:
        raise ValueError(f"frames must be an integer 1..{MAX_FRAMES}; got {frames!r}")
    _check_memory(settings, resolution, backend, limits)
    solver = FireSolver(settings, resolution, backend)
    run = _Run(Path(out_dir), _identity(settings, resolution), suffix, solver)
    created = _make_folder(run.out_dir)
    try:
        done, state = run.start(overwrite, frames)
        return run.frames(done, state, frames, on_frame)
    except BaseException:
        run.tidy(created)
        raise


MAX_FRAMES = 100_000


def _make_folder(out_dir: Path) -> list[Path]:
    """Make ``out_dir`` (and its parents); the folders this call made, deepest first."""
    if out_dir.exists() and not out_dir.is_dir():
        raise NotADirectoryError(f"{out_dir}: is not a folder; the frames need a folder")
    created = [p for p in (out_dir, *out_dir.absolute().parents) if not p.exists()]
    out_dir.mkdir(parents=True, exist_ok=True)
    return created


@dataclass
class _Run:
    """One run's folder, identity (settings and resolution), frame format and solver; whether
    it started the checkpoint (``fresh``) and how many frames it has committed."""

    out_dir: Path
    identity: str
    suffix: str
    solver: FireSolver
    fresh: bool = False
    committed: int = 0

    def start(self, overwrite: bool, frames: int) -> tuple[int, FireState]:
        """(last frame done, its state): from this run's checkpoint, else the initial state —
        then written as checkpoint frame 0, so that the folder is marked as this run's before
        any frame lands in it."""
        path = self.out_dir / CHECKPOINT
        if os.path.lexists(path) and not overwrite:
            done, state = read_checkpoint(path, self.identity, self.suffix, self.solver)
            self._check_frames(done, frames, resumed=True, overwrite=False)
            diagnostics.keep_until(self.out_dir, done)
            return done, state
        self._check_frames(0, frames, resumed=False, overwrite=overwrite)
        state = self.solver.initial_state()
        self._save(0, state)
        diagnostics.keep_until(self.out_dir, 0)
        self.fresh = True
        return 0, state

    def _check_frames(self, done: int, frames: int, resumed: bool, overwrite: bool) -> None:
        """Refuse, before any work, an existing frame file this run did not write: every one
        unless ``overwrite``; on resume, all but the frame after the checkpoint's (a run stopped
        between committing a frame and its checkpoint leaves it)."""
        for frame in range(done + 1, frames + 1):
            path = frame_path(self.out_dir, frame, self.suffix)
            if not os.path.lexists(path):
                continue
            ours = overwrite or (resumed and frame == done + 1)
            try:
                check_output(path, ours, FRAME_FORMATS, "frame")
            except FileExistsError:
                recorded = f"its checkpoint is at frame {done}" if resumed else "no checkpoint"
                raise FileExistsError(
                    f"{path} already exists and this run did not write it ({recorded}); pass "
                    "--overwrite (overwrite=True) to replace it, or write to another folder"
                ) from None

    def frames(self, done, state, frames, on_frame) -> list[FrameReport]:
        written = []
        for frame in range(done + 1, frames + 1):
            began = time.perf_counter()
            state, steps = advance_frame(self.solver, state)
            path = self._commit(frame, state)
            seconds = time.perf_counter() - began
            record = diagnostics.frame_record(self.solver, state, frame, path, steps, seconds)
            diagnostics.append(self.out_dir, record)
            report = FrameReport(frame, path, steps, seconds, record)
            written.append(report)
            if on_frame is not None:
                on_frame(report)
        return written

    def _commit(self, frame: int, state: FireState) -> Path:
        """Write frame ``frame`` (checked finite first), then its checkpoint; a checkpoint that
        cannot be written takes the frame with it (the next run would not know it as its own)."""
        fields = frame_fields(self.solver, state)
        _check_finite(fields, frame, self.solver.settings)
        path = _write_frame(
            self.solver, fields, frame, frame_path(self.out_dir, frame, self.suffix)
        )
        try:
            self._save(frame, state)
        except BaseException as error:
            path.unlink(missing_ok=True)
            if not isinstance(error, OSError):
                raise
            raise OutputError(
                f"frame {frame}: {error}; {path} was removed with it (no checkpoint would record "
                f"it) — free space and run again to resume after frame {frame - 1}"
            ) from None
        self.committed += 1
        return path

    def _save(self, frame: int, state: FireState) -> None:
        _save_checkpoint(self.out_dir, self.identity, self.suffix, frame, state, self.solver.ops)

    def tidy(self, created: list[Path]) -> None:
        """After a failure before any frame: remove the checkpoint this run started (frame 0)
        and the folders this run made (``created``, deepest first; each only if empty)."""
        if self.committed:
            return
        if self.fresh:
            (self.out_dir / CHECKPOINT).unlink(missing_ok=True)
            (self.out_dir / diagnostics.DIAGNOSTICS).unlink(missing_ok=True)
        for folder in created:
            with contextlib.suppress(OSError):
                folder.rmdir()


def _check_finite(fields: dict[str, np.ndarray], frame: int, settings: FireSettings) -> None:
    for name, values in fields.items():
        if not np.isfinite(values).all():
            raise SimulationDiverged(
                f"frame {frame}: the simulation went non-finite ({name} holds NaN or infinity): "
                f"the gas is driven too hard for the solver; likely {likely_unstable(settings)}; "
                f"frame {frame} was not written"
            )


# --- checkpoints ---------------------------------------------------------------------------

#: The solver's cell-centred fields a checkpoint holds (besides velocity_0..2 on the faces).
STATE_FIELDS = ("phi", "temperature", "soot", "pressure", "mixture")
#: Its scalars: the run's identity (settings and resolution as JSON), frame format, frame, time.
CHECKPOINT_SCALARS = ("identity", "format", "frame", "time_s", "steps")


def _save_checkpoint(
    out_dir: Path, identity: str, suffix: str, frame: int, state: FireState, ops
) -> None:
    arrays = {f"velocity_{a}": ops.numpy(state.velocity[a].values) for a in range(3)}
    arrays |= {name: ops.numpy(getattr(state, name).values) for name in STATE_FIELDS}

    def write(tmp: Path) -> None:
        with open(tmp, "xb") as handle:
            np.savez(
                handle,
                identity=np.asarray(identity),
                format=np.asarray(suffix),
                frame=np.int64(frame),
                time_s=np.float64(state.time_s),
                steps=np.int64(state.steps),
                **arrays,
            )

    atomic_write(out_dir / CHECKPOINT, write, overwrite=True)


def read_checkpoint(
    path: Path, identity: str, suffix: str, solver: FireSolver
) -> tuple[int, FireState]:
    """(frame, state) of the checkpoint ``path`` of this run — the one validation of a
    checkpoint: an .npz of incandescent's, of the same settings, resolution and frame format,
    a frame number 0..MAX_FRAMES, every field of the grid's shape and finite. Anything else is
    one ``ValueError`` naming the file and what is wrong."""
    values = _checkpoint_arrays(path, solver)
    _check_identity(path, values, identity, suffix)
    frame = _counter(path, values, "frame", MAX_FRAMES)
    steps = _counter(path, values, "steps", 2**62)
    time_s = _scalar_float(path, values, "time_s")
    ops = solver.ops
    fields = {
        name: solver.cell_field(ops.array(_field(path, values, name, solver)))
        for name in STATE_FIELDS
    }
    velocity = [ops.array(_field(path, values, f"velocity_{a}", solver)) for a in range(3)]
    state = FireState(solver.velocity_field(velocity), **fields, time_s=time_s, steps=steps)
    return frame, state


_START_AGAIN = "pass --overwrite to start again"


def _checkpoint_arrays(path: Path, solver: FireSolver) -> dict[str, np.ndarray]:
    """Every array of the checkpoint, its size checked before it is inflated."""
    from incandescent.io.volumes import _CORRUPT, check_input_file, check_npz_signature

    check_input_file(path, "checkpoint")
    try:
        check_npz_signature(path, "checkpoint of incandescent simulate")
    except ValueError as error:
        raise ValueError(f"{error}; {_START_AGAIN}") from None
    largest = max(solver.cell.size, *(f.size for f in solver.face)) * 8 + 2**16
    try:
        data = np.load(path, allow_pickle=False)
        if isinstance(data, np.ndarray):
            raise ValueError("a single .npy array, not an .npz archive")
        with data:
            for info in data.zip.infolist():
                if info.file_size > largest:
                    raise ValueError(f"{info.filename} inflates to {info.file_size} bytes")
            values = {name: data[name] for name in data.files}
    except _CORRUPT as error:
        raise ValueError(f"{path}: not a readable checkpoint ({error}); {_START_AGAIN}") from None
    missing = [name for name in _REQUIRED if name not in values]
    if missing:
        raise ValueError(
            f"{path}: not a checkpoint of incandescent simulate (no {missing[0]!r} array); "
            f"{_START_AGAIN}"
        )
    return values


_REQUIRED = ("identity", "frame", "time_s", "steps", *STATE_FIELDS) + tuple(
    f"velocity_{a}" for a in range(3)
)


def _text(values: dict[str, np.ndarray], name: str) -> str | None:
    value = values.get(name)
    if value is None or value.shape != () or value.dtype.kind != "U":
        return None
    return str(value)


def _check_identity(path: Path, values, identity: str, suffix: str) -> None:
    """Same settings and resolution, and the same frame format (one folder, one format)."""
    if _text(values, "identity") != identity:
        raise ValueError(
            f"{path.parent} holds frames of another simulation (other settings or resolution); "
            "pass --overwrite to start again"
        )
    stored = _text(values, "format") or _format_of_frames(path.parent)
    if stored is not None and stored != suffix:
        raise ValueError(
            f"{path.parent} holds this simulation's frames as {stored} (recorded in {path.name}); "
            f"resuming in {suffix} would mix formats: run again with --format {stored[1:]}, or "
            f"pass --overwrite to start again in {suffix}"
        )


def _format_of_frames(out_dir: Path) -> str | None:
    """The frame format of a checkpoint that does not record it (before 0.x): its frames'."""
    found = [s for s in FRAME_FORMATS if os.path.lexists(frame_path(out_dir, 1, s))]
    return found[0] if len(found) == 1 else None


def _damaged(path: Path, problem: str) -> ValueError:
    return ValueError(f"{path}: damaged checkpoint: {problem}; {_START_AGAIN}")


def _shown(value: np.ndarray) -> str:
    if value.shape == ():
        return f"{value.item()!r} ({value.dtype})"
    return f"an array of shape {value.shape}"


def _counter(path: Path, values, name: str, most: int) -> int:
    value = values[name]
    if value.shape != () or value.dtype.kind not in "iu" or not 0 <= int(value) <= most:
        raise _damaged(path, f"{name} is {_shown(value)}, not an integer 0..{most}")
    return int(value)


def _scalar_float(path: Path, values, name: str) -> float:
    value = values[name]
    if value.shape != () or value.dtype.kind != "f" or not 0.0 <= float(value) < math.inf:
        raise _damaged(path, f"{name} is {_shown(value)}, not a finite number ≥ 0")
    return float(value)


def _field(path: Path, values, name: str, solver: FireSolver) -> np.ndarray:
    """A field of the checkpoint: one value per cell (per face for velocity_*), all finite."""
    expected = solver.face[int(name[-1])].size if name.startswith("velocity_") else solver.cell.size
    value = values[name]
    if value.dtype.kind != "f" or value.shape != (expected,):
        raise _damaged(
            path,
            f"{name} is {value.dtype} of shape {value.shape}, expected floats of shape "
            f"({expected},) for the {'×'.join(map(str, solver.shape))} grid",
        )
    if not np.isfinite(value).all():
        raise _damaged(path, f"{name} holds NaN or infinite values")
    return value


#: Values held per cell during a step: 3 velocities and 4 scalars (with their advected copies),
#: the multigrid's operator codes (1 per cell, ~1.15× over the levels), the CG vectors and the
#: temporaries of advection and of a frame's NumPy copies. Measured: a 128³ step peaks at 539 MB
#: resident, an 8³ one at 129 MB (the interpreter and Dr.Jit), so ~196 B = 49 values per cell.
VALUES_PER_CELL = 52


def _check_memory(settings: FireSettings, resolution: int, backend: str, limits=None) -> None:
    """Refuse a grid the machine's memory cannot hold, before any work (``budget.Limits``)."""
    from incandescent.budget import Limits
    from incandescent.simulation.solver import grid_shape

    shape, _ = grid_shape(settings, resolution)
    cells = float(np.prod(shape))
    value_bytes = 8.0 if backend == "reference" else 4.0
    (limits or Limits()).check_memory(
        cells * VALUES_PER_CELL * value_bytes,
        f"simulating a {shape[0]}×{shape[1]}×{shape[2]} grid",
    )


def _write_frame(solver: FireSolver, fields: dict[str, np.ndarray], frame: int, path: Path) -> Path:
    """Write a frame atomically (``save_volume``); a failure names the frame and its file."""
    from incandescent.io.output import save_volume

    try:
        return save_volume(_volume(solver, fields), path, overwrite=os.path.lexists(path))
    except (OSError, RuntimeError) as error:
        message = str(error) if str(path) in str(error) else f"cannot write {path}: {error}"
        raise OutputError(f"frame {frame}: {message}") from None
