"""Backend registry: ``reference`` (NumPy float64), ``cpu`` (Dr.Jit LLVM), ``cuda`` (Dr.Jit CUDA).

Selection (DESIGN.md §4): an explicit name, else the environment variable ``INCANDESCENT_BACKEND``,
else "auto" (cuda if a GPU is usable, then cpu). No global state: the resolved name is passed down.
"""

from __future__ import annotations

import logging
import os

from incandescent._jit import BackendUnavailable, cuda_problem, llvm_problem
from incandescent.renderer.backends.common import MarchInputs, MarchResult

BACKENDS = ("reference", "cpu", "cuda")
ENV_VAR = "INCANDESCENT_BACKEND"
log = logging.getLogger("incandescent")

__all__ = ["BACKENDS", "BackendUnavailable", "available_backends", "resolve_backend", "run_march"]


def _problem(name: str) -> str | None:
    if name == "reference":
        return None
    return llvm_problem() if name == "cpu" else cuda_problem()


def available_backends() -> list[str]:
    """Backends that can run on this machine, fastest first."""
    return [b for b in ("cuda", "cpu", "reference") if _problem(b) is None]


def resolve_backend(name: str | None = "auto") -> str:
    """Resolve "auto" / None / env to a concrete backend name; errors say what is missing."""
    requested = name if name not in (None, "auto") else os.environ.get(ENV_VAR, "auto")
    source = (
        f"environment {ENV_VAR}" if name in (None, "auto") and requested != "auto" else "backend"
    )
    if requested == "auto":
        chosen = available_backends()[0]
        log.info("backend auto-selected: %s", chosen)
        return chosen
    if requested not in BACKENDS:
        raise ValueError(
            f"unknown {source} {requested!r}; expected one of: auto, {', '.join(BACKENDS)}"
        )
    problem = _problem(requested)
    if problem:
        raise BackendUnavailable(f"backend {requested!r} is unavailable: {problem}")
    return requested


def run_march(inputs: MarchInputs, backend: str, progress=None) -> MarchResult:
    """March with a resolved backend name; ``progress(fraction)`` is called as rays finish (the
    fast backends, between chunks of rays)."""
    if backend == "reference":
        from incandescent.renderer.backends import reference

        return reference.march(inputs)
    from incandescent.renderer.backends import chunks

    return chunks.march(inputs, backend, progress)
