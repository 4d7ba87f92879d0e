"""Backend parameters for tests that check every backend against a closed form: the float64
reference, Dr.Jit on the CPU, and Dr.Jit on CUDA where a GPU exists (skipped cleanly elsewhere)."""

from __future__ import annotations

import numpy as np
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


def assert_states_close(reference, fast, names, rtol: float = 1e-5, nonzero: bool = False) -> None:
    """Two fire-solver runs, each ``(solver, state)``, agree: the cell fields ``names`` and the
    three face velocities within ``rtol`` (and ``rtol`` × each reference field's largest value);
    ``nonzero``: each named reference field must also hold something (a comparison of zeros
    shows nothing)."""
    (ref_solver, ref), (fast_solver, out) = reference, fast
    pairs = [(getattr(out, n), getattr(ref, n)) for n in names]
    pairs += [(out.velocity[a], ref.velocity[a]) for a in range(3)]
    for index, (a, b) in enumerate(pairs):
        a, b = fast_solver.ops.numpy(a.values), ref_solver.ops.numpy(b.values)
        if nonzero and index < len(names):
            assert np.abs(b).max() > 0, names[index]
        np.testing.assert_allclose(a, b, rtol=rtol, atol=rtol * np.abs(b).max())
