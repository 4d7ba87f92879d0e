"""The in-scatter cache: the sampled lights' part of the in-scattered radiance (the fire's own
light, skies, lat-long maps) estimated once per render at the voxel centres, for one camera,
and interpolated at every sample of every camera ray.

At a sample p of a camera ray along d, the single-scattering integrator adds σ_s(p)·J(p, d),

    J(p, d) = ∫ p_HG(ω·d) L_i(p, ω) dω

(Henyey–Greenstein phase included, g constant or a grid). For a pinhole camera at e the camera
ray through p has exactly the direction d(p) = (p − e)/|p − e|; for an orthographic camera d is
its forward everywhere. So for one camera J is a function of p alone, J_c(p) = J(p, d(p)).
``in_scatter = "cache"`` estimates J_c at every voxel centre c that a trilinear lookup with
σ_s > 0 can reach (within one voxel of a voxel with σ_s > 0), with ``cache_pairs`` samples of
the per-sample estimator's own next events (``monte_carlo``: the fire's balance-weighted pairs,
the sky's phase-sampled shadow, the maps' events), hashed by the voxel's index instead of a
camera ray's; the camera march then adds σ_s(p)·exp(trilinear(ln Ĵ_c)(p)) — one lookup per
sample instead of ``spp`` emission marches. (A lighting cache per view, as the irradiance
volumes of Greger et al. 1998 are per scene; here the phase function is folded in because the
view direction at a point is fixed by the camera.)

Each of X, Y, Z is interpolated geometrically (trilinearly in ln J, floored at
:data:`FLOOR`): J falls off from a flame roughly as a power of the distance, convex, and
interpolating it linearly between voxel centres overshoots — +13.5 % in the fire demo's mean
scattered luminance at its 32 × 48 × 32 voxels (``benchmarks/fire_light_cost.py``) — while its
logarithm is nearly linear there (geometric interpolation is exact for an exponential falloff).
The price is Jensen's inequality: E[ln Ĵ] < ln J by about half Ĵ's relative variance v, a bias
low that falls as 1/``cache_pairs`` (measured −4.1 % at 4, −1.8 % at 16 in the same demo), so
each voxel adds v̂/2, estimated from its own samples' second moment (:func:`log_mean`; the
delta method): −1.2 % at 4, −0.9 % at 16.

Bias, then: the interpolation's between voxel centres (vanishing as the grid refines; the
direction is exact at each centre) and what is left of the logarithm's (vanishing as
``cache_pairs`` grows).
Noise: ``cache_pairs`` samples per voxel, shared by every camera ray through it, so it shows as
smooth blotches of a voxel's size rather than per-pixel grain, and does not fall with more rays
per pixel (it falls with ``cache_pairs`` and with ``--batches``: each batch draws a new cache
from its seed). J's X, Y and Z are light, never negative.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.renderer.backends.kernel import dense_strides
from incandescent.renderer.backends.sampling import blurs
from incandescent.renderer.integrators import emission_light as el
from incandescent.renderer.integrators.monte_carlo import CACHE_STEP

#: How the sampled lights reach a camera ray's scattering samples: estimated at each sample
#: (``spp`` samples) or interpolated from the per-camera cache (``cache_pairs`` per voxel).
IN_SCATTER = ("per-sample", "cache")
#: Samples per voxel centre of the cache (measured: ``benchmarks/fire_light_cost.py``).
CACHE_PAIRS = 16
#: The least J (XYZ per sr) the cache holds: ln J is interpolated, and J may be 0.
FLOOR = 1e-30
#: Voxels per side of the cache's cells (``cache_voxels``): 1, a centre per voxel; 2, one per
#: 2×2×2 block — 8× fewer estimates, interpolated over twice the distance.
CACHE_VOXELS = (1, 2)


def refusal(integrator) -> str | None:
    """Why ``integrator``'s ``in_scatter = "cache"`` cannot run, or None."""
    if integrator.in_scatter != "cache":
        return None
    if integrator.max_bounces != 1:
        return (
            f"in_scatter 'cache' covers single scattering only (max_bounces 1); got "
            f"max_bounces {integrator.max_bounces} (use in_scatter 'per-sample')"
        )
    if integrator.spectral_bins:
        return (
            f"in_scatter 'cache' runs in the grey band only; got spectral_bins "
            f"{integrator.spectral_bins} (use in_scatter 'per-sample')"
        )
    return None


def check_camera(spec, volume) -> None:
    """Refuse a render the cache of one camera's view directions does not describe: a rig of
    several cameras, or gas that moves during the shutter (the cache holds J at the frame's
    positions, not at the advected ones a blurred ray samples)."""
    if len(spec.views) > 1:
        raise ValueError(
            f"in_scatter 'cache' is built for one camera's view directions; got a rig of "
            f"{len(spec.views)} cameras (render each alone, or use in_scatter 'per-sample')"
        )
    if blurs(spec, volume):
        raise ValueError(
            "in_scatter 'cache' does not cover motion blur (the cache holds the frame's "
            "positions); render with in_scatter 'per-sample' or without a shutter"
        )


def lattice(shape: tuple[int, ...], cell: int) -> tuple[int, int, int]:
    """The cache's grid: ``cell``-voxel cells over the volume's ``shape`` (the last partial)."""
    return tuple(-(-n // cell) for n in shape)  # type: ignore[return-value]


def needed_voxels(scattering: NDArray, cell: int = 1) -> NDArray[np.int64]:
    """Flat (C order) indices of the cache's centres a trilinear lookup with σ_s > 0 reaches:
    those within one cell (a 3×3×3 neighbourhood) of a cell holding a voxel within one voxel
    of σ_s > 0 (``cell`` 1: within one voxel of a voxel with σ_s > 0)."""
    near = el._dilated(scattering) > 0.0
    if cell == 1:
        return np.flatnonzero(near)
    shape = lattice(near.shape, cell)
    padded = np.zeros(tuple(n * cell for n in shape), dtype=bool)
    padded[tuple(slice(0, n) for n in near.shape)] = near
    blocks = padded.reshape(shape[0], cell, shape[1], cell, shape[2], cell).any(axis=(1, 3, 5))
    return np.flatnonzero(el._dilated(np.asarray(blocks, dtype=np.float64)) > 0.0)


def centres_and_views(spec, shape: tuple[int, int, int], index: NDArray, cell: int = 1) -> tuple:
    """(the centres (n, 3) of cache cells ``index`` on the lattice of ``shape`` (``cell``
    voxels a side), the unit directions of the camera rays through them (n, 3)), in voxel
    coordinates, float64: from the pinhole at ``spec.eye`` (its forward where a centre is the
    eye itself), or the orthographic camera's forward."""
    cells = np.stack(np.unravel_index(index, shape), axis=1).astype(np.float64)
    centres = (cells + 0.5) * cell
    forward = np.asarray(spec.forward, dtype=np.float64)
    forward = forward / np.linalg.norm(forward)
    if not spec.perspective:
        return centres, np.broadcast_to(forward, centres.shape).copy()
    eye = (np.asarray(spec.eye) - np.asarray(spec.origin_m)) / spec.voxel_size_m
    v = centres - eye
    r = np.linalg.norm(v, axis=1)
    at_eye = r < 1e-9
    views = v / np.where(at_eye, 1.0, r)[:, None]
    views[at_eye] = forward
    return centres, views


def log_mean(mean, mean_square, n: int, log, maximum, select):
    """ln J from the mean and the mean square of n samples, corrected for Jensen's bias to
    second order (the delta method): E[ln Ĵ] ≈ ln J − v/2 with v Ĵ's relative variance, so
    ln Ĵ + v̂/2, v̂ = (mean_square/mean² − 1)/(n − 1) (no correction from one sample; v̂ ≤
    n/(n − 1)); floored at ln :data:`FLOOR`. NumPy or Dr.Jit (``log``, ``maximum``,
    ``select``)."""
    value = log(maximum(mean, FLOOR))
    if n < 2:
        return value
    positive = mean > FLOOR
    safe = select(positive, mean, 1.0)
    v = maximum(mean_square / (safe * safe) - 1.0, 0.0) * (1.0 / (n - 1))
    return value + select(positive, 0.5 * v, 0.0)


def traced(program, estimator, cell: int = 1) -> list:
    """Traced: ln Ĵ_c's X, Y and Z as three Float grids on the lattice of ``cell``-voxel cells
    (C order, ln :data:`FLOOR` where not needed), evaluated now — one kernel over the needed
    centres as lanes (``estimator``: a ``TracedMonteCarlo`` of single scattering with
    ``cache_pairs`` samples)."""
    K = program.kernel
    dr, m = K.dr, K.m
    shape = lattice(K.shape, cell)
    index = needed_voxels(K.volume.scattering_per_m, cell)
    size = int(np.prod(shape))
    grids = [dr.full(m.Float, float(np.log(FLOOR)), size) for _ in range(3)]
    if index.size:
        centres, views = centres_and_views(K.ray_spec, shape, index, cell)
        p, d = (m.Array3f(*(m.Float(a.astype(np.float32)) for a in v.T)) for v in (centres, views))
        lanes = m.UInt(index.astype(np.uint32))
        J, J2 = estimator.moments(p, d, lanes)
        for a in range(3):
            value = log_mean(J[a], J2[a], estimator.spp, dr.log, dr.maximum, dr.select)
            dr.scatter(grids[a], value, lanes)
    dr.eval(grids)
    return grids


def reference(inputs, estimator, cell: int = 1) -> list[NDArray[np.float64]]:
    """Float64: ln Ĵ_c's X, Y and Z as three grids on the lattice of ``cell``-voxel cells, the
    same samples as :func:`traced` (``estimator``: a ``ReferenceMonteCarlo`` of single
    scattering)."""
    shape = lattice(inputs.volume.shape, cell)
    index = needed_voxels(inputs.volume.scattering_per_m, cell)
    flat = np.full((int(np.prod(shape)), 3), np.log(FLOOR))
    if index.size:
        centres, views = centres_and_views(inputs.ray_spec, shape, index, cell)
        step = np.full(index.size, CACHE_STEP, dtype=np.uint32)
        squares = np.zeros((index.size, 3))
        total = estimator.total(centres, views, index.astype(np.uint32), step, squares)
        n = estimator.spp
        flat[index] = log_mean(total / n, squares / n, n, np.log, np.maximum, np.where)
    return [flat[:, a].reshape(shape) for a in range(3)]


def lookup(K, grids: list, cell: int):
    """Traced: Ĵ (XYZ per sr) at the sample, exp of the trilinear ln Ĵ: on the voxel grid at the
    sample's corners (``cell`` 1), else on the lattice at the sample's position / ``cell``
    (its cells' centres at i + ½ there, edges as :meth:`Kernel.corners` has them)."""
    if cell == 1:
        return K.dr.exp(K.m.Array3f(*(K.trilinear(grid, K.at) for grid in grids)))
    shape = lattice(K.shape, cell)
    strides = dense_strides(shape)
    c = K.corners(K.position * (1.0 / cell), (shape, strides))
    return K.dr.exp(K.m.Array3f(*(K.trilinear(grid, c, strides=strides) for grid in grids)))
