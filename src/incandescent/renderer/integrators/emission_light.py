"""The volume's own emission as a light: what a fire gives the smoke around it (and inside it).

The light scattered once toward the camera (direction −d along a camera ray d) at p is
σ_s(p)·J(p) with

    J(p) = ∫_{S²} p_HG(ω·d) L_e(p, ω) dω,   L_e(p, ω) = ∫_0^{t_ω} Tr(p, p + tω) η(p + tω) dt

η the emission coefficient (κ·S + the lines, per metre) and Tr the transmittance by
σ_t = κ + σ_s: L_e is the emission–absorption radiance arriving at p from ω, marched along the
whole half-line to the box. Two strategies pick ω, each evaluated along its whole line (no
1/r² singularity where the smoke is inside the fire, as a point sample of the emitter would
have):

* **light** — a cell of a coarse grid of ``cell_voxels``³ voxels with probability ∝ the power
  it emits, a point q uniform in it, ω = (q − p)/|q − p|: the shadow ray goes where the fire is
  bright. Its solid-angle pdf is the line integral pdf_L(ω) = ∫_0^{t_ω} pdf_V(p + tω) t² dt of
  the piecewise-constant volume pdf, computed exactly by a DDA over the cells;
* **phase** — ω from Henyey–Greenstein about d by the inverse of its CDF (pdf p_HG(ω·d)).

One sample of each, combined by the balance heuristic (Veach 1997, thesis §9.2):

    Ĵ = Σ_{s ∈ {L, P}} p_HG(ω_s·d) L_e(p, ω_s) / (pdf_L(ω_s) + p_HG(ω_s·d)),

averaged over ``spp`` pairs: unbiased wherever either pdf is positive — the phase pdf is,
everywhere — so a cell the power misses only costs noise. The power that guides the sampling
is κ·Y(T) (the first table's luminance, times the emission scale) at voxel centres, dilated by
one voxel (trilinear interpolation reaches that far) and summed per cell. Random numbers are a
hash of (ray, step, sample, dimension) and the render's seed: both backends draw the same
directions, so the float64 reference and Dr.Jit agree to rounding, not only in distribution.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from numpy.typing import NDArray

from incandescent.renderer import rays
from incandescent.renderer.backends.camera_rays import clip_to_box
from incandescent.renderer.backends.common import THIN_STEP, trilinear
from incandescent.renderer.backends.sampling import lowbias32
from incandescent.renderer.lights import henyey_greenstein

#: Most cells along an axis of the light grid (the DDA's cost); at least 4 voxels per cell.
MAX_CELLS_PER_AXIS, MIN_CELL_VOXELS = 32, 4
#: |g| below this samples the phase isotropically (the inverse CDF loses float32 precision).
ISOTROPIC_G = 1e-3
#: Random numbers per sample pair: cell, point in the cell (3), phase direction (2).
DIMENSIONS = 6
#: Salts of the hash: the render's seed, the sample index, each dimension and the bounce.
_KEY_SALT, _SAMPLE_MUL, _DIM_ADD, _BOUNCE_MUL = 0x2545F491, 0x9E3779B9, 0x6A09E667, 0x85EBCA6B
#: The emission march stops once the optical depth exceeds this (e^−40 ≈ 4e-18), as shadows do,
#: or sooner where the render's ``min_transmittance`` says (:func:`max_depth`).
MAX_DEPTH = 40.0

#: The operations the direction samplers (here and ``environment_map``) need, from NumPy.
NUMPY_OPS = SimpleNamespace(
    sqrt=np.sqrt, maximum=np.maximum, minimum=np.minimum, cos=np.cos, sin=np.sin,
    select=np.where, arccos=np.arccos, arctan2=np.arctan2,
)  # fmt: skip


def drjit_ops(dr) -> SimpleNamespace:
    """:data:`NUMPY_OPS` from Dr.Jit."""
    return SimpleNamespace(
        sqrt=dr.sqrt, maximum=dr.maximum, minimum=dr.minimum, cos=dr.cos, sin=dr.sin,
        select=dr.select, arccos=dr.acos, arctan2=dr.atan2,
    )  # fmt: skip


# --- what both backends share -------------------------------------------------------------------
def hash_key(seed: int) -> int:
    """The render's seed as the key the sample hashes XOR in."""
    return int(rays.lowbias32(np.array([(seed + _KEY_SALT) & 0xFFFFFFFF]))[0])


def uniforms(ray_index, step, sample, key: int, count: int, bounce=None) -> list:
    """``count`` independent 24-bit integers (uniform · 2²⁴) from UInt32 lanes of the camera
    ray's index, its step, the sample's index and (on a path) the bounce (NumPy uint32 arrays
    or Dr.Jit UInt; both wrap mod 2³²)."""
    h = lowbias32(ray_index ^ key)
    h = lowbias32(h ^ step)
    h = lowbias32(h ^ (sample * _SAMPLE_MUL))
    if bounce is not None:
        h = lowbias32(h ^ (bounce * _BOUNCE_MUL))
    out = []
    for _ in range(count):
        h = lowbias32(h + _DIM_ADD)
        out.append(h >> 8)
    return out


def max_depth(min_transmittance: float | np.floating) -> float:
    """The optical depth at which an emission march stops: where the camera march stops, once
    the transmittance falls below the render's ``min_transmittance`` (−ln 10⁻⁴ ≈ 9.2 at the
    default), and at most :data:`MAX_DEPTH` (``min_transmittance`` 0). Light from behind it
    reaches the scattering point attenuated by less than ``min_transmittance``, as light from
    behind a camera ray's end reaches the camera. In the fire demo this changes the image by
    −0.02 % and makes its 512² frame with the in-scatter cache (3 samples a voxel) cost 3.3× the
    emission-only frame instead of 4.25× (``benchmarks/fire_light_cost.py``)."""
    m = float(min_transmittance)
    return MAX_DEPTH if m <= 0.0 else min(MAX_DEPTH, -float(np.log(m)))


def orthonormal_basis(n, ops) -> tuple[tuple, tuple]:
    """Two unit vectors completing unit n to an orthonormal basis (Duff et al. 2017, JCGT 6:1)."""
    sign = ops.select(n[2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    e1 = (1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0])
    e2 = (b, sign + n[1] * n[1] * a, -n[1])
    return e1, e2


def sample_henyey_greenstein(u0, u1, d, g, ops) -> tuple:
    """A direction ω with pdf p_HG(ω·d) (1/sr) from uniforms u0, u1 in [0, 1): cos θ from the
    inverse CDF, μ = (1 + g² − ((1 − g²)/(1 − g + 2g·u0))²)/(2g) (isotropic where
    |g| < ``ISOTROPIC_G``), the azimuth 2π·u1; g a float, or an array (traced or NumPy) of one
    g per sample."""
    if isinstance(g, float) and abs(g) < ISOTROPIC_G:
        mu = 1.0 - 2.0 * u0
    elif isinstance(g, float):
        s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u0)
        mu = (1.0 + g * g - s * s) * (0.5 / g)
    else:  # g per sample (a grid): the same, lane by lane
        isotropic = g * g < ISOTROPIC_G * ISOTROPIC_G
        h = ops.select(isotropic, 0.5, g)
        s = (1.0 - h * h) / (1.0 - h + 2.0 * h * u0)
        mu = ops.select(isotropic, 1.0 - 2.0 * u0, (1.0 + h * h - s * s) * (0.5 / h))
    sin_theta = ops.sqrt(ops.maximum(1.0 - mu * mu, 0.0))
    phi = 2.0 * np.pi * u1
    e1, e2 = orthonormal_basis(d, ops)
    cp, sp = ops.cos(phi) * sin_theta, ops.sin(phi) * sin_theta
    return tuple(mu * d[a] + cp * e1[a] + sp * e2[a] for a in range(3))


@dataclass(frozen=True)
class LightCells:
    """The power distribution over cells of ``cell_voxels``³ voxels: each cell's probability,
    its CDF, and the volume pdf (probability / cell volume, per voxel³) — C order."""

    cell_voxels: int
    shape: tuple[int, int, int]
    probability: NDArray[np.float64]
    cdf: NDArray[np.float64]
    density: NDArray[np.float64]
    total_power: float

    @classmethod
    def of(cls, volume, lut) -> LightCells:
        """The cells of ``volume``'s emitted luminance (κ·Y(T) from ``lut``, an ``EmissionLUT``)."""
        n = max(volume.shape)
        size = max(MIN_CELL_VOXELS, -(-n // MAX_CELLS_PER_AXIS))
        power = _dilated(volume.absorption_per_m * lut.lookup(volume.temperature_K)[..., 1])
        if volume.emission_scale is not None:
            power = power * _dilated(volume.emission_scale)
        shape = tuple(-(-s // size) for s in volume.shape)
        padded = np.zeros(tuple(s * size for s in shape))
        padded[tuple(slice(0, s) for s in volume.shape)] = power
        cells = padded.reshape(shape[0], size, shape[1], size, shape[2], size).sum(axis=(1, 3, 5))
        total = float(cells.sum())
        probability = (cells / total if total > 0 else cells).ravel()
        pairs = zip(volume.shape, shape, strict=True)
        extent = [np.minimum(size, s - size * np.arange(c)) for s, c in pairs]
        cell_volume = np.einsum("i,j,k->ijk", *extent).ravel()
        cdf = np.cumsum(probability)
        if total > 0:
            cdf /= cdf[-1]
        return cls(size, shape, probability, cdf, probability / cell_volume, total)  # type: ignore[arg-type]

    @property
    def emits(self) -> bool:
        return self.total_power > 0


def _dilated(grid: NDArray) -> NDArray:
    """The largest value within one voxel along each axis (a 3×3×3 max filter)."""
    out = np.asarray(grid, dtype=np.float64)
    for axis in range(3):
        up, down = np.roll(out, 1, axis), np.roll(out, -1, axis)
        np.moveaxis(up, axis, 0)[0] = 0.0  # np.roll wraps: the far side is not a neighbour
        np.moveaxis(down, axis, 0)[-1] = 0.0
        out = np.maximum(out, np.maximum(up, down))
    return out


# --- Dr.Jit -----------------------------------------------------------------------------------
class TracedEmissionLight:
    """The traced estimator of the emission part of J (XYZ per sr) for the single-scattering
    program ``program`` (which has ``scattering``, ``g_at`` and ``emission_coefficient``)."""

    def __init__(self, program, cells: LightCells) -> None:
        self.program, self.K = program, program.kernel
        m = self.K.m
        self.cells = cells
        self.cdf = m.Float(cells.cdf.astype(np.float32))
        self.density = m.Float(cells.density.astype(np.float32))
        self.ops = drjit_ops(self.K.dr)

    def pair(self, p, d, u):
        """Traced: Ĵ at p seen along d from one light-sampled and one phase-sampled direction,
        balance-weighted (``u``: :data:`DIMENSIONS` uniforms)."""
        K = self.K
        out = K.m.Array3f(0.0)
        for w, weight in self.weighted(p, d, u):
            out = K.dr.fma(self.radiance_along(p, w), weight, out)
        return out

    def weighted(self, p, d, u) -> list:
        """Traced: the pair's two directions, each with its balance-heuristic weight
        p_HG/(pdf_L + p_HG)."""
        K = self.K
        dr, m = K.dr, K.m
        g = self.program.g_at(p)
        q = self.point_in_cell(u[0], u[1:4])
        v = q - p
        r = dr.norm(v)
        toward_light = dr.select(r > 1e-6, v / r, d)
        toward_phase = m.Array3f(*sample_henyey_greenstein(u[4], u[5], d, g, self.ops))
        out = []
        for w in (toward_light, toward_phase):
            phase = henyey_greenstein(dr.dot(w, d), g)
            out.append((w, phase / (self.pdf_light(p, w) + phase)))
        return out

    def point_in_cell(self, u_cell, u_point):
        """Traced: a cell with probability ∝ its power (binary search of the CDF), then a
        uniform point in it (clipped to the box), voxel coordinates."""
        K = self.K
        dr, m = K.dr, K.m
        cdf, (_, ny, nz), size = self.cdf, self.cells.shape, self.cells.cell_voxels
        last = len(self.cells.cdf) - 1
        i = dr.binary_search(0, last, lambda i: dr.gather(m.Float, cdf, i) <= u_cell)
        index = (i // (ny * nz), (i // nz) % ny, i % nz)
        out = []
        for a in range(3):
            low = m.Float(index[a]) * float(size)
            extent = dr.minimum(float(size), float(K.shape[a]) - low)
            out.append(dr.fma(u_point[a], extent, low))
        return m.Array3f(*out)

    def pdf_light(self, p, w):
        """Traced: ∫ pdf_V(p + tω) t² dt (1/sr) along ω to the box, exactly, by a DDA over the
        cells (Amanatides & Woo 1987)."""
        K = self.K
        dr, m = K.dr, K.m
        size, shape = float(self.cells.cell_voxels), self.cells.shape
        _, t_exit = clip_to_box(dr, m, p, w, K.shape)
        t_exit = dr.maximum(t_exit, 0.0)
        cell, t_next, t_step = [], [], []
        for a in range(3):
            c = dr.clip(dr.floor(p[a] / size), 0.0, float(shape[a] - 1))
            forward = w[a] > 0.0
            bound = (c + dr.select(forward, 1.0, 0.0)) * size
            parallel = w[a] == 0.0
            cell.append(c)
            t_next.append(dr.select(parallel, np.inf, (bound - p[a]) / w[a]))
            t_step.append(dr.select(parallel, np.inf, size / dr.abs(w[a])))
        steps = [dr.select(w[a] > 0.0, 1.0, -1.0) for a in range(3)]
        _, ny, nz = shape

        def cond(t, acc, cx, cy, cz, nx_, ny_, nz_):
            return t < t_exit

        def body(t, acc, cx, cy, cz, tx, ty, tz):
            t1 = dr.minimum(dr.minimum(dr.minimum(tx, ty), tz), t_exit)
            flat = m.UInt((dr.clip(cx, 0, shape[0] - 1) * ny + dr.clip(cy, 0, ny - 1)) * nz)
            flat = flat + m.UInt(dr.clip(cz, 0, nz - 1))
            density = dr.gather(m.Float, self.density, flat)
            acc = dr.fma(density, (t1 * t1 * t1 - t * t * t) * (1.0 / 3.0), acc)
            moved = [tx <= t1, ty <= t1, tz <= t1]
            triples = zip(moved, (cx, cy, cz), steps, strict=True)
            cx, cy, cz = (dr.select(mv, c + s, c) for mv, c, s in triples)
            tx, ty, tz = (
                dr.select(mv, tn + ts, tn)
                for mv, tn, ts in zip(moved, (tx, ty, tz), t_step, strict=True)
            )
            return t1, acc, cx, cy, cz, tx, ty, tz

        state = (m.Float(0.0), m.Float(0.0), *cell, *t_next)
        labels = ("t", "pdf", "cx", "cy", "cz", "tx", "ty", "tz")
        return dr.while_loop(state, cond, body, labels=labels)[1]

    def radiance_along(self, p, w):
        """Traced: L_e(p, ω), the emission–absorption radiance reaching p from ω (XYZ), marched
        at the program's ``path_dt`` from p to the box (midpoint samples, exact per segment), or
        until its optical depth reaches :func:`max_depth`."""
        K, program = self.K, self.program
        dr, m = K.dr, K.m
        _, t_exit = clip_to_box(dr, m, p, w, K.shape)

        dt, depth = program.path_dt, max_depth(K.min_tr)

        def cond(k, tau, L):
            return (k * dt < t_exit) & (tau < depth)

        def body(k, tau, L):
            a = k * dt
            b = dr.minimum(a + dt, t_exit)
            c = K.corners(dr.fma(w, 0.5 * (a + b), p))
            kappa, temp = K.medium_at(c)
            sigma_t = kappa + K.trilinear(program.scattering, c)
            sampled = [model.sample(K, bound, c) for model, bound in K.terms]
            eta = program.emission_coefficient(0, kappa, temp, sampled)
            if K.scale is not None:
                eta = eta * K.trilinear(K.scale, c)
            ds_m = (b - a) * K.ds_per_voxel
            x = sigma_t * ds_m
            series = 1.0 - x * (0.5 - x * (1.0 / 6.0))
            weight = dr.select(x < THIN_STEP, ds_m * series, (1.0 - dr.exp(-x)) / sigma_t)
            return k + 1.0, tau + x, dr.fma(eta, dr.exp(-tau) * weight, L)

        state = (m.Float(0.0), m.Float(0.0), m.Array3f(0.0))
        return dr.while_loop(state, cond, body, labels=("k", "tau", "L"))[2]


# --- float64 ----------------------------------------------------------------------------------
class ReferenceEmissionLight:
    """The float64 estimator: the same directions as :class:`TracedEmissionLight` (the same
    hashes), exact emission terms (the program's ``emitted_at``)."""

    def __init__(self, program, cells: LightCells) -> None:
        self.program, self.inputs, self.cells = program, program.inputs, cells

    def pair(self, p, d, u) -> NDArray:
        """Ĵ at samples p (m, 3) seen along unit d (m, 3), from uniforms ``u`` (float64): XYZ,
        or (spectral programs) per wavelength."""
        return sum(
            self.radiance_along(p, w) * weight[:, None] for w, weight in self.weighted(p, d, u)
        )

    def weighted(self, p, d, u) -> list[tuple[NDArray, NDArray]]:
        """The pair's two directions (m, 3), each with its balance-heuristic weights (m,)."""
        g = self.program.g_at(p)
        v = self.point_in_cell(u[0], np.stack(u[1:4], axis=1)) - p
        r = np.linalg.norm(v, axis=1)
        toward_light = np.where((r > 1e-6)[:, None], v / np.maximum(r, 1e-300)[:, None], d)
        toward_phase = np.stack(sample_henyey_greenstein(u[4], u[5], d.T, g, NUMPY_OPS), axis=1)
        out = []
        for w in (toward_light, toward_phase):
            phase = henyey_greenstein(np.einsum("ij,ij->i", w, d), g)
            out.append((w, phase / (self.pdf_light(p, w) + phase)))
        return out

    def point_in_cell(self, u_cell, u_point) -> NDArray:
        cdf, shape, size = self.cells.cdf, self.cells.shape, self.cells.cell_voxels
        i = np.minimum(np.searchsorted(cdf, u_cell, side="right"), cdf.size - 1)
        index = np.stack(np.unravel_index(i, shape), axis=1).astype(np.float64)
        low = index * size
        extent = np.minimum(size, np.asarray(self.inputs.volume.shape) - low)
        return low + u_point * extent

    def pdf_light(self, p, w) -> NDArray:
        """∫ pdf_V(p + tω) t² dt along ω to the box, by the same DDA, float64."""
        size, shape = float(self.cells.cell_voxels), np.asarray(self.cells.shape)
        box = np.asarray(self.inputs.volume.shape, dtype=np.float64)
        _, t_exit = rays.clip_to_box(p, w, box)
        cell = np.clip(np.floor(p / size), 0, shape - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = (cell + (w > 0)) * size
            t_next = np.where(w == 0, np.inf, (bound - p) / w)
            t_step = np.where(w == 0, np.inf, size / np.abs(w))
        steps = np.where(w > 0, 1, -1)
        t, acc = np.zeros(len(p)), np.zeros(len(p))
        density = self.cells.density.reshape(self.cells.shape)
        live = t < t_exit
        while live.any():
            t1 = np.minimum(t_next[live].min(axis=1), t_exit[live])
            c = np.clip(cell[live], 0, shape - 1).astype(np.int64)
            acc[live] += density[c[:, 0], c[:, 1], c[:, 2]] * (t1**3 - t[live] ** 3) / 3.0
            moved = t_next[live] <= t1[:, None]
            cell[live] += np.where(moved, steps[live], 0)
            t_next[live] += np.where(moved, t_step[live], 0.0)
            t[live] = t1
            live = t < t_exit
        return acc

    def radiance_along(self, p, w) -> NDArray:
        """L_e(p, ω) by the same march, with the exact emission terms."""
        program, inputs = self.program, self.inputs
        vol, dt = inputs.volume, program.path_dt
        depth = max_depth(np.float32(inputs.settings.min_transmittance))
        _, t_exit = rays.clip_to_box(p, w, np.asarray(vol.shape, dtype=np.float64))
        tau, L, k = np.zeros(len(p)), np.zeros((len(p), 3)), 0
        while True:
            a = k * dt
            live = np.flatnonzero((a < t_exit) & (tau < depth))
            if not live.size:
                return L
            b = np.minimum(a + dt, t_exit[live])
            q = p[live] + w[live] * (0.5 * (a + b))[:, None]
            ds_m = (b - a) * vol.voxel_size_m
            kappa = trilinear(vol.absorption_per_m, q)
            sigma_t = kappa + trilinear(vol.scattering_per_m, q)
            eta = program.emitted_at(q, kappa)
            x = sigma_t * ds_m
            weight = np.where(x > 0, -np.expm1(-x) / np.where(x > 0, sigma_t, 1.0), ds_m)
            L[live] += (np.exp(-tau[live]) * weight)[:, None] * eta
            tau[live] += x
            k += 1
