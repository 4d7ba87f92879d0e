"""Why the fire solver's step is gather-bound on the CPU: a 7-point stencil product at 128³ in
Dr.Jit's LLVM backend, side by side with a pass that reads its array contiguously.

Dr.Jit reads a neighbour ``x[c ± stride]`` with a gather — on x86 a hardware gather instruction
per SIMD vector, one element per lane — even where the indices are consecutive; it has no
contiguous shifted load. Timed in interleaved rounds (medians), each forcing the kernel's
evaluation:

- ``elementwise``: y = 2x + 1 (one contiguous read, one write): the memory-bound floor;
- ``stencil``: the pressure operator's product ``pressure.apply`` on the whole 128³ grid
  (a fluid box with an open top, six masked neighbour gathers a cell);
- ``stencil_packet``: the same product with Dr.Jit's packet gathers (each thread reads 8
  consecutive cells as one ``ArrayXf`` and shifts along z in registers; 5 packet gathers and 2
  single ones per 8 cells, a packet scatter of the result);
- ``solve``: one multigrid-preconditioned CG solve (``pressure.solve``, tolerance 1e-4) of a
  smooth right-hand side, with Dr.Jit's kernel history: each kernel's execution time, grouped by
  (size, operations), so the share of the gather-heavy fine-grid products is counted, not guessed.

Usage: ``python benchmarks/stencil_gather_cost.py OUT.json [--size 128] [--rounds 10]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from collections import defaultdict
from pathlib import Path

import drjit as dr
import numpy as np
from scipy.ndimage import gaussian_filter

from incandescent.simulation import pressure
from incandescent.simulation.arrays import ops_for

PACKET = 8


def _problem(n: int):
    """(ops, levels, b): a fluid box with a solid floor and open sides and top."""
    ops = ops_for("cpu")
    fluid = np.ones((n, n, n), bool)
    fluid[:, 0, :] = False
    levels = pressure.hierarchy(ops, (n, n, n), fluid, (1, 1, 0, 1, 1, 1))
    noise = np.random.default_rng(1).standard_normal((n, n, n))
    b = ops.array((gaussian_filter(noise, 3) * fluid).astype(np.float32).ravel())
    ops.evaluate(b)
    return ops, levels, b


def packet_apply(level: pressure.Level, x):
    """``pressure.apply`` with packet gathers of PACKET consecutive cells along z."""
    from drjit.llvm import ArrayXf, ArrayXi, Float, Int32, UInt32

    size, (sx, sy, _) = level.layout.size, level.strides()
    m = size // PACKET
    t = dr.arange(Int32, m)
    code = dr.gather(ArrayXi, level.code, UInt32(t), shape=(PACKET, m))
    xc = dr.gather(ArrayXf, x, UInt32(t), shape=(PACKET, m))
    total = [Float(0.0)] * PACKET
    for axis, stride in enumerate((sx, sy)):
        for side, step in enumerate((-stride, stride)):
            index = t + step // PACKET
            inside = (index >= 0) & (index < m)
            near = dr.gather(ArrayXf, x, UInt32(index), inside, shape=(PACKET, m))
            bit = 1 << (2 * axis + side)
            for k in range(PACKET):
                total[k] = total[k] + dr.select((code[k] & bit) != 0, near[k], 0.0)
    below = dr.gather(Float, x, UInt32(t * PACKET - 1), t > 0)
    above = dr.gather(Float, x, UInt32(t * PACKET + PACKET), t < m - 1)
    lower, upper = [below, *xc[: PACKET - 1]], [*xc[1:], above]
    out = []
    for k in range(PACKET):
        near = dr.select((code[k] & (1 << 4)) != 0, lower[k], 0.0)  # z−, bit 2·axis + side
        near = near + dr.select((code[k] & (1 << 5)) != 0, upper[k], 0.0)  # z+
        out.append(Float(code[k] >> pressure.DIAGONAL_SHIFT) * xc[k] - (total[k] + near))
    result = dr.zeros(Float, size)
    dr.scatter(result, ArrayXf(out), UInt32(t))
    return result


def _timed(function, x) -> float:
    began = time.perf_counter()
    y = function(x)
    dr.eval(y)
    dr.sync_thread()
    return time.perf_counter() - began


def products(ops, levels, b, rounds: int) -> dict:
    """Median ms of each product over interleaved rounds, and the packet product's agreement."""
    level = levels[0]
    cases = {
        "elementwise": lambda x: x * 2.0 + 1.0,
        "stencil": lambda x: pressure.apply(ops, level, x),
        "stencil_packet": lambda x: packet_apply(level, x),
    }
    for f in cases.values():  # compile
        _timed(f, b)
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(rounds):
        for name, f in cases.items():
            times[name].append(_timed(f, b))
    plain, packed = cases["stencil"](b), cases["stencil_packet"](b)
    differ = float(np.abs(ops.numpy(plain) - ops.numpy(packed)).max())
    return {name: statistics.median(t) * 1e3 for name, t in times.items()} | {
        "packet_max_difference": differ
    }


def solve_kernels(ops, levels, b) -> dict:
    """One solve's kernels by (size, operations): count and total execution ms."""
    pressure.solve(ops, levels, b, 1e-4)  # compile
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()
    began = time.perf_counter()
    x, report = pressure.solve(ops, levels, b, 1e-4)
    dr.eval(x)
    dr.sync_thread()
    wall = time.perf_counter() - began
    history = dr.kernel_history()
    dr.set_flag(dr.JitFlag.KernelHistory, False)
    groups: dict[tuple, list[float]] = defaultdict(lambda: [0, 0.0])
    for kernel in history:
        key = (int(kernel.get("size") or 0), kernel.get("operation_count"))
        groups[key][0] += 1
        groups[key][1] += float(kernel.get("execution_time", 0.0))
    rows = sorted(groups.items(), key=lambda kv: -kv[1][1])
    return {
        "iterations": report.iterations,
        "wall_ms": wall * 1e3,
        "kernel_ms": sum(t for _, t in groups.values()),
        "kernels": [{"size": k[0], "operations": k[1], "count": c, "ms": t} for k, (c, t) in rows],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--rounds", type=int, default=10)
    args = parser.parse_args()
    if args.size % PACKET or args.size < 2 * PACKET:
        parser.error(f"--size {args.size}: expected a multiple of {PACKET}, at least {2 * PACKET}")
    ops, levels, b = _problem(args.size)
    result = {
        "size": args.size,
        "machine": platform.processor() or platform.machine(),
        "products_ms": products(ops, levels, b, args.rounds),
        "solve": solve_kernels(ops, levels, b),
    }
    args.out.write_text(json.dumps(result, indent=1))
    print(json.dumps(result["products_ms"], indent=1))
    print({k: v for k, v in result["solve"].items() if k != "kernels"})


if __name__ == "__main__":
    main()
