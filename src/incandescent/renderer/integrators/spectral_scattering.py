"""Single scattering in spectral bins: wavelength-dependent scattering beside soot's absorption.

Soot absorbs as κ_λ = κ·(550 nm/λ)^α (``Volume.soot_alpha``) and particles scatter as
σ_s,λ = σ_s·(550 nm/λ)^β (``Volume.scattering_alpha``; β = 4 is Rayleigh's limit for particles
much smaller than λ, Bohren & Huffman 1983 §5.2; Ångström 1929's turbidity law in general). The
transfer equation of ``single_scattering`` then holds per wavelength,

    dL_λ/ds = −(κ_λ + σ_s,λ) L_λ + κ_λ S_λ(T) + Σ_lights σ_s,λ·p(cos θ)·E_l,λ·Tr_l,λ(x),

with Tr_l,λ = exp(−(k_λ τ_κ + s_λ τ_σ)): one march toward each light gives the two optical
depths τ_κ = ∫κ ds and τ_σ = ∫σ_s ds, and every wavelength its transmittance from them
(k_λ, s_λ the two laws' scales). Dr.Jit carries the bins of ``spectra.bins`` (each light's
spectrum summed over a bin, one scale per bin at its Y-weighted wavelength); the float64
reference carries every 1 nm sample of the CIE functions, the bins' limit. The Monte Carlo
lights (the fire's own, skies, maps) and paths run per band too (``spectral_monte_carlo``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.constants import K_M
from incandescent.renderer.backends.common import THIN_STEP, Segment, trilinear
from incandescent.renderer.integrators import emission_absorption as ea
from incandescent.renderer.integrators import single_scattering as ss
from incandescent.renderer.integrators import spectral_monte_carlo as smc
from incandescent.renderer.lights import (
    DirectionalLight,
    EnvironmentLight,
    SpotLight,
    henyey_greenstein,
)
from incandescent.spectra.bins import REFERENCE_NM, SpectralBins
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.planck import planck_radiance


def spectral_scale(wavelength_nm, exponent: float) -> NDArray[np.float64]:
    """(550 nm/λ)^exponent: a coefficient at λ over its value at 550 nm."""
    return (REFERENCE_NM / np.asarray(wavelength_nm, dtype=np.float64)) ** exponent


def light_spectrum(light, wavelength_nm, observer: str) -> NDArray[np.float64]:
    """The light's spectral amount per nm at the CIE samples — W·m⁻²·nm⁻¹ of a directional
    light, W·sr⁻¹·nm⁻¹ of a point light, W·sr⁻¹·m⁻²·nm⁻¹ of a uniform sky — a blackbody's shape
    (or flat), scaled so that K_m Σ E_λ ȳ(λ) Δλ is its illuminance in lux (intensity in cd,
    luminance in cd/m²)."""
    cmf = cmfs(observer)
    if light.temperature_K is None:
        shape = np.ones_like(cmf.wavelength_nm)
    else:
        shape = planck_radiance(cmf.wavelength_nm, float(light.temperature_K))
    amount = _amount(light)
    luminous = K_M * cmf.step_nm * float(np.sum(shape * cmf.xyz_bar[:, 1]))
    return shape * (amount / luminous)


def _amount(light) -> float:
    """A light's photometric amount: lux (directional), cd/m² (a sky) or cd (point, spot)."""
    if isinstance(light, DirectionalLight):
        return light.illuminance_lux
    return light.luminance_cd_m2 if isinstance(light, EnvironmentLight) else light.intensity_cd


def light_bins(light, bins: SpectralBins, observer: str) -> NDArray[np.float64]:
    """The light's XYZ in each bin, (N, 3): K_m Σ_{λ∈b} E_λ x̄ȳz̄(λ) Δλ (sums to its XYZ over
    the CIE range; Y to its lux or cd)."""
    cmf = cmfs(observer)
    per_nm = K_M * cmf.step_nm * light_spectrum(light, cmf.wavelength_nm, observer)[:, None]
    per_nm = per_nm * cmf.xyz_bar
    return np.stack([per_nm[a:b].sum(axis=0) for a, b in zip(bins.edges[:-1], bins.edges[1:],
                                                              strict=True)])  # fmt: skip


def _smallest_scale(*scales) -> float:
    """The smallest spectral scale: optical depth × it bounds every band's from below."""
    return float(min(np.min(s) for s in scales))


class TracedSpectral(ss._Traced):
    """The traced step in spectral bins: per band its own κ_b, σ_s,b, lights' XYZ and shadows."""

    def __init__(self, kernel, integrator) -> None:
        bins = kernel.bands.bins
        sigma_scale = spectral_scale(bins.centre_nm, kernel.volume.scattering_alpha)
        self.sigma_scale = [np.float32(s) for s in sigma_scale]
        self.most = _smallest_scale(kernel.bands.kappa_scale, sigma_scale)  # before the grids
        super().__init__(kernel, integrator)
        observer = integrator.emission.observer
        self.light_xyz = [light_bins(light, bins, observer) for light, _, _ in self.lights]

    def monte_carlo(self, integrator) -> smc.TracedSpectralMonteCarlo | None:
        """The sampled lights and paths per band, or None without them."""
        K = self.kernel
        sampled = ss._sampled_lights(integrator, K.volume, K.first_table)
        if sampled is None:
            return None
        cells, skies, maps = sampled
        emitter = None if cells is None else smc.TracedSpectralEmissionLight(self, cells)
        observer = integrator.emission.observer
        sky = sum(light_bins(x, K.bands.bins, observer) for x in skies) if skies else None
        traced_maps = [
            smc.TracedSpectralEnvironmentMap(self, x, K.bands.bins, observer) for x in maps
        ]
        lights = (emitter, sky, traced_maps)
        return smc.TracedSpectralMonteCarlo(
            self, lights, integrator.spp, integrator.max_bounces, K.seed
        )

    def transmittance_grid(self, index: int):
        """Light ``index``'s two optical depths (κ, σ_s) marched from every voxel centre."""
        return self.from_centres(index, self.optical_depths_along)

    def optical_depths_along(self, p, d, length, dt=None):
        """Traced: (∫κ ds, ∫σ_s ds) from p along d for ``length`` voxels (midpoint rule at
        steps of ``dt`` voxels, the render's by default), stopping once every band's optical
        depth passes the shadow limit."""
        K = self.kernel
        dr, m = K.dr, K.m
        dt, most = (K.dt if dt is None else dt), self.most

        def cond(k, tau_k, tau_s):
            return (k * dt < length) & (most * (tau_k + tau_s) < ss.MAX_SHADOW_DEPTH)

        def body(k, tau_k, tau_s):
            a, b, _, kappa, _, sigma = self.segment(p, d, k, dt, length)
            metres = (b - a) * K.ds_per_voxel
            return k + 1.0, dr.fma(kappa, metres, tau_k), dr.fma(sigma, metres, tau_s)

        state = (m.Float(0.0), m.Float(0.0), m.Float(0.0))
        _, tau_k, tau_s = dr.while_loop(state, cond, body, labels=("k", "tau_k", "tau_s"))
        return tau_k, tau_s

    def lit_bands(self, p, c, view) -> list:
        """Traced: per band, Σ_lights p(cos θ)·E_l,b·Tr_l,b at p (corners c) seen along ``view``."""
        K = self.kernel
        dr, m = K.dr, K.m
        out = [m.Array3f(0.0) for _ in self.sigma_scale]
        for index, (light, _, _) in enumerate(self.lights):
            d, length, falloff = self.geometry(index, p)
            if self.shadow_grids is not None:
                tau_k, tau_s = (K.trilinear(grid, c) for grid in self.shadow_grids[index])
            else:
                tau_k, tau_s = self.optical_depths_along(p, d, length)
            weight = henyey_greenstein(dr.dot(d, view), self.g_at(p, c)) * falloff
            if isinstance(light, SpotLight):
                weight = weight * light.factor(-dr.dot(d, m.Array3f(*light.direction)), dr.clip)
            scales = zip(self.kappa_scale, self.sigma_scale, self.light_xyz[index], strict=True)
            for band, (ks, sigma_scale, xyz) in enumerate(scales):
                shadow = dr.exp(-(tau_k * ks + tau_s * sigma_scale))
                out[band] = dr.fma(m.Array3f(*(float(v) for v in xyz)), weight * shadow, out[band])
        return out

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        K = self.kernel
        dr = K.dr
        lit = self.lit_bands(K.position, c, K.ray_direction)
        if self.sampled is not None:
            lit = smc._add(lit, self.sampled.estimate(self.sigma_s))
        scale = None if K.scale is None else K.trilinear(K.scale, c)
        updated = []
        for band, (ks, sigma_scale, tr_b) in enumerate(
            zip(self.kappa_scale, self.sigma_scale, tr, strict=True)
        ):
            kappa_b, sigma_b = kappa * ks, self.sigma_s * sigma_scale
            eta = self.emission_coefficient(band, kappa_b, temp, sampled)
            eta = dr.fma(lit[band], sigma_b, eta if scale is None else eta * scale)
            sigma_t = kappa_b + sigma_b
            x = sigma_t * ds_m
            e = dr.exp(-x)
            series = 1.0 - x * (0.5 - x * (1.0 / 6.0))
            weight = dr.select(x < THIN_STEP, ds_m * series, (1.0 - e) / sigma_t)
            L = dr.fma(eta, tr_b * weight, L)
            updated.append(tr_b * e)
        return updated, L


class ReferenceSpectral(ss._ReferenceLights, ea._SpectralReference):
    """Float64 at every 1 nm CIE sample: κ_λ, σ_s,λ, the lights' spectra and transmittances."""

    def __init__(self, inputs, integrator) -> None:
        observer = integrator.emission.observer
        super().__init__(inputs, observer)
        vol = inputs.volume
        self.sigma_scale = spectral_scale(self.cmf.wavelength_nm, vol.scattering_alpha)
        self.most = _smallest_scale(self.kappa_scale, self.sigma_scale)
        wavelength = self.cmf.wavelength_nm
        self.lights = [
            (light, np.asarray(ss._in_voxels(light, vol)), light_spectrum(light, wavelength,
                                                                           observer))
            for light in ss._fixed(integrator.lights)
        ]  # fmt: skip
        self.path_dt = float(ss.path_step(inputs.settings.step_voxels, integrator))
        bins = inputs.bands.bins
        self.bin_kappa = bins.kappa_scale
        self.bin_sigma = spectral_scale(bins.centre_nm, vol.scattering_alpha)
        self.sampled = self.monte_carlo(integrator)
        self.shadow_grids: list[tuple[NDArray, NDArray]] | None = None
        if integrator.shadows == "grid":
            centres = np.indices(vol.shape, dtype=np.float64).reshape(3, -1).T + 0.5
            pairs = [self._depths(i, centres) for i in range(len(self.lights))]
            self.shadow_grids = [(k.reshape(vol.shape), s.reshape(vol.shape)) for k, s in pairs]

    def monte_carlo(self, integrator) -> smc.ReferenceSpectralMonteCarlo | None:
        """The sampled lights and paths at every nanometre, or None without them."""
        inputs = self.inputs
        sampled = ss._sampled_lights(integrator, inputs.volume, inputs.lut)
        if sampled is None:
            return None
        cells, skies, maps = sampled
        emitter = None if cells is None else smc.ReferenceSpectralEmissionLight(self, cells)
        observer, wavelength = integrator.emission.observer, self.cmf.wavelength_nm
        sky = sum(light_spectrum(x, wavelength, observer) for x in skies) if skies else None
        ref_maps = [smc.ReferenceSpectralEnvironmentMap(self, x, observer) for x in maps]
        seed = inputs.settings.seed
        return smc.ReferenceSpectralMonteCarlo(
            self, (emitter, sky, ref_maps), integrator.spp, integrator.max_bounces, seed
        )

    def emitted_nm(self, p: NDArray, kappa: NDArray) -> NDArray:
        """η_λ (per m, (m, 471)) at positions p where the absorption at 550 nm is ``kappa``,
        emission scale included."""
        inputs, vol = self.inputs, self.inputs.volume
        temp, sampled = trilinear(vol.temperature_K, p), ea._sampled(inputs, p)
        emits = ea._present(kappa, sampled) & (temp >= inputs.lut.t_min_K)
        kappa_nm = kappa[:, None] * self.kappa_scale
        eta, per_metre = self.eta(kappa_nm, temp, sampled, emits)
        eta = eta if per_metre else eta * kappa_nm
        if vol.emission_scale is not None:
            eta *= trilinear(vol.emission_scale, p)[:, None]
        return eta

    def _depths(self, index: int, p: NDArray) -> tuple[NDArray, NDArray]:
        d, length, _ = self.geometry(index, p)
        return self.optical_depths(p, d, length, most=self.most)

    def lit_nm(self, p: NDArray, view: NDArray) -> NDArray:
        """Σ_lights p(cos θ)·E_l,λ·Tr_l,λ at p (m, 3) seen along unit ``view``, (m, 471)."""
        g = self.g_at(p)
        out = np.zeros((len(p), self.cmf.wavelength_nm.size))
        for index, (light, _, spectrum) in enumerate(self.lights):
            d, _, falloff = self.geometry(index, p)
            if self.shadow_grids is not None:
                tau_k, tau_s = (trilinear(grid, p) for grid in self.shadow_grids[index])
            else:
                tau_k, tau_s = self._depths(index, p)
            weight = henyey_greenstein(np.einsum("ij,ij->i", view, d), g) * falloff
            if isinstance(light, SpotLight):
                weight = weight * light.factor(-(d @ np.asarray(light.direction)), np.clip)
            depth = tau_k[:, None] * self.kappa_scale + tau_s[:, None] * self.sigma_scale
            out += (weight[:, None] * spectrum) * np.exp(-depth)
        return out

    def step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        vol, inputs = self.inputs.volume, self.inputs
        r, p, ds_m = segment.r, segment.p, segment.ds_m
        kappa, sigma_s, temp, sampled, emits = self.medium(p)
        kappa_nm = kappa[:, None] * self.kappa_scale
        sigma_nm = sigma_s[:, None] * self.sigma_scale
        eta, per_metre = self.eta(kappa_nm, temp, sampled, emits)
        eta = eta if per_metre else eta * kappa_nm
        if vol.emission_scale is not None:
            eta *= trilinear(vol.emission_scale, p)[:, None]
        lit = sigma_s > 0
        if lit.any() and self.lights:
            view = inputs.rays.direction[r[lit]]
            eta[lit] += sigma_nm[lit] * self.lit_nm(p[lit], view)
        if lit.any() and self.sampled is not None:
            rows = r[lit]
            view, index = inputs.rays.direction[rows], inputs.rays.ray_index[rows]
            assert segment.k is not None, "the reference march numbers its segments"
            total = self.sampled.total(p[lit], view, index, segment.k[lit])
            eta[lit] += sigma_nm[lit] * total * (1.0 / self.sampled.spp)
        sigma_t = kappa_nm + sigma_nm
        x = sigma_t * ds_m[:, None]
        weight = np.where(x > 0, -np.expm1(-x) / np.where(x > 0, sigma_t, 1.0), ds_m[:, None])
        xyz[r] += (tr[r] * weight * eta) @ self.weights
        tr[r] *= np.exp(-x)
        return emits


ss.SPECTRAL.update(traced=TracedSpectral, reference=ReferenceSpectral)
