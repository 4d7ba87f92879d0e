"""Inverse rendering: gradients of a render with respect to its volume (``gradients``: the exact
float64 adjoint of emission–absorption, replayed on the reference march)."""

from incandescent.inverse.gradients import Gradients, gradients

__all__ = ["Gradients", "gradients"]
