"""The fire solver: Nguyen, Fedkiw & Jensen 2002 on a MAC grid, written once over ``arrays.Ops``.

One step (``FireSolver.step``), in the order of Fedkiw et al. 2001 §3 and Nguyen et al. 2002 §4:

1. advect velocity, temperature T, soot and the level set φ semi-Lagrangian (backtrace with the
   trilinear velocity), optionally MacCormack-corrected with Selle et al. 2008's limiter; air
   entering through an open side brings T_air, no soot and no velocity along that side;
   then heat and soot mixed below the grid's scale (Smagorinsky's eddy diffusivity, ``_mix``);
2. sources: φ ← min(φ, signed distance of each active source) (fuel, φ < 0 inside the blue core);
   nozzles set the velocity of their faces to the jet (with seeded turbulence);
3. the reaction front moves into the fuel at the flame speed S: φ is advected with the fuel's
   velocity (sampled 2.5 cells into the fuel near the front), then φ ← φ + S·Δt (Nguyen eqs. 2–3
   with |∇φ| = 1, φ a distance in cells; no re-initialisation);
4. forces: buoyancy a_y = g(1 − T_air/T) − g·c_soot/ρ_air (Boussinesq with the ideal gas's
   density; Fedkiw eq. 8 with physical constants) and vorticity confinement
   f = ε h (N × ω), N = ∇|ω|/|∇|ω|| (Fedkiw eq. 11); inflow through an open side slowed by its
   Bernoulli pressure drop (``_entrainment``);
5. projection: ∇·u = D with D = (ρ_f/ρ_h − 1)·S·δ_ε(φ), the volume the burning fuel adds at the
   front (Nguyen eq. 6's jump as a divergence source, smeared over ε = 1.5 cells); the solid floor
   and obstacles are Neumann, the open sides and top Dirichlet (``pressure``);
6. temperature: T_ignition in the fuel, T_max in the reaction zone just behind the front, then
   radiative cooling dT/dt = −c_T ((T − T_air)/(T_max − T_air))⁴ (Nguyen eq. 9), clamped to
   [T_air, T_max]; soot produced at ``soot_rate`` where products are hotter than ``soot_min_K``,
   decaying (oxidised) at ``soot_decay``.

A diffusion flame (``combustion = "mixing"``, ``_step_diffusion_flame``) replaces steps 2, 3
and 6: the sources feed fuel into the mixture fraction Z, the temperature is Z's under fast
chemistry (``flame_temperature``) and φ the distance to the flame sheet Z = Z_st. With
``density = "ideal_gas"`` steps 4 and 5 give each parcel its own inertia, ρ = ρ_air T_air/T
(buoyancy per its mass, the projection −∇·(β∇p) with β = T/T_air on the faces).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from incandescent.simulation import pressure
from incandescent.simulation.arrays import Array, ops_for
from incandescent.simulation.fields import Field, StaggeredField
from incandescent.simulation.grid import (
    Layout,
    cells,
    faces,
    indices,
    positions,
    sample,
)
from incandescent.simulation.operators import (
    advect,
    advect_conservative,
    advect_together,
    cell_value_at_faces,
    central,
    central_at,
    divergence,
    eddy_diffuse,
    eddy_exchange,
    face_mean,
    gradient,
    strain_rate,
    vorticity_confinement,
)
from incandescent.simulation.settings import FireSettings, air_density_kg_m3
from incandescent.simulation.state_relation import equilibrium_table_K, interpolate

#: Half width of the reaction zone and of the smeared δ(φ), cells.
FRONT_CELLS = 1.5
#: φ is kept within ± this many cells (a distance is only needed near the front).
PHI_LIMIT = 20.0
#: Cells within PHI_NEAR of the front take the fuel's velocity from FUEL_SIDE_CELLS into the fuel,
#: past the smeared expansion (2·FRONT_CELLS wide).
PHI_NEAR, FUEL_SIDE_CELLS = 4.0, 2.5
#: The share of the gap between the carried density and the state relation's that the low-Mach
#: step's next divergence closes (``_step_low_mach``): all of it. (A first form, which reset the
#: density to the state relation's each step and so had to lag, flipped between expansion and
#: contraction at a gain of 1 and lost 11 % of the mass heating moves at ½; measured.)
EXPANSION_GAIN = 1.0


@dataclass
class FireState:
    """The fields of one instant, each a typed field (values and layout together; a checkpoint
    holds their flat arrays): ``velocity`` on the faces (cells/s, component a on the faces
    normal to axis a), and at the cell centres ``phi`` (cells; < 0 in the fuel),
    ``temperature`` (K), ``soot`` (unit density) and ``pressure``, the last projection's
    (cells²/s, the next solve's first guess) and ``mixture``, the mixture fraction Z (the mass
    fraction of gas that came from fuel; 0 with the premixed front); the time (s) and the step
    count. Every cell field must lie on the cell centres of the velocity's grid (checked when
    the state is made)."""

    velocity: StaggeredField
    phi: Field
    temperature: Field
    soot: Field
    pressure: Field
    mixture: Field
    time_s: float = 0.0
    steps: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.velocity, StaggeredField):
            raise TypeError(f"velocity must be a StaggeredField; got {type(self.velocity)}")
        centres = self.velocity.cells
        for name in ("phi", "temperature", "soot", "pressure", "mixture"):
            field = getattr(self, name)
            if not isinstance(field, Field) or field.layout != centres:
                where = field.layout if isinstance(field, Field) else type(field).__name__
                raise ValueError(f"{name} must be a Field on the cells {centres}; got {where}")


@dataclass(frozen=True)
class StepReport:
    dt_s: float
    pressure_iterations: int
    pressure_residual: float
    max_divergence: float  # after projection, max |∇·u − D| in 1/s (cells per s per cell)
    cfl: float = 0.0  # Δt·(max|u| + S)/h of the step, set by ``run.advance_frame``


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
        self.wind = settings.wind_m_s / self.h  # cells/s along +x
        # A wind's x− side is an inflow of given velocity: a Neumann side for the pressure.
        solved_sides = (side and self.wind == 0.0,) + self.open_sides[1:]
        self.levels = pressure.hierarchy(self.ops, self.shape, ~solid, solved_sides)
        self.exact = self._exact_inverse(solid, solved_sides)
        self.fluid = self.ops.array((~solid).ravel().astype(np.float64))
        self.face_open = [self._face_open(a, solid) for a in range(3)]
        self.wind_faces = self._wind_faces()
        # The faces the pressure acts across: the open ones, but not a wind's inflow (Neumann).
        inflow = self.wind_faces if self.wind > 0.0 else 0.0
        self.solved_faces = [self.face_open[0] * (1.0 - inflow), *self.face_open[1:]]
        self.inflow_sign = [self._inflow_sign(a) for a in range(3)]
        self.sources = [self._source_distance(s) for s in settings.sources]
        self.source_m3 = [float((self.ops.numpy(d) < 0.0).sum()) * self.h**3 for d in self.sources]
        equilibrium = settings.state_relation == "equilibrium"
        fuel = settings.equilibrium_fuel
        self.state_table = self.ops.array(equilibrium_table_K(fuel)) if equilibrium else None

    def _exact_inverse(self, solid: np.ndarray, solved_sides: tuple) -> pressure.Direct | None:
        """The obstacle-free box's exact A⁻¹ as the pressure preconditioner, per
        ``pressure_preconditioner``. Auto: for a Boussinesq fire on the host backends where the
        box has no obstacle — there it solves the projection in one iteration. The
        variable-density operator still needs 12 (15 with the V-cycle; the 1 m, 200 kW pool at
        128 cells) and each application, a round trip to the host, costs more than a V-cycle: a
        frame took 0.41–0.45 s with it against 0.34 s (interleaved, quiet)."""
        choice = self.settings.pressure_preconditioner
        host = self.ops.name != "cuda" and self.settings.density == "boussinesq"
        if choice == "multigrid" or (choice == "auto" and not host):
            return None
        if solid.any():
            if choice == "exact":
                raise ValueError(
                    "pressure_preconditioner: 'exact' needs a box without obstacles; these "
                    f"settings have {len(self.settings.obstacles)}: use 'multigrid' or 'auto'"
                )
            return None
        dtype = np.float64 if self.ops.name == "reference" else np.float32
        return pressure.direct(self.shape, solved_sides, dtype, self._host_threads())

    def _host_threads(self) -> int:
        """The threads host work may use: Dr.Jit's pool's on cpu, the machine's otherwise."""
        if self.ops.name == "cpu":
            from incandescent._jit import drjit_module

            return int(drjit_module().thread_count())
        return os.cpu_count() or 1

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

    def _wind_faces(self):
        """1 on the open faces of the x− side (where a wind blows in, ``_blow``), else 0."""
        first = np.zeros(self.face[0].shape)
        first[0] = 1.0
        return self.ops.array(first.ravel()) * self.face_open[0]

    def _blow(self, velocity: Sequence[Array]) -> list[Array]:
        """The wind's inflow faces set to the wind (cells/s); the others as given."""
        velocity = list(velocity)
        if self.wind > 0.0:
            velocity[0] = self.ops.select(self.wind_faces > 0.0, self.wind, velocity[0])
        return velocity

    def _inflow_sign(self, axis: int):
        """On the faces of the open sides normal to ``axis``, the sign of a velocity flowing in
        (+1 on the low side, −1 on the high side); 0 on every other face."""
        sign = np.zeros(self.face[axis].shape)
        ends = np.moveaxis(sign, axis, 0)  # a view: its first and last faces are the sides'
        if self.open_sides[2 * axis]:
            ends[0] = 1.0
        if self.open_sides[2 * axis + 1]:
            ends[-1] = -1.0
        return self.ops.array(sign.ravel())

    def _source_distance(self, source) -> Array:
        """Signed distance (cells) to a source's surface: < 0 inside. A source narrower than a
        cell is widened to one (a coarse grid still has its fire). A sphere's surface is
        rippled by ``noise`` × its radius (``_ripples``, seeded): a perfect sphere burns into
        perfectly symmetric lobes, as no real fireball does."""
        x, y, z = self._world()
        c = self._at(source.centre)
        radius = max(source.radius_m, self.h)
        if source.kind == "sphere":
            d = np.sqrt((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) - radius
            d = d - self.settings.noise * radius * _ripples(x, y, z, radius, self.settings.seed)
        else:  # a disc (nozzle) one cell thick, facing up
            r = np.sqrt((x - c[0]) ** 2 + (z - c[2]) ** 2) - radius
            d = np.maximum(r, np.abs(y - c[1]) - self.h)
        return self.ops.array(d.ravel() / self.h)

    # --- state -----------------------------------------------------------------------------
    def initial_state(self) -> FireState:
        ops, n = self.ops, self.cell.size
        velocity = [ops.full(f.size, 0.0) for f in self.face]
        velocity[0] = velocity[0] + self.wind * self.face_open[0]  # the domain starts in the wind
        return FireState(
            self.velocity_field(velocity),
            self.cell_field(ops.full(n, PHI_LIMIT)),
            self.cell_field(ops.full(n, self.settings.t_air_K)),
            self.cell_field(ops.full(n, 0.0)),
            self.cell_field(ops.full(n, 0.0)),
            self.cell_field(ops.full(n, 0.0)),
        )

    def velocity_field(self, velocity: Sequence[Array]) -> StaggeredField:
        """The three face components (cells/s) as a typed field of this grid."""
        return StaggeredField.on(self.shape, velocity)

    def cell_field(self, values: Array) -> Field:
        """A cell-centred array of this grid as a typed field."""
        return Field(values, self.cell)

    def _advect(self, q: Field, points, u: StaggeredField, dt, ambient=None, velocity_at=None):
        """``operators.advect`` with this solver's scheme and open sides; the backend array."""
        return advect(
            self.ops,
            q,
            u,
            dt,
            maccormack=self.settings.maccormack,
            open_sides=self.open_sides,
            points=points,
            ambient=ambient,
            velocity_at=velocity_at,
        ).values

    def _advect_cells(self, qs: Sequence[Field], u: StaggeredField, dt, ambients,
                      velocity_at=None) -> list:  # fmt: skip
        """Cell fields carried together from the centres (``operators.advect_together``: one
        velocity sample, shared indices), each with its inflowing air's value; backend arrays.
        ``velocity_at``: the velocity at the centres if already sampled."""
        out = advect_together(self.ops, qs, u, dt, maccormack=self.settings.maccormack,
                              open_sides=self.open_sides, points=self.centres,
                              ambients=ambients, points_on=self.cell,
                              velocity_at=velocity_at)  # fmt: skip
        return [q.values for q in out]

    def _centre_velocity(self, u: StaggeredField) -> list:
        """The velocity at the cell centres, each component the mean of its two faces
        (evaluated: the cell scalars' and the front's advection read it)."""
        v = [face_mean(self.ops, c, a).values for a, c in enumerate(u)]
        self.ops.evaluate(*v)
        return v

    # --- one step --------------------------------------------------------------------------
    def step(self, state: FireState, dt: float) -> tuple[FireState, StepReport]:
        if self.settings.combustion == "mixing":
            return self._step_diffusion_flame(state, dt)
        ops, s = self.ops, self.settings
        u, step = state.velocity, ops.scalar(dt)  # Δt a kernel input
        velocity = [self._advect_velocity(u, a, step) for a in range(3)]
        centre = self._centre_velocity(u)
        temperature, soot = self._advect_cells(
            (state.temperature, state.soot), u, step, (s.t_air_K, 0.0), centre
        )
        phi = self._advect(state.phi, self.centres, u, step, ambient=PHI_LIMIT,
                           velocity_at=self._front_velocity(state.phi, u, centre))  # fmt: skip
        temperature, soot = self._mix(u, temperature, soot, step=step, centre=centre)
        ops.evaluate(*velocity, phi, temperature, soot)
        phi, velocity = self._sources(phi, velocity, state)
        speed = s.flame_speed_m_s / self.h
        phi = ops.clip(phi + speed * step, -PHI_LIMIT, PHI_LIMIT)
        inertia = self.inertia(temperature)
        velocity = self._forces(velocity, temperature, soot, step, inertia)
        velocity = self._entrainment(velocity, step)
        target = (s.density_ratio - 1.0) * speed * self._delta(phi)
        velocity, p, report = self.project(velocity, target, state.pressure.values, inertia)
        temperature, soot = self._heat(phi, temperature, soot, dt, step)
        ops.evaluate(*velocity, phi, temperature, soot, p)
        fields = {"phi": phi, "temperature": temperature, "soot": soot, "pressure": p}
        return self._advanced(state, dt, velocity, fields), replace(report, dt_s=dt)

    def _step_diffusion_flame(self, state: FireState, dt: float) -> tuple[FireState, StepReport]:
        """One step of a diffusion flame (``combustion = "mixing"``): the mixture fraction Z and
        soot advected and mixed, the sources' fuel fed in, the temperature Z's flame temperature
        (``flame_temperature``), buoyancy and confinement, then a divergence-free projection
        (with ``density = "ideal_gas"`` the variable-density one). The heat's expansion, the
        low-Mach constraint ∇·u = −(1/ρ) Dρ/Dt, only with ``expansion`` (``_step_low_mach``)."""
        ops = self.ops
        u, step = state.velocity, ops.scalar(dt)
        velocity = [self._advect_velocity(u, a, step) for a in range(3)]
        centre = self._centre_velocity(u)
        if self.settings.reaction == "mixing_time":
            return self._step_mixing_time(state, dt, velocity, centre)
        if self.settings.expansion:
            return self._step_low_mach(state, dt, velocity, centre)
        mixture, soot = self._carry_mixture(state, u, dt)
        mixture, soot = self._mix(u, mixture, soot, step=step, centre=centre)
        ops.evaluate(*velocity, mixture, soot)
        mixture, velocity = self._feed(mixture, velocity, state, step)
        temperature = self.flame_temperature(mixture)
        return self._burnt(state, dt, velocity, mixture, temperature, soot)

    def _step_mixing_time(self, state: FireState, dt: float, velocity, centre):
        """The diffusion flame's step with ``reaction = "mixing_time"``: the temperature carried
        and mixed with Z and soot (it holds the burnt fuel, ``_burn``), then the fuel burnt over
        Δt at its mixing-limited rate."""
        ops, u, step = self.ops, state.velocity, self.ops.scalar(dt)
        carried = self._carry_mixture(state, u, dt, with_heat=True)
        strain = strain_rate(ops, u, centre)
        mixture, soot, heat = self._mix(u, *carried, step=step, centre=centre, strain=strain)
        ops.evaluate(*velocity, mixture, soot, heat)
        mixture, velocity = self._feed(mixture, velocity, state, step)
        temperature = self._burn(mixture, heat, strain.values, dt)
        return self._burnt(state, dt, velocity, mixture, temperature, soot)

    def _step_low_mach(self, state: FireState, dt: float, velocity, centre):
        """The diffusion flame's step with ``expansion``: the low-Mach equations (Rehm & Baum
        1978, J. Res. NBS 83:297) as FDS solves them (McGrattan et al., FDS Technical Reference
        Guide, NIST SP 1018-1, §2–3): the gas's density ρ and its fuel ρZ are carried in flux
        form (here as fractions of the air's density, r = ρ/ρ_air and μ = ρZ/ρ_air), with the
        fuel's mass fed into both and mixed as ∇·(ρ D_t ∇Z), so the gas's and the fuel's
        masses change only by the feed and what the sides pass; the temperature follows from
        the density by the ideal gas at the ambient pressure, T = T_air/r (FDS's equation of
        state), Z = μ/r. Heat enters through the divergence: the next velocity is projected to
        ∇·u = (r − r_Z)/(r Δt), which carries the density in one step (for ``EXPANSION_GAIN``
        = 1) to r_Z = T_air/T(Z), the state relation's (``flame_temperature``): burning gas
        expands, gas that cools contracts."""
        ops, u, step = self.ops, state.velocity, self.ops.scalar(dt)
        density = self.settings.t_air_K / state.temperature.values
        fields = [self.cell_field(state.mixture.values * density), self.cell_field(density)]
        fuel, density, soot = self._carry_conservative(
            [*fields, state.soot], (0.0, 1.0, 0.0), u, dt
        )
        fuel, soot = self._mix_fuel(u, fuel, density, soot, step, centre)
        ops.evaluate(*velocity, fuel, soot, density)
        fed, velocity = self._feed(fuel, velocity, state, step)
        density = density + (fed - fuel)  # the fuel's mass joins the gas's
        mixture = ops.clip(fed / density, 0.0, 1.0)
        settled = self.settings.t_air_K / self.flame_temperature(mixture)
        target = EXPANSION_GAIN * (density - settled) / (density * step) * self.fluid
        temperature = self.settings.t_air_K / density
        return self._burnt(state, dt, velocity, mixture, temperature, soot, target)

    def _mix_fuel(self, u: StaggeredField, fuel, density, soot, step, centre):
        """``_mix`` for the low-Mach step: the fuel μ = ρZ/ρ_air gains ∇·(ρ D_t ∇Z)Δt
        (``operators.eddy_exchange`` weighted by the density r), soot as ``_mix``."""
        ops = self.ops
        if self.settings.smagorinsky <= 0.0:
            return fuel, soot
        diffusivity = self._eddy_diffusivity(u, centre)
        mixture = self.cell_field(fuel / density)
        gain = eddy_exchange(ops, mixture, diffusivity, step, weight=density)
        soot = eddy_diffuse(ops, self.cell_field(soot), diffusivity, step).values
        return fuel + gain, soot

    def _burnt(self, state: FireState, dt: float, velocity, mixture, temperature, soot, target=0.0):
        """The diffusion flame's step from its new temperature on: forces, projection (to
        ∇·u = ``target``, 1/s), soot, the sheet's distance."""
        ops = self.ops
        step = ops.scalar(dt)
        inertia = self.inertia(temperature)
        velocity = self._forces(velocity, temperature, soot, step, inertia)
        velocity = self._entrainment(velocity, step)
        velocity, p, report = self.project(velocity, target, state.pressure.values, inertia)
        soot = self._soot(
            temperature, mixture > self.settings.stoichiometric_mixture, soot, dt, step
        )
        phi = self.sheet_distance(mixture)
        ops.evaluate(*velocity, phi, temperature, soot, p, mixture)
        fields = {"phi": phi, "temperature": temperature, "soot": soot, "pressure": p}
        fields["mixture"] = mixture
        return self._advanced(state, dt, velocity, fields), replace(report, dt_s=dt)

    def _carry_mixture(self, state: FireState, u: StaggeredField, dt: float, with_heat=False):
        """Z and soot carried in flux form (``operators.advect_conservative``), so the fuel and
        soot in the gas change only by what the sides pass, the feed and the soot's sources
        (tested): carried semi-Lagrangian, the 0.5 m, 50 kW pool at 32 cells let 3.3 g/s of
        fuel out of its top for the 1 g/s fed — and so released 3.3 × (1 − χ_r)Q of heat."""
        fields = (state.mixture, state.soot, state.temperature)[: 3 if with_heat else 2]
        ambients = (0.0, 0.0, self.settings.t_air_K)[: len(fields)]
        return self._carry_conservative(fields, ambients, u, dt)

    def _carry_conservative(self, fields, ambients, u: StaggeredField, dt: float) -> list:
        """The cell ``fields`` carried in flux form over ``dt`` (``advect_conservative``, its
        sub-steps from the velocity's largest components), ``ambients`` entering through the
        sides; their values, in order."""
        courant = sum(self.ops.max_abs(c.values) for c in u) * dt
        out = advect_conservative(self.ops, fields, u, dt, ambients=ambients, courant_cells=courant)
        return [q.values for q in out]

    def _burn(self, mixture, temperature, strain, dt: float):
        """The temperature (K) after Δt of mixing-limited burning (``reaction =
        "mixing_time"``). The gas's burnt fuel b (kg per kg of gas) is its heat: T = T_air +
        k·b with k = (1 − χ_r)(T_ad − T_air)/Z_st, the fast-chemistry state relation's slope
        (``flame_temperature``: b = min(Z, (1 − Z)/s) there). Unburnt fuel Y_F = Z − b and
        unburnt air Y_A = 1 − Z − s·b burn as a partially stirred reactor (McGrattan et al.,
        FDS Technical Reference Guide, 6th ed., NIST SP 1018-1, §5.1: eddy dissipation):
        b += min(Y_F, Y_A/s)(1 − exp(−Δt/τ_mix)), with ``mixing_time_s``'s τ_mix. As τ_mix → 0
        this is ``flame_temperature`` exactly (tested)."""
        s, ops = self.settings, self.ops
        z_st, t_air = s.stoichiometric_mixture, s.t_air_K
        air_per_fuel = (1.0 - z_st) / z_st
        k = (1.0 - s.radiant_fraction) * (s.t_max_K - t_air) / z_st
        burnt = ops.maximum((temperature - t_air) / k, 0.0)
        fuel = ops.maximum(mixture - burnt, 0.0)
        air = ops.maximum(1.0 - mixture - air_per_fuel * burnt, 0.0)
        share = 1.0 - ops.exp(-dt / self.mixing_time_s(strain))
        return t_air + k * (burnt + ops.minimum(fuel, air / air_per_fuel) * share)

    def mixing_time_s(self, strain):
        """τ_mix (s) per cell: min(τ_u, τ_g) (McDermott, McGrattan & Floyd 2011, Fire Safety
        Science 10:809; FDS 6's default, its molecular τ_d = Δ²/D_F ≈ 10 s at these cells left
        out): τ_g = √(2Δ/g), a parcel's free fall across the cell, and τ_u = C_u Δ/√(⅔k_sgs),
        C_u = 0.4, with Deardorff's k_sgs = (ν_t/(C_ν Δ))², C_ν = 0.1, from this solver's
        Smagorinsky ν_t = (C_s Δ)²|S|: τ_u = C_u C_ν/(√⅔ C_s² |S|). ``strain``: |S| (1/s;
        the strain rate in cells/s per cell)."""
        s, ops = self.settings, self.ops
        fall = math.sqrt(2.0 * self.h / max(s.gravity_m_s2, 1e-30))
        if s.smagorinsky <= 0.0:
            return ops.full(self.cell.size, fall)
        turbulence = 0.4 * 0.1 / (math.sqrt(2.0 / 3.0) * s.smagorinsky**2)
        return ops.minimum(turbulence / ops.maximum(strain, 1e-30), fall)

    def _advanced(self, state: FireState, dt: float, velocity, fields: dict) -> FireState:
        """``state`` Δt later: the new face ``velocity`` and cell ``fields`` (name → array)."""
        typed = {name: getattr(state, name).like(values) for name, values in fields.items()}
        return replace(
            state,
            velocity=self.velocity_field(velocity),
            time_s=state.time_s + dt,
            steps=state.steps + 1,
            **typed,
        )

    def _feed(self, mixture, velocity, state: FireState, step):
        """Each active source's fuel, ``fuel_kg_s``, added to Z evenly over its cells (a mass
        source of ṁ_f/(ρ_air V) per second — Z is carried as in a flow of the air's density
        throughout; the ideal gas's density enters the momentum only, ``density`` — Z capped at
        1, pure fuel); a nozzle's faces blow at ``jet_m_s``, the fuel's own speed."""
        ops, s = self.ops, self.settings
        for source, distance, volume_m3 in zip(
            s.sources, self.sources, self.source_m3, strict=True
        ):
            if not self._active(source, state.time_s):
                continue
            inside = ops.select(distance < 0.0, 1.0, 0.0)
            rate = source.fuel_kg_s / (air_density_kg_m3(s.t_air_K) * volume_m3)
            mixture = ops.minimum(mixture + inside * (rate * step), 1.0)
            if source.kind == "nozzle":
                velocity = self._jet(velocity, distance, source.jet_m_s / self.h, state.steps)
        return mixture, velocity

    def flame_temperature(self, mixture):
        """The temperature (K) of gas of mixture fraction Z under fast chemistry (Burke &
        Schumann 1928: fuel and oxygen cannot coexist; the flame sheet is at Z_st), with the
        radiant fraction χ_r of the heat lost: T = T_air + (1 − χ_r)(T_ad − T_air)·ψ(Z),
        ψ = Z/Z_st on the lean side and (1 − Z)/(1 − Z_st) on the rich side; T_ad = ``t_max_K``.
        On the lean side this is T_air + (1 − χ_r) Z ΔH_c/c_p: the heat of the fuel burnt in the
        cell, since T_ad − T_air = Z_st ΔH_c/c_p. The state relation of FDS 5's mixture-fraction
        model (McGrattan et al. 2007, FDS 5 Technical Reference Guide, NIST SP 1018-5, §5.1).
        With ``state_relation = "equilibrium"``, T_air + (1 − χ_r)(T_eq(Z) − T_air) instead, T_eq
        the fuel–air mixture's at chemical equilibrium (``state_relation``'s tables)."""
        s, ops = self.settings, self.ops
        if self.state_table is not None:
            equilibrium = interpolate(ops, self.state_table, mixture)
            return s.t_air_K + (1.0 - s.radiant_fraction) * (equilibrium - s.t_air_K)
        z_st = s.stoichiometric_mixture
        psi = ops.maximum(ops.minimum(mixture / z_st, (1.0 - mixture) / (1.0 - z_st)), 0.0)
        return s.t_air_K + (1.0 - s.radiant_fraction) * (s.t_max_K - s.t_air_K) * psi

    def sheet_distance(self, mixture):
        """φ for a diffusion flame: the distance in cells to the flame sheet Z = Z_st,
        (Z_st − Z)/|∇Z| to first order (< 0 on the fuel side), within ±PHI_LIMIT — where the
        frames put the reaction zone's CH* and C₂*."""
        ops, z_st = self.ops, self.settings.stoichiometric_mixture
        field = self.cell_field(mixture)
        grad = [central(ops, field, a).values for a in range(3)]
        length = ops.sqrt(grad[0] ** 2 + grad[1] ** 2 + grad[2] ** 2) + 1e-6
        return ops.clip((z_st - mixture) / length, -PHI_LIMIT, PHI_LIMIT)

    def _active(self, source, time_s: float) -> bool:
        return time_s >= source.start_s and (source.stop_s is None or time_s < source.stop_s)

    def _advect_velocity(self, u: StaggeredField, axis: int, step):
        """Face component ``axis`` advected; air entering through an open side *parallel* to it
        brings the far field's velocity along it (still air: 0; the wind along x), while the
        component normal to a side keeps its edge value (``_entrainment`` damps it; a wind's
        inflow faces are held at the wind by ``project``). With the edge value extended
        for every component, a flow started in a box with open sides and no force gained 3–4×
        its kinetic energy in 200 steps (tested: ``test_open_sides_inject_no_energy``)."""
        tangential = [side and index // 2 != axis for index, side in enumerate(self.open_sides)]
        return advect(
            self.ops,
            u[axis],
            u,
            step,
            maccormack=self.settings.maccormack,
            open_sides=self.open_sides,
            points=self.face_points[axis],
            ambient=self.wind if axis == 0 else 0.0,
            ambient_sides=tangential,
            points_on=self.face[axis],
        ).values

    def _mix(self, u: StaggeredField, *fields, step, centre=None, strain=None):
        """Sub-grid turbulent mixing of heat and soot: ∂q/∂t = ∇·(D_t ∇q) with Smagorinsky's
        eddy viscosity ν_t = (C_s h)²|S| (Smagorinsky 1963, Mon. Weather Rev. 91:99) and
        D_t = ν_t/Pr_t — the closure of FDS's LES (McGrattan et al., FDS Technical Reference
        Guide, C_s = 0.2, Pr_t = Sc_t = 0.5). In cell units h = 1. Without it the hot products
        are diluted only by the eddies the grid resolves; at 64 cells across a pool fire the
        sub-grid term changes little (the centreline slope −0.22 with it, −0.23 without:
        ``docs/simulation.md``). ``centre``: u at the cell centres, if already evaluated;
        ``strain``: |S| there, if already computed. Returns the ``fields`` mixed, in order."""
        if self.settings.smagorinsky <= 0.0:
            return list(fields)
        diffusivity = self._eddy_diffusivity(u, centre, strain)
        mixed = (eddy_diffuse(self.ops, self.cell_field(q), diffusivity, step) for q in fields)
        return [q.values for q in mixed]

    def _eddy_diffusivity(self, u: StaggeredField, centre=None, strain=None) -> Field:
        """D_t = (C_s h)²|S|/Pr_t per cell (cells²/s; ``_mix``), evaluated; ``strain``: |S|
        if already computed."""
        s = self.settings
        strain = strain_rate(self.ops, u, centre) if strain is None else strain
        diffusivity = strain.like(strain.values * (s.smagorinsky**2 / s.turbulent_prandtl))
        self.ops.evaluate(diffusivity.values)
        return diffusivity

    def _entrainment(self, velocity, step):
        """Air drawn in through an open side starts from rest: between the far field (p = 0,
        half a cell out) and the side's face its static pressure falls by ½|u|² (Bernoulli), so
        the inflowing normal velocity u decelerates as du/dt = −u|u|/2 per cell (−u|u|/2h in m),
        integrated implicitly: u ← u / (1 + ½Δt|u|). Outflow is untouched. This is the
        total-pressure inflow condition that keeps an open boundary from feeding energy in
        (Bruneau & Fabrie 1996, M2AN 30:815; Dong, Karniadakis & Chryssostomidis 2014, J. Comput.
        Phys. 261:83): with p = 0 alone, inflow carried kinetic energy in unchecked."""
        ops, out = self.ops, []
        for a in range(3):
            u, sign = velocity[a], self.inflow_sign[a]
            slowed = u / (1.0 + 0.5 * step * ops.sqrt(u * u))
            out.append(ops.select(sign * u > 0.0, slowed, u))
        return out

    def _front_velocity(self, phi: Field, u: StaggeredField, centre: list) -> list:
        """The velocity each cell's φ is carried by: the centre's, except within PHI_NEAR of the
        front, where it is taken FUEL_SIDE_CELLS into the fuel along −∇φ (Nguyen eq. 3: the
        front moves with the *fuel's* velocity plus S·n; the smeared velocity across the front
        would carry it with the expanding products). Those cells (2–9 % of the explosion's at
        128³, none once its fuel is burnt) are sampled alone, after ``compress``, and written
        into a copy of ``centre``: sampling every cell there cost 16 ms a step at 128³."""
        ops = self.ops
        values = phi.values
        near = ops.compress((values >= -PHI_NEAR) & (values <= PHI_NEAR))
        if ops.width(near) == 0:
            return centre
        at = indices(ops, self.cell, near)
        grad = [central_at(ops, phi, a, at) for a in range(3)]
        length = ops.sqrt(grad[0] ** 2 + grad[1] ** 2 + grad[2] ** 2) + 1e-12
        points = [ops.to_float(at[a]) + 0.5 - FUEL_SIDE_CELLS * grad[a] / length for a in range(3)]
        return [ops.scatter(centre[a], sample(ops, c.values, c.layout, points), near)
                for a, c in enumerate(u)]  # fmt: skip

    def _sources(self, phi, velocity, state: FireState):
        ops, s = self.ops, self.settings
        for source, distance in zip(s.sources, self.sources, strict=True):
            if not self._active(source, state.time_s):
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

    def _buoyancy(self, temperature, soot):
        """Upward acceleration (m/s²): the Boussinesq approximation with the ambient air's
        density ρ_air as the inertia of every parcel and the ideal gas's density unlinearised,
        a = g(ρ_air − ρ)/ρ_air − g c/ρ_air = g(1 − T_air/T) − g c/ρ_air, where c = soot·κ₁/σ_m is
        soot's mass per volume (kg/m³; κ₁ = ``soot_kappa_per_m`` of unit soot, σ_m its mass
        extinction coefficient, 8.7 m²/g: Mulholland & Croarkin 2000, Fire Mater. 24:227).

        Why ρ_air: the solver gives every parcel one density, and a rising parcel of hot gas
        must push aside cold air, whose inertia dominates; dividing by the parcel's own density
        instead, g(T − T_air)/T_air, drove 2000 K gas at 5.7 g and the campfire's plume at
        13–15 m/s (a real one moves at a few m/s: McCaffrey 1979's 1.9 Q^(1/5) m/s)."""
        s = self.settings
        soot_kg_m3 = soot * (s.soot_kappa_per_m / s.soot_mass_extinction_m2_kg)
        heavy = s.gravity_m_s2 / air_density_kg_m3(s.t_air_K)
        return s.gravity_m_s2 * (1.0 - s.t_air_K / temperature) - heavy * soot_kg_m3

    def inertia(self, temperature) -> list[Array] | None:
        """β = ρ_air/ρ = T/T_air on every face (T the mean of the two cells either side: the
        ideal gas's 1/ρ averaged), for ``density = "ideal_gas"``; None for "boussinesq"."""
        if self.settings.density == "boussinesq":
            return None
        field = self.cell_field(temperature / self.settings.t_air_K)
        return [cell_value_at_faces(self.ops, field, a).values for a in range(3)]

    def _lift(self, temperature, soot, inertia):
        """The upward acceleration (m/s²) on the vertical faces: ``_buoyancy`` at the cells,
        then averaged; with the ideal gas's inertia (β on the faces) the force per mass of gas
        of its own density, g(ρ_air − ρ)/ρ − g c/ρ = β(g(1 − T_air/T) − g c/ρ_air) with β = T/T_air
        (the low-Mach momentum equation, ρ Du/Dt = −∇p′ + (ρ − ρ_air) g; Rehm & Baum 1978,
        J. Res. NBS 83:297)."""
        at_faces = cell_value_at_faces(
            self.ops, self.cell_field(self._buoyancy(temperature, soot)), 1
        ).values
        return at_faces if inertia is None else at_faces * inertia[1]

    def _forces(self, velocity, temperature, soot, dt, inertia=None):
        s = self.settings
        velocity = list(velocity)
        at_faces = self._lift(temperature, soot, inertia)
        velocity[1] = velocity[1] + dt * (1.0 / self.h) * at_faces
        if s.vorticity > 0:
            confinement = vorticity_confinement(
                self.ops, self.velocity_field(velocity), s.vorticity
            )
            for a in range(3):
                velocity[a] = (
                    velocity[a] + dt * cell_value_at_faces(self.ops, confinement[a], a).values
                )
        return velocity

    def project(
        self,
        velocity: Sequence[Array],
        target: Array | float,
        guess: Array | None = None,
        inertia: Sequence[Array] | None = None,
    ):
        """(velocity, pressure, report): the face velocities (cells/s) made to ∇·u = ``target``
        (1/s per cell) in the fluid, solid faces closed: u ← u − β∇p with −∇·(β∇p) = D − ∇·u
        (Fedkiw et al. 2001 eq. 4–5; Nguyen et al. 2002 §4.2 with the front's expansion in D);
        ``guess``: the pressure to start the solve from (the last step's); ``inertia``: β =
        ρ_air/ρ on each face (the variable-density projection, ``density = "ideal_gas"``;
        None: β = 1, every parcel with the air's inertia)."""
        ops = self.ops
        velocity = self._blow([velocity[a] * self.face_open[a] for a in range(3)])
        rhs = (target - self._divergence(velocity)) * self.fluid
        operator = scale = weights = None
        if inertia is not None:
            weights = [w * m for w, m in zip(inertia, self.solved_faces, strict=True)]
            operator, scale = self._weighted_operator(weights)
        p, solve = pressure.solve(
            ops, self.levels, rhs, self.settings.pressure_tolerance, guess=guess,
            operator=operator, scale_cells=scale, exact=self.exact,
        )  # fmt: skip
        p_field = self.cell_field(p)
        push = [gradient(ops, p_field, a).values for a in range(3)]
        if weights is not None:
            push = [g * w for g, w in zip(push, weights, strict=True)]
        velocity = self._blow([(velocity[a] - push[a]) * self.face_open[a] for a in range(3)])
        residual = (self._divergence(velocity) - target) * self.fluid
        report = StepReport(0.0, solve.iterations, solve.relative_residual, ops.max_abs(residual))
        return velocity, p, report

    def _weighted_operator(self, weights: Sequence[Array]):
        """(x ↦ −∇·(β∇x), s): the variable-density operator and its preconditioner's scaling
        s = √(d/d_β), d the constant operator's diagonal and d_β = Σ of a cell's face weights."""
        ops = self.ops
        faces = self.velocity_field(weights)
        diagonal = sum(2.0 * face_mean(ops, faces[a], a).values for a in range(3))
        constant = pressure.diagonal(ops, self.levels[0])
        scale = ops.select(self.fluid > 0.0, ops.sqrt(constant / ops.maximum(diagonal, 1e-30)), 1.0)
        ops.evaluate(scale)
        return (lambda x: self._weighted_laplacian(x, weights)), scale

    def _weighted_laplacian(self, x, weights: Sequence[Array]):
        """−∇·(β∇x) on the cells, β the face ``weights`` (0 on faces no flow crosses, x = 0
        beyond an open side), and x itself on solid cells (no unknowns): the constant-coefficient
        ``pressure.apply`` when every weight is 1 (tested)."""
        field = self.cell_field(x)
        flux = [gradient(self.ops, field, a).values * weights[a] for a in range(3)]
        return (1.0 - self.fluid) * x - self._divergence(flux)

    def _divergence(self, velocity: Sequence[Array]) -> Array:
        return divergence(self.ops, self.velocity_field(velocity)).values

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
        return temperature, self._soot(temperature, phi >= 0.0, soot, dt, step)

    def _soot(self, temperature, burnt, soot, dt: float, step):
        """Soot made at ``soot_rate_per_s`` where gas is hotter than ``soot_min_K`` on the side
        ``burnt`` (the products of the premixed front; the fuel-rich side of a diffusion
        flame, where soot forms), oxidised at ``soot_decay_per_s`` everywhere."""
        ops, s = self.ops, self.settings
        sooting = (temperature > s.soot_min_K) & burnt
        soot = soot + ops.select(sooting, step * s.soot_rate_per_s, 0.0)
        return ops.maximum(soot * ops.scalar(math.exp(-s.soot_decay_per_s * dt)), 0.0)


#: Random plane waves summed for a sphere source's ripples, and their wavelengths in radii.
RIPPLE_WAVES, RIPPLE_WAVELENGTHS = 8, (0.5, 1.5)


def _ripples(x, y, z, radius_m: float, seed: int) -> np.ndarray:
    """A smooth seeded field of unit RMS: ``RIPPLE_WAVES`` plane waves of random directions,
    wavelengths 0.5–1.5 radii and phases (positions x, y, z in m)."""
    rng = np.random.default_rng(seed)
    total = np.zeros_like(x)
    for _ in range(RIPPLE_WAVES):
        direction = rng.normal(size=3)
        k = (
            direction
            / np.linalg.norm(direction)
            * 2
            * np.pi
            / (radius_m * rng.uniform(*RIPPLE_WAVELENGTHS))
        )
        total += np.sin(k[0] * x + k[1] * y + k[2] * z + rng.uniform(0, 2 * np.pi))
    return total * np.sqrt(2.0 / RIPPLE_WAVES)
