"""The reference backend: a readable float64 NumPy marcher, the ground truth for the others.

All rays advance in lockstep, one segment per iteration (see ``common`` for the step lattice).
Each emission model (``incandescent.emission``) adds its term *exactly* — the Planck × CMF
integral at each sample's temperature, the species' line sums — not from the tables the fast
backends use, so parity tests also check the tables. Spectral bins are marched in their limit,
every 1 nm CMF sample. A display model (the 2011 paper's) sums its colour along the ray without
absorption; the cap at 255 is applied when the image is assembled. No empty-space skipping.
"""

from __future__ import annotations

import time

import numpy as np

from incandescent.constants import K_M
from incandescent.renderer.backends.common import MarchInputs, MarchResult, trilinear


def _sampled(inputs: MarchInputs, p: np.ndarray) -> list[list[np.ndarray]]:
    """Every model's grid values at positions p (trilinear, float64)."""
    return [[trilinear(g, p) for g in model.grids(inputs.volume)] for model in inputs.models]


def _sources(inputs: MarchInputs, temp_K: np.ndarray, sampled) -> np.ndarray:
    """S: the source models' exact XYZ per unit absorption at the samples."""
    eta = None
    for model, values in zip(inputs.models, sampled, strict=True):
        if model.kind == "source":
            eta = model.reference_add(eta, temp_K, values, inputs)
    return np.zeros(temp_K.shape + (3,)) if eta is None else eta


def _emission_xyz(temp_K: np.ndarray, inputs: MarchInputs, sampled) -> np.ndarray:
    """S, exact; zero below the table's T_min as in the fast backends."""
    hot = temp_K >= inputs.lut.t_min_K
    out = np.zeros(temp_K.shape + (3,))
    if hot.any():
        out[hot] = _sources(inputs, temp_K[hot], [[v[hot] for v in vs] for vs in sampled])
    return out


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
    if not inputs.bands.grey:
        return _march_spectral(inputs, start)
    n = rays.size
    xyz, transmittance, depth = np.zeros((n, 3)), np.ones(n), np.full(n, np.inf)
    k, samples, active = np.zeros(n), 0, np.arange(n)
    display = inputs.display
    while active.size:
        r = active
        a, b, p = _segment(rays, r, k[r], s.step_voxels)
        samples += r.size
        ds_m = (b - a) * vol.voxel_size_m
        if display is not None:
            emits = display.reference_step(inputs, trilinear, r, p, ds_m, xyz)  # type: ignore[attr-defined]
        else:
            emits = _integrate_step(inputs, r, p, ds_m, xyz, transmittance)
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
    if any(m.kind == "coefficient" for m in inputs.models):
        return _integrate_coefficient_step(inputs, r, p, ds_m, xyz, transmittance)
    vol = inputs.volume
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
    source = _emission_xyz(temp, inputs, _sampled(inputs, p))
    xyz[r] += (transmittance[r] * alpha * scale)[:, None] * source
    transmittance[r] *= np.exp(-optical_depth)
    return emits


def _integrate_coefficient_step(inputs, r, p, ds_m, xyz, transmittance) -> np.ndarray:
    """As :func:`_integrate_step` with coefficient models (lines): η = κ·S + Σ η_model per
    metre, and the segment adds Tr·η·(1 − e^{−κΔs})/κ (Tr·η·Δs where κ = 0)."""
    vol = inputs.volume
    kappa = trilinear(vol.absorption_per_m, p)
    sampled = _sampled(inputs, p)
    temp = trilinear(vol.temperature_K, p)
    present = kappa > 0
    for values in sampled:
        for fraction in values:
            present = present | (fraction > 0)
    emits = present & (temp >= inputs.lut.t_min_K)
    if not emits.any():
        transmittance[r] *= np.exp(-kappa * ds_m)
        return emits
    hot, at = temp[emits], [[v[emits] for v in vs] for vs in sampled]
    eta = kappa[emits, None] * _emission_xyz(hot, inputs, at)
    for model, values in zip(inputs.models, at, strict=True):
        if model.kind == "coefficient":
            eta = model.reference_add(eta, hot, values, inputs)
    if vol.emission_scale is not None:
        eta *= trilinear(vol.emission_scale, p[emits])[:, None]
    x = kappa[emits] * ds_m[emits]
    safe = np.where(x > 0, kappa[emits], 1.0)
    weight = np.where(x > 0, -np.expm1(-x) / safe, ds_m[emits])
    xyz[r[emits]] += (transmittance[r[emits]] * weight)[:, None] * eta
    transmittance[r] *= np.exp(-kappa * ds_m)
    return emits


def _spectral_eta(inputs, kappa_nm, temp, sampled, wavelength_nm, emits) -> tuple:
    """Per-nm (η or S, coefficient?) at the samples: S_λ of the sources (per unit κ), or with
    coefficient models η_λ = κ_λ·S_λ + Σ η_λ,model per metre; 0 where a sample does not emit."""
    source = None
    for model, values in zip(inputs.models, sampled, strict=True):
        if model.kind == "source":
            source = model.reference_spectrum_add(source, temp, values, wavelength_nm, inputs)
    assert source is not None, "spectral bins need a source model (blackbody)"
    pairs = zip(inputs.models, sampled, strict=True)
    coefficients = [(model, values) for model, values in pairs if model.kind == "coefficient"]
    if not coefficients:
        source[~emits] = 0.0
        return source, False
    eta = kappa_nm * source
    for model, values in coefficients:
        eta = model.reference_spectrum_add(eta, temp, values, wavelength_nm, inputs)
    eta[~emits] = 0.0
    return eta, True


def _march_spectral(inputs: MarchInputs, start: float) -> MarchResult:
    """Spectral κ_λ = κ·(λ_ref/λ)^α marched at every 1 nm CMF sample (the limit of N bins):
    L = K_m Σ_λ Σ_segments Tr_λ (1 − e^{−κ_λΔs}) B_λ(T) x̄ȳz̄(λ) Δλ (with lines, Tr_λ η_λ
    (1 − e^{−κ_λΔs})/κ_λ). Same lattice as the others."""
    from incandescent.spectra.bins import REFERENCE_NM
    from incandescent.spectra.cmf import cmfs

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
        sampled = _sampled(inputs, p)
        present = kappa > 0
        for values in sampled:
            for fraction in values:
                present = present | (fraction > 0)
        emits = present & (temp >= inputs.lut.t_min_K)
        ds_m = (b - a) * vol.voxel_size_m
        kappa_nm = kappa[:, None] * kappa_scale
        x = (kappa * (b - a) * vol.voxel_size_m)[:, None] * kappa_scale  # (m, 471)
        radiance, per_metre = _spectral_eta(
            inputs, kappa_nm, temp, sampled, cmf.wavelength_nm, emits
        )
        if vol.emission_scale is not None:
            radiance *= trilinear(vol.emission_scale, p)[:, None]
        if per_metre:
            safe = np.where(x > 0, kappa_nm, 1.0)
            weight = np.where(x > 0, -np.expm1(-x) / safe, ds_m[:, None])
        else:
            weight = -np.expm1(-x)
        xyz[r] += (tr[r] * weight * radiance) @ weights
        tr[r] *= np.exp(-x)
        first = emits & np.isinf(depth[r])
        depth[r[first]] = 0.5 * (a + b)[first] * vol.voxel_size_m
        k[r] += 1
        active = r[(b < rays.t_exit[r]) & (tr[r].max(axis=1) >= s.min_transmittance)]
    seconds = time.perf_counter() - start
    return MarchResult(
        xyz, tr.mean(axis=1), samples, seconds, "numpy float64", depth, rays.ray_index
    )
