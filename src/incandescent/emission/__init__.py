"""Emission models: what emits light in the gas, one module each (``emission.base`` has the
interface). :func:`models_for` picks the models a render uses from its volume and settings."""

from __future__ import annotations

from incandescent.emission.base import KINDS, Bands, EmissionModel, check_kind
from incandescent.emission.blackbody import BlackbodyBins, BlackbodyGrey
from incandescent.emission.lines import SpeciesLines
from incandescent.emission.paper2011 import Paper2011

__all__ = [
    "KINDS",
    "Bands",
    "BlackbodyBins",
    "BlackbodyGrey",
    "EmissionModel",
    "Paper2011",
    "SpeciesLines",
    "models_for",
]


def models_for(volume, settings) -> tuple[EmissionModel, ...]:
    """The models a render uses: the paper's alone (``brightness="paper"``), else blackbody —
    grey, or in ``spectral_bins`` bins — plus the lines of the volume's species."""
    if settings.brightness == "paper":
        return (Paper2011(settings, volume.sodium_fraction is not None),)
    if settings.spectral_bins:
        blackbody: BlackbodyGrey = BlackbodyBins(
            settings.spectral_bins, settings.soot_alpha, settings.observer, settings.constants
        )
    else:
        blackbody = BlackbodyGrey(settings.observer, settings.constants)
    if not volume.species:
        return (blackbody,)
    lines = SpeciesLines(
        tuple(volume.species), blackbody.bands, settings.line_table, settings.observer
    )
    return blackbody, lines


def transport_bands(models: tuple[EmissionModel, ...]) -> Bands:
    """The bands of a render: those of its first model (every model's tables follow them)."""
    for model in models:
        check_kind(model)
    return getattr(models[0], "bands", Bands())
