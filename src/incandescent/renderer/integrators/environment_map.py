"""An HDR lat-long sky (``lights.EnvironmentMap``) as a light of the scattering integrators.

Its next event at a point x seen along d takes two directions — one from the map's pixels with
probability ∝ their luminance × sin θ (the pixel's solid angle; a CDF searched, then a uniform
point in the pixel, pdf_M(ω) = P_pixel·W·H/(2π² sin θ)), one from the phase function — and
weights each by the balance heuristic (Veach 1997):

    Ĵ = Σ_{s ∈ {M, P}} p_HG(ω_s·d) L_map(ω_s) Tr(x → box along ω_s) / (pdf_M(ω_s) + p_HG(ω_s·d))

with L_map the pixel's XYZ radiance (piecewise constant, as the pdf). Its uniforms are a hash
stream of their own (``MAP_SALT``), so adding a map leaves every other sample unchanged.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from incandescent.renderer import rays
from incandescent.renderer.backends.camera_rays import clip_to_box
from incandescent.renderer.integrators import emission_light as el
from incandescent.renderer.lights import EnvironmentMap, henyey_greenstein

#: XORed into the hash key for the map's uniforms: a pixel, a point in it (2), a phase
#: direction (2).
MAP_SALT, MAP_DIMENSIONS = 0x3C6EF372, 5


def direction(u, v, ops) -> tuple:
    """The unit direction of map coordinates (u, v) ∈ [0, 1)² (``EnvironmentMap``'s axes)."""
    theta, phi = np.pi * v, 2.0 * np.pi * (u - 0.5)
    s = ops.sin(theta)
    return s * ops.sin(phi), ops.cos(theta), -s * ops.cos(phi)


def coordinates(w, ops) -> tuple:
    """(u, v, sin θ) of unit directions w (inverse of :func:`direction`)."""
    y = ops.minimum(ops.maximum(w[1], -1.0), 1.0)
    theta = ops.arccos(y)
    u = ops.arctan2(w[0], -w[2]) * (0.5 / np.pi) + 0.5
    return u, theta * (1.0 / np.pi), ops.sin(theta)


class MapTables:
    """The map's per-pixel XYZ (C order, (H·W, 3)), its pixels' probabilities and CDF."""

    def __init__(self, sky: EnvironmentMap) -> None:
        xyz = sky.xyz()
        self.height, self.width = xyz.shape[:2]
        theta = np.pi * (np.arange(self.height) + 0.5) / self.height
        power = np.maximum(xyz[..., 1], 0.0) * np.sin(theta)[:, None]
        total = power.sum()
        flat = power.ravel() / total if total > 0 else np.full(power.size, 1.0 / power.size)
        self.xyz, self.probability = xyz.reshape(-1, 3), flat
        self.cdf = np.cumsum(flat)
        self.cdf /= self.cdf[-1]

    def pdf_factor(self) -> float:
        """W·H/(2π²): pdf_M = P_pixel × this / sin θ."""
        return self.width * self.height / (2.0 * np.pi**2)


class TracedEnvironmentMap:
    """The traced next event of the map for the program ``program`` (its ``g``, ``path_dt``
    and ``transmittance_along``)."""

    def __init__(self, program, sky: EnvironmentMap) -> None:
        self.program, self.K = program, program.kernel
        m = self.K.m
        self.tables = t = MapTables(sky)
        self.xyz = [m.Float(t.xyz[:, a].astype(np.float32)) for a in range(3)]
        self.probability = m.Float(t.probability.astype(np.float32))
        self.cdf = m.Float(t.cdf.astype(np.float32))
        self.ops = el.drjit_ops(self.K.dr)

    def pixel(self, w):
        """Traced: (flat pixel index, sin θ) of directions w."""
        dr, m, t = self.K.dr, self.K.m, self.tables
        u, v, sin = coordinates(w, self.ops)
        col = dr.minimum(m.UInt(dr.maximum(u * t.width, 0.0)), t.width - 1)
        row = dr.minimum(m.UInt(dr.maximum(v * t.height, 0.0)), t.height - 1)
        return row * t.width + col, sin

    def event(self, p, d, u):
        """Traced: Ĵ of the map at p seen along d (``u``: :data:`MAP_DIMENSIONS` uniforms)."""
        K = self.K
        dr, m = K.dr, K.m
        out = m.Array3f(0.0)
        for w, index, weight in self.weighted(p, d, u):
            _, t_exit = clip_to_box(dr, m, p, w, K.shape)
            shadow = self.program.transmittance_along(
                p, w, dr.maximum(t_exit, 0.0), self.program.path_dt
            )
            radiance = m.Array3f(*(dr.gather(m.Float, c, index) for c in self.xyz))
            out = dr.fma(radiance, weight * shadow, out)
        return out

    def weighted(self, p, d, u) -> list:
        """Traced: the map-sampled and the phase-sampled directions, each with its pixel and
        its balance-heuristic weight p_HG/(pdf_M + p_HG)."""
        K, t = self.K, self.tables
        dr, m = K.dr, K.m
        last = len(t.cdf) - 1
        i = dr.binary_search(0, last, lambda i: dr.gather(m.Float, self.cdf, i) <= u[0])
        col, row = m.Float(i % t.width), m.Float(i // t.width)
        toward_map = m.Array3f(
            *direction((col + u[1]) / t.width, (row + u[2]) / t.height, self.ops)
        )
        g = self.program.g_at(p)
        toward_phase = m.Array3f(*el.sample_henyey_greenstein(u[3], u[4], d, g, self.ops))
        out = []
        for w in (toward_map, toward_phase):
            index, sin = self.pixel(w)
            pdf = (
                dr.gather(m.Float, self.probability, index) * t.pdf_factor() / dr.maximum(sin, 1e-8)
            )
            phase = henyey_greenstein(dr.dot(w, d), g)
            out.append((w, index, phase / (pdf + phase)))
        return out


class ReferenceEnvironmentMap:
    """The float64 next event of the map, the same samples."""

    def __init__(self, program, sky: EnvironmentMap) -> None:
        self.program, self.inputs = program, program.inputs
        self.tables = MapTables(sky)

    def event(self, p, d, u) -> NDArray:
        shape = np.asarray(self.inputs.volume.shape, dtype=np.float64)
        out = np.zeros((len(p), 3))
        for w, index, weight in self.weighted(p, d, u):
            _, t_exit = rays.clip_to_box(p, w, shape)
            shadow = self.program.transmittance_along(
                p, w, np.maximum(t_exit, 0.0), self.program.path_dt
            )
            out += self.tables.xyz[index] * (weight * shadow)[:, None]
        return out

    def weighted(self, p, d, u) -> list[tuple[NDArray, NDArray, NDArray]]:
        """The map-sampled and phase-sampled directions (m, 3), their pixels and weights."""
        t, g = self.tables, self.program.g_at(p)
        i = np.minimum(np.searchsorted(t.cdf, u[0], side="right"), t.cdf.size - 1)
        col, row = i % t.width, i // t.width
        toward_map = np.stack(
            direction((col + u[1]) / t.width, (row + u[2]) / t.height, el.NUMPY_OPS), 1
        )
        toward_phase = np.stack(el.sample_henyey_greenstein(u[3], u[4], d.T, g, el.NUMPY_OPS), 1)
        out = []
        for w in (toward_map, toward_phase):
            uu, vv, sin = coordinates(w.T, el.NUMPY_OPS)
            col_w = np.minimum((np.maximum(uu * t.width, 0)).astype(np.int64), t.width - 1)
            row_w = np.minimum((np.maximum(vv * t.height, 0)).astype(np.int64), t.height - 1)
            index = row_w * t.width + col_w
            pdf = t.probability[index] * t.pdf_factor() / np.maximum(sin, 1e-8)
            phase = henyey_greenstein(np.einsum("ij,ij->i", w, d), g)
            out.append((w, index, phase / (pdf + phase)))
        return out
