"""Rendering: the pure ``render()`` API, settings, the HDR image and the backends."""

from incandescent.render.api import render
from incandescent.render.film import HDRImage
from incandescent.render.settings import RenderSettings

__all__ = ["HDRImage", "RenderSettings", "render"]
