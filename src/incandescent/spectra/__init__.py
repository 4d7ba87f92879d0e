"""Spectra: Planck's law, CIE colour matching functions and the T ↦ XYZ tables."""

from incandescent.spectra.blackbody import blackbody_xyz, planckian_white
from incandescent.spectra.cmf import ColourMatchingFunctions, cmfs
from incandescent.spectra.lut import EmissionLUT, build_emission_lut
from incandescent.spectra.planck import planck_radiance

__all__ = [
    "ColourMatchingFunctions",
    "EmissionLUT",
    "blackbody_xyz",
    "build_emission_lut",
    "cmfs",
    "planck_radiance",
    "planckian_white",
]
