"""Fire simulation (Nguyen, Fedkiw & Jensen 2002) on the renderer's Dr.Jit backends.

``simulate(settings, resolution, frames, out_dir)`` writes frames the renderer reads
(temperature in K, soot as κ, the blue core as CH and C₂ fractions, velocity for motion blur);
``PRESETS``: candle, torch, campfire, explosion.
"""

from incandescent.simulation.run import FrameReport, frame_volume, simulate
from incandescent.simulation.settings import PRESETS, FireSettings, Obstacle, Source, preset
from incandescent.simulation.solver import FireSolver, FireState

__all__ = [
    "PRESETS",
    "FireSettings",
    "FireSolver",
    "FireState",
    "FrameReport",
    "Obstacle",
    "Source",
    "frame_volume",
    "preset",
    "simulate",
]
