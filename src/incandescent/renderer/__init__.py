"""Rendering: the pure ``render()`` API, settings, the HDR image and the backends."""

from incandescent.renderer.api import render
from incandescent.renderer.film import HDRImage
from incandescent.renderer.settings import RenderSettings

__all__ = ["HDRImage", "RenderSettings", "render"]
