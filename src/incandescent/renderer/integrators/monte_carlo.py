"""The Monte Carlo part of the scattering integrators: the lights sampled at a scattering
sample (the volume's own emission, a uniform sky) and, for multiple scattering, the paths that
carry light scattered more than once.

At a camera ray's sample p (direction d), the in-scattered radiance is σ_s(p)·J(p) with

    J(p) = ∫ p_HG(ω·d) L_i(p, ω) dω.

The deterministic lights (directional, point; ``single_scattering``) give their part of J
exactly; this module estimates the rest, averaged over ``spp`` samples:

* **next-event estimation** at a point x seen along d — the emission light's balance-weighted
  pair (``emission_light``) and the sky: ω from the phase function, L_sky·Tr(x → box along ω)
  (the phase pdf cancels the phase);
* **paths** (``max_bounces`` ≥ 2): from p, ω₁ from the phase function about d (with the
  fire's light: from the mixture q = (1 − γ)·p_HG + γ·pdf_L of the phase function and the
  power-sampled cells, γ = ``GUIDE``, weighted p_HG/q — one-sample MIS that sends paths where
  the light they will find is: in a cloud lit by a small fire, the order-2 light concentrates
  near the fire), a free-flight
  distance t₁ with pdf σ_t·Tr (the march inverted exactly: the segment where the optical depth
  passes −ln(1 − u)), x₁ = p + t₁ω₁; the path's weight gains the albedo σ_s/σ_t there and J
  gains weight × (all lights' next events at x₁ seen along ω₁) — one more order of scattering;
  then from x₁ along ω₂ … up to ``max_bounces`` − 1 vertices, or until a flight leaves the box
  or Russian roulette ends it: after each vertex the path goes on with probability
  min(1, weight/``ROULETTE``) and its weight is divided by that (Arvo & Kirk 1990; unbiased,
  and a path whose albedos have made it dim stops costing marches). This is pbrt-v4's volpath with
  ratio tracking replaced by the exact march (no majorant, no null collisions), and its
  ``maxdepth`` counting the same scattering events: orders 1 … ``max_bounces`` of the lights.

Random numbers hash (ray, step, sample, bounce, dimension) as the emission light's do
(:func:`~incandescent.renderer.integrators.emission_light.uniforms`), so the float64 reference
walks the same paths as Dr.Jit up to rounding.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.renderer import rays
from incandescent.renderer.backends.camera_rays import clip_to_box
from incandescent.renderer.backends.common import trilinear
from incandescent.renderer.integrators import emission_light as el
from incandescent.renderer.integrators import environment_map as env
from incandescent.renderer.lights import henyey_greenstein

#: Uniforms of one next-event estimate: the emission light's pair, then the sky's direction.
NEE_DIMENSIONS = el.DIMENSIONS + 2
#: Uniforms of one path vertex: its next events, the phase direction (2), the free flight,
#: the light-guided direction (a cell and a point in it: 4), the choice between the two,
#: Russian roulette, and (spectral bins) the band whose extinction samples the free flight.
VERTEX_DIMENSIONS = NEE_DIMENSIONS + 10
#: With the fire's light, the probability that a path's next direction is guided toward it.
GUIDE = 0.5
#: Russian roulette spares a path until its weight falls below this.
ROULETTE = 0.25
#: The step the in-scatter cache's hashes key on (with the voxel's index in place of the camera
#: ray's): no camera ray takes 2³² − 1 steps, so the cache's samples are not a ray's.
CACHE_STEP = 0xFFFFFFFF


def _to_float(h, m=None):
    """24-bit integers → uniforms in [0, 1) (Dr.Jit Float with ``m``, else float64)."""
    if m is None:
        return h.astype(np.float64) * 2.0**-24
    return m.Float(h) * 2.0**-24


class TracedMonteCarlo:
    """The traced estimator: next events of the sampled lights at the camera ray's sample,
    and (``max_bounces`` ≥ 2) paths whose vertices see every light."""

    def __init__(self, program, lights, spp: int, max_bounces: int, seed: int) -> None:
        """``lights``: (the emission light's estimator or None, the uniform skies' total XYZ or
        None, the lat-long skies' estimators)."""
        self.program, self.K = program, program.kernel
        self.emitter, sky_xyz, self.maps = lights
        self.spp, self.max_bounces = spp, max_bounces
        self.sky = None if sky_xyz is None else [float(v) for v in sky_xyz]
        self.key = el.hash_key(seed)
        self.ops = el.drjit_ops(self.K.dr)
        #: the (index, step) UInt lanes the hashes key on: None for the camera ray's index and
        #: its step; the voxel index and :data:`CACHE_STEP` for the in-scatter cache (``mean``)
        self.lanes = None

    def estimate(self, sigma_s):
        """Traced: σ_s × the mean over ``spp`` samples of the sampled part of J (XYZ per m)."""
        K = self.K
        dr, m = K.dr, K.m

        def body(j, acc):
            return j + 1, acc + self.sample(j)

        def run(sigma_s):
            state = (m.UInt(0), m.Array3f(0.0))
            _, acc = dr.while_loop(state, lambda j, acc: j < self.spp, body, labels=("j", "J"))
            return acc * (sigma_s * (1.0 / self.spp))

        return dr.if_stmt((sigma_s,), sigma_s > 0.0, run, lambda sigma_s: m.Array3f(0.0))

    def moments(self, p, d, index):
        """Traced: the means over ``spp`` samples of the sampled lights' next events (XYZ per
        sr) and of their squares, at positions p seen along unit d, one lane per ``index``
        (UInt: a voxel's flat index, hashed with :data:`CACHE_STEP` in place of a camera ray's
        and its step)."""
        K = self.K
        dr, m = K.dr, K.m
        self.lanes = (index, m.UInt(CACHE_STEP))

        def body(j, acc, squares):
            x = self.next_events(p, d, self.uniforms(j, NEE_DIMENSIONS), j)
            return j + 1, acc + x, dr.fma(x, x, squares)

        zero = dr.zeros(m.Array3f, dr.width(index))
        _, acc, squares = dr.while_loop((m.UInt(0), zero, zero), lambda j, *_: j < self.spp,
                                        body, labels=("j", "J", "J2"))  # fmt: skip
        return acc * (1.0 / self.spp), squares * (1.0 / self.spp)

    def uniforms(self, j, count: int, bounce=None, salt: int = 0) -> list:
        K = self.K
        index, step = self.lanes or (K.ray_index, K.m.UInt(K.step_k))
        hashes = el.uniforms(index, step, j, self.key ^ salt, count, bounce)
        return [_to_float(h, K.m) for h in hashes]

    def sample(self, j):
        """Traced: one sample of the sampled lights' next events at the camera ray's sample,
        plus one path."""
        K = self.K
        p, d = K.position, K.ray_direction
        out = self.next_events(p, d, self.uniforms(j, NEE_DIMENSIONS), j)
        if self.max_bounces >= 2:
            out = out + self.path(p, d, j)
        return out

    def next_events(self, p, d, u, j, bounce=None):
        """Traced: the emission light's pair, the sky and the maps at p seen along d (XYZ per
        sr); the maps draw their own uniforms from (j, ``bounce``)."""
        K = self.K
        dr, m = K.dr, K.m
        out = m.Array3f(0.0)
        for sky_map in self.maps:
            u_map = self.uniforms(j, env.MAP_DIMENSIONS, bounce, env.MAP_SALT)
            out = out + sky_map.event(p, d, u_map)
        if self.emitter is not None:
            out = out + self.emitter.pair(p, d, u[: el.DIMENSIONS])
        if self.sky is not None:
            n, g = el.DIMENSIONS, self.program.g_at(p)
            w = m.Array3f(*el.sample_henyey_greenstein(u[n], u[n + 1], d, g, self.ops))
            _, t_exit = clip_to_box(dr, m, p, w, K.shape)
            length = dr.maximum(t_exit, 0.0)
            shadow = self.program.transmittance_along(p, w, length, self.program.path_dt)
            out = dr.fma(m.Array3f(*self.sky), shadow, out)
        return out

    def path(self, p0, d0, j):
        """Traced: Σ over the path's vertices of its weight × every light's next events there."""
        K = self.K
        dr, m = K.dr, K.m

        def cond(b, p, d, weight, acc, alive):
            return alive & (b < self.max_bounces)

        def body(b, p, d, weight, acc, alive):
            u = self.uniforms(j, VERTEX_DIMENSIONS, b)
            n = NEE_DIMENSIONS
            w, ratio = self.direction(p, d, u[n:])
            hit, t, albedo = self.free_flight(p, w, u[n + 2])
            x = dr.fma(w, t, p)
            weight = weight * albedo * ratio

            def seen(x, w, weight, acc):
                events = self.program.direct(x, K.corners(x), w)
                events = events + self.next_events(x, w, u[:n], j, b)
                return dr.fma(events, weight, acc)

            acc = dr.if_stmt((x, w, weight, acc), hit, seen, lambda x, w, weight, acc: acc)
            survive = dr.minimum(weight * (1.0 / ROULETTE), 1.0)
            alive = hit & (u[n + 8] < survive)
            return b + 1, x, w, weight / dr.maximum(survive, 1e-30), acc, alive

        state = (m.UInt(1), p0, d0, m.Float(1.0), m.Array3f(0.0), m.Bool(True))
        labels = ("b", "p", "d", "weight", "J", "alive")
        return dr.while_loop(state, cond, body, labels=labels)[4]

    def direction(self, p, d, u):
        """Traced: a path's next direction ω and its weight p_HG(ω·d)/q(ω) (``u``: the vertex's
        uniforms after its next events')."""
        K = self.K
        dr, m = K.dr, K.m
        g = self.program.g_at(p)
        w = m.Array3f(*el.sample_henyey_greenstein(u[0], u[1], d, g, self.ops))
        if self.emitter is None:
            return w, 1.0
        v = self.emitter.point_in_cell(u[3], u[4:7]) - p
        r = dr.norm(v)
        w = dr.select((u[7] < GUIDE) & (r > 1e-6), v / r, w)
        phase = henyey_greenstein(dr.dot(w, d), g)
        return w, phase / ((1.0 - GUIDE) * phase + GUIDE * self.emitter.pdf_light(p, w))

    def free_flight(self, p, w, u):
        """Traced: (hit, distance in voxels, albedo σ_s/σ_t there) of a flight from p along w
        with pdf σ_t·Tr: the march's segment where the optical depth passes −ln(1 − u)."""
        K, program = self.K, self.program
        dr, m = K.dr, K.m
        target = -dr.log(1.0 - u)
        _, t_exit = clip_to_box(dr, m, p, w, K.shape)

        dt = program.path_dt

        def cond(k, tau, t_hit, albedo, hit):
            return (k * dt < t_exit) & ~hit

        def body(k, tau, t_hit, albedo, hit):
            a, b, _, kappa, _, sigma_s = program.segment(p, w, k, dt, t_exit)
            sigma_t = dr.maximum(kappa + sigma_s, 1e-30)
            x = sigma_t * (b - a) * K.ds_per_voxel
            now = tau + x >= target
            t_now = a + (target - tau) / (sigma_t * K.ds_per_voxel)
            t_hit = dr.select(now, dr.minimum(t_now, b), t_hit)
            albedo = dr.select(now, sigma_s / sigma_t, albedo)
            return k + 1.0, tau + x, t_hit, albedo, hit | now

        state = (m.Float(0.0), m.Float(0.0), m.Float(0.0), m.Float(0.0), m.Bool(False))
        labels = ("k", "tau", "t", "albedo", "hit")
        _, _, t_hit, albedo, hit = dr.while_loop(state, cond, body, labels=labels)
        return hit, t_hit, albedo


class ReferenceMonteCarlo:
    """The float64 estimator: the same samples and paths as :class:`TracedMonteCarlo`."""

    def __init__(self, program, lights, spp: int, max_bounces: int, seed: int) -> None:
        self.program, self.inputs = program, program.inputs
        self.emitter, sky_xyz, self.maps = lights
        self.spp, self.max_bounces = spp, max_bounces
        self.sky = None if sky_xyz is None else np.asarray(sky_xyz, dtype=np.float64)
        self.key = el.hash_key(seed)

    #: Values per sample: XYZ (spectral estimators: one per wavelength).
    width = 3

    def estimate(self, p, sigma_s, d, ray_index, step) -> NDArray:
        """σ_s × the mean over ``spp`` samples at samples p (m, 3) of rays with unit directions
        d, camera-ray indices and steps, XYZ per m, (m, 3)."""
        return self.total(p, d, ray_index, step) * (sigma_s / self.spp)[:, None]

    def total(self, p, d, ray_index, step, squares: NDArray | None = None) -> NDArray:
        """The sum over ``spp`` samples of the sampled part of J, (m, :attr:`width`); the sum
        of the squares of their next events is added to ``squares`` if given."""
        ray_index, step = ray_index.astype(np.uint32), step.astype(np.uint32)
        out = np.zeros((len(p), self.width))
        for j in range(self.spp):
            sample = np.full(len(p), j, dtype=np.uint32)
            u = [
                _to_float(h) for h in el.uniforms(ray_index, step, sample, self.key, NEE_DIMENSIONS)
            ]
            x = self.next_events(p, d, u, (ray_index, step, sample))
            out += x
            if squares is not None:  # the in-scatter cache's: single scattering, no paths
                squares += x * x
            if self.max_bounces >= 2:
                out += self.path(p, d, (ray_index, step, sample))
        return out

    def next_events(self, p, d, u, seeds, bounce=None) -> NDArray:
        out = np.zeros((len(p), 3))
        for sky_map in self.maps:
            ray_index, step, sample = seeds
            key = self.key ^ env.MAP_SALT
            hashes = el.uniforms(ray_index, step, sample, key, env.MAP_DIMENSIONS, bounce)
            out += sky_map.event(p, d, [_to_float(h) for h in hashes])
        if self.emitter is not None:
            out += self.emitter.pair(p, d, u[: el.DIMENSIONS])
        if self.sky is not None:
            g, n = self.program.g_at(p), el.DIMENSIONS
            hg = el.sample_henyey_greenstein(u[n], u[n + 1], d.T, g, el.NUMPY_OPS)
            w = np.stack(hg, axis=1)
            shape = np.asarray(self.inputs.volume.shape, dtype=np.float64)
            _, t_exit = rays.clip_to_box(p, w, shape)
            length = np.maximum(t_exit, 0.0)
            shadow = self.program.transmittance_along(p, w, length, self.program.path_dt)
            out += shadow[:, None] * self.sky
        return out

    def path(self, p, d, seeds) -> NDArray:
        ray_index, step, sample = seeds
        acc, weight = np.zeros((len(p), 3)), np.ones(len(p))
        live = np.arange(len(p))
        p, d = p.copy(), d.copy()
        for b in range(1, self.max_bounces):
            if not live.size:
                break
            bounce = np.full(live.size, b, dtype=np.uint32)
            hashes = el.uniforms(ray_index[live], step[live], sample[live], self.key,
                                 VERTEX_DIMENSIONS, bounce)  # fmt: skip
            u = [_to_float(h) for h in hashes]
            n = NEE_DIMENSIONS
            w, ratio = self.direction(p[live], d[live], u[n:])
            hit, t, albedo = self.free_flight(p[live], w, u[n + 2])
            live, w, t, albedo, ratio = live[hit], w[hit], t[hit], albedo[hit], ratio[hit]
            x = p[live] + w * t[:, None]
            weight[live] *= albedo * ratio
            rows = (ray_index[live], step[live], sample[live])
            u_nee = [v[hit] for v in u[:n]]
            events = self.program.direct(x, w) + self.next_events(x, w, u_nee, rows, bounce[hit])
            acc[live] += weight[live, None] * events
            p[live], d[live] = x, w
            survive = np.minimum(weight[live] / ROULETTE, 1.0)
            going = u[n + 8][hit] < survive
            weight[live] /= np.maximum(survive, 1e-30)
            live = live[going]
        return acc

    def direction(self, p, d, u) -> tuple[NDArray, NDArray]:
        """A path's next directions and weights p_HG/q, as traced."""
        g = self.program.g_at(p)
        w = np.stack(el.sample_henyey_greenstein(u[0], u[1], d.T, g, el.NUMPY_OPS), axis=1)
        if self.emitter is None:
            return w, np.ones(len(p))
        v = self.emitter.point_in_cell(u[3], np.stack(u[4:7], axis=1)) - p
        r = np.linalg.norm(v, axis=1)
        guided = (u[7] < GUIDE) & (r > 1e-6)
        w[guided] = v[guided] / r[guided, None]
        phase = henyey_greenstein(np.einsum("ij,ij->i", w, d), g)
        return w, phase / ((1.0 - GUIDE) * phase + GUIDE * self.emitter.pdf_light(p, w))

    def free_flight(self, p, w, u) -> tuple[NDArray, NDArray, NDArray]:
        """(hit, distance in voxels, albedo there) of flights from p along w, as traced."""
        vol, dt = self.inputs.volume, self.program.path_dt
        target = -np.log1p(-u)
        _, t_exit = rays.clip_to_box(p, w, np.asarray(vol.shape, dtype=np.float64))
        tau, t_hit, albedo = np.zeros(len(p)), np.zeros(len(p)), np.zeros(len(p))
        hit, k = np.zeros(len(p), dtype=bool), 0
        while True:
            a = k * dt
            live = np.flatnonzero((a < t_exit) & ~hit)
            if not live.size:
                return hit, t_hit, albedo
            b = np.minimum(a + dt, t_exit[live])
            q = p[live] + w[live] * (0.5 * (a + b))[:, None]
            sigma_s = trilinear(vol.scattering_per_m, q)
            sigma_t = np.maximum(trilinear(vol.absorption_per_m, q) + sigma_s, 1e-30)
            x = sigma_t * (b - a) * vol.voxel_size_m
            now = tau[live] + x >= target[live]
            rows = live[now]
            t_now = a + (target[rows] - tau[rows]) / (sigma_t[now] * vol.voxel_size_m)
            t_hit[rows] = np.minimum(t_now, b[now])
            albedo[rows] = sigma_s[now] / sigma_t[now]
            hit[rows] = True
            tau[live] += x
            k += 1
