"""The emission-model interface: what a source of light in the gas answers, on the host, in the
Dr.Jit kernel and in the float64 reference (``docs/design/DESIGN.md`` §3).

A render's emission–absorption integrator (``renderer.integrators``) uses a tuple of models
(:meth:`incandescent.emission.Emission.models`). Each has a *kind*:

``"source"``
    Thermal emission of the absorbing gas, κ·S(T) with S the source function per unit
    absorption (Kirchhoff): blackbody, grey or in spectral bins. A segment adds
    Tr·S·(1 − e^{−κΔs}).
``"coefficient"``
    An emission coefficient η(T, fractions) per metre that does not need κ (optically thin
    lines). With one, a segment adds Tr·η·(1 − e^{−κΔs})/κ, where η = κ·ΣS + Ση.
``"display"``
    A model that replaces transport altogether (the 2011 paper: display RGB summed along the
    ray, no absorption). It is the render's only model.

Transport runs in *bands* (:class:`Bands`): one grey band (the table mode, κ the same at every
wavelength) or N spectral bins with κ_b = κ·(λ_ref/λ_b)^α. Every model gives one 1/T table per
band, all on the spacing of :mod:`incandescent.spectra.lut`, so one table position serves all.

Adding a model is one subclass (see ``tests/emission/test_emission_models.py`` for a constant
emitter): its tables, the grids it samples, its traced per-sample term and its float64 term.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from incandescent.spectra.bins import SpectralBins
from incandescent.spectra.lut import EmissionLUT

KINDS = ("source", "coefficient")


@dataclass(frozen=True)
class Bands:
    """The wavelength bands transport carries: one grey band, or spectral ``bins``."""

    bins: SpectralBins | None = None

    @property
    def grey(self) -> bool:
        return self.bins is None

    @property
    def count(self) -> int:
        return 1 if self.bins is None else self.bins.count

    @property
    def kappa_scale(self) -> tuple[float, ...]:
        """κ_b / κ per band: (λ_ref/λ_b)^α, or 1 for the grey band."""
        return (1.0,) if self.bins is None else tuple(float(s) for s in self.bins.kappa_scale)


class EmissionModel(ABC):
    """One source of light. Subclasses set ``name``, ``kind`` and build ``tables`` (one
    :class:`EmissionLUT` per band) in their constructor.

    Host: :meth:`occupancy` (where the model may emit besides κ > 0: macrocells mark those cells
    non-empty) and :meth:`grids` (the volume grids its per-sample term samples).
    Kernel (traced, Dr.Jit): :meth:`bind` uploads its tables and grids once per render;
    :meth:`sample` reads its grids at a sample's trilinear corners before the branch on whether
    the sample interacts; :meth:`present` widens that branch's mask; :meth:`add` adds its term
    for band b to the running sum. Reference (float64 NumPy): the same, exact instead of
    tabulated: :meth:`reference_add` (table mode) and :meth:`reference_spectrum_add` (the 1 nm
    spectral limit).
    """

    name: ClassVar[str]
    kind: ClassVar[str]
    tables: tuple[EmissionLUT, ...]
    #: the bands the model's tables are for (its first table is band 0's)
    bands: Bands = Bands()

    # --- host -------------------------------------------------------------------------------
    @property
    def occupancy_key(self) -> str:
        """What :meth:`occupancy` depends on besides the volume (macrocells are cached by it)."""
        return self.name

    def occupancy(self, volume) -> NDArray[np.float32] | None:
        """A grid > 0 where this model may emit where κ = 0 (None: only where κ > 0)."""
        return None

    def grids(self, volume) -> tuple[NDArray[np.float32], ...]:
        """The volume grids :meth:`sample` reads, in order (e.g. species fractions)."""
        return ()

    # --- kernel -----------------------------------------------------------------------------
    def bind(self, kernel) -> Any:
        """Device data for one render: by default the tables and grids, uploaded by the kernel's
        helpers (``kernel.table``, ``kernel.grid``)."""
        grids = [kernel.grid((self.name, i), g) for i, g in enumerate(self.grids(kernel.volume))]
        return [kernel.table(t) for t in self.tables], grids

    def sample(self, kernel, bound, corners) -> list:
        """Traced: this model's grid values at a sample (trilinear at ``corners``)."""
        return [kernel.trilinear(grid, corners) for grid in bound[1]]

    def present(self, mask, values: list):
        """Traced: ``mask`` (κ > 0 so far) widened to where this model emits."""
        return mask

    @abstractmethod
    def add(self, kernel, bound, eta, band: int, position, values: list):
        """Traced: ``eta`` plus this model's term in ``band`` at table ``position`` — S for a
        source (``eta`` None for the first), η per metre for a coefficient."""

    # --- reference --------------------------------------------------------------------------
    @abstractmethod
    def reference_add(self, eta, temperature_K: NDArray, values: list, inputs) -> NDArray:
        """Float64: ``eta`` (None or (m, 3)) plus this model's exact XYZ term at the samples."""

    def reference_spectrum_add(
        self, eta, temperature_K: NDArray, values: list, wavelength_nm: NDArray, inputs
    ) -> NDArray:
        """Float64: ``eta`` plus this model's term per nm, (m, nλ) in W·sr⁻¹·m⁻²·nm⁻¹ (per
        unit κ for a source, per metre for a coefficient)."""
        raise NotImplementedError(f"emission model {self.name!r} has no per-nm reference")


def check_kind(model: EmissionModel) -> EmissionModel:
    """Refuse a model whose kind is not one of :data:`KINDS`."""
    if model.kind not in KINDS:
        raise ValueError(f"emission model {model.name!r} has kind {model.kind!r}; expected {KINDS}")
    return model
