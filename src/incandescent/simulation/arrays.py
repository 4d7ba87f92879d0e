"""The few array operations the fire solver needs, for NumPy (float64, the reference) and Dr.Jit
(float32, cpu and cuda): the solver is written once over the :class:`Ops` protocol and runs on
either, so the float64 reference and the fast backends execute the same algorithm step for step.

Fields are flat arrays in C order of their (nx, ny, nz) shape, z fastest, like the volumes.
"""

from __future__ import annotations

from typing import Any, Protocol, TypeAlias, runtime_checkable

import numpy as np

#: One backend array: a NumPy float64 (or int64) ndarray on the reference ops, a Dr.Jit Float
#: (or Int) on cpu and cuda. Dr.Jit generates its array types per backend, so no static type
#: names both: what the type checker verifies is that each backend implements :class:`Ops`.
Array: TypeAlias = Any


@runtime_checkable
class Ops(Protocol):
    """Array operations of one backend. ``name``: "reference" (NumPy float64), "cpu" or "cuda".
    A protocol: :func:`ops_for` returns each backend as one, so mypy checks that both implement
    every operation with these signatures."""

    name: str

    def array(self, values) -> Array: ...

    def index(self, values) -> Array:
        """An integer index array (int32 on Dr.Jit)."""
        ...

    def arange(self, n: int) -> Array: ...

    def full(self, n: int, value: float) -> Array: ...

    def gather(self, source: Array, index: Array, mask: Array | None = None) -> Array:
        """source[index]; where ``mask`` is False, 0 (and the index is not read)."""
        ...

    def select(self, mask: Array, a: Array | float, b: Array | float) -> Array: ...

    def compress(self, mask: Array) -> Array:
        """The indices where ``mask`` is True, in order (this synchronises)."""
        ...

    def scatter(self, target: Array, values: Array, index: Array) -> Array:
        """A copy of ``target`` with ``values`` at ``index`` (``target`` itself unchanged)."""
        ...

    def width(self, x: Array) -> int: ...

    def floor_int(self, x: Array) -> Array:
        """⌊x⌋ as an integer array."""
        ...

    def to_float(self, i: Array) -> Array: ...

    def sum(self, x: Array) -> float: ...

    def max_abs(self, x: Array) -> float: ...

    def evaluate(self, *arrays: Array) -> None:
        """Compute lazily built arrays now (a no-op for NumPy)."""
        ...

    def scalar(self, value: float) -> Array | float:
        """A per-call number (a time step, a CG coefficient): a kernel *input* on Dr.Jit, so a
        new value reuses the compiled kernel instead of tracing a new constant into one."""
        ...

    def scalar_int(self, value: int) -> Array | int:
        """An integer kernel input (see :meth:`scalar`)."""
        ...

    def numpy(self, x: Array) -> np.ndarray: ...

    def clip(self, x: Array, low: Array | float, high: Array | float) -> Array:
        """min(max(x, low), high)."""
        ...

    def minimum(self, a: Array, b: Array | float) -> Array: ...

    def maximum(self, a: Array, b: Array | float) -> Array: ...

    def sqrt(self, x: Array) -> Array: ...

    def cos(self, x: Array) -> Array: ...

    def exp(self, x: Array) -> Array: ...


class NumpyOps:
    """The float64 reference."""

    name = "reference"

    def array(self, values) -> np.ndarray:
        return np.array(values, dtype=np.float64).ravel()

    def index(self, values) -> np.ndarray:
        return np.asarray(values, dtype=np.int64).ravel()

    def arange(self, n: int) -> np.ndarray:
        return np.arange(n, dtype=np.int64)

    def full(self, n: int, value: float) -> np.ndarray:
        return np.full(n, float(value))

    def gather(self, source: Array, index: Array, mask: Array | None = None) -> Array:
        if mask is None:
            return source[index]
        return np.where(mask, source[np.where(mask, index, 0)], 0.0)

    def select(self, mask: Array, a: Array | float, b: Array | float) -> Array:
        return np.where(mask, a, b)

    def compress(self, mask: Array) -> Array:
        return np.flatnonzero(mask)

    def scatter(self, target: Array, values: Array, index: Array) -> Array:
        out = np.array(target, copy=True)
        out[index] = values
        return out

    def width(self, x: Array) -> int:
        return int(np.size(x))

    def floor_int(self, x: Array) -> Array:
        return np.floor(x).astype(np.int64)

    def to_float(self, i: Array) -> Array:
        return np.asarray(i, dtype=np.float64)

    def sum(self, x: Array) -> float:
        return float(np.sum(x))

    def max_abs(self, x: Array) -> float:
        return float(np.max(np.abs(x))) if np.size(x) else 0.0

    def evaluate(self, *arrays: Array) -> None:
        """NumPy computes eagerly: nothing to do."""

    def scalar(self, value: float) -> float:
        return float(value)

    def scalar_int(self, value: int) -> int:
        return int(value)

    def numpy(self, x: Array) -> np.ndarray:
        return np.asarray(x, dtype=np.float64)

    def clip(self, x: Array, low: Array | float, high: Array | float) -> Array:
        return np.minimum(np.maximum(x, low), high)

    def minimum(self, a: Array, b: Array | float) -> Array:
        return np.minimum(a, b)

    def maximum(self, a: Array, b: Array | float) -> Array:
        return np.maximum(a, b)

    def sqrt(self, x: Array) -> Array:
        return np.sqrt(x)

    def cos(self, x: Array) -> Array:
        return np.cos(x)

    def exp(self, x: Array) -> Array:
        return np.exp(x)


class DrJitOps:
    """Dr.Jit on ``kind`` "cpu" (LLVM) or "cuda", float32."""

    def __init__(self, kind: str) -> None:
        from incandescent._jit import array_module, drjit_module

        self.m, self.dr, self.name = array_module(kind), drjit_module(), kind

    def array(self, values) -> Array:
        return self.m.Float(np.ascontiguousarray(values, dtype=np.float32).ravel())

    def index(self, values) -> Array:
        return self.m.Int(np.ascontiguousarray(values, dtype=np.int32).ravel())

    def arange(self, n: int) -> Array:
        return self.dr.arange(self.m.Int, n)

    def full(self, n: int, value: float) -> Array:
        return self.dr.full(self.m.Float, float(value), n)

    def gather(self, source: Array, index: Array, mask: Array | None = None) -> Array:
        active = True if mask is None else mask
        return self.dr.gather(type(source), source, self.m.UInt(index), active)

    def select(self, mask: Array, a: Array | float, b: Array | float) -> Array:
        return self.dr.select(mask, a, b)

    def compress(self, mask: Array) -> Array:
        return self.m.Int(self.dr.compress(mask))

    def scatter(self, target: Array, values: Array, index: Array) -> Array:
        out = type(target)(target)  # the same variable: Dr.Jit copies it before writing
        self.dr.scatter(out, values, self.m.UInt(index))
        return out

    def width(self, x: Array) -> int:
        return int(self.dr.width(x))

    def floor_int(self, x: Array) -> Array:
        return self.m.Int(self.dr.floor(x))

    def to_float(self, i: Array) -> Array:
        return self.m.Float(i)

    def sum(self, x: Array) -> float:
        return self._scalar(self.dr.sum(x))

    def max_abs(self, x: Array) -> float:
        return self._scalar(self.dr.max(self.dr.abs(x))) if self.dr.width(x) else 0.0

    @staticmethod
    def _scalar(value: Array) -> float:
        """A 1-wide Dr.Jit result (a reduction) as a Python float (this synchronises)."""
        return float(np.asarray(value, dtype=np.float64).ravel()[0])

    def evaluate(self, *arrays: Array) -> None:
        self.dr.eval(*arrays)

    def scalar(self, value: float) -> Array:
        return self.dr.opaque(self.m.Float, float(value))

    def scalar_int(self, value: int) -> Array:
        return self.dr.opaque(self.m.Int, int(value))

    def numpy(self, x: Array) -> np.ndarray:
        return np.asarray(x, dtype=np.float64)

    def clip(self, x: Array, low: Array | float, high: Array | float) -> Array:
        return self.dr.minimum(self.dr.maximum(x, low), high)

    def minimum(self, a: Array, b: Array | float) -> Array:
        return self.dr.minimum(a, b)

    def maximum(self, a: Array, b: Array | float) -> Array:
        return self.dr.maximum(a, b)

    def sqrt(self, x: Array) -> Array:
        return self.dr.sqrt(x)

    def cos(self, x: Array) -> Array:
        return self.dr.cos(x)

    def exp(self, x: Array) -> Array:
        return self.dr.exp(x)


def ops_for(backend: str) -> Ops:
    """The operations of ``backend``: "reference", "cpu" or "cuda"."""
    if backend == "reference":
        return NumpyOps()
    if backend in ("cpu", "cuda"):
        return DrJitOps(backend)
    raise ValueError(f"unknown simulation backend {backend!r}; expected reference, cpu or cuda")
