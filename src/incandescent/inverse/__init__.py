"""Inverse rendering: gradients of a render with respect to its volume (``gradients``: the exact
float64 adjoint of emission–absorption, replayed on the reference march; ``adjoint``: the same on
a Dr.Jit backend, a replay march with scatter-adds)."""

from incandescent.inverse.adjoint import DeviceGradients, gradients_on
from incandescent.inverse.gradients import Gradients, gradients

__all__ = ["DeviceGradients", "Gradients", "gradients", "gradients_on"]
