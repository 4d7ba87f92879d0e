"""The fire solver: Nguyen, Fedkiw & Jensen 2002 on a MAC grid, written once over ``arrays.Ops``.

One step (``FireSolver.step``), in the order of Fedkiw et al. 2001 §3 and Nguyen et al. 2002 §4:

1. advect velocity, temperature T, soot and the level set φ semi-Lagrangian (backtrace with the
   trilinear velocity), optionally MacCormack-corrected with Selle et al. 2008's limiter;
2. sources: φ ← min(φ, signed distance of each active source) (fuel, φ < 0 inside the blue core);
   nozzles set the velocity of their faces to the jet (with seeded turbulence);
3. the reaction front moves into the fuel at the flame speed S: φ is advected with the fuel's
   velocity (sampled 2.5 cells into the fuel near the front), then φ ← φ + S·Δt (Nguyen eqs. 2–3
   with |∇φ| = 1, φ a distance in cells; no re-initialisation);
4. forces: buoyancy a_y = β(T − T_air) − α·soot (Fedkiw eq. 8) and vorticity confinement
   f = ε h (N × ω), N = ∇|ω|/|∇|ω|| (Fedkiw eq. 11);
5. projection: ∇·u = D with D = (ρ_f/ρ_h − 1)·S·δ_ε(φ), the volume the burning fuel adds at the
   front (Nguyen eq. 6's jump as a divergence source, smeared over ε = 1.5 cells); the solid floor
   and obstacles are Neumann, the open sides and top Dirichlet (``pressure``);
6. temperature: T_ignition in the fuel, T_max in the reaction zone just behind the front, then
   radiative cooling dT/dt = −c_T ((T − T_air)/(T_max − T_air))⁴ (Nguyen eq. 9), clamped to
   [T_air, T_max]; soot produced at ``soot_rate`` where products are hotter than ``soot_min_K``,
   decaying (oxidised) at ``soot_decay``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from incandescent.simulation import pressure
from incandescent.simulation.arrays import ops_for
from incandescent.simulation.grid import (
    Layout,
    cells,
    faces,
    flat_index,
    indices,
    neighbour,
    positions,
    sample,
)
from incandescent.simulation.settings import FireSettings

#: Half width of the reaction zone and of the smeared δ(φ), cells.
FRONT_CELLS = 1.5
#: φ is kept within ± this many cells (a distance is only needed near the front).
PHI_LIMIT = 20.0
#: Cells within PHI_NEAR of the front take the fuel's velocity from FUEL_SIDE_CELLS into the fuel,
#: past the smeared expansion (2·FRONT_CELLS wide).
PHI_NEAR, FUEL_SIDE_CELLS = 4.0, 2.5


@dataclass
class FireState:
    """The fields of one instant: face velocities (cells/s) along x, y, z, and cell-centred
    φ (cells; < 0 in the fuel), T (K) and soot (unit density); the time and step count."""

    velocity: list
    phi: object
    temperature: object
    soot: object
    pressure: object
    time_s: float = 0.0
    steps: int = 0
    reports: list = field(default_factory=list)


@dataclass(frozen=True)
class StepReport:
    dt_s: float
    pressure_iterations: int
    pressure_residual: float
    max_divergence: float  # after projection, max |∇·u − D| in 1/s (cells per s per cell)


def grid_shape(settings: FireSettings, resolution: int) -> tuple[tuple[int, int, int], float]:
    """(cells along x, y, z; cell side h in m): ``resolution`` cells on the longest side, the
    others in proportion, each a multiple of 8 (the multigrid halves them)."""
    if isinstance(resolution, bool) or not isinstance(resolution, int | np.integer):
        raise TypeError(f"resolution must be an integer 8..1024; got {resolution!r}")
    if not 8 <= resolution <= 1024:
        raise ValueError(f"resolution must be 8..1024 cells; got {resolution}")
    h = max(settings.domain_m) / resolution
    _check_cells(settings.domain_m, h, resolution)
    shape = tuple(max(8, 8 * round(d / h / 8)) for d in settings.domain_m)
    return shape, h  # type: ignore[return-value]


#: Smallest cell side, m: below ~1 µm gas is no continuum (the mean free path in a flame is
#: ~0.5 µm); largest, m: the renderer's bound on a voxel (``VOXEL_SIZE_RANGE_M``).
CELL_RANGE_M = (1e-6, 1e6)
#: Fewest cells along a side of the domain as given (it is then widened to a multiple of 8).
MIN_SIDE_CELLS = 4


def _check_cells(domain_m, h: float, resolution: int) -> None:
    """Refuse a domain whose cells are outside ``CELL_RANGE_M`` or a side under 4 cells."""
    low, high = CELL_RANGE_M
    if not low <= h <= high:
        raise ValueError(
            f"domain_m {list(domain_m)} at resolution {resolution} makes cells of {h:.3g} m; "
            f"a cell must be {low:g}..{high:g} m (below 1 µm gas is no continuum)"
        )
    for axis, side in zip("xyz", domain_m, strict=True):
        if side / h < MIN_SIDE_CELLS:
            raise ValueError(
                f"domain_m: the {axis} side ({side:g} m) is {side / h:.2g} cells at resolution "
                f"{resolution} (cells of {h:.3g} m); each side needs at least {MIN_SIDE_CELLS} "
                f"cells: make it at least {MIN_SIDE_CELLS * h:.3g} m or raise the resolution"
            )


class FireSolver:
    """A fire on a ``resolution``-cell grid, on ``backend`` ("cpu", "cuda" or "reference")."""

    def __init__(self, settings: FireSettings, resolution: int, backend: str = "cpu") -> None:
        self.settings, self.ops = settings, ops_for(backend)
        self.shape, self.h = grid_shape(settings, resolution)
        self.cell = cells(self.shape)
        self.face = [faces(self.shape, a) for a in range(3)]
        self.centres = positions(self.ops, self.cell)
        self.face_points = [positions(self.ops, f) for f in self.face]
        solid = self._solid_cells()
        side = not settings.walls
        self.open_sides = (side, side, False, True, side, side)  # the floor (y−) is solid
        self.levels = pressure.hierarchy(self.ops, self.shape, ~solid, self.open_sides)
        self.fluid = self.ops.array((~solid).ravel().astype(np.float64))
        self.face_open = [self._face_open(a, solid) for a in range(3)]
        self.sources = [self._source_distance(s) for s in settings.sources]

    # --- geometry --------------------------------------------------------------------------
    def _world(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell-centre positions in m (NumPy), the domain's corner at the origin."""
        axes = [(np.arange(n) + 0.5) * self.h for n in self.shape]
        return tuple(np.meshgrid(*axes, indexing="ij"))  # type: ignore[return-value]

    def _at(self, fraction) -> np.ndarray:
        return np.asarray(fraction) * np.asarray(self.shape) * self.h

    def _solid_cells(self) -> np.ndarray:
        x, y, z = self._world()
        solid = np.zeros(self.shape, dtype=bool)
        for obstacle in self.settings.obstacles:
            c = self._at(obstacle.centre)
            if obstacle.kind == "sphere":
                solid |= (x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2 < obstacle.radius_m**2
            else:
                half = self._at(obstacle.size) / 2.0
                inside = [np.abs(q - c[a]) < half[a] for a, q in enumerate((x, y, z))]
                solid |= inside[0] & inside[1] & inside[2]
        return solid

    def _face_open(self, axis: int, solid: np.ndarray):
        """1 on faces fluid may cross, 0 on faces touching a solid cell or the floor."""
        layout = self.face[axis]
        shape = layout.shape
        lower = np.ones(shape, dtype=bool)  # the cell on the low side is not solid
        upper = np.ones(shape, dtype=bool)
        index = [slice(None)] * 3
        index[axis] = slice(1, None)
        lower[tuple(index)] = ~solid
        index[axis] = slice(None, -1)
        upper[tuple(index)] = ~solid
        crossing = lower & upper
        if axis == 1:
            crossing[:, 0, :] = False  # the floor
        elif self.settings.walls:
            ends = np.moveaxis(crossing, axis, 0)  # a view: the first and last faces are walls
            ends[0] = ends[-1] = False
        return self.ops.array(crossing.ravel().astype(np.float64))

    def _source_distance(self, source) -> object:
        """Signed distance (cells) to a source's surface: < 0 inside. A source narrower than a
        cell is widened to one (a coarse grid still has its fire)."""
        x, y, z = self._world()
        c = self._at(source.centre)
        radius = max(source.radius_m, self.h)
        if source.kind == "sphere":
            d = np.sqrt((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) - radius
        else:  # a disc (nozzle) one cell thick, facing up
            r = np.sqrt((x - c[0]) ** 2 + (z - c[2]) ** 2) - radius
            d = np.maximum(r, np.abs(y - c[1]) - self.h)
        return self.ops.array(d.ravel() / self.h)

    # --- state -----------------------------------------------------------------------------
    def initial_state(self) -> FireState:
        ops, n = self.ops, self.cell.size
        velocity = [ops.full(f.size, 0.0) for f in self.face]
        return FireState(
            velocity,
            ops.full(n, PHI_LIMIT),
            ops.full(n, self.settings.t_air_K),
            ops.full(n, 0.0),
            ops.full(n, 0.0),
        )

    def _velocity_at(self, velocity, p):
        return [sample(self.ops, velocity[a], self.face[a], p) for a in range(3)]

    def _advect(self, q, layout: Layout, points, velocity, dt, carried_by=None, ambient=None):
        """q advected by ``velocity`` over dt: semi-Lagrangian, MacCormack-corrected if set;
        ``carried_by``: where each sample takes its velocity from (default: where it is);
        ``ambient``: the value of air that flows in through an open side (default: the edge
        value extended, right for velocities). MacCormack's correction needs the forward trace
        inside the domain: where it leaves (the gas flowing out of the top or sides), the
        semi-Lagrangian value stays — else the clamped return sample holds outflowing gas back —
        and so it does where ambient air flows in."""
        ops = self.ops
        v = self._velocity_at(velocity, points if carried_by is None else carried_by)
        ops.evaluate(*v)  # stored: else each kernel reading it gathers it again (24 gathers)
        back = [points[a] - v[a] * dt for a in range(3)]
        entering = None if ambient is None else self._outside(back)  # air flowing in
        if not self.settings.maccormack:
            return _where(ops, entering, ambient, sample(ops, q, layout, back))
        forward, low, high = sample(ops, q, layout, back, with_range=True)
        forward = _where(ops, entering, ambient, forward)
        ops.evaluate(forward, low, high)  # one kernel shares their 8 gathers
        ahead = [points[a] + v[a] * dt for a in range(3)]
        returned = sample(ops, forward, layout, ahead)
        corrected = ops.clip(forward + 0.5 * (q - returned), low, high)
        outside = self._outside(ahead)
        if outside is not None:
            if entering is not None:  # the ambient value is exact there: no correction
                outside = outside | entering
            corrected = ops.select(outside, forward, corrected)
        ops.evaluate(corrected)  # now: the stored intermediates are freed field by field
        return corrected

    def _outside(self, p):
        """Positions (cell units) beyond an open side of the domain (air, not a wall or floor)."""
        out = None
        for axis in range(3):
            for side in (0, 1):
                if not self.open_sides[2 * axis + side]:
                    continue
                beyond = p[axis] < 0.0 if side == 0 else p[axis] > float(self.shape[axis])
                out = beyond if out is None else out | beyond
        return out

    # --- one step --------------------------------------------------------------------------
    def step(self, state: FireState, dt: float) -> tuple[FireState, StepReport]:
        ops, s = self.ops, self.settings
        u, step = state.velocity, ops.scalar(dt)  # a kernel input: a new Δt compiles nothing
        velocity = [
            self._advect(u[a], self.face[a], self.face_points[a], u, step) for a in range(3)
        ]
        temperature, soot = (
            self._advect(q, self.cell, self.centres, u, step, ambient=air)
            for q, air in ((state.temperature, s.t_air_K), (state.soot, 0.0))
        )
        fuel_side = self._fuel_side(state.phi)
        phi = self._advect(
            state.phi, self.cell, self.centres, u, step, carried_by=fuel_side, ambient=PHI_LIMIT
        )
        ops.evaluate(*velocity, phi, temperature, soot)
        phi, velocity = self._sources(phi, velocity, state)
        speed = s.flame_speed_m_s / self.h
        phi = ops.clip(phi + speed * step, -PHI_LIMIT, PHI_LIMIT)
        velocity = self._forces(velocity, temperature, soot, step)
        target = (s.density_ratio - 1.0) * speed * self._delta(phi)
        velocity, p, report = self._project(velocity, target, state.pressure)
        temperature, soot = self._heat(phi, temperature, soot, dt, step)
        ops.evaluate(*velocity, phi, temperature, soot, p)
        new = replace(
            state,
            velocity=velocity,
            phi=phi,
            temperature=temperature,
            soot=soot,
            pressure=p,
            time_s=state.time_s + dt,
            steps=state.steps + 1,
        )
        return new, replace(report, dt_s=dt)

    def _fuel_side(self, phi):
        """Where the front takes its velocity from: FUEL_SIDE_CELLS into the fuel along −∇φ for
        cells near the front (Nguyen eq. 3: the front moves with the *fuel's* velocity plus S·n;
        the smeared velocity across the front would carry it with the expanding products)."""
        ops = self.ops
        grad = [_central(self, phi, a) for a in range(3)]
        length = ops.sqrt(grad[0] ** 2 + grad[1] ** 2 + grad[2] ** 2) + 1e-12
        near = ops.select(ops.clip(phi, -PHI_NEAR, PHI_NEAR) == phi, FUEL_SIDE_CELLS, 0.0)
        return [self.centres[a] - near * grad[a] / length for a in range(3)]

    def _sources(self, phi, velocity, state: FireState):
        ops, s = self.ops, self.settings
        for source, distance in zip(s.sources, self.sources, strict=True):
            if state.time_s < source.start_s or (
                source.stop_s is not None and state.time_s >= source.stop_s
            ):
                continue
            phi = ops.minimum(phi, distance)
            if source.kind == "nozzle":
                velocity = self._jet(velocity, distance, source.jet_m_s / self.h, state.steps)
        return phi, velocity

    def _jet(self, velocity, distance, jet_cells: float, step: int):
        """Nozzle faces blow up at the jet speed, ± seeded turbulence in all three components."""
        ops = self.ops
        out = []
        for a in range(3):
            inside = sample(ops, distance, self.cell, self.face_points[a]) < 0.0
            noise = self._noise(self.face[a], step, a) * (self.settings.noise * jet_cells)
            value = noise + (jet_cells if a == 1 else 0.0)
            out.append(ops.select(inside, value, velocity[a]))
        return out

    def _noise(self, layout: Layout, step: int, salt: int):
        """Deterministic noise in [−1, 1) per sample: a hash of index, step, component and seed."""
        ops = self.ops
        key = (self.settings.seed * 0x9E3779B1 + step * 0x85EBCA77 + salt * 0xC2B2AE3D) & 0x7FFFFFFF
        x = (ops.arange(layout.size) * 1103515245 + ops.scalar_int(key)) & 0x7FFFFFFF
        x = (x * 1103515245 + 12345) & 0x7FFFFFFF
        return ops.to_float(x) * (2.0 / 2147483648.0) - 1.0

    def _delta(self, phi):
        """δ_ε(φ) = (1 + cos(πφ/ε)) / 2ε for |φ| < ε, else 0 (1/cells)."""
        ops, eps = self.ops, FRONT_CELLS
        near = ops.select(ops.clip(phi, -eps, eps) == phi, 1.0, 0.0)
        cosine = ops.cos(math.pi * ops.clip(phi, -eps, eps) / eps)
        return near * (1.0 + cosine) / (2.0 * eps)

    def _cell_value_at_faces(self, q, axis: int):
        """The mean of the two cells on either side of each face along ``axis`` (edge cells
        repeat at the boundary)."""
        ops = self.ops
        i, j, k = indices(ops, self.face[axis])
        ijk_low = [i, j, k]
        ijk_low[axis] = ops.clip(ijk_low[axis] - 1, 0, self.shape[axis] - 1)
        ijk_high = [i, j, k]
        ijk_high[axis] = ops.clip(ijk_high[axis], 0, self.shape[axis] - 1)
        low = ops.gather(q, flat_index(self.cell, *ijk_low))
        high = ops.gather(q, flat_index(self.cell, *ijk_high))
        return 0.5 * (low + high)

    def _forces(self, velocity, temperature, soot, dt):
        s = self.settings
        lift = s.buoyancy_m_s2_K * (temperature - s.t_air_K) - s.soot_weight_m_s2 * soot
        velocity = list(velocity)
        velocity[1] = velocity[1] + dt * (1.0 / self.h) * self._cell_value_at_faces(lift, 1)
        if s.vorticity > 0:
            confinement = vorticity_confinement(self, velocity)
            for a in range(3):
                velocity[a] = velocity[a] + dt * self._cell_value_at_faces(confinement[a], a)
        return velocity

    def _project(self, velocity, target, guess):
        ops = self.ops
        velocity = [velocity[a] * self.face_open[a] for a in range(3)]
        rhs = (target - divergence(self, velocity)) * self.fluid
        p, solve = pressure.solve(
            ops, self.levels, rhs, self.settings.pressure_tolerance, guess=guess
        )
        velocity = [(velocity[a] - gradient(self, p, a)) * self.face_open[a] for a in range(3)]
        residual = (divergence(self, velocity) - target) * self.fluid
        report = StepReport(0.0, solve.iterations, solve.relative_residual, ops.max_abs(residual))
        return velocity, p, report

    def _heat(self, phi, temperature, soot, dt: float, step):
        """Ignition in the fuel, T_max at the front, radiative cooling, soot; ``step`` is Δt as
        a kernel input."""
        ops, s = self.ops, self.settings
        fuel = phi < 0.0
        reacting = (phi >= 0.0) & (phi < FRONT_CELLS)
        temperature = ops.select(fuel, s.t_ignition_K, temperature)
        temperature = ops.select(reacting, s.t_max_K, temperature)
        excess = ops.clip((temperature - s.t_air_K) / (s.t_max_K - s.t_air_K), 0.0, 1.0)
        temperature = temperature - step * s.cooling_K_s * excess**4
        temperature = ops.clip(temperature, s.t_air_K, s.t_max_K)
        sooting = (temperature > s.soot_min_K) & (phi >= 0.0)
        soot = soot + ops.select(sooting, step * s.soot_rate_per_s, 0.0)
        soot = ops.maximum(soot * ops.scalar(math.exp(-s.soot_decay_per_s * dt)), 0.0)
        return temperature, soot


def _where(ops, mask, value, otherwise):
    """``value`` where ``mask`` (None: nowhere), else ``otherwise``."""
    return otherwise if mask is None else ops.select(mask, value, otherwise)


def divergence(solver: FireSolver, velocity):
    """Σ over axes of (face above − face below), per cell (1/s in cells per second)."""
    ops = solver.ops
    i, j, k = indices(ops, solver.cell)
    total = None
    for a in range(3):
        ijk = [i, j, k]
        below = ops.gather(velocity[a], flat_index(solver.face[a], *ijk))
        ijk[a] = ijk[a] + 1
        above = ops.gather(velocity[a], flat_index(solver.face[a], *ijk))
        total = above - below if total is None else total + above - below
    return total


def gradient(solver: FireSolver, p, axis: int):
    """(p above − p below) across each face along ``axis``; p = 0 outside the domain (open)."""
    ops = solver.ops
    i, j, k = indices(ops, solver.face[axis])
    n = solver.shape[axis]
    ijk = [i, j, k]
    low = [i, j, k]
    low[axis] = ijk[axis] - 1
    high = [i, j, k]
    values = []
    for cell_ijk in (low, high):
        inside = (cell_ijk[axis] >= 0) & (cell_ijk[axis] < n)
        clamped = list(cell_ijk)
        clamped[axis] = ops.clip(cell_ijk[axis], 0, n - 1)
        value = ops.gather(p, flat_index(solver.cell, *clamped))
        values.append(ops.select(inside, value, 0.0))
    return values[1] - values[0]


def vorticity_confinement(solver: FireSolver, velocity):
    """f = ε (N × ω) per cell, cells/s² (Fedkiw, Stam & Jensen 2001 eq. 11 in cell units)."""
    ops = solver.ops
    centre = [_face_mean(solver, velocity[a], a) for a in range(3)]
    d = [[_central(solver, centre[c], a) for a in range(3)] for c in range(3)]  # d[c][a] = ∂u_c/∂a
    omega = (d[2][1] - d[1][2], d[0][2] - d[2][0], d[1][0] - d[0][1])
    magnitude = ops.sqrt(omega[0] ** 2 + omega[1] ** 2 + omega[2] ** 2)
    grad = [_central(solver, magnitude, a) for a in range(3)]
    length = ops.sqrt(grad[0] ** 2 + grad[1] ** 2 + grad[2] ** 2) + 1e-12
    n = [g / length for g in grad]
    eps = solver.settings.vorticity
    return (
        eps * (n[1] * omega[2] - n[2] * omega[1]),
        eps * (n[2] * omega[0] - n[0] * omega[2]),
        eps * (n[0] * omega[1] - n[1] * omega[0]),
    )


def _face_mean(solver: FireSolver, face_values, axis: int):
    """A face component averaged to the cell centres."""
    ops = solver.ops
    i, j, k = indices(ops, solver.cell)
    ijk = [i, j, k]
    below = ops.gather(face_values, flat_index(solver.face[axis], *ijk))
    ijk[axis] = ijk[axis] + 1
    above = ops.gather(face_values, flat_index(solver.face[axis], *ijk))
    return 0.5 * (below + above)


def _central(solver: FireSolver, q, axis: int):
    """∂q/∂axis at cell centres by central differences (one-sided at the edges), per cell."""
    ops = solver.ops
    i, j, k = indices(ops, solver.cell)
    up, up_in = neighbour(ops, solver.cell, i, j, k, axis, 1)
    down, down_in = neighbour(ops, solver.cell, i, j, k, axis, -1)
    span = ops.select(up_in, 1.0, 0.0) + ops.select(down_in, 1.0, 0.0)
    return (ops.gather(q, up) - ops.gather(q, down)) / ops.maximum(span, 1.0)


def frame_fields(solver: FireSolver, state: FireState) -> dict[str, np.ndarray]:
    """What a frame holds, as NumPy (nx, ny, nz) grids: temperature_K, absorption_per_m (soot),
    CH and C2 fractions in the reaction zone (the blue core glows by its spectrum), and the
    cell-centred velocity in m/s (motion blur)."""
    ops, s, shape = solver.ops, solver.settings, solver.shape
    phi = ops.numpy(state.phi).reshape(shape)
    zone = np.where(np.abs(phi) < FRONT_CELLS, 0.5 * (1 + np.cos(np.pi * phi / FRONT_CELLS)), 0.0)
    velocity = np.stack(
        [ops.numpy(_face_mean(solver, state.velocity[a], a)).reshape(shape) for a in range(3)],
        axis=-1,
    )
    temperature = ops.numpy(state.temperature).reshape(shape)
    return {
        "temperature_K": temperature,
        "absorption_per_m": ops.numpy(state.soot).reshape(shape) * s.soot_kappa_per_m,
        "CH": zone * s.ch_fraction,
        "C2": zone * s.c2_fraction,
        "velocity_m_s": velocity * solver.h,
    }
