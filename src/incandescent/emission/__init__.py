"""Emission models: what emits light in the gas, one module each (``emission.base`` has the
interface). :class:`Emission` — the observer, the Planck constants and the line table — builds
the models a render uses from its volume and bands (:meth:`Emission.models`)."""

from __future__ import annotations

from dataclasses import dataclass

from incandescent.constants import PLANCK_CONSTANT_SETS, planck_constants
from incandescent.emission.base import KINDS, Bands, EmissionModel, check_kind
from incandescent.emission.blackbody import BlackbodyBins, BlackbodyGrey
from incandescent.emission.lines import SpeciesLines
from incandescent.spectra.cmf import OBSERVERS, cmfs

__all__ = [
    "KINDS",
    "OBSERVERS",
    "PLANCK_CONSTANTS",
    "Bands",
    "BlackbodyBins",
    "BlackbodyGrey",
    "Emission",
    "EmissionModel",
    "SpeciesLines",
    "transport_bands",
]

#: Planck constant sets by name (``incandescent.constants``).
PLANCK_CONSTANTS = tuple(PLANCK_CONSTANT_SETS)


@dataclass(frozen=True)
class Emission:
    """How the gas emits: blackbody through ``observer`` with the ``constants`` set, plus the lines
    of the volume's species from ``line_table`` (a .csv/.toml file; None: the shipped table,
    ``incandescent.spectra.lines``). The scene file's ``[emission]`` section."""

    observer: str = "cie1931_2"
    constants: str = "codata2018"
    line_table: str | None = None

    def __post_init__(self) -> None:
        cmfs(self.observer)  # unknown names list the choices
        planck_constants(self.constants)
        if self.line_table is not None and not isinstance(self.line_table, str):
            object.__setattr__(self, "line_table", str(self.line_table))

    def models(self, volume, bins: int = 0) -> tuple[EmissionModel, ...]:
        """Blackbody — grey, or in ``bins`` spectral bins with the volume's soot law
        κ_λ = κ·(550 nm/λ)^α (``volume.soot_alpha``) — plus the lines of the volume's species."""
        blackbody: BlackbodyGrey
        if bins:
            blackbody = BlackbodyBins(bins, volume.soot_alpha, self.observer, self.constants)
        else:
            blackbody = BlackbodyGrey(self.observer, self.constants)
        if not volume.species:
            return (blackbody,)
        lines = SpeciesLines(tuple(volume.species), blackbody.bands, self.line_table, self.observer)
        return blackbody, lines


def transport_bands(models: tuple[EmissionModel, ...]) -> Bands:
    """The bands of a render: those of its first model (every model's tables follow them)."""
    for model in models:
        check_kind(model)
    return getattr(models[0], "bands", Bands())
