"""The few array operations the fire solver needs, for NumPy (float64, the reference) and Dr.Jit
(float32, cpu and cuda): the solver is written once over :class:`Ops` and runs on either, so the
float64 reference and the fast backends execute the same algorithm step for step.

Fields are flat arrays in C order of their (nx, ny, nz) shape, z fastest, like the volumes.
"""

from __future__ import annotations

from typing import Any

import numpy as np


class Ops:
    """Array operations of one backend. ``name``: "reference" (NumPy float64), "cpu" or "cuda"."""

    name: str

    def array(self, values) -> Any:
        raise NotImplementedError

    def index(self, values) -> Any:
        """An integer index array (int32 on Dr.Jit)."""
        raise NotImplementedError

    def arange(self, n: int) -> Any:
        raise NotImplementedError

    def full(self, n: int, value: float) -> Any:
        raise NotImplementedError

    def gather(self, source, index, mask=None) -> Any:
        """source[index]; where ``mask`` is False, 0 (and the index is not read)."""
        raise NotImplementedError

    def select(self, mask, a, b) -> Any:
        raise NotImplementedError

    def floor_int(self, x) -> Any:
        """⌊x⌋ as an integer array."""
        raise NotImplementedError

    def to_float(self, i) -> Any:
        raise NotImplementedError

    def sum(self, x) -> float:
        raise NotImplementedError

    def max_abs(self, x) -> float:
        raise NotImplementedError

    def evaluate(self, *arrays) -> None:
        """Compute lazily built arrays now (a no-op for NumPy)."""

    def scalar(self, value: float):
        """A per-call number (a time step, a CG coefficient): a kernel *input* on Dr.Jit, so a
        new value reuses the compiled kernel instead of tracing a new constant into one."""
        return float(value)

    def scalar_int(self, value: int):
        """An integer kernel input (see :meth:`scalar`)."""
        return int(value)

    def numpy(self, x) -> np.ndarray:
        raise NotImplementedError

    # shared spellings
    def clip(self, x, low, high):
        return self.minimum(self.maximum(x, low), high)

    def minimum(self, a, b):
        raise NotImplementedError

    def maximum(self, a, b):
        raise NotImplementedError

    def sqrt(self, x):
        raise NotImplementedError

    def cos(self, x):
        raise NotImplementedError


class NumpyOps(Ops):
    """The float64 reference."""

    name = "reference"

    def array(self, values):
        return np.array(values, dtype=np.float64).ravel()

    def index(self, values):
        return np.asarray(values, dtype=np.int64).ravel()

    def arange(self, n):
        return np.arange(n, dtype=np.int64)

    def full(self, n, value):
        return np.full(n, float(value))

    def gather(self, source, index, mask=None):
        if mask is None:
            return source[index]
        return np.where(mask, source[np.where(mask, index, 0)], 0.0)

    def select(self, mask, a, b):
        return np.where(mask, a, b)

    def floor_int(self, x):
        return np.floor(x).astype(np.int64)

    def to_float(self, i):
        return np.asarray(i, dtype=np.float64)

    def sum(self, x):
        return float(np.sum(x))

    def max_abs(self, x):
        return float(np.max(np.abs(x))) if np.size(x) else 0.0

    def numpy(self, x):
        return np.asarray(x, dtype=np.float64)

    def minimum(self, a, b):
        return np.minimum(a, b)

    def maximum(self, a, b):
        return np.maximum(a, b)

    def sqrt(self, x):
        return np.sqrt(x)

    def cos(self, x):
        return np.cos(x)


class DrJitOps(Ops):
    """Dr.Jit on ``kind`` "cpu" (LLVM) or "cuda", float32."""

    def __init__(self, kind: str) -> None:
        from incandescent._jit import array_module, drjit_module

        self.m, self.dr, self.name = array_module(kind), drjit_module(), kind

    def array(self, values):
        return self.m.Float(np.ascontiguousarray(values, dtype=np.float32).ravel())

    def index(self, values):
        return self.m.Int(np.ascontiguousarray(values, dtype=np.int32).ravel())

    def arange(self, n):
        return self.dr.arange(self.m.Int, n)

    def full(self, n, value):
        return self.dr.full(self.m.Float, float(value), n)

    def gather(self, source, index, mask=None):
        active = True if mask is None else mask
        return self.dr.gather(type(source), source, self.m.UInt(index), active)

    def select(self, mask, a, b):
        return self.dr.select(mask, a, b)

    def floor_int(self, x):
        return self.m.Int(self.dr.floor(x))

    def to_float(self, i):
        return self.m.Float(i)

    def sum(self, x):
        return self._scalar(self.dr.sum(x))

    def max_abs(self, x):
        return self._scalar(self.dr.max(self.dr.abs(x))) if self.dr.width(x) else 0.0

    @staticmethod
    def _scalar(value) -> float:
        """A 1-wide Dr.Jit result (a reduction) as a Python float (this synchronises)."""
        return float(np.asarray(value, dtype=np.float64).ravel()[0])

    def evaluate(self, *arrays):
        self.dr.eval(*arrays)

    def scalar(self, value: float):
        return self.dr.opaque(self.m.Float, float(value))

    def scalar_int(self, value: int):
        return self.dr.opaque(self.m.Int, int(value))

    def numpy(self, x):
        return np.asarray(x, dtype=np.float64)

    def minimum(self, a, b):
        return self.dr.minimum(a, b)

    def maximum(self, a, b):
        return self.dr.maximum(a, b)

    def sqrt(self, x):
        return self.dr.sqrt(x)

    def cos(self, x):
        return self.dr.cos(x)


def ops_for(backend: str) -> Ops:
    """The operations of ``backend``: "reference", "cpu" or "cuda"."""
    if backend == "reference":
        return NumpyOps()
    if backend in ("cpu", "cuda"):
        return DrJitOps(backend)
    raise ValueError(f"unknown simulation backend {backend!r}; expected reference, cpu or cuda")
