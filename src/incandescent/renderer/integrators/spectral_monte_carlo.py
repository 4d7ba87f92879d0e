"""The Monte Carlo lights and paths of ``monte_carlo`` in spectral bins: the fire's own light,
uniform skies, lat-long maps and multiple scattering carried per band (Dr.Jit) or per nanometre
(float64).

Each light's radiance is carried per band: the emission light's L_e,b marched with κ_b, σ_s,b
and the bins' emission tables, a sky's spectrum summed over each bin and its transmittance
Tr_b = exp(−(k_b τ_κ + s_b τ_σ)) from one march of the two optical depths (as the sun's in
``spectral_scattering``), a map's RGB pixel as three flat spectra with its XYZ exactly
(:func:`map_coefficients`). Directions do not depend on λ (the phase function is grey): one
direction serves every band.

A path's free flights do depend on λ. Each path draws a hero band h (uniform) and samples
every flight with pdf σ_t,h·Tr_h; band b's contribution is its throughput over the mean of the
bands' path pdfs,

    Π_v σ_s,b·Tr_b / ((1/N) Σ_c Π_v σ_t,c·Tr_c),

one-sample multiple importance sampling over wavelengths on whole paths (Wilkie et al. 2014,
"Hero wavelength spectral sampling", EGSR; pbrt-v4's volpath with its r_u ratios): unbiased in
every band (each band's path pdf is in the mixture; a flight that leaves the box carries
nothing), at most N × the band's own albedo product, and with grey laws the grey path's albedo
product exactly. (Mixing per vertex instead lets a thick blue band's weight become a product of
rare large factors: measured 8 % dark in a Rayleigh white furnace.) Russian roulette reads the
largest band weight. The float64 reference draws the same bands, distances and roulette from
the bins' scales (the same samples as Dr.Jit) and weighs them at every 1 nm sample, the bins'
limit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.constants import K_M
from incandescent.renderer import rays
from incandescent.renderer.backends.camera_rays import clip_to_box
from incandescent.renderer.backends.common import THIN_STEP, trilinear
from incandescent.renderer.integrators import emission_light as el
from incandescent.renderer.integrators import environment_map as env
from incandescent.renderer.integrators import monte_carlo as mc
from incandescent.spectra.cmf import cmfs


def _add(a: list, b: list) -> list:
    """Band by band sums of two traced radiances (lists of Array3f)."""
    return [x + y for x, y in zip(a, b, strict=True)]


def _flight_factors(kappa, sigma, tau_k, tau_s, hero, scales, ops) -> tuple[list, list]:
    """At a flight's end, for each (k, s) of ``scales``: σ_s·Tr/(σ_t,h·Tr_h) (the throughput's
    factor) and σ_t·Tr/(σ_t,h·Tr_h) (its flight pdf relative to the hero band h's, which drew
    the distance); exponents clamped at e^80."""
    kh, sh = hero
    inverse = 1.0 / ops.maximum(kappa * kh + sigma * sh, 1e-30)
    depth_h = tau_k * kh + tau_s * sh
    through, pdfs = [], []
    for k, s in scales:
        tr = ops.exp(ops.minimum(depth_h - (tau_k * k + tau_s * s), 80.0)) * inverse
        through.append(sigma * s * tr)
        pdfs.append((kappa * k + sigma * s) * tr)
    return through, pdfs


#: Where an RGB map pixel's spectrum steps, nm: three flat bands, 360–490, 490–590, 590–830.
MAP_STEPS_NM = (490.0, 590.0)


def map_basis(wavelength_nm) -> NDArray[np.float64]:
    """The three flat spectra a map pixel is made of, (3, n) at ``wavelength_nm``."""
    lam = np.asarray(wavelength_nm, dtype=np.float64)
    edges = (-np.inf, *MAP_STEPS_NM, np.inf)
    return np.stack([(lam >= a) & (lam < b) for a, b in zip(edges[:-1], edges[1:], strict=True)])


def map_coefficients(xyz, observer: str) -> NDArray:
    """Each pixel's amounts a (P, 3) of the three flat spectra, its XYZ exactly: K_m Σ_λ
    (a·B(λ)) x̄ȳz̄(λ) Δλ = XYZ (a < 0 where a colour is more saturated than the steps give)."""
    cmf = cmfs(observer)
    basis_xyz = map_basis(cmf.wavelength_nm) @ (K_M * cmf.step_nm * cmf.xyz_bar)  # (3, 3)
    return np.linalg.solve(basis_xyz.T, np.asarray(xyz, dtype=np.float64).reshape(-1, 3).T).T


def map_bins(bins, observer: str) -> NDArray[np.float64]:
    """Per bin the XYZ of each flat spectrum, (N, 3, 3) [bin, spectrum, XYZ]: a pixel's XYZ in
    bin b is a @ this[b], and the bins sum to its XYZ."""
    cmf = cmfs(observer)
    per_nm = map_basis(cmf.wavelength_nm)[:, :, None] * (K_M * cmf.step_nm * cmf.xyz_bar)
    spans = zip(bins.edges[:-1], bins.edges[1:], strict=True)
    return np.stack([per_nm[:, a:b].sum(axis=1) for a, b in spans])


# --- Dr.Jit -----------------------------------------------------------------------------------
class TracedSpectralEmissionLight(el.TracedEmissionLight):
    """The emission light's pair per band (a list of XYZ), for a ``TracedSpectral`` program."""

    def pair(self, p, d, u) -> list:
        K = self.K
        out = [K.m.Array3f(0.0) for _ in self.program.sigma_scale]
        for w, weight in self.weighted(p, d, u):
            radiance = self.radiance_along(p, w)
            out = [K.dr.fma(L, weight, o) for L, o in zip(radiance, out, strict=True)]
        return out

    def radiance_along(self, p, w) -> list:
        """Traced: L_e,b(p, ω) per band, marched at ``path_dt`` with κ_b, σ_s,b and the bins'
        tables (exact per segment), until every band's optical depth passes ``max_depth``."""
        K, program = self.K, self.program
        dr, m = K.dr, K.m
        _, t_exit = clip_to_box(dr, m, p, w, K.shape)
        dt, most, limit = program.path_dt, program.most, el.max_depth(K.min_tr)
        scales = list(zip(program.kappa_scale, program.sigma_scale, strict=True))

        def cond(k, tau_k, tau_s, L):
            return (k * dt < t_exit) & (most * (tau_k + tau_s) < limit)

        def body(k, tau_k, tau_s, L):
            a, b, c, kappa, temp, sigma = program.segment(p, w, k, dt, t_exit)
            sampled = [model.sample(K, bound, c) for model, bound in K.terms]
            scale = None if K.scale is None else K.trilinear(K.scale, c)
            ds_m = (b - a) * K.ds_per_voxel
            out = []
            for band, ((ks, ss), L_b) in enumerate(zip(scales, L, strict=True)):
                kappa_b = kappa * ks
                eta = program.emission_coefficient(band, kappa_b, temp, sampled)
                eta = eta if scale is None else eta * scale
                sigma_t = kappa_b + sigma * ss
                x = sigma_t * ds_m
                series = 1.0 - x * (0.5 - x * (1.0 / 6.0))
                weight = dr.select(x < THIN_STEP, ds_m * series, (1.0 - dr.exp(-x)) / sigma_t)
                tr = dr.exp(-(tau_k * ks + tau_s * ss))
                out.append(dr.fma(eta, tr * weight, L_b))
            return k + 1.0, dr.fma(kappa, ds_m, tau_k), dr.fma(sigma, ds_m, tau_s), out

        state = (m.Float(0.0), m.Float(0.0), m.Float(0.0), [m.Array3f(0.0) for _ in scales])
        return dr.while_loop(state, cond, body, labels=("k", "tau_k", "tau_s", "L"))[3]


class TracedSpectralEnvironmentMap(env.TracedEnvironmentMap):
    """A lat-long map's next event per band: each pixel the three flat spectra of
    :func:`map_coefficients`, each band's XYZ of them (:func:`map_bins`) and its Tr_b."""

    def __init__(self, program, sky, bins, observer: str) -> None:
        super().__init__(program, sky)
        m = self.K.m
        coefficients = map_coefficients(self.tables.xyz, observer)
        self.coefficients = [m.Float(coefficients[:, c].astype(np.float32)) for c in range(3)]
        self.per_band = map_bins(bins, observer)
        pairs = zip(program.kappa_scale, program.sigma_scale, strict=True)
        self.scales = [(float(k), float(s)) for k, s in pairs]

    def event(self, p, d, u) -> list:
        K, program = self.K, self.program
        dr, m = K.dr, K.m
        out = [m.Array3f(0.0) for _ in self.scales]
        for w, index, weight in self.weighted(p, d, u):
            _, t_exit = clip_to_box(dr, m, p, w, K.shape)
            length = dr.maximum(t_exit, 0.0)
            tau_k, tau_s = program.optical_depths_along(p, w, length, program.path_dt)
            a = [dr.gather(m.Float, c, index) for c in self.coefficients]
            for band, ((ks, ss), table) in enumerate(zip(self.scales, self.per_band, strict=True)):
                xyz = m.Array3f(
                    *(sum(a[c] * float(table[c, i]) for c in range(3)) for i in range(3))
                )
                shadow = dr.exp(-(tau_k * ks + tau_s * ss))
                out[band] = dr.fma(xyz, weight * shadow, out[band])
        return out


class TracedSpectralMonteCarlo(mc.TracedMonteCarlo):
    """The traced estimator per band: the sampled lights' next events and the paths, whose
    throughputs are per band and whose flights follow a hero band per path."""

    def __init__(self, program, lights, spp: int, max_bounces: int, seed: int) -> None:
        """``lights``: (the emission light's estimator or None, the skies' XYZ per band (N, 3)
        or None, the maps' estimators)."""
        emitter, sky_bands, maps = lights
        super().__init__(program, (emitter, None, maps), spp, max_bounces, seed)
        self.sky_bands = (
            None if sky_bands is None else [[float(v) for v in xyz] for xyz in sky_bands]
        )
        pairs = zip(program.kappa_scale, program.sigma_scale, strict=True)
        self.scales = [(float(k), float(s)) for k, s in pairs]
        m = self.K.m
        self.band_kappa = m.Float(np.asarray(program.kappa_scale, dtype=np.float32))
        self.band_sigma = m.Float(np.asarray(program.sigma_scale, dtype=np.float32))
        self.ops.exp = self.K.dr.exp

    def zero(self) -> list:
        return [self.K.m.Array3f(0.0) for _ in self.scales]

    def estimate(self, sigma_s) -> list:
        """Traced: per band the mean over ``spp`` samples of the sampled part of J (XYZ per sr;
        the caller multiplies by σ_s,b); 0 where σ_s = 0."""
        K = self.K
        dr, m = K.dr, K.m

        def body(j, acc):
            return j + 1, _add(acc, self.sample(j))

        def run(sigma_s):
            state = (m.UInt(0), self.zero())
            _, acc = dr.while_loop(state, lambda j, acc: j < self.spp, body, labels=("j", "J"))
            return [a * (1.0 / self.spp) for a in acc]

        return dr.if_stmt((sigma_s,), sigma_s > 0.0, run, lambda sigma_s: self.zero())

    def sample(self, j) -> list:
        K = self.K
        p, d = K.position, K.ray_direction
        out = self.next_events(p, d, self.uniforms(j, mc.NEE_DIMENSIONS), j)
        return _add(out, self.path(p, d, j)) if self.max_bounces >= 2 else out

    def next_events(self, p, d, u, j, bounce=None) -> list:
        """Traced: the maps, the emission light's pair and the skies at p seen along d, per
        band."""
        K, program = self.K, self.program
        dr, m = K.dr, K.m
        out = self.zero()
        for sky_map in self.maps:
            u_map = self.uniforms(j, env.MAP_DIMENSIONS, bounce, env.MAP_SALT)
            out = _add(out, sky_map.event(p, d, u_map))
        if self.emitter is not None:
            out = _add(out, self.emitter.pair(p, d, u[: el.DIMENSIONS]))
        if self.sky_bands is not None:
            n, g = el.DIMENSIONS, program.g_at(p)
            w = m.Array3f(*el.sample_henyey_greenstein(u[n], u[n + 1], d, g, self.ops))
            _, t_exit = clip_to_box(dr, m, p, w, K.shape)
            length = dr.maximum(t_exit, 0.0)
            tau_k, tau_s = program.optical_depths_along(p, w, length, program.path_dt)
            pairs = zip(self.scales, self.sky_bands, out, strict=True)
            out = [
                dr.fma(m.Array3f(*xyz), dr.exp(-(tau_k * ks + tau_s * ss)), o)
                for (ks, ss), xyz, o in pairs
            ]
        return out

    def path(self, p0, d0, j) -> list:
        """Traced: Σ over the path's vertices of its band weights × every light's next events."""
        K = self.K
        dr, m = K.dr, K.m
        n = mc.NEE_DIMENSIONS

        count = len(self.scales)
        band = dr.minimum(m.UInt(self.uniforms(j, mc.VERTEX_DIMENSIONS, 1)[n + 9] * count),
                          count - 1)  # fmt: skip
        hero = (
            dr.gather(m.Float, self.band_kappa, band),
            dr.gather(m.Float, self.band_sigma, band),
        )

        def cond(b, p, d, beta, pdfs, acc, alive):
            return alive & (b < self.max_bounces)

        def body(b, p, d, beta, pdfs, acc, alive):
            u = self.uniforms(j, mc.VERTEX_DIMENSIONS, b)
            w, ratio = self.direction(p, d, u[n:])
            hit, t, (through, relative) = self.hero_flight(p, w, u[n + 2], hero)
            x = dr.fma(w, t, p)
            beta = [bb * f * ratio for bb, f in zip(beta, through, strict=True)]
            pdfs = [q * r for q, r in zip(pdfs, relative, strict=True)]
            inverse = count / sum(pdfs[1:], pdfs[0])
            weight = [bb * inverse for bb in beta]

            def seen(x, w, weight, acc):
                lit = self.program.lit_bands(x, K.corners(x), w)
                events = _add(lit, self.next_events(x, w, u[:n], j, b))
                return [dr.fma(e, wb, a) for e, wb, a in zip(events, weight, acc, strict=True)]

            acc = dr.if_stmt((x, w, weight, acc), hit, seen, lambda x, w, weight, acc: acc)
            most = weight[0]
            for wb in weight[1:]:
                most = dr.maximum(most, wb)
            survive = dr.minimum(most * (1.0 / mc.ROULETTE), 1.0)
            alive = hit & (u[n + 8] < survive)
            beta = [bb / dr.maximum(survive, 1e-30) for bb in beta]
            return b + 1, x, w, beta, pdfs, acc, alive

        ones = [m.Float(1.0) for _ in self.scales]
        state = (m.UInt(1), p0, d0, ones, list(ones), self.zero(), m.Bool(True))
        labels = ("b", "p", "d", "beta", "pdfs", "J", "alive")
        return dr.while_loop(state, cond, body, labels=labels)[5]

    def hero_flight(self, p, w, u, hero):
        """Traced: (hit, distance in voxels, (each band's throughput factor, its pdf relative
        to the hero's)) of a flight from p along w: the distance where the ``hero`` band's
        (k_h, s_h) optical depth passes −ln(1 − u) (the march inverted exactly)."""
        K, program = self.K, self.program
        dr, m = K.dr, K.m
        kh, sh = hero
        target = -dr.log(1.0 - u)
        _, t_exit = clip_to_box(dr, m, p, w, K.shape)
        dt, ds = program.path_dt, K.ds_per_voxel

        def cond(k, tau_k, tau_s, hit_at, hit):
            return (k * dt < t_exit) & ~hit

        def body(k, tau_k, tau_s, hit_at, hit):
            a, b, _, kappa, _, sigma = program.segment(p, w, k, dt, t_exit)
            sigma_h = dr.maximum(kh * kappa + sh * sigma, 1e-30)
            tau_h = kh * tau_k + sh * tau_s
            now = tau_h + sigma_h * (b - a) * ds >= target
            t_now = dr.minimum(a + (target - tau_h) / (sigma_h * ds), b)
            into = (t_now - a) * ds
            found = (t_now, kappa, sigma, dr.fma(kappa, into, tau_k), dr.fma(sigma, into, tau_s))
            hit_at = tuple(dr.select(now, new, old) for new, old in zip(found, hit_at, strict=True))
            metres = (b - a) * ds
            return (
                k + 1.0,
                dr.fma(kappa, metres, tau_k),
                dr.fma(sigma, metres, tau_s),
                hit_at,
                hit | now,
            )

        zero = m.Float(0.0)
        state = (
            zero,
            m.Float(0.0),
            m.Float(0.0),
            tuple(m.Float(0.0) for _ in range(5)),
            m.Bool(False),
        )
        _, _, _, hit_at, hit = dr.while_loop(
            state, cond, body, labels=("k", "tau_k", "tau_s", "at", "hit")
        )
        t_hit, kappa, sigma, tau_k, tau_s = hit_at
        factors = _flight_factors(kappa, sigma, tau_k, tau_s, hero, self.scales, self.ops)
        return hit, t_hit, factors


# --- float64 ----------------------------------------------------------------------------------
class ReferenceSpectralEmissionLight(el.ReferenceEmissionLight):
    """The emission light's pair at every 1 nm sample, for a ``ReferenceSpectral`` program."""

    def radiance_along(self, p, w) -> NDArray:
        """L_e,λ(p, ω), (m, 471): the traced march with κ_λ, σ_s,λ and the exact spectra."""
        program, vol = self.program, self.inputs.volume
        ks, ss, dt = program.kappa_scale, program.sigma_scale, program.path_dt
        _, t_exit = rays.clip_to_box(p, w, np.asarray(vol.shape, dtype=np.float64))
        tau_k, tau_s, L, k = np.zeros(len(p)), np.zeros(len(p)), np.zeros((len(p), ks.size)), 0
        limit = el.max_depth(np.float32(self.inputs.settings.min_transmittance))
        while True:
            a = k * dt
            depth = program.most * (tau_k + tau_s)
            live = np.flatnonzero((a < t_exit) & (depth < limit))
            if not live.size:
                return L
            b = np.minimum(a + dt, t_exit[live])
            q = p[live] + w[live] * (0.5 * (a + b))[:, None]
            ds_m = (b - a) * vol.voxel_size_m
            kappa, sigma = trilinear(vol.absorption_per_m, q), trilinear(vol.scattering_per_m, q)
            sigma_t = kappa[:, None] * ks + sigma[:, None] * ss
            x = sigma_t * ds_m[:, None]
            weight = np.where(x > 0, -np.expm1(-x) / np.where(x > 0, sigma_t, 1.0), ds_m[:, None])
            tr = np.exp(-(tau_k[live, None] * ks + tau_s[live, None] * ss))
            L[live] += tr * weight * program.emitted_nm(q, kappa)
            tau_k[live] += kappa * ds_m
            tau_s[live] += sigma * ds_m
            k += 1


class ReferenceSpectralEnvironmentMap(env.ReferenceEnvironmentMap):
    """A lat-long map's next event at every 1 nm sample: each pixel's three flat spectra."""

    def __init__(self, program, sky, observer: str) -> None:
        super().__init__(program, sky)
        self.coefficients = map_coefficients(self.tables.xyz, observer)
        self.basis = map_basis(program.cmf.wavelength_nm)

    def event(self, p, d, u) -> NDArray:
        program = self.program
        shape = np.asarray(self.inputs.volume.shape, dtype=np.float64)
        out = np.zeros((len(p), self.basis.shape[1]))
        for w, index, weight in self.weighted(p, d, u):
            _, t_exit = rays.clip_to_box(p, w, shape)
            length = np.maximum(t_exit, 0.0)
            tau_k, tau_s = program.optical_depths(p, w, length, program.path_dt, program.most)
            depth = tau_k[:, None] * program.kappa_scale + tau_s[:, None] * program.sigma_scale
            out += (self.coefficients[index] @ self.basis) * np.exp(-depth) * weight[:, None]
        return out


class ReferenceSpectralMonteCarlo(mc.ReferenceMonteCarlo):
    """The float64 estimator at every 1 nm sample, with the samples of
    :class:`TracedSpectralMonteCarlo` (its bands, distances and roulette from the bins)."""

    def __init__(self, program, lights, spp: int, max_bounces: int, seed: int) -> None:
        """``lights``: (the emission light's estimator or None, the skies' radiance per nm
        (471,) or None, the maps' estimators)."""
        emitter, sky_nm, maps = lights
        super().__init__(program, (emitter, None, maps), spp, max_bounces, seed)
        self.sky = sky_nm
        self.width = program.kappa_scale.size
        self.nm = list(zip(program.kappa_scale, program.sigma_scale, strict=True))
        self.bins = list(zip(program.bin_kappa, program.bin_sigma, strict=True))

    def next_events(self, p, d, u, seeds, bounce=None) -> NDArray:
        program = self.program
        out = np.zeros((len(p), self.width))
        for sky_map in self.maps:
            ray_index, step, sample = seeds
            key = self.key ^ env.MAP_SALT
            hashes = el.uniforms(ray_index, step, sample, key, env.MAP_DIMENSIONS, bounce)
            out += sky_map.event(p, d, [mc._to_float(h) for h in hashes])
        if self.emitter is not None:
            out += self.emitter.pair(p, d, u[: el.DIMENSIONS])
        if self.sky is not None:
            g, n = program.g_at(p), el.DIMENSIONS
            w = np.stack(el.sample_henyey_greenstein(u[n], u[n + 1], d.T, g, el.NUMPY_OPS), 1)
            _, t_exit = rays.clip_to_box(p, w, np.asarray(self.inputs.volume.shape, dtype=float))
            length = np.maximum(t_exit, 0.0)
            tau_k, tau_s = program.optical_depths(p, w, length, program.path_dt, program.most)
            depth = tau_k[:, None] * program.kappa_scale + tau_s[:, None] * program.sigma_scale
            out += np.exp(-depth) * self.sky
        return out

    def path(self, p, d, seeds) -> NDArray:
        ray_index, step, sample = seeds
        acc, beta = np.zeros((len(p), self.width)), np.ones((len(p), self.width))
        beta_bins, pdfs = np.ones((len(p), len(self.bins))), np.ones((len(p), len(self.bins)))
        live, n = np.arange(len(p)), mc.NEE_DIMENSIONS
        first = el.uniforms(ray_index, step, sample, self.key, mc.VERTEX_DIMENSIONS,
                            np.ones(len(p), dtype=np.uint32))[n + 9]  # fmt: skip
        hero = np.minimum((mc._to_float(first) * len(self.bins)).astype(np.int64),
                          len(self.bins) - 1)  # fmt: skip
        p, d = p.copy(), d.copy()
        for b in range(1, self.max_bounces):
            if not live.size:
                break
            bounce = np.full(live.size, b, dtype=np.uint32)
            hashes = el.uniforms(ray_index[live], step[live], sample[live], self.key,
                                 mc.VERTEX_DIMENSIONS, bounce)  # fmt: skip
            u = [mc._to_float(h) for h in hashes]
            w, ratio = self.direction(p[live], d[live], u[n:])
            hit, t, f_nm, f_bins, relative = self.hero_flight(p[live], w, u[n + 2], hero[live])
            live, w, t, ratio = live[hit], w[hit], t[hit], ratio[hit, None]
            x = p[live] + w * t[:, None]
            beta[live] *= f_nm[hit] * ratio
            beta_bins[live] *= f_bins[hit] * ratio
            pdfs[live] *= relative[hit]
            inverse = len(self.bins) / pdfs[live].sum(axis=1, keepdims=True)
            rows = (ray_index[live], step[live], sample[live])
            u_nee = [v[hit] for v in u[:n]]
            events = self.program.lit_nm(x, w) + self.next_events(x, w, u_nee, rows, bounce[hit])
            acc[live] += beta[live] * inverse * events
            p[live], d[live] = x, w
            survive = np.minimum((beta_bins[live] * inverse).max(axis=1) / mc.ROULETTE, 1.0)
            going = u[n + 8][hit] < survive
            beta[live] /= np.maximum(survive, 1e-30)[:, None]
            beta_bins[live] /= np.maximum(survive, 1e-30)[:, None]
            live = live[going]
        return acc

    def hero_flight(self, p, w, u, hero) -> tuple[NDArray, ...]:
        """(hit, distance in voxels, the throughput factors per nm (m, 471) and per bin (m, N),
        the bins' pdfs relative to the hero's (m, N)) of flights from p along w, as traced
        (``hero``: each flight's band)."""
        vol, dt = self.inputs.volume, self.program.path_dt
        kh, sh = (np.asarray(s)[hero] for s in zip(*self.bins, strict=True))
        target = -np.log1p(-u)
        _, t_exit = rays.clip_to_box(p, w, np.asarray(vol.shape, dtype=np.float64))
        tau_k, tau_s = np.zeros(len(p)), np.zeros(len(p))
        at = np.zeros((5, len(p)))  # t, κ, σ_s, τ_κ, τ_σ where each flight ends
        hit, k = np.zeros(len(p), dtype=bool), 0
        while True:
            a = k * dt
            live = np.flatnonzero((a < t_exit) & ~hit)
            if not live.size:
                break
            b = np.minimum(a + dt, t_exit[live])
            q = p[live] + w[live] * (0.5 * (a + b))[:, None]
            kappa, sigma = trilinear(vol.absorption_per_m, q), trilinear(vol.scattering_per_m, q)
            sigma_h = np.maximum(kh[live] * kappa + sh[live] * sigma, 1e-30)
            tau_h = kh[live] * tau_k[live] + sh[live] * tau_s[live]
            metres = (b - a) * vol.voxel_size_m
            now = tau_h + sigma_h * metres >= target[live]
            rows = live[now]
            t_now = np.minimum(
                a + (target[rows] - tau_h[now]) / (sigma_h[now] * vol.voxel_size_m), b[now]
            )
            into = (t_now - a) * vol.voxel_size_m
            at[:, rows] = (
                t_now,
                kappa[now],
                sigma[now],
                tau_k[rows] + kappa[now] * into,
                tau_s[rows] + sigma[now] * into,
            )
            hit[rows] = True
            tau_k[live] += kappa * metres
            tau_s[live] += sigma * metres
            k += 1
        bins, nm = np.asarray(self.bins).T, np.asarray(self.nm).T  # (2, N), (2, 471)
        end = (at[1], at[2], at[3], at[4], (kh, sh))
        f_nm, _ = _flight_factors_nd(*end, nm)
        f_bins, relative = _flight_factors_nd(*end, bins)
        return hit, at[0], f_nm, f_bins, relative


def _flight_factors_nd(kappa, sigma, tau_k, tau_s, hero, scales) -> tuple[NDArray, NDArray]:
    """:func:`_flight_factors` in float64 arrays: ``scales`` (2, n) rows of (k, s); (m, n)."""
    kh, sh = hero
    inverse = 1.0 / np.maximum(kappa * kh + sigma * sh, 1e-30)
    depth = tau_k[:, None] * scales[0] + tau_s[:, None] * scales[1]
    tr = np.exp(np.minimum((tau_k * kh + tau_s * sh)[:, None] - depth, 80.0)) * inverse[:, None]
    extinction = kappa[:, None] * scales[0] + sigma[:, None] * scales[1]
    return sigma[:, None] * scales[1] * tr, extinction * tr
