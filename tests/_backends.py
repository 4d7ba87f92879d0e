"""Backend parameters for tests that check every backend against a closed form: the float64
reference, Dr.Jit on the CPU, and Dr.Jit on CUDA where a GPU exists (skipped cleanly elsewhere)."""

from __future__ import annotations

import pytest

from incandescent._jit import cuda_problem, llvm_problem


def backend_param(name: str):
    """``name`` as a pytest param, skipped (with the reason) where it cannot run."""
    problem = {"reference": None, "cpu": llvm_problem, "cuda": cuda_problem}[name]
    reason = problem() if problem else None
    marks = [pytest.mark.skipif(reason is not None, reason=reason or "")]
    if name == "cuda":
        marks.append(pytest.mark.cuda)
    return pytest.param(name, marks=marks, id=name)


#: Every backend: reference, cpu, cuda.
ALL_BACKENDS = [backend_param(name) for name in ("reference", "cpu", "cuda")]
