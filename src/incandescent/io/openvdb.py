"""Reading ``.vdb`` files with OpenVDB itself, through a worker process (``io/openvdb_worker.py``).

OpenVDB's Python module ``pyopenvdb`` comes with the operating system (Debian/Ubuntu
``apt-get install python3-openvdb``; ``scripts/setup.sh`` installs it; macOS: ``brew install
openvdb``) and is built for the system's Python and its NumPy 1.x, so it cannot be imported here.
The worker runs under that interpreter — ``$INCANDESCENT_OPENVDB_PYTHON``, else the first of
:data:`INTERPRETERS` that imports pyopenvdb — with a clean environment, one request a line. It is
started once and reused; if it dies (OpenVDB can crash on a corrupt file) the read is a
``ValueError`` naming the file and the next read starts a new worker.

OpenVDB expands active tiles at every tree level, reads half floats as float and decodes zip and
Blosc itself, so a grid reads exactly as OpenVDB reads it. Where no such interpreter exists,
:mod:`incandescent.io.vdb` falls back to tinyvdb (leaf voxels only) and says how to install
OpenVDB when a grid has tiles.
"""

from __future__ import annotations

import copy
import functools
import json
import os
import select
import subprocess
import tempfile
import threading
from pathlib import Path

import numpy as np

ENV_VAR = "INCANDESCENT_OPENVDB_PYTHON"
#: System interpreters that may have pyopenvdb (Debian/Ubuntu, Homebrew on Intel and Apple).
INTERPRETERS = ("/usr/bin/python3", "/usr/local/bin/python3", "/opt/homebrew/bin/python3")
WORKER = Path(__file__).with_name("openvdb_worker.py")
#: Seconds the worker may take to start (import pyopenvdb and NumPy: ~0.2 s warm, a few s cold).
START_TIMEOUT_S = 20.0
INSTALL_HINT = (
    "install OpenVDB's Python module for the system Python (Debian/Ubuntu: apt-get install "
    "python3-openvdb; macOS: brew install openvdb) or point INCANDESCENT_OPENVDB_PYTHON at an "
    "interpreter that has pyopenvdb"
)


def _clean_env() -> dict[str, str]:
    """The environment without this project's Python settings (its NumPy must not leak in), and
    the worker's memory budget (``openvdb_worker.BUDGET_ENV``)."""
    drop = ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSTARTUP")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env["PYTHONNOUSERSITE"] = "1"
    env["INCANDESCENT_OPENVDB_MAX_BYTES"] = str(int(worker_budget_bytes()))
    return env


#: ``--max-memory`` in bytes, for the worker (None: the memory available when it starts).
_BUDGET_BYTES: float | None = None


def set_memory_budget(max_bytes: float | None) -> None:
    """Bound the worker's memory (RLIMIT_AS over what it maps at start) to ``max_bytes``; a
    running worker with another budget is stopped, so the next read starts one under it."""
    global _BUDGET_BYTES
    if max_bytes == _BUDGET_BYTES:
        return
    _BUDGET_BYTES = max_bytes
    with _LOCK:
        for worker in _WORKERS.values():
            worker.close()
        _WORKERS.clear()


def worker_budget_bytes() -> float:
    from incandescent.budget import available_memory_bytes

    return _BUDGET_BYTES if _BUDGET_BYTES is not None else available_memory_bytes()


@functools.cache
def interpreter() -> str | None:
    """The interpreter the worker runs under — ``$INCANDESCENT_OPENVDB_PYTHON``, else the first of
    :data:`INTERPRETERS` whose worker starts (it imports pyopenvdb and NumPy, then says so) — or
    None. The worker started to find it is the one the reads use: no separate probe process
    (which cost ~160 ms of every `incandescent render` of a .vdb)."""
    given = os.environ.get(ENV_VAR)
    for candidate in (given,) if given else INTERPRETERS:
        if candidate and os.access(candidate, os.X_OK) and _started(candidate):
            return candidate
    return None


#: Why a worker did not start, by interpreter (for :func:`problem`'s message).
_START_ERRORS: dict[str, str] = {}


def start() -> None:
    """Find the interpreter — starting its worker, ~0.2 s to import OpenVDB — on a thread, while
    the caller does other work; the first read then finds the worker ready (or waits for it)."""
    threading.Thread(target=interpreter, name="incandescent-openvdb-start", daemon=True).start()


def _started(python: str) -> bool:
    """Is a worker running under ``python`` (started now if there was none)?"""
    with _LOCK:
        if python in _WORKERS and _WORKERS[python].process.poll() is None:
            return True
        try:
            _WORKERS[python] = _Worker(python)
        except (OSError, RuntimeError) as error:
            _START_ERRORS[python] = str(error)
            return False
        return True


def problem() -> str | None:
    """None when OpenVDB can be used, else one sentence saying what is wrong and what to do."""
    if interpreter():
        return None
    given = os.environ.get(ENV_VAR)
    if given and given in _START_ERRORS:
        return f"{_START_ERRORS[given]} (${ENV_VAR}); {INSTALL_HINT}"
    return f"OpenVDB's Python module was not found; {INSTALL_HINT}"


class _Worker:
    """One worker process and its pipes; replies are JSON lines."""

    def __init__(self, python: str) -> None:
        self.process = subprocess.Popen(
            [python, str(WORKER)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=_clean_env(),
        )
        try:
            hello = self._reply()
        except ValueError as error:
            hello = {"error": str(error)}
        if not hello or not hello.get("ok") or "openvdb" not in hello:
            self.close()
            said = "did not answer" if hello is None else f"answered {str(hello)[:80]!r}"
            raise RuntimeError(
                f"the OpenVDB worker under {python} did not start: it {said} within "
                f"{START_TIMEOUT_S:g} s"
            )

    def _reply(self, timeout_s: float | None = None) -> dict | None:
        """The next reply line; None when the worker died or did not answer within the time;
        ValueError for a line that is not a JSON object (not our worker)."""
        assert self.process.stdout is not None
        wait_s = START_TIMEOUT_S if timeout_s is None else timeout_s
        ready, _, _ = select.select([self.process.stdout], [], [], wait_s)
        if not ready:
            return None
        line = self.process.stdout.readline()
        if not line:
            return None
        try:
            reply = json.loads(line)
        except ValueError:
            reply = None
        if not isinstance(reply, dict):
            raise ValueError(f"garbage: {line.strip()[:60]!r}")
        return reply

    def ask(self, request: dict, timeout_s: float) -> dict | None:
        """The reply, or None when the worker died or hung on the way."""
        assert self.process.stdin is not None
        try:
            self.process.stdin.write(json.dumps(request) + "\n")
            self.process.stdin.flush()
            return self._reply(timeout_s)
        except (BrokenPipeError, ValueError):
            return None

    def close(self) -> None:
        self.process.kill()
        self.process.wait()
        for pipe in (self.process.stdin, self.process.stdout):
            if pipe is not None:
                pipe.close()


def read_timeout_s(path: Path) -> float:
    """How long a read of ``path`` may take before the worker is taken to hang (OpenVDB can
    spend minutes on a corrupt block): generous for real files, ~100 MB/s and 30 s more."""
    size = path.stat().st_size if path.is_file() else 0
    return 30.0 + size / 100e6


_LOCK = threading.Lock()
_WORKERS: dict[str, _Worker] = {}  # the reusable worker per interpreter


def ask(path: Path, request: dict) -> dict:
    """Send ``request`` to the worker; a failure or a crash is a ValueError naming ``path``."""
    python = interpreter()
    if python is None:
        raise ValueError(f"{path}: OpenVDB is not available; {INSTALL_HINT}")
    with _LOCK:
        worker = _WORKERS.get(python)
        if worker is not None and worker.process.poll() is not None:
            worker.close()  # it died since the last request
            worker = None
        if worker is None:
            worker = _WORKERS[python] = _Worker(python)
        timeout_s = read_timeout_s(path)
        reply = worker.ask(request, timeout_s)
        if reply is None:
            hung = not _exited(worker.process)
            worker.close()
            del _WORKERS[python]
            what = f"did not finish within {timeout_s:.0f} s" if hung else "crashed"
            raise ValueError(
                f"{path}: OpenVDB {what} reading this file: it is corrupt or truncated"
            )
    if reply.get("memory"):
        raise ValueError(
            f"{path}: OpenVDB {reply.get('error')} reading it (--max-memory, else the memory "
            "available): the file is corrupt, or raise --max-memory"
        )
    if not reply.get("ok"):
        doing = "cannot write it" if request.get("op") == "write" else "cannot read it"
        raise ValueError(f"{path}: OpenVDB {doing} ({reply.get('error')})")
    return reply


def _exited(process: subprocess.Popen, grace_s: float = 2.0) -> bool:
    """Did the worker exit (closed its pipe and died: a crash), rather than hang? A worker that
    crashed is not always reaped when its pipe closes, so it gets ``grace_s`` to be seen dead."""
    try:
        process.wait(timeout=grace_s)
    except subprocess.TimeoutExpired:
        return False
    return True


#: The last descriptions, by file (path, inode, size, modification time) and options: a render
#: asks three times (to open the file, for its extent, to read it), and each is OpenVDB reading
#: the whole file (~110 ms for a 192³ grid pair).
_DESCRIBED: dict[tuple, list[dict]] = {}
_DESCRIBED_KEPT = 8
_DESCRIBED_LOCK = threading.Lock()  # the read-ahead thread describes files too


def describe(
    path: Path, sums: bool = False, ranges: bool = True, max_bytes: int | None = None
) -> list[dict]:
    """Every grid of the file as the worker describes it (see ``openvdb_worker``); with
    ``sums``, float grids also get the sum of their active values (tiles included); without
    ``ranges``, no value ranges (what a read needs: a vector range visits every value).
    Remembered while the file's inode, size and modification time stay the same. ``max_bytes``:
    the worker may allocate at most this much for it (a read-back of a file just written)."""
    resolved = path.resolve()
    request = {"op": "describe", "path": str(resolved), "sums": sums, "ranges": ranges}
    if max_bytes:
        request["max_bytes"] = int(max_bytes)
    try:
        stat = resolved.stat()
    except OSError:  # the worker says what is wrong with the path
        return ask(path, request)["grids"]
    key = (str(resolved), stat.st_ino, stat.st_size, stat.st_mtime_ns, sums, ranges)
    with _DESCRIBED_LOCK:
        grids = _DESCRIBED.get(key)
    if grids is None:
        grids = ask(path, request)["grids"]
        with _DESCRIBED_LOCK:
            while len(_DESCRIBED) >= _DESCRIBED_KEPT:
                del _DESCRIBED[next(iter(_DESCRIBED))]
            _DESCRIBED[key] = grids
    return copy.deepcopy(grids)


def _box_request(op: str, path: Path, names, lo, hi, folder: str) -> dict:
    """A request for grids ``names`` on the inclusive index box [lo, hi], files into ``folder``."""
    return {
        "op": op,
        "path": str(path.resolve()),
        "names": list(names),
        "lo": [int(v) for v in lo],
        "hi": [int(v) for v in hi],
        "out": folder,
    }


def dense(path: Path, names: list[str], lo, hi) -> dict[str, np.ndarray]:
    """The grids ``names`` on the inclusive index box [lo, hi], float32 (vec3: (…, 3))."""
    with tempfile.TemporaryDirectory(prefix="incandescent-vdb-") as folder:
        files = ask(path, _box_request("dense", path, names, lo, hi, folder))["files"]
        return {name: np.load(files[name], allow_pickle=False) for name in names}


def leaves(path: Path, names: list[str], lo, hi, z_up: bool, rings: int = 0):
    """The box [lo, hi] as 8³ leaves (see ``openvdb_worker.leaves``): (coords (n, 3) int32,
    {name: (n, 8, 8, 8[, 3]) float32}, shape of the (turned) box)."""
    with tempfile.TemporaryDirectory(prefix="incandescent-vdb-") as folder:
        extra = {"z_up": bool(z_up), "rings": int(rings)}
        request = _box_request("leaves", path, names, lo, hi, folder) | extra
        reply = ask(path, request)
        coords = np.load(reply["coords"], allow_pickle=False)
        arrays = {name: np.load(reply["files"][name], allow_pickle=False) for name in names}
        return coords, arrays, tuple(int(n) for n in reply["shape"])


def write(path: Path, grids: dict[str, np.ndarray], voxel_size_m: float, origin_m, metadata):
    """Write ``grids`` (name → float32 (nx, ny, nz) or (nx, ny, nz, 3)) to ``path`` as a sparse
    ``.vdb`` with OpenVDB; ``origin_m`` is the corner of voxel (0, 0, 0), so OpenVDB's index
    (0, 0, 0) is centred half a voxel inside it. ``metadata``: name → {key: str}."""
    with tempfile.TemporaryDirectory(prefix="incandescent-vdb-") as folder:
        translation = [float(o) + 0.5 * voxel_size_m for o in origin_m]
        specs = []
        for i, (name, values) in enumerate(grids.items()):
            file = os.path.join(folder, f"grid_{i}.npy")
            np.save(file, np.ascontiguousarray(values, dtype=np.float32), allow_pickle=False)
            specs.append(
                {
                    "name": name,
                    "file": file,
                    "voxel_size": voxel_size_m,
                    "translation": translation,
                    "metadata": metadata.get(name, {}),
                }
            )
        ask(path, {"op": "write", "path": str(path), "grids": specs})
