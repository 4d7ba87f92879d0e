"""The fire solver's discrete operators on the MAC grid, as free functions of ``(ops, field…)``.

Each takes the backend's :class:`~incandescent.simulation.arrays.Ops` and typed fields
(``fields``) and returns a :class:`~incandescent.simulation.fields.Field` on the layout it
lives on; nothing here knows the solver (as PhiFlow's ``phi.field`` operators and Taichi's
per-stage kernels keep the numerics apart from the time stepper). Unit spacing: derivatives are
per cell; a velocity in cells/s gives a divergence in 1/s. On the staggered grid the divergence
of a cell and the gradient across a face are exact centred differences (Harlow & Welch 1965;
Fedkiw, Stam & Jensen 2001 §3), so the projection built from them has no odd–even decoupling.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from incandescent.simulation.arrays import Array, Ops
from incandescent.simulation.fields import Field, StaggeredField
from incandescent.simulation.grid import (
    Layout,
    cells,
    faces,
    flat_index,
    indices,
    neighbour,
    positions,
    sample,
    sample_aligned,
)


def divergence(ops: Ops, velocity: StaggeredField) -> Field:
    """(∇·u)_c = Σ_a (u_a above − u_a below), per cell (1/s for u in cells/s)."""
    layout = velocity.cells
    i, j, k = indices(ops, layout)
    total = None
    for a, component in enumerate(velocity):
        ijk = [i, j, k]
        below = ops.gather(component.values, flat_index(component.layout, *ijk))
        ijk[a] = ijk[a] + 1
        above = ops.gather(component.values, flat_index(component.layout, *ijk))
        total = above - below if total is None else total + above - below
    return Field(total, layout)


def gradient(ops: Ops, p: Field, axis: int) -> Field:
    """(∇p)_a = p above − p below across each face normal to ``axis``; p = 0 outside the domain
    (the open sides' Dirichlet value; solid faces are masked by the caller)."""
    layout = faces(p.shape, axis)
    low, high = _face_neighbours(ops, layout, axis)
    n = p.shape[axis]
    values = []
    for cell_ijk in (low, high):
        inside = (cell_ijk[axis] >= 0) & (cell_ijk[axis] < n)
        clamped = list(cell_ijk)
        clamped[axis] = ops.clip(cell_ijk[axis], 0, n - 1)
        value = ops.gather(p.values, flat_index(p.layout, *clamped))
        values.append(ops.select(inside, value, 0.0))
    return Field(values[1] - values[0], layout)


def _face_neighbours(ops: Ops, layout, axis: int) -> tuple[list[Array], list[Array]]:
    """The (i, j, k) of the cells below and above each face of ``layout`` (normal to ``axis``),
    unclamped: the first and last faces have one outside the domain."""
    i, j, k = indices(ops, layout)
    low = [i, j, k]
    low[axis] = low[axis] - 1
    return low, [i, j, k]


def cell_value_at_faces(ops: Ops, q: Field, axis: int) -> Field:
    """A cell-centred ``q`` on the faces normal to ``axis``: the mean of the two cells either
    side (the edge cell repeated at the domain's boundary)."""
    layout = faces(q.shape, axis)
    low, high = _face_neighbours(ops, layout, axis)
    n = q.shape[axis]
    low[axis] = ops.clip(low[axis], 0, n - 1)
    high[axis] = ops.clip(high[axis], 0, n - 1)
    below = ops.gather(q.values, flat_index(q.layout, *low))
    above = ops.gather(q.values, flat_index(q.layout, *high))
    return Field(0.5 * (below + above), layout)


def face_mean(ops: Ops, component: Field, axis: int) -> Field:
    """A face component (normal to ``axis``) at the cell centres: the mean of a cell's two faces."""
    shape = list(component.shape)
    shape[axis] -= 1
    layout = cells(shape)
    return Field(sample_aligned(ops, component.values, component.layout, layout), layout)


def central(ops: Ops, q: Field, axis: int) -> Field:
    """∂q/∂axis at the cell centres, per cell: (q₊ − q₋)/2 inside, one-sided (q₊ − q) or
    (q − q₋) at the domain's edges."""
    return q.like(central_at(ops, q, axis, indices(ops, q.layout)))


def central_at(ops: Ops, q: Field, axis: int, at) -> Array:
    """:func:`central`'s ∂q/∂axis at the cells ``at`` = (i, j, k) only (an array of theirs)."""
    i, j, k = at
    up, up_in = neighbour(ops, q.layout, i, j, k, axis, 1)
    down, down_in = neighbour(ops, q.layout, i, j, k, axis, -1)
    span = ops.select(up_in, 1.0, 0.0) + ops.select(down_in, 1.0, 0.0)
    return (ops.gather(q.values, up) - ops.gather(q.values, down)) / ops.maximum(span, 1.0)


def _velocity_gradient(ops: Ops, velocity: StaggeredField, centres=None) -> list[list[Array]]:
    """∂u_c/∂a at the cell centres ([c][a]): central differences of the face means, stored
    first (``centres``, or evaluated here) so that each difference gathers 2 values, not the 4
    faces around them (at 128³ a strain-rate kernel took 18 ms with them inline)."""
    if centres is None:
        centres = [face_mean(ops, component, a).values for a, component in enumerate(velocity)]
        ops.evaluate(*centres)
    fields = [Field(c, velocity.cells) for c in centres]
    return [[central(ops, fields[c], a).values for a in range(3)] for c in range(3)]


def vorticity(ops: Ops, velocity: StaggeredField) -> tuple[Field, Field, Field]:
    """ω = ∇ × u at the cell centres (1/s), from the face means and central differences."""
    d = _velocity_gradient(ops, velocity)
    layout = velocity.cells
    return (
        Field(d[2][1] - d[1][2], layout),
        Field(d[0][2] - d[2][0], layout),
        Field(d[1][0] - d[0][1], layout),
    )


def vorticity_confinement(
    ops: Ops, velocity: StaggeredField, epsilon: float
) -> tuple[Field, Field, Field]:
    """f = ε (N × ω) per cell, cells/s² (Fedkiw, Stam & Jensen 2001 eq. 11 with h = 1 cell):
    N = ∇|ω| / |∇|ω|| points towards the vortex cores and f spins them up."""
    omega = [w.values for w in vorticity(ops, velocity)]
    magnitude = Field(ops.sqrt(omega[0] ** 2 + omega[1] ** 2 + omega[2] ** 2), velocity.cells)
    ops.evaluate(*omega, magnitude.values)  # one kernel; else each reader gathers ω again
    grad = [central(ops, magnitude, a).values for a in range(3)]
    length = ops.sqrt(grad[0] ** 2 + grad[1] ** 2 + grad[2] ** 2) + 1e-12
    n = [g / length for g in grad]
    force = (
        epsilon * (n[1] * omega[2] - n[2] * omega[1]),
        epsilon * (n[2] * omega[0] - n[0] * omega[2]),
        epsilon * (n[0] * omega[1] - n[1] * omega[0]),
    )
    ops.evaluate(*force)  # the three share ∇|ω|'s gathers
    return magnitude.like(force[0]), magnitude.like(force[1]), magnitude.like(force[2])


def advect(
    ops: Ops,
    q: Field,
    velocity: StaggeredField,
    dt: Array | float,
    *,
    maccormack: bool = True,
    open_sides: Sequence[bool] = (False,) * 6,
    points: Sequence[Array] | None = None,
    ambient: float | None = None,
    ambient_sides: Sequence[bool] | None = None,
    points_on: Layout | None = None,
    velocity_at: Sequence[Array] | None = None,
) -> Field:
    """``q`` carried by ``velocity`` (cells/s) over ``dt`` (s): semi-Lagrangian (Stam 1999:
    q(x − u(x)Δt), trilinear), MacCormack-corrected if ``maccormack`` (Selle et al. 2008: the
    forward value plus half the error of tracing it back, clamped to the 8 values it was
    interpolated from). ``points``: the samples' positions (cells; default: ``q``'s layout's,
    which is then ``points_on``); ``ambient``: the
    value of air that flows in through an open side (x−, x+, y−, y+, z−, z+ in ``open_sides``,
    or only those of ``ambient_sides``; default: the edge value extended). The correction needs
    the forward trace inside the domain: where it leaves (gas flowing out of an open side), the
    semi-Lagrangian value stays — else the clamped return sample holds the outflow back — and so
    it does where ambient air flows in. ``points_on``: the layout whose samples ``points`` are
    (faces or centres), so the velocity there is read (the component on that layout) or the
    mean of the faces around (``grid.sample_aligned``), not a general trilinear sample;
    ``velocity_at``: the velocity (x, y, z) each point takes, already sampled (e.g. the fuel
    side's, ``FireSolver._front_velocity``)."""
    (out,) = advect_together(ops, [q], velocity, dt, maccormack=maccormack, open_sides=open_sides,
                             points=points, ambients=[ambient], ambient_sides=ambient_sides,
                             points_on=points_on, velocity_at=velocity_at)  # fmt: skip
    return out


def advect_together(
    ops: Ops,
    fields: Sequence[Field],
    velocity: StaggeredField,
    dt: Array | float,
    *,
    maccormack: bool = True,
    open_sides: Sequence[bool] = (False,) * 6,
    points: Sequence[Array] | None = None,
    ambients: Sequence[float | None] | None = None,
    ambient_sides: Sequence[bool] | None = None,
    points_on: Layout | None = None,
    velocity_at: Sequence[Array] | None = None,
) -> list[Field]:
    """:func:`advect` of several fields on one layout along the same paths (each with its own
    ambient value): the velocity at the points is sampled once and the fields' trilinear
    samples share one kernel's indices and weights."""
    layout = fields[0].layout
    ambients = [None] * len(fields) if ambients is None else list(ambients)
    if points is None:
        points, points_on = positions(ops, layout), layout
    v = _velocity_at(ops, velocity, points, points_on) if velocity_at is None else list(velocity_at)
    ops.evaluate(*v)  # stored: else each kernel reading it gathers it again (24 gathers)
    back = [points[a] - v[a] * dt for a in range(3)]
    sides = open_sides if ambient_sides is None else ambient_sides
    air_in = outside(back, velocity.shape, sides)
    entering = [None if a is None else air_in for a in ambients]
    if not maccormack:
        return [q.like(_where(ops, e, a, sample(ops, q.values, layout, back)))
                for q, e, a in zip(fields, entering, ambients, strict=True)]  # fmt: skip
    traced = []
    for q, e, a in zip(fields, entering, ambients, strict=True):
        forward, low, high = sample(ops, q.values, layout, back, with_range=True)
        traced.append((_where(ops, e, a, forward), low, high))
    ops.evaluate(*(x for t in traced for x in t))  # one kernel shares their gathers' indices
    ahead = [points[a] + v[a] * dt for a in range(3)]
    leaving = outside(ahead, velocity.shape, open_sides)
    triples = zip(fields, traced, entering, strict=True)
    out = [_corrected(ops, q, t, ahead, leaving, e) for q, t, e in triples]
    ops.evaluate(*out)  # now: the stored intermediates are freed
    return [q.like(c) for q, c in zip(fields, out, strict=True)]


def _velocity_at(ops: Ops, velocity: StaggeredField, points, points_on: Layout | None):
    """The three components at ``points``: where they are ``points_on``'s samples, read (the
    component on that layout) or averaged (``grid.sample_aligned``); else trilinear."""
    if points_on is None:
        return [sample(ops, c.values, c.layout, points) for c in velocity]
    return [c.values if c.layout == points_on else sample_aligned(ops, c.values, c.layout,
            points_on) for c in velocity]  # fmt: skip


def _corrected(ops: Ops, q: Field, traced, ahead, leaving, entering):
    """MacCormack's value from the forward trace (value, low, high): kept semi-Lagrangian where
    the trace forward leaves through an open side or ambient air came in."""
    forward, low, high = traced
    returned = sample(ops, forward, q.layout, ahead)
    corrected = ops.clip(forward + 0.5 * (q.values - returned), low, high)
    if leaving is None:
        return corrected
    keep = leaving if entering is None else leaving | entering
    return ops.select(keep, forward, corrected)


def outside(p: Sequence[Array], shape: Sequence[int], open_sides: Sequence[bool]) -> Array | None:
    """Positions p (cells) beyond an open side of a ``shape``-cell domain (air, not a wall or the
    floor); None where no side is open."""
    out = None
    for axis in range(3):
        for side in (0, 1):
            if not open_sides[2 * axis + side]:
                continue
            beyond = p[axis] < 0.0 if side == 0 else p[axis] > float(shape[axis])
            out = beyond if out is None else out | beyond
    return out


def _where(ops: Ops, mask: Array | None, value: float | None, otherwise: Array) -> Array:
    """``value`` where ``mask`` (None: nowhere), else ``otherwise``."""
    return otherwise if mask is None else ops.select(mask, value, otherwise)


def strain_rate(ops: Ops, velocity: StaggeredField, centres=None) -> Field:
    """|S| = √(2 S_ij S_ij) at the cell centres (1/s for u in cells/s), S_ij = ½(∂u_i/∂x_j +
    ∂u_j/∂x_i) from the face means and central differences: the resolved strain that sets
    Smagorinsky's eddy viscosity (``eddy_diffuse``). ``centres``: the face means if already
    evaluated."""
    d = _velocity_gradient(ops, velocity, centres)
    total = None
    for c in range(3):
        for a in range(3):
            s = 0.5 * (d[c][a] + d[a][c])
            total = 2.0 * s * s if total is None else total + 2.0 * s * s
    return Field(ops.sqrt(total), velocity.cells)


#: Largest diffusion number D·Δt per cell² of one explicit step (3-D FTCS is stable to 1/6).
STABLE_DIFFUSION = 1.0 / 6.0


def eddy_diffuse(ops: Ops, q: Field, diffusivity: Field, dt: Array | float) -> Field:
    """One explicit step of ∂q/∂t = ∇·(D ∇q) with a per-cell diffusivity D (cells²/s), the
    face's D the mean of its two cells, no flux through the domain's sides (the ambient's
    exchange is by advection). D·Δt is capped at ``STABLE_DIFFUSION`` per cell (FTCS's stability
    bound; where the strain is so high that it binds, one step mixes less than D asks): each
    value becomes a convex combination of itself and its neighbours, so mixing never makes new
    extremes."""
    return q.like(q.values + eddy_exchange(ops, q, diffusivity, dt))


def eddy_exchange(
    ops: Ops, q: Field, diffusivity: Field, dt: Array | float, weight: Array | None = None
) -> Array:
    """What each cell gains in one explicit step of ∂(wq)/∂t = ∇·(w D ∇q) (``eddy_diffuse``'s
    step with a weight w, e.g. the density for a mass fraction q: the gain is then in w's
    units): each face passes w_f·D_f·Δt·(q_other − q), w_f the smaller of its two cells' w, so
    a cell's q moves by a convex combination of its neighbours' (w_f/w ≤ 1) and what one cell
    gives its neighbour gains. ``weight`` None: w = 1."""
    i, j, k = indices(ops, q.layout)
    rate = ops.minimum(diffusivity.values * dt, STABLE_DIFFUSION)
    total = None
    for axis in range(3):
        for step in (-1, 1):
            index, inside = neighbour(ops, q.layout, i, j, k, axis, step)
            other = ops.minimum(ops.gather(rate, index), STABLE_DIFFUSION)
            flux = 0.5 * (rate + other) * (ops.gather(q.values, index) - q.values)
            if weight is not None:
                flux = flux * ops.minimum(weight, ops.gather(weight, index))
            flux = ops.select(inside, flux, 0.0)
            total = flux if total is None else total + flux
    return total


#: The largest Σ_a |u_a|Δt (cells) of one forward-Euler step of :func:`advect_conservative`:
#: with MUSCL faces (the upwind value plus at most its own difference to the next cell) the
#: update is then a convex combination, so it makes no new extremes (Harten 1983, J. Comput.
#: Phys. 49:357, the TVD condition for a limited second-order flux, ν ≤ 1/(1 + ψ_max/2)).
CONSERVATIVE_COURANT = 0.5


def advect_conservative(
    ops: Ops,
    fields: Sequence[Field],
    velocity: StaggeredField,
    dt: float,
    *,
    ambients: Sequence[float],
    courant_cells: float,
) -> list[Field]:
    """Cell fields carried in flux form, ∂q/∂t + ∇·(u q) = 0, over ``dt`` (s): each face
    passes u·q_face, q_face the upwind cell's value plus half its van Leer-limited difference
    (MUSCL; van Leer 1979, J. Comput. Phys. 32:101), in forward-Euler sub-steps of at most
    ``CONSERVATIVE_COURANT`` cells (``courant_cells``: the step's Σ_a max|u_a|Δt). What a cell
    loses its neighbour gains, so Σq changes only by what crosses the domain's sides — exactly,
    where the semi-Lagrangian step (:func:`advect`) is not conservative: in a 0.5 m, 50 kW pool
    fire at 32 cells it made 2.3 g/s of fuel for the 1 g/s fed. Gas entering through a side
    (a wind's, entrainment, a nozzle's jet) carries ``ambients``; solid faces carry nothing
    (their velocity is 0)."""
    substeps = max(1, math.ceil(courant_cells / CONSERVATIVE_COURANT))
    values = [q.values for q in fields]
    for _ in range(substeps):
        fluxes = [_muscl_fluxes(ops, values, c, a, ambients) for a, c in enumerate(velocity)]
        values = _flux_update(ops, values, fluxes, fields[0].layout, dt / substeps)
        ops.evaluate(*values)
    return [q.like(v) for q, v in zip(fields, values, strict=True)]


def _muscl_fluxes(ops: Ops, values, component: Field, axis: int, ambients) -> list[Array]:
    """u·q_face on the faces normal to ``axis``, one array per field (cells/s × q)."""
    layout = component.layout
    cell_shape = list(layout.shape)
    cell_shape[axis] -= 1
    cell_layout = cells(cell_shape)
    i, j, k = indices(ops, layout)
    n = cell_shape[axis]
    u = component.values
    forward = u > 0.0
    out = []
    for q, ambient in zip(values, ambients, strict=True):
        # the cells below the face (near, far) and above it (next, beyond)
        near, far, next_, beyond = (
            _shifted(ops, q, cell_layout, (i, j, k), axis, s, n) for s in (-1, -2, 0, 1)
        )
        up = ops.select(forward, near[0], next_[0])
        upup = ops.select(forward, far[0], beyond[0])
        down = ops.select(forward, next_[0], near[0])
        up_in = ops.select(forward, near[1], next_[1])
        face = up + 0.5 * _van_leer(ops, up - upup, down - up)
        out.append(u * ops.select(up_in, face, ambient))
    return out


def _shifted(ops: Ops, q: Array, layout: Layout, ijk, axis: int, step: int, n: int):
    """(value, inside?) of the cell ``step`` along ``axis`` from each face's upper cell, the
    edge cell's value where that lies outside (the limiter then sees no slope)."""
    moved = list(ijk)
    moved[axis] = moved[axis] + step
    inside = (moved[axis] >= 0) & (moved[axis] < n)
    moved[axis] = ops.clip(moved[axis], 0, n - 1)
    return ops.gather(q, flat_index(layout, *moved)), inside


def _van_leer(ops: Ops, a: Array, b: Array) -> Array:
    """van Leer's limited difference 2ab/(a + b) where a and b share a sign, else 0."""
    same = a * b > 0.0
    return ops.select(same, 2.0 * a * b / ops.select(same, a + b, 1.0), 0.0)


def _flux_update(ops: Ops, values, fluxes, layout: Layout, dt: float) -> list[Array]:
    """q − Δt Σ_a (F above − F below) per cell (unit spacing): the divergence of the fluxes."""
    out = []
    for f, q in enumerate(values):
        flux = StaggeredField.on(layout.shape, [fluxes[a][f] for a in range(3)])
        out.append(q - dt * divergence(ops, flux).values)
    return out
