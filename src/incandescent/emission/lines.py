"""Species line emission: optically thin lines of Na, Li, K, Sr, … (``docs/species.md``).

Each species s with fraction f_s emits η_s = f_s·E_s(T) per metre, E_s from the cited line table
(:mod:`incandescent.spectra.lines`), independent of κ: a *coefficient* model. In the grey band
its table is the species' whole XYZ; in spectral bins, bin b's table holds the lines falling in
that bin (K_m Σ_{λ∈b} E_s,λ x̄ȳz̄ Δλ), so the bins sum to the grey table.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from incandescent.constants import K_M
from incandescent.emission.base import Bands, EmissionModel
from incandescent.spectra.bins import SpectralBins, make_bins
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.lines import (
    LineTable,
    build_species_lut,
    load_lines,
    species_names,
    species_spectrum,
    species_xyz,
)
from incandescent.spectra.lut import T_MAX_K, EmissionLUT, build_emission_luts


@functools.lru_cache(maxsize=8)
def line_table(path: str | None) -> LineTable:
    """The line table at ``path`` (None: the shipped one), read once."""
    return load_lines(path)


@functools.lru_cache(maxsize=64)
def species_lut(path: str | None, name: str, observer: str) -> EmissionLUT:
    """The species' T ↦ XYZ-per-metre table; unknown names list the table's species."""
    table = line_table(path)
    known = species_names(table)
    if name not in known:
        raise ValueError(
            f"volume has a fraction grid for species {name!r}, which the line table "
            f"{table.origin} does not list; it has: {', '.join(known)}"
        )
    return build_species_lut(table, name, T_MAX_K, observer=observer)


def species_bin_xyz(
    table: LineTable, name: str, bins: SpectralBins, temperature_K: NDArray, observer: str
) -> NDArray[np.float64]:
    """XYZ per metre of species ``name`` (fraction 1) in each bin, T.shape + (N, 3)."""
    cmf = cmfs(observer)
    spectrum = species_spectrum(table, name, temperature_K, cmf.wavelength_nm, observer)
    per_sample = K_M * cmf.step_nm * spectrum[..., :, None] * cmf.xyz_bar
    spans = zip(bins.edges[:-1], bins.edges[1:], strict=True)
    return np.stack([per_sample[..., a:b, :].sum(axis=-2) for a, b in spans], axis=-2)


@functools.lru_cache(maxsize=64)
def species_bin_luts(path: str | None, name: str, n: int, observer: str) -> tuple[EmissionLUT, ...]:
    """One table per bin of species ``name``, for ``n`` bins (their edges do not depend on α)."""
    species_lut(path, name, observer)  # validates the name
    table = line_table(path)
    bins = make_bins(n, 0.0, observer)
    return tuple(
        build_emission_luts(
            T_MAX_K, lambda t: species_bin_xyz(table, name, bins, t, observer), bins.count
        )
    )


class SpeciesLines(EmissionModel):
    """The lines of the volume's species (fraction grids ``volume.species``), in order."""

    name = "lines"
    kind = "coefficient"

    def __init__(
        self,
        species: tuple[str, ...],
        bands: Bands,
        line_table_path: str | None = None,
        observer: str = "cie1931_2",
    ) -> None:
        self.species, self.observer, self.path = species, observer, line_table_path
        self.table = line_table(line_table_path)
        per_species: list[tuple[EmissionLUT, ...]] = []
        for name in species:
            if bands.grey:
                per_species.append((species_lut(self.path, name, observer),))
            else:
                per_species.append(species_bin_luts(self.path, name, bands.count, observer))
        self.per_species = tuple(per_species)
        self.tables = tuple(t for tables in self.per_species for t in tables)

    @property
    def occupancy_key(self) -> str:
        return f"{self.name}: {', '.join(self.species)}"

    def occupancy(self, volume) -> NDArray[np.float32]:
        grid = None
        for fraction in self.grids(volume):
            grid = fraction if grid is None else np.maximum(grid, fraction)
        assert grid is not None
        return grid

    def grids(self, volume) -> tuple[NDArray[np.float32], ...]:
        return tuple(volume.species[name] for name in self.species)

    def bind(self, kernel):
        tables = [[kernel.table(t) for t in per] for per in self.per_species]
        grids = [
            kernel.grid(("species", name), volume_grid)
            for name, volume_grid in zip(self.species, self.grids(kernel.volume), strict=True)
        ]
        return tables, grids

    def present(self, mask, values):
        for fraction in values:
            mask = mask | (fraction > 0.0)
        return mask

    def add(self, kernel, bound, eta, band, position, values):
        for fraction, tables in zip(values, bound[0], strict=True):
            eta = kernel.dr.fma(kernel.lookup(tables[band], position), fraction, eta)
        return eta

    def reference_add(self, eta, temperature_K, values, inputs):
        for name, fraction in zip(self.species, values, strict=True):
            eta += fraction[:, None] * species_xyz(self.table, name, temperature_K, self.observer)
        return eta

    def reference_spectrum_add(self, eta, temperature_K, values, wavelength_nm, inputs):
        for name, fraction in zip(self.species, values, strict=True):
            spectrum = species_spectrum(
                self.table, name, temperature_K, wavelength_nm, self.observer
            )
            eta = eta + fraction[:, None] * spectrum
        return eta
