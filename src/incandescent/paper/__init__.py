"""Reproduction of Zonenberg & Forrest (2011), "A GPU Accelerated Volumetric Ray Tracer for
Incandescent Gas": the paper's colour model (:mod:`incandescent.paper.colour`)."""

from incandescent.paper.colour import (
    PAPER_EXPONENT,
    PAPER_SODIUM_NM,
    PAPER_WAVELENGTHS_NM,
    PAPER_XYZ_TO_RGB,
    paper_chromaticity_rgb,
    paper_cmf,
    paper_rgb,
    paper_sodium_xyz,
    paper_spectrum_xyz,
    truncation_shift_uv,
)

__all__ = [
    "PAPER_EXPONENT",
    "PAPER_SODIUM_NM",
    "PAPER_WAVELENGTHS_NM",
    "PAPER_XYZ_TO_RGB",
    "paper_chromaticity_rgb",
    "paper_cmf",
    "paper_rgb",
    "paper_sodium_xyz",
    "paper_spectrum_xyz",
    "truncation_shift_uv",
]
