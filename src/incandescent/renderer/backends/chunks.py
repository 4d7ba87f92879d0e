"""The host loop of the Dr.Jit backends: camera rays marched in chunks (a Ctrl-C is honoured
between chunks, ``progress`` is called after each), sized from the last chunk's ray rate, with
inputs aligned so that one compiled kernel serves every process."""

from __future__ import annotations

import time

import numpy as np

from incandescent._jit import array_module, device_name, drjit_module
from incandescent.renderer.backends.common import MarchInputs, MarchResult, upper_samples_per_ray
from incandescent.renderer.backends.kernel import Kernel
from incandescent.renderer.backends.march import trace
from incandescent.renderer.rays import lane_order

#: Chunks of rays. The first holds FIRST_CHUNK_SAMPLES upper-bound samples (rays × steps across
#: the box diagonal): a 512² image of a 256³ volume at step 0.5 is one chunk. Later chunks take
#: about CHUNK_SECONDS at the last chunk's ray rate, grow at most 2× per chunk (rays elsewhere in
#: the image can cost far more) and hold at most MAX_CHUNK_SAMPLES upper-bound samples. Below
#: MIN_CHUNK_RAYS the CPU backend loses its threads (Dr.Jit hands threads blocks of 16 384
#: lanes). A Ctrl-C raises KeyboardInterrupt between chunks.
FIRST_CHUNK_SAMPLES, MAX_CHUNK_SAMPLES = 2.5e8, 1e9


CHUNK_SECONDS = 0.25


MIN_CHUNK_RAYS, MAX_CHUNK_RAYS = 1 << 15, 1 << 22


def _first_chunk(spec, settings) -> int:
    per_ray = upper_samples_per_ray(spec.shape, settings.step_voxels)
    rays = int(np.clip(FIRST_CHUNK_SAMPLES / per_ray, MIN_CHUNK_RAYS, MAX_CHUNK_RAYS))
    return rays // ALIGN_LANES * ALIGN_LANES


def _next_chunk(rays: int, seconds: float, upper_per_ray: float) -> int:
    """Rays in the next chunk after ``rays`` took ``seconds`` (see CHUNK_SECONDS), a multiple of
    ALIGN_LANES."""
    size = min(2 * rays, rays / max(seconds, 1e-3) * CHUNK_SECONDS)
    size = min(size, MAX_CHUNK_SAMPLES / upper_per_ray)
    return int(np.clip(size, MIN_CHUNK_RAYS, MAX_CHUNK_RAYS)) // ALIGN_LANES * ALIGN_LANES


#: Lanes per 64 bytes of a 32-bit input. Dr.Jit maps NumPy inputs without a copy and writes each
#: one's alignment into the kernel it traces: arrays that start on a 64-byte boundary in every
#: process keep one kernel (a disk-cache hit) instead of one per alignment found (a 30 ms compile).
ALIGN_LANES = 16


def _aligned(a: np.ndarray, alignment: int = 64) -> np.ndarray:
    """A copy of ``a`` whose data starts on an ``alignment``-byte boundary."""
    buffer = np.empty(a.nbytes + alignment, dtype=np.uint8)
    offset = -buffer.ctypes.data % alignment
    out = buffer[offset : offset + a.nbytes].view(a.dtype)
    out[:] = a
    return out


def _march_chunk(inputs: MarchInputs, m, K: Kernel, order) -> tuple[list[np.ndarray], int, float]:
    """March the rays of one chunk: ([X, Y, Z, Tr, depth] per lane, samples, compile seconds)."""
    dr = drjit_module()
    dr.kernel_history()  # clear
    L, tr, n, depth = trace(inputs, m, order, K)
    dr.eval(L, tr, n, depth)
    dr.sync_thread()
    compile_s = sum(_compile_seconds(h) for h in dr.kernel_history())
    lanes = len(order[0])

    def per_lane(values) -> np.ndarray:  # a loop variable no lane changed comes back as 1 value
        return np.broadcast_to(np.asarray(values, dtype=np.float64), (lanes,))

    columns = [per_lane(L[a]) for a in range(3)] + [per_lane(tr), per_lane(depth)]
    return columns, int(np.asarray(n, dtype=np.uint64).sum()), compile_s


def _kernel(m, inputs: MarchInputs) -> tuple[Kernel, float]:
    """The render's kernel and the seconds its program's one-off work took (shadow grids, the
    in-scatter cache: part of the render's cost), compilation excluded."""
    dr = drjit_module()
    dr.kernel_history()  # clear
    began = time.perf_counter()
    K = Kernel(m, inputs)
    dr.sync_thread()
    compile_s = sum(_compile_seconds(h) for h in dr.kernel_history())
    return K, max(time.perf_counter() - began - compile_s, 0.0)


def march(inputs: MarchInputs, kind: str, progress=None) -> MarchResult:
    """Run the megakernel on backend ``kind`` ("cpu" or "cuda"), in chunks of rays (a Ctrl-C
    raises KeyboardInterrupt between chunks); ``progress(fraction of rays done)`` after each."""
    m = array_module(kind)
    dr = drjit_module()
    spec = inputs.ray_spec
    assert spec is not None, "the Dr.Jit kernels generate their rays from a RaySpec"
    lanes = lane_order(spec.width, spec.height, spec.supersample)
    order = tuple(_aligned(a) for a in lanes)
    parts, samples, march_s = [], 0, 0.0
    start, size = 0, _first_chunk(spec, inputs.settings)
    upper_per_ray = upper_samples_per_ray(spec.shape, inputs.settings.step_voxels)
    with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        K, march_s = _kernel(m, inputs)
        while start < spec.n_total:
            chunk = [a[start : start + size] for a in order]
            began = time.perf_counter()
            columns, n, compile_s = _march_chunk(inputs, m, K, chunk)
            seconds = max(time.perf_counter() - began - compile_s, 0.0)
            parts.append(columns)
            samples, march_s = samples + n, march_s + seconds
            rays = len(chunk[0])
            start, size = start + rays, _next_chunk(rays, seconds, upper_per_ray)
            if progress is not None:
                progress(start / spec.n_total)
    columns = parts[0] if len(parts) == 1 else [np.concatenate(c) for c in zip(*parts, strict=True)]
    xyz = np.stack(columns[:3], axis=1)
    # the cached lane order itself as the ray index: the image is then gathered in one pass
    return MarchResult(xyz, columns[3], samples, march_s, device_name(kind), columns[4], lanes[2])


def _compile_seconds(entry: dict) -> float:
    """Code generation and backend compilation time of one kernel-history entry, in s."""
    ms = float(entry.get("codegen_time", 0.0)) + float(entry.get("backend_time", 0.0))
    return ms / 1000.0
