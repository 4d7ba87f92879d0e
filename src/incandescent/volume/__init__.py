"""Volumes: temperature grids in kelvin with absorption, placement and remapping."""

from incandescent.volume.grid import Remap, Volume
from incandescent.volume.macrocells import MacrocellGrid, build_macrocells

__all__ = ["MacrocellGrid", "Remap", "Volume", "build_macrocells"]
