"""The reference backend: a readable float64 NumPy marcher, the ground truth for the others.

All rays advance in lockstep, one segment per iteration (see ``common`` for the step lattice).
Paper mode (``brightness="paper"``) sums the 2011 paper's colour (``spectra.paper2011``) along
the ray without absorption; the cap at 255 is applied when the image is assembled.
Emission is evaluated *exactly* — the Planck × CMF integral at each sample's temperature — not from
the table the fast backends use, so parity tests also check the table. No empty-space skipping.
"""

from __future__ import annotations

import time

import numpy as np

from incandescent.constants import K_M
from incandescent.renderer.backends.common import MarchInputs, MarchResult, trilinear
from incandescent.spectra.blackbody import blackbody_xyz


def _emission_xyz(temp_K: np.ndarray, inputs: MarchInputs) -> np.ndarray:
    """XYZ per unit absorption, exact; zero below the table's T_min as in the fast backends."""
    s = inputs.settings
    hot = temp_K >= inputs.lut.t_min_K
    out = np.zeros(temp_K.shape + (3,))
    if hot.any():
        out[hot] = blackbody_xyz(temp_K[hot], s.observer, s.constants)
    return out


def _paper_step(inputs, r, p, ds_m, xyz) -> np.ndarray:
    """The 2011 paper: add paper_rgb(T, sodium)·gain per voxel of path where T ≥ paper_min_K.

    Returns the mask of rays whose sample contributed."""
    from incandescent.spectra.paper2011 import paper_rgb

    vol, s = inputs.volume, inputs.settings
    temp = trilinear(vol.temperature_K, p)
    hot = temp >= np.float32(s.paper_min_K)
    if not hot.any():
        return hot
    sodium = 0.0 if vol.sodium_fraction is None else trilinear(vol.sodium_fraction, p[hot])
    rgb = paper_rgb(temp[hot], np.clip(sodium, 0.0, 1.0), s.paper_exponent)
    if vol.emission_scale is not None:
        rgb = rgb * trilinear(vol.emission_scale, p[hot])[:, None]
    xyz[r[hot]] += rgb * (s.paper_gain * ds_m[hot] / vol.voxel_size_m)[:, None]
    return hot


def _segment(rays, r, k, step_voxels: float):
    """Segment k of rays ``r`` (see ``common``): its ends a, b (voxels) and midpoint position."""
    a = np.maximum(rays.t_enter[r] + (k - 1 + rays.jitter[r]) * step_voxels, rays.t_enter[r])
    b = np.minimum(rays.t_enter[r] + (k + rays.jitter[r]) * step_voxels, rays.t_exit[r])
    return a, b, rays.origin[r] + rays.direction[r] * (0.5 * (a + b))[:, None]


def march(inputs: MarchInputs) -> MarchResult:
    """March every ray of ``inputs.rays`` front to back; float64 throughout."""
    start = time.perf_counter()
    rays, vol, s = inputs.rays, inputs.volume, inputs.settings
    assert rays is not None, "the reference backend marches host-generated rays"
    n = rays.size
    xyz = np.zeros((n, 3))
    transmittance = np.ones(n)
    depth = np.full(n, np.inf)
    k = np.zeros(n)
    samples = 0
    active = np.arange(n)
    if s.spectral_bins:
        return _march_spectral(inputs, start)
    while active.size:
        r = active
        a, b, p = _segment(rays, r, k[r], s.step_voxels)
        samples += r.size
        if s.brightness == "paper":
            emits = _paper_step(inputs, r, p, (b - a) * vol.voxel_size_m, xyz)
        else:
            emits = _integrate_step(inputs, r, p, (b - a) * vol.voxel_size_m, xyz, transmittance)
        first = emits & np.isinf(depth[r])
        depth[r[first]] = 0.5 * (a + b)[first] * vol.voxel_size_m
        k[r] += 1
        more = (b < rays.t_exit[r]) & (transmittance[r] >= s.min_transmittance)
        active = r[more]
    seconds = time.perf_counter() - start
    return MarchResult(xyz, transmittance, samples, seconds, "numpy float64", depth, rays.ray_index)


def _integrate_step(inputs, r, p, ds_m, xyz, transmittance) -> np.ndarray:
    """Exact emission–absorption over one segment of ``ds_m`` metres for rays ``r``, in place.

    Returns the mask of rays whose sample emits (κ > 0 and T at or above the table's T_min)."""
    vol = inputs.volume
    if vol.species:
        return _integrate_species_step(inputs, r, p, ds_m, xyz, transmittance)
    kappa = trilinear(vol.absorption_per_m, p)
    absorbing = kappa > 0  # where κ = 0 nothing is emitted (Kirchhoff): skip the spectral integral
    emits = absorbing.copy()
    if not absorbing.any():
        return emits
    r, p, kappa, ds_m = r[absorbing], p[absorbing], kappa[absorbing], ds_m[absorbing]
    temp = trilinear(vol.temperature_K, p)
    emits[absorbing] = temp >= inputs.lut.t_min_K
    scale = 1.0 if vol.emission_scale is None else trilinear(vol.emission_scale, p)
    optical_depth = kappa * ds_m
    alpha = -np.expm1(-optical_depth)
    emitted = (transmittance[r] * alpha * scale)[:, None] * _emission_xyz(temp, inputs)
    xyz[r] += emitted
    transmittance[r] *= np.exp(-optical_depth)
    return emits


def _integrate_species_step(inputs, r, p, ds_m, xyz, transmittance) -> np.ndarray:
    """As :func:`_integrate_step` with species lines: η = κ·B(T) + Σ_s f_s·E_s(T) per metre,
    and the segment adds Tr·η·(1 − e^{−κΔs})/κ (Tr·η·Δs where κ = 0); E_s exact, not tabulated."""
    from incandescent.spectra.lines import species_xyz

    vol, s = inputs.volume, inputs.settings
    kappa = trilinear(vol.absorption_per_m, p)
    fractions = {name: trilinear(grid, p) for name, grid in vol.species.items()}
    temp = trilinear(vol.temperature_K, p)
    emits = ((kappa > 0) | np.any([f > 0 for f in fractions.values()], axis=0)) & (
        temp >= inputs.lut.t_min_K
    )
    if not emits.any():
        transmittance[r] *= np.exp(-kappa * ds_m)
        return emits
    hot = temp[emits]
    eta = kappa[emits, None] * _emission_xyz(hot, inputs)
    for name, fraction in fractions.items():
        eta += fraction[emits, None] * species_xyz(inputs.line_table, name, hot, s.observer)
    if vol.emission_scale is not None:
        eta *= trilinear(vol.emission_scale, p[emits])[:, None]
    x = kappa[emits] * ds_m[emits]
    safe = np.where(x > 0, kappa[emits], 1.0)
    weight = np.where(x > 0, -np.expm1(-x) / safe, ds_m[emits])
    xyz[r[emits]] += (transmittance[r[emits]] * weight)[:, None] * eta
    transmittance[r] *= np.exp(-kappa * ds_m)
    return emits


def _march_spectral(inputs: MarchInputs, start: float) -> MarchResult:
    """Spectral κ_λ = κ·(λ_ref/λ)^α marched at every 1 nm CMF sample (the limit of N bins):
    L = K_m Σ_λ Σ_segments Tr_λ (1 − e^{−κ_λΔs}) B_λ(T) x̄ȳz̄(λ) Δλ. Same lattice as the others."""
    from incandescent.constants import planck_constants
    from incandescent.spectra.bins import REFERENCE_NM
    from incandescent.spectra.cmf import cmfs
    from incandescent.spectra.planck import NM_TO_M, _planck_m

    rays, vol, s = inputs.rays, inputs.volume, inputs.settings
    assert rays is not None, "the reference backend marches host-generated rays"
    cmf = cmfs(s.observer)
    kappa_scale = (REFERENCE_NM / cmf.wavelength_nm) ** s.soot_alpha
    weights = K_M * cmf.step_nm * cmf.xyz_bar  # (471, 3)
    n = rays.size
    xyz, tr, depth = np.zeros((n, 3)), np.ones((n, cmf.wavelength_nm.size)), np.full(n, np.inf)
    k, samples, active = np.zeros(n), 0, np.arange(n)
    while active.size:
        r = active
        a, b, p = _segment(rays, r, k[r], s.step_voxels)
        samples += r.size
        kappa, temp = trilinear(vol.absorption_per_m, p), trilinear(vol.temperature_K, p)
        emits = (kappa > 0) & (temp >= inputs.lut.t_min_K)
        x = (kappa * (b - a) * vol.voxel_size_m)[:, None] * kappa_scale  # (m, 471)
        radiance = (
            _planck_m(
                cmf.wavelength_nm * NM_TO_M,
                np.maximum(temp, 1.0)[:, None],
                planck_constants(s.constants),
            )
            * NM_TO_M
        )
        radiance[~emits] = 0.0
        if vol.emission_scale is not None:
            radiance *= trilinear(vol.emission_scale, p)[:, None]
        xyz[r] += (tr[r] * -np.expm1(-x) * radiance) @ weights
        tr[r] *= np.exp(-x)
        first = emits & np.isinf(depth[r])
        depth[r[first]] = 0.5 * (a + b)[first] * vol.voxel_size_m
        k[r] += 1
        active = r[(b < rays.t_exit[r]) & (tr[r].max(axis=1) >= s.min_transmittance)]
    seconds = time.perf_counter() - start
    return MarchResult(
        xyz, tr.mean(axis=1), samples, seconds, "numpy float64", depth, rays.ray_index
    )
