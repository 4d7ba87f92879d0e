"""A solver state as what a frame holds: the renderer's inputs in SI units.

``frame_fields`` turns the solver's cell-unit fields (``fields``) into NumPy (nx, ny, nz) grids:
temperature in K; absorption κ = soot × ``soot_kappa_per_m`` in 1/m; the CH and C₂ fractions of
the reaction zone, ``ch_fraction`` and ``c2_fraction`` weighted by the smeared front
(1 + cos(πφ/ε))/2 for |φ| < ε = ``FRONT_CELLS`` (the blue core glows by its band spectrum); and
the cell-centred velocity in m/s (cells/s × h, for motion blur).
"""

from __future__ import annotations

import numpy as np

from incandescent.simulation.operators import face_mean
from incandescent.simulation.solver import FRONT_CELLS, FireSolver, FireState


def reaction_zone(phi: np.ndarray) -> np.ndarray:
    """The reaction zone's weight, 1 on the front φ = 0 falling to 0 at |φ| = FRONT_CELLS."""
    return np.where(np.abs(phi) < FRONT_CELLS, 0.5 * (1 + np.cos(np.pi * phi / FRONT_CELLS)), 0.0)


def frame_fields(solver: FireSolver, state: FireState) -> dict[str, np.ndarray]:
    """What a frame holds, as NumPy (nx, ny, nz) grids: temperature_K, absorption_per_m (soot),
    CH and C2 (fractions), velocity_m_s (nx, ny, nz, 3); see the module docstring."""
    ops, s, shape = solver.ops, solver.settings, solver.shape
    zone = reaction_zone(ops.numpy(state.phi.values).reshape(shape))
    centred = [
        ops.numpy(face_mean(ops, c, a).values).reshape(shape) for a, c in enumerate(state.velocity)
    ]
    return {
        "temperature_K": ops.numpy(state.temperature.values).reshape(shape),
        "absorption_per_m": ops.numpy(state.soot.values).reshape(shape) * s.soot_kappa_per_m,
        "CH": zone * s.ch_fraction,
        "C2": zone * s.c2_fraction,
        "velocity_m_s": np.stack(centred, axis=-1) * solver.h,
    }
