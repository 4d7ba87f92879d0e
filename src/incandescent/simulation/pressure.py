"""Pressure projection: multigrid-preconditioned conjugate gradients on the cell Laplacian.

The projection solves A φ = b with A = −∇² discretised on the cells (unit spacing): for cell c,
(A φ)_c = d_c φ_c − Σ_n w_cn φ_n over its six faces, where a face to a fluid cell has w = 1 and
adds 1 to d_c, a face to open air (the domain's open sides and top) adds 1 to d_c with φ = 0 there
(Dirichlet), and a face to a solid (the floor, obstacles) adds nothing (Neumann: no flow through
it). Solid cells are not unknowns (d = 1, φ = 0). A is symmetric positive definite.

Preconditioner (McAdams, Sifakis & Teran 2010, simplified): one V-cycle with damped Jacobi
smoothing (ω = 0.9, one sweep before and one after), restriction R = sum over the 8 children and
piecewise-constant prolongation P = Rᵀ, and coarse operators ``COARSE_RATIO`` = 3 per level × the
rediscretised unit Laplacian of the coarsened masks — softer than the Galerkin product PᵀAP of
interior cells (4 per level), which with piecewise-constant transfers is too stiff for smooth
errors (by 2 per level: it under-corrects them; Braess 1995's over-correction of aggregation
multigrid). Jacobi and R = Pᵀ keep the V-cycle symmetric, and ω < 1 (2D/ω − A positive
definite) keeps it positive definite, as CG needs (tested). The solve stops when
max|r| ≤ ``tolerance`` · max|b|; the iterations and the final relative residual are reported.

On a box without obstacles A separates, A = T_x ⊗ I ⊗ I + I ⊗ T_y ⊗ I + I ⊗ I ⊗ T_z with T_a the
1-D operator of axis a (2 on the diagonal, −1 off it; a closed side's end row 1), and its inverse
is exact and cheap by fast diagonalisation (Lynch, Rice & Thomas 1964, Numer. Math. 6:185):
T_a = Q_a Λ_a Q_aᵀ, A⁻¹ = (Q_x ⊗ Q_y ⊗ Q_z) (Λ_x ⊕ Λ_y ⊕ Λ_z)⁻¹ (Q_x ⊗ Q_y ⊗ Q_z)ᵀ — six
matrix products along the axes (BLAS, on the host) and a division. ``Direct`` is that inverse;
as the preconditioner of the same PCG it solves the constant-coefficient projection in one
iteration (and can precondition the variable-density one, where the V-cycle is faster). A 128³
solve takes ~40 ms in float32 on 2 cores where the V-cycle's takes ~300–360 ms (17–19
iterations; issue 28, ``benchmarks/fire_vs_mantaflow.py``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from threadpoolctl import ThreadpoolController

from incandescent.simulation.grid import Layout, cells, flat_index, indices

#: Damped Jacobi, one sweep before and after (ω < 1 keeps the V-cycle positive definite).
#: Measured on the explosion's 128³ solves (issue 28; interleaved medians, the same
#: right-hand side): with the Galerkin ratio 4 and ω = 0.8, 26–28 iterations, 510 ms; with
#: ``COARSE_RATIO`` 3, ω = 0.8 21 iterations, ω = 0.9 19 (362 ms), ω = 0.95 18–19; two sweeps
#: (ratio 2.5, ω = 0.8) 12–13 iterations but 366 ms (each sweep a stencil product).
JACOBI_WEIGHT = 0.9
SMOOTHING_SWEEPS = 1
#: Each coarser level's operator is this times the unit Laplacian of its own cells, relative to
#: the level above: 4 would be the Galerkin product PᵀAP, 2 the smooth modes' exact ratio with
#: R = sum of 8 and P = injection. Iterations at 64³ / 128³ (ω = 0.8): ratio 4: 19–20 / 26–28,
#: 3: 16–17 / 21, 2.5: 16–17 / 21, 2: 20 / –, 1.8: 22–23 / –.
COARSE_RATIO = 3.0
COARSEST_SWEEPS = 24


#: A level's per-cell code: bit 2·axis + side (side 0: −, 1: +) set when that neighbour is a fluid
#: cell (weight 1), and the diagonal count — fluid neighbours plus open-air faces, 0..6 — above
#: DIAGONAL_SHIFT. One int32 per cell instead of a stored diagonal, six indices and six weights
#: (52 bytes) — the products read far less memory — with the neighbours' indices c ± stride.
DIAGONAL_SHIFT = 8


@dataclass
class Level:
    """One grid of the hierarchy: its per-cell ``code`` (see DIAGONAL_SHIFT) and ``scale``, the
    factor of its operator (``COARSE_RATIO`` per level below the finest)."""

    layout: Layout
    code: Any  # an int array of the backend
    scale: float = 1.0

    def strides(self) -> tuple[int, int, int]:
        _, ny, nz = self.layout.shape
        return ny * nz, nz, 1


@dataclass(frozen=True)
class SolveReport:
    iterations: int
    relative_residual: float


def operator_code(fluid: np.ndarray, open_sides: tuple) -> np.ndarray:
    """The per-cell code (NumPy int32, C order) of a fluid-cell mask and which of the six domain
    sides (x−, x+, y−, y+, z−, z+) are open air; solid cells get 0."""
    code = np.zeros(fluid.shape, dtype=np.int32)
    count = np.zeros(fluid.shape, dtype=np.int32)
    for axis in range(3):
        for side, step in enumerate((-1, 1)):
            other = np.roll(fluid, -step, axis=axis)
            border = np.zeros(fluid.shape, dtype=bool)
            edge = [slice(None)] * 3
            edge[axis] = slice(-1, None) if step > 0 else slice(0, 1)
            border[tuple(edge)] = True
            connected = fluid & other & ~border
            code |= connected.astype(np.int32) << (2 * axis + side)
            count += connected + (fluid & border & bool(open_sides[2 * axis + side]))
    return np.where(fluid, code | (count << DIAGONAL_SHIFT), 0).astype(np.int32)


def operator(ops, layout: Layout, fluid: np.ndarray, open_sides: tuple, scale=1.0) -> Level:
    """The level's A from a fluid-cell mask (NumPy bool, shape ``layout.shape``)."""
    return Level(layout, ops.index(operator_code(fluid, open_sides)), scale)


def diagonal(ops, level: Level):
    """A's diagonal: the count × scale; 1 on solid (and isolated) cells, which are no unknowns."""
    count = ops.to_float(level.code >> DIAGONAL_SHIFT)
    return ops.select(count > 0.0, count * level.scale, 1.0)


def apply(ops, level: Level, x):
    """A x on ``level``: d x − scale · Σ x over the fluid neighbours (indices c ± stride)."""
    cell, total = ops.arange(level.layout.size), 0.0
    for axis, stride in enumerate(level.strides()):
        for side, step in enumerate((-stride, stride)):
            connected = (level.code & (1 << (2 * axis + side))) != 0
            total = total + ops.gather(x, cell + step, connected)
    return diagonal(ops, level) * x - level.scale * total


def hierarchy(ops, shape, fluid: np.ndarray, open_sides: tuple, coarsest: int = 4) -> list[Level]:
    """Levels from ``shape`` down, halving while every side is even and larger than ``coarsest``."""
    levels = [operator(ops, cells(shape), fluid, open_sides)]
    scale = 1.0
    while all(n % 2 == 0 and n > coarsest for n in shape):
        coarse_shape = tuple(n // 2 for n in shape)
        coarse_fluid = np.asarray(
            fluid.reshape(coarse_shape[0], 2, coarse_shape[1], 2, coarse_shape[2], 2).any(
                axis=(1, 3, 5)
            )
        )
        scale *= COARSE_RATIO
        levels.append(operator(ops, cells(coarse_shape), coarse_fluid, open_sides, scale))
        shape, fluid = coarse_shape, coarse_fluid
    ops.evaluate(*(level.code for level in levels))
    return levels


@dataclass(frozen=True)
class Direct:
    """A⁻¹ of an obstacle-free box: the orthonormal eigenvectors ``bases`` (Q_x, Q_y, Q_z, columns)
    of each axis's 1-D operator and ``inverse`` = 1/(λ_x + λ_y + λ_z) on the eigenvalue grid (0
    where the sum is 0: a box closed on every side, whose constant mode is not determined);
    ``workers``: the host threads its matrix products are split over; ``scratch``: three work
    grids kept between solves (fresh ones cost a page fault per 4 KiB each solve)."""

    bases: tuple[np.ndarray, np.ndarray, np.ndarray]
    inverse: np.ndarray
    workers: int = 1
    scratch: tuple[np.ndarray, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        grids = tuple(np.empty(self.inverse.shape, self.inverse.dtype) for _ in range(3))
        object.__setattr__(self, "scratch", grids)


def line_operator(n: int, lower_open: bool, upper_open: bool) -> np.ndarray:
    """T, the 1-D operator of n cells (unit spacing): 2 on the diagonal, −1 beside it; a closed
    end's row has 1 on the diagonal (Neumann: no neighbour there), an open one keeps 2 (the
    Dirichlet ghost cell φ = 0), as ``operator_code`` counts the faces."""
    t = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    t[0, 0] -= 0.0 if lower_open else 1.0
    t[-1, -1] -= 0.0 if upper_open else 1.0
    return t


def direct(
    shape: tuple[int, int, int], open_sides: tuple, dtype=np.float32, workers: int = 1
) -> Direct:
    """The exact inverse of A on an obstacle-free ``shape`` with ``open_sides`` (x−, x+, y−, y+,
    z−, z+), its matrices in ``dtype`` (the backend's float), its products on ``workers``
    threads."""
    pairs = [np.linalg.eigh(line_operator(n, open_sides[2 * a], open_sides[2 * a + 1]))
             for a, n in enumerate(shape)]  # fmt: skip
    lx, ly, lz = (lam for lam, _ in pairs)
    total = lx[:, None, None] + ly[None, :, None] + lz[None, None, :]
    safe = np.where(total > 1e-9, total, 1.0)
    inverse = np.where(total > 1e-9, 1.0 / safe, 0.0)
    bases = tuple(np.ascontiguousarray(q, dtype=dtype) for _, q in pairs)
    return Direct(bases, inverse.astype(dtype), max(1, int(workers)))  # type: ignore[arg-type]


@functools.cache
def _blas() -> ThreadpoolController:
    return ThreadpoolController()


@functools.cache
def _pool(workers: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(workers, thread_name_prefix="incandescent-pressure")


def _split(work: Callable[[slice], None], n: int, workers: int) -> None:
    """``work`` on ``workers`` contiguous slices of range(n), each on a thread of its own (NumPy
    releases the GIL in its products); Python's idle threads sleep, unlike OpenBLAS's."""
    bounds = np.linspace(0, n, min(workers, n) + 1).astype(int)
    parts = [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
    if len(parts) == 1:
        work(parts[0])
        return
    for future in [_pool(workers).submit(work, part) for part in parts]:
        future.result()


def _along_axes(x: np.ndarray, q: tuple, inverse: Direct, out: np.ndarray,
                weight: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """``out`` = x (nx, ny, nz) multiplied along each axis, Σ qx[i, a] qy[j, b] qz[k, c]
    x[a, b, c], then by ``weight`` (nx, ny, nz) if given (while each slab is in cache)."""
    qx, qy, qz = q
    nx, ny, nz = x.shape
    first, middle = inverse.scratch[:2]
    flat, first_flat = x.reshape(nx, ny * nz), first.reshape(nx, ny * nz)

    def along_x(rows: slice) -> None:
        np.matmul(qx[rows], flat, out=first_flat[rows])

    def along_y_z(rows: slice) -> None:
        np.matmul(qy, first[rows], out=middle[rows])  # each x-slab: qy (ny, ny) @ (ny, nz)
        np.matmul(middle[rows], qz.T, out=out[rows])
        if weight is not None:
            out[rows] *= weight[rows]

    _split(along_x, nx, inverse.workers)
    _split(along_y_z, nx, inverse.workers)
    return out


def apply_direct(ops, inverse: Direct, b):
    """A⁻¹ b on the host (b a backend array over the box's cells, C order), BLAS held to one
    thread a call and the work split over ``inverse.workers`` threads."""
    qx, qy, qz = inverse.bases
    shape = inverse.inverse.shape
    values = np.asarray(b).reshape(shape).astype(qx.dtype, copy=False)
    # x fresh each solve: Dr.Jit's Float wraps a NumPy array's memory without copying it
    spectrum, x = inverse.scratch[2], np.empty(shape, qx.dtype)
    with _blas().limit(limits=1, user_api="blas"):
        _along_axes(values, (qx.T, qy.T, qz.T), inverse, spectrum, inverse.inverse)
        _along_axes(spectrum, (qx, qy, qz), inverse, x)
    return ops.array(x.ravel())


def _jacobi(ops, level: Level, x, b, sweeps: int):
    """Damped Jacobi sweeps; x = None is x = 0, whose first sweep is ω b / d (no product)."""
    d = diagonal(ops, level)
    for _ in range(sweeps):
        if x is None:
            x = JACOBI_WEIGHT * b / d
        else:
            x = x + JACOBI_WEIGHT * (b - apply(ops, level, x)) / d
    return x


def _restrict(ops, levels: list[Level], depth: int, r):
    """Σ over each coarse cell's 8 children of ``r`` (R = Pᵀ), gathered (no scatter)."""
    fine, coarse = levels[depth], levels[depth + 1]
    i, j, k = indices(ops, coarse.layout)
    total = None
    for a in (0, 1):
        for b in (0, 1):
            for c in (0, 1):
                child = flat_index(fine.layout, 2 * i + a, 2 * j + b, 2 * k + c)
                value = ops.gather(r, child)
                total = value if total is None else total + value
    return total


def _parent(ops, fine: Level, coarse: Level):
    """Each fine cell's parent on the next coarser level (P: piecewise constant)."""
    i, j, k = indices(ops, fine.layout)
    return flat_index(coarse.layout, i // 2, j // 2, k // 2)


def v_cycle(ops, levels: list[Level], b, depth: int = 0):
    """One V-cycle for A x = b from x = 0 (the preconditioner M⁻¹ b)."""
    level = levels[depth]
    if depth == len(levels) - 1:
        return _jacobi(ops, level, None, b, COARSEST_SWEEPS)
    x = _jacobi(ops, level, None, b, SMOOTHING_SWEEPS)
    residual = b - apply(ops, level, x)
    coarse = v_cycle(ops, levels, _restrict(ops, levels, depth, residual), depth + 1)
    x = x + ops.gather(coarse, _parent(ops, level, levels[depth + 1]))
    x = _jacobi(ops, level, x, b, SMOOTHING_SWEEPS)
    ops.evaluate(x)
    return x


def _exactly(ops, level: Level, exact: Direct, b, scale: float):
    """(x = A⁻¹ b, max|b − A x| / ``scale``): the exact inverse's solution and its residual."""
    x = apply_direct(ops, exact, b)
    ops.evaluate(x)
    return x, ops.max_abs(b - apply(ops, level, x)) / scale


def solve(
    ops,
    levels: list[Level],
    b,
    tolerance: float = 1e-4,
    max_iterations: int = 200,
    guess=None,
    operator: Callable[[Any], Any] | None = None,
    scale_cells=None,
    exact: Direct | None = None,
):
    """x with A x = b; (x, SolveReport). PCG from ``guess`` (the last step's pressure) or 0,
    preconditioned by the V-cycle or by ``exact``, the obstacle-free box's A⁻¹; for A itself
    ``exact`` solves at once (one iteration; PCG from there only if float32 rounding left the
    residual above ``tolerance``). ``operator``: another symmetric positive definite A of the
    same grid (x ↦ A x; the variable-density projection's −∇·(β∇)), preconditioned by the
    constant-coefficient inverse symmetrically scaled by ``scale_cells`` s (M⁻¹ r = s V(s r);
    s = √(d/d_β), the ratio of the diagonals, makes it see β's scale); None: ``levels[0]``'s."""
    level = levels[0]
    product = operator or (lambda x: apply(ops, level, x))

    def inverse(r):
        return v_cycle(ops, levels, r) if exact is None else apply_direct(ops, exact, r)

    def precondition(r):
        if scale_cells is None:
            return inverse(r)
        return scale_cells * inverse(scale_cells * r)

    scale = ops.max_abs(b)
    if scale == 0.0:
        return b * 0.0, SolveReport(0, 0.0)
    if exact is not None and operator is None:  # A⁻¹ b at once; PCG only if rounding left more
        x, relative = _exactly(ops, level, exact, b, scale)
        if relative <= tolerance:
            return x, SolveReport(1, relative)
        guess = x
    x = b * 0.0 if guess is None else guess
    r = b - product(x)
    if ops.max_abs(r) <= tolerance * scale:
        return x, SolveReport(0, ops.max_abs(r) / scale)
    z = precondition(r)
    p, rz = z, ops.sum(r * z)
    for iteration in range(1, max_iterations + 1):
        ap = product(p)
        ops.evaluate(ap)
        alpha = ops.scalar(rz / ops.sum(p * ap))
        x, r = x + alpha * p, r - alpha * ap
        ops.evaluate(x, r)
        relative = ops.max_abs(r) / scale
        if relative <= tolerance:
            return x, SolveReport(iteration, relative)
        z = precondition(r)
        rz_next = ops.sum(r * z)
        p, rz = z + ops.scalar(rz_next / rz) * p, rz_next
        ops.evaluate(p)
    return x, SolveReport(max_iterations, ops.max_abs(r) / scale)
