"""Rendering: the pure ``render()`` API, settings, the HDR image, the integrators and the
backends."""

from incandescent.renderer.api import render
from incandescent.renderer.film import HDRImage
from incandescent.renderer.integrators import EmissionAbsorption, Integrator, Paper2011
from incandescent.renderer.settings import RenderSettings

__all__ = ["EmissionAbsorption", "HDRImage", "Integrator", "Paper2011", "RenderSettings", "render"]
