"""Emission–absorption: absolute radiance of a gas that emits and absorbs, no scattering
(``DESIGN.md`` §3).

Along a ray the radiative transfer equation without scattering, dL/ds = −κ_λ L + κ_λ B_λ(T)
(+ η_λ of optically thin lines), is integrated exactly over each segment of constant κ, T
(Kirchhoff):

    L += Tr·S·(1 − e^{−κΔs}),   Tr ← Tr·e^{−κΔs}        (source models: S per unit κ)
    L += Tr·η·(1 − e^{−κΔs})/κ  (→ Tr·η·Δs as κ → 0)     (with coefficient models: η per m)

in one grey band (``spectral_bins = 0``: κ the same at every wavelength, one table XYZ(B(T))
exact) or in N spectral bins with κ_b = κ·(λ_ref/λ_b)^α — the volume's soot law
(``Volume.soot_alpha``) — each with its own transmittance (the reference marches that in its
1 nm limit). The emission models come from :class:`~incandescent.emission.Emission` (observer,
Planck constants, line table).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from incandescent.constants import K_M
from incandescent.emission import Bands, Emission, EmissionModel, transport_bands
from incandescent.renderer.backends.common import THIN_STEP, trilinear
from incandescent.renderer.integrators.base import Integrator, Reference, Segment, Traced
from incandescent.spectra.bins import REFERENCE_NM
from incandescent.spectra.cmf import cmfs

#: Most spectral bins a render may march.
MAX_BINS = 64


@dataclass(frozen=True)
class EmissionAbsorption(Integrator):
    """Emission–absorption in one grey band (``spectral_bins = 0``) or ``spectral_bins`` bins,
    with the emission models of ``emission``."""

    spectral_bins: int = 0
    emission: Emission = field(default_factory=Emission)

    name = "emission_absorption"

    def __post_init__(self) -> None:
        bins = self.spectral_bins
        if isinstance(bins, np.integer):
            object.__setattr__(self, "spectral_bins", bins := int(bins))
        if isinstance(bins, bool) or not isinstance(bins, int):
            raise ValueError(f"spectral_bins must be an integer; got {bins!r}")
        if not 0 <= bins <= MAX_BINS:
            raise ValueError(f"spectral_bins must be in 0..{MAX_BINS}; got {bins!r}")
        if not isinstance(self.emission, Emission):
            raise TypeError(f"emission must be an incandescent Emission; got {self.emission!r}")

    # --- host -------------------------------------------------------------------------------
    def models(self, volume) -> tuple[EmissionModel, ...]:
        return self.emission.models(volume, self.spectral_bins)

    def bands(self, models) -> Bands:
        return transport_bands(models)

    def occupancy(self, models) -> tuple[str, Callable | None]:
        """κ > 0 widened by each model's own occupancy (lines emit where κ = 0)."""
        if all(type(m).occupancy is EmissionModel.occupancy for m in models):
            return "absorption", None
        key = repr(tuple(model.occupancy_key for model in models))

        def grid(volume) -> NDArray:
            out = volume.absorption_per_m
            for model in models:
                extra = model.occupancy(volume)
                out = out if extra is None else np.maximum(out, extra)
            return out

        return key, grid

    def sparse_problem(self, models) -> str | None:
        for model in models:
            plain = type(model).occupancy is EmissionModel.occupancy
            if not plain or type(model).grids is not EmissionModel.grids:
                return f"the {model.name} model reads grids besides T and κ"
        return None

    def metadata(self) -> dict[str, object]:
        return {
            "integrator": self.name,
            "brightness": "physical",
            "observer": self.emission.observer,
            "planck_constants": self.emission.constants,
            "spectral_bins": self.spectral_bins,
        }

    def traced(self, kernel) -> Traced:
        return _Traced(kernel)

    def reference(self, inputs) -> Reference:
        if inputs.bands.grey:
            return _Reference(inputs)
        return _SpectralReference(inputs, self.emission.observer)


class _Traced(Traced):
    """The traced segment update in the grey band or in spectral bins."""

    def __init__(self, kernel) -> None:
        super().__init__(kernel)
        self.bands = kernel.bands
        self.kappa_scale = [np.float32(k) for k in self.bands.kappa_scale]
        terms = list(enumerate(kernel.terms))
        self.sources = [(mo, b, i) for i, (mo, b) in terms if mo.kind == "source"]
        self.coefficients = [(mo, b, i) for i, (mo, b) in terms if mo.kind == "coefficient"]

    def transmittance0(self):
        m = self.kernel.m
        return m.Float(1.0) if self.bands.grey else [m.Float(1.0) for _ in range(self.bands.count)]

    def alive(self, tr):
        """The grey transmittance, or the largest over the bins."""
        if self.bands.grey:
            return tr
        most = tr[0]
        for tr_b in tr[1:]:
            most = self.kernel.dr.maximum(most, tr_b)
        return most

    def transmittance_out(self, tr):
        """The grey transmittance, or the mean over the bins."""
        if self.bands.grey:
            return tr
        return sum(tr[1:], tr[0]) * (1.0 / self.bands.count)

    def interacts(self, kappa, temp, sampled):
        """κ > 0 or a coefficient model present; a cold sample (T below the tables) still
        absorbs, it only emits nothing."""
        K = self.kernel
        present = kappa > 0.0
        for (model, _), values in zip(K.terms, sampled, strict=True):
            present = model.present(present, values)
        return present, present & (temp >= K.lut_t_min)

    def step(self, tr, L, kappa, temp, c, ds_m, sampled):
        if self.bands.grey:
            return self.integrate(tr, L, kappa, temp, c, ds_m, sampled)
        return self.integrate_bands(tr, L, kappa, temp, c, ds_m, sampled)

    # --- the models' sums -------------------------------------------------------------------
    def source_function(self, band: int, position, sampled):
        """S = Σ of the source models' terms in ``band`` (XYZ per unit absorption)."""
        eta = None
        for model, bound, i in self.sources:
            eta = model.add(self.kernel, bound, eta, band, position, sampled[i])
        return self.kernel.m.Array3f(0.0) if eta is None else eta

    def emission_coefficient(self, band: int, kappa, temp, sampled):
        """η = κ·S + Σ of the coefficient models' terms, per metre; 0 below the tables' T_min."""
        K = self.kernel
        position = K.lut_position(temp)
        eta = self.source_function(band, position, sampled) * kappa
        for model, bound, i in self.coefficients:
            eta = model.add(K, bound, eta, band, position, sampled[i])
        return K.dr.select(temp >= K.lut_t_min, eta, 0.0)

    # --- one segment ----------------------------------------------------------------------
    def integrate(self, tr, L, kappa, temp, c, ds_m, sampled):
        """Exact emission–absorption over one segment in the grey band (Kirchhoff, DESIGN §3):
        L += Tr·S·(1 − e^{−κΔs}); with coefficient models, L += Tr·η·(1 − e^{−κΔs})/κ
        (→ Tr·η·Δs as κ → 0)."""
        K = self.kernel
        dr = K.dr
        x = kappa * ds_m
        e = dr.exp(-x)
        series = 1.0 - x * (0.5 - x * (1.0 / 6.0))
        if self.coefficients:
            eta = self.emission_coefficient(0, kappa, temp, sampled)
            weight = dr.select(x < THIN_STEP, ds_m * series, (1.0 - e) / kappa)
        else:
            source = self.source_function(0, K.lut_position(temp), sampled)
            eta = dr.select(temp >= K.lut_t_min, source, 0.0)
            weight = dr.select(x < THIN_STEP, x * series, 1.0 - e)
        if K.scale is not None:
            eta = eta * K.trilinear(K.scale, c)
        return tr * e, dr.fma(eta, tr * weight, L)

    def integrate_bands(self, tr, L, kappa, temp, c, ds_m, sampled):
        """Spectral bins: per band b, κ_b = κ·(λ_ref/λ_b)^α and L += Tr_b·S_b·(1 − e^{−κ_bΔs})
        (with coefficient models Tr_b·η_b·(1 − e^{−κ_bΔs})/κ_b); ``tr`` is the list of
        per-band transmittances."""
        K = self.kernel
        dr = K.dr
        position = K.lut_position(temp)
        valid = temp >= K.lut_t_min
        scale = 1.0 if K.scale is None else K.trilinear(K.scale, c)
        updated = []
        for band, (kappa_scale, tr_b) in enumerate(zip(self.kappa_scale, tr, strict=True)):
            x = kappa * (ds_m * kappa_scale)
            e = dr.exp(-x)
            series = 1.0 - x * (0.5 - x * (1.0 / 6.0))
            if self.coefficients:
                kappa_b = kappa * kappa_scale
                eta = self.emission_coefficient(band, kappa_b, temp, sampled) * scale
                weight = dr.select(x < THIN_STEP, ds_m * series, (1.0 - e) / kappa_b)
                L = dr.fma(eta, tr_b * weight, L)
            else:
                alpha = dr.select(x < THIN_STEP, x * series, 1.0 - e)
                xyz = dr.select(valid, self.source_function(band, position, sampled), 0.0)
                L = dr.fma(xyz, tr_b * alpha * scale, L)
            updated.append(tr_b * e)
        return updated, L


# --- the float64 reference --------------------------------------------------------------------
def _sampled(inputs, p: NDArray) -> list[list[NDArray]]:
    """Every model's grid values at positions p (trilinear, float64)."""
    return [[trilinear(g, p) for g in model.grids(inputs.volume)] for model in inputs.models]


def _present(kappa: NDArray, sampled) -> NDArray[np.bool_]:
    """κ > 0, or a model's fraction > 0 (lines emit where κ = 0)."""
    present = kappa > 0
    for values in sampled:
        for fraction in values:
            present = present | (fraction > 0)
    return present


class _Reference(Reference):
    """Exact grey emission–absorption: each model's exact term — the Planck × CMF integral at
    each sample's temperature, the species' line sums — not the fast backends' tables."""

    def sources(self, temp_K: NDArray, sampled) -> NDArray:
        """S: the source models' exact XYZ per unit absorption at the samples."""
        eta = None
        for model, values in zip(self.inputs.models, sampled, strict=True):
            if model.kind == "source":
                eta = model.reference_add(eta, temp_K, values, self.inputs)
        return np.zeros(temp_K.shape + (3,)) if eta is None else eta

    def emission_xyz(self, temp_K: NDArray, sampled) -> NDArray:
        """S, exact; zero below the table's T_min as in the fast backends."""
        hot = temp_K >= self.inputs.lut.t_min_K
        out = np.zeros(temp_K.shape + (3,))
        if hot.any():
            out[hot] = self.sources(temp_K[hot], [[v[hot] for v in vs] for vs in sampled])
        return out

    def step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        if any(m.kind == "coefficient" for m in self.inputs.models):
            return self.coefficient_step(segment, xyz, tr)
        vol = self.inputs.volume
        r, p, ds_m = segment.r, segment.p, segment.ds_m
        kappa = trilinear(vol.absorption_per_m, p)
        absorbing = kappa > 0  # where κ = 0 nothing is emitted: skip the spectral integral
        emits = absorbing.copy()
        if not absorbing.any():
            return emits
        r, p, kappa, ds_m = r[absorbing], p[absorbing], kappa[absorbing], ds_m[absorbing]
        temp = trilinear(vol.temperature_K, p)
        emits[absorbing] = temp >= self.inputs.lut.t_min_K
        scale = 1.0 if vol.emission_scale is None else trilinear(vol.emission_scale, p)
        optical_depth = kappa * ds_m
        alpha = -np.expm1(-optical_depth)
        source = self.emission_xyz(temp, _sampled(self.inputs, p))
        xyz[r] += (tr[r] * alpha * scale)[:, None] * source
        tr[r] *= np.exp(-optical_depth)
        return emits

    def emission_coefficient(self, kappa, temp, sampled, emits) -> NDArray:
        """η = κ·S + Σ η_model per metre, exact, at the samples where ``emits``, (m_emits, 3)."""
        inputs = self.inputs
        hot, at = temp[emits], [[v[emits] for v in vs] for vs in sampled]
        eta = kappa[emits, None] * self.emission_xyz(hot, at)
        for model, values in zip(inputs.models, at, strict=True):
            if model.kind == "coefficient":
                eta = model.reference_add(eta, hot, values, inputs)
        return eta

    def coefficient_step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        """With coefficient models (lines): η = κ·S + Σ η_model per metre, and the segment adds
        Tr·η·(1 − e^{−κΔs})/κ (Tr·η·Δs where κ = 0)."""
        inputs, vol = self.inputs, self.inputs.volume
        r, p, ds_m = segment.r, segment.p, segment.ds_m
        kappa = trilinear(vol.absorption_per_m, p)
        sampled = _sampled(inputs, p)
        temp = trilinear(vol.temperature_K, p)
        emits = _present(kappa, sampled) & (temp >= inputs.lut.t_min_K)
        if not emits.any():
            tr[r] *= np.exp(-kappa * ds_m)
            return emits
        eta = self.emission_coefficient(kappa, temp, sampled, emits)
        if vol.emission_scale is not None:
            eta *= trilinear(vol.emission_scale, p[emits])[:, None]
        x = kappa[emits] * ds_m[emits]
        safe = np.where(x > 0, kappa[emits], 1.0)
        weight = np.where(x > 0, -np.expm1(-x) / safe, ds_m[emits])
        xyz[r[emits]] += (tr[r[emits]] * weight)[:, None] * eta
        tr[r] *= np.exp(-kappa * ds_m)
        return emits


class _SpectralReference(Reference):
    """Spectral κ_λ = κ·(λ_ref/λ)^α marched at every 1 nm CMF sample (the limit of N bins):
    L = K_m Σ_λ Σ_segments Tr_λ (1 − e^{−κ_λΔs}) B_λ(T) x̄ȳz̄(λ) Δλ (with lines, Tr_λ η_λ
    (1 − e^{−κ_λΔs})/κ_λ). One transmittance per wavelength per ray."""

    def __init__(self, inputs, observer: str) -> None:
        super().__init__(inputs)
        self.cmf = cmfs(observer)
        alpha = inputs.volume.soot_alpha
        self.kappa_scale = (REFERENCE_NM / self.cmf.wavelength_nm) ** alpha
        self.weights = K_M * self.cmf.step_nm * self.cmf.xyz_bar  # (471, 3)

    def transmittance0(self, n: int) -> NDArray:
        return np.ones((n, self.cmf.wavelength_nm.size))

    def alive(self, tr_rows: NDArray) -> NDArray:
        return tr_rows.max(axis=1)

    def transmittance_out(self, tr: NDArray) -> NDArray:
        return tr.mean(axis=1)

    def eta(self, kappa_nm, temp, sampled, emits) -> tuple[NDArray, bool]:
        """Per-nm (η or S, coefficient?) at the samples: S_λ of the sources (per unit κ), or with
        coefficient models η_λ = κ_λ·S_λ + Σ η_λ,model per metre; 0 where a sample does not
        emit."""
        inputs, wavelength_nm = self.inputs, self.cmf.wavelength_nm
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

    def step(self, segment: Segment, xyz, tr) -> NDArray[np.bool_]:
        vol = self.inputs.volume
        r, a, b, p, ds_m = segment.r, segment.a, segment.b, segment.p, segment.ds_m
        kappa, temp = trilinear(vol.absorption_per_m, p), trilinear(vol.temperature_K, p)
        sampled = _sampled(self.inputs, p)
        emits = _present(kappa, sampled) & (temp >= self.inputs.lut.t_min_K)
        kappa_nm = kappa[:, None] * self.kappa_scale
        x = (kappa * (b - a) * vol.voxel_size_m)[:, None] * self.kappa_scale  # (m, 471)
        radiance, per_metre = self.eta(kappa_nm, temp, sampled, emits)
        if vol.emission_scale is not None:
            radiance *= trilinear(vol.emission_scale, p)[:, None]
        if per_metre:
            safe = np.where(x > 0, kappa_nm, 1.0)
            weight = np.where(x > 0, -np.expm1(-x) / safe, ds_m[:, None])
        else:
            weight = -np.expm1(-x)
        xyz[r] += (tr[r] * weight * radiance) @ self.weights
        tr[r] *= np.exp(-x)
        return emits
