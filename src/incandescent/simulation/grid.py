"""The staggered (MAC) grid of the fire solver: cell-centred scalars, face-centred velocities.

Cells are cubes of side h (m); cell (i, j, k) spans [i, i+1] × [j, j+1] × [k, k+1] in *cell units*,
+y up. Scalars (φ, T, soot) live at cell centres (i + ½, j + ½, k + ½); the velocity component
along axis a lives on the faces normal to a (u on x-faces at (i, j + ½, k + ½), …), so the
divergence of a cell and the pressure gradient across a face are exact centred differences and
the projection has no odd–even decoupling (why MAC rather than collocated: Harlow & Welch 1965;
Fedkiw, Stam & Jensen 2001 and Nguyen, Fedkiw & Jensen 2002 use it too). Velocities are stored in
cells per second inside the solver.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Where the sample of index (i, j, k) sits, in cell units, for cell-centred fields and for the
#: faces normal to x, y and z.
CENTRE = (0.5, 0.5, 0.5)
FACE_OFFSETS = ((0.0, 0.5, 0.5), (0.5, 0.0, 0.5), (0.5, 0.5, 0.0))


@dataclass(frozen=True)
class Layout:
    """A field's shape and where its samples sit (``offset``, cell units)."""

    shape: tuple[int, int, int]
    offset: tuple[float, float, float]

    @property
    def size(self) -> int:
        nx, ny, nz = self.shape
        return nx * ny * nz


def cells(shape) -> Layout:
    return Layout(tuple(shape), CENTRE)  # type: ignore[arg-type]


def faces(shape, axis: int) -> Layout:
    grown = tuple(n + (a == axis) for a, n in enumerate(shape))
    return Layout(grown, FACE_OFFSETS[axis])  # type: ignore[arg-type]


def indices(ops, layout: Layout, flat=None):
    """(i, j, k) integer arrays of every sample of ``layout``, C order (z fastest), or of the
    samples whose flat indices are ``flat``."""
    _, ny, nz = layout.shape
    flat = ops.arange(layout.size) if flat is None else flat
    return flat // (ny * nz), (flat // nz) % ny, flat % nz


def flat_index(layout: Layout, i, j, k):
    _, ny, nz = layout.shape
    return (i * ny + j) * nz + k


def positions(ops, layout: Layout):
    """Cell-unit positions of every sample of ``layout``."""
    return tuple(
        ops.to_float(n) + o for n, o in zip(indices(ops, layout), layout.offset, strict=True)
    )


def _corner(ops, layout: Layout, p, axis: int):
    """Lower neighbour index and weight along ``axis`` of positions p (clamped to the samples:
    outside them a field is extended by its edge value)."""
    n = layout.shape[axis]
    local = p - layout.offset[axis]
    if n == 1:
        return ops.floor_int(local * 0.0), local * 0.0
    i0 = ops.clip(ops.floor_int(local), 0, n - 2)
    return i0, ops.clip(local - ops.to_float(i0), 0.0, 1.0)


def sample(ops, field, layout: Layout, p, with_range: bool = False):
    """Trilinear value of ``field`` at positions p = (x, y, z) in cell units; with ``with_range``
    also the min and max of the 8 values interpolated (MacCormack's limiter, Selle et al. 2008)."""
    (i0, fx), (j0, fy), (k0, fz) = (_corner(ops, layout, p[a], a) for a in range(3))
    nx, ny, nz = layout.shape
    di, dj, dk = (1 if nx > 1 else 0), (1 if ny > 1 else 0), (1 if nz > 1 else 0)
    values = {}
    for a in (0, 1):
        for b in (0, 1):
            for c in (0, 1):
                index = flat_index(layout, i0 + a * di, j0 + b * dj, k0 + c * dk)
                values[a, b, c] = ops.gather(field, index)

    def lerp(lo, hi, t):
        return lo + (hi - lo) * t

    c00 = lerp(values[0, 0, 0], values[1, 0, 0], fx)
    c10 = lerp(values[0, 1, 0], values[1, 1, 0], fx)
    c01 = lerp(values[0, 0, 1], values[1, 0, 1], fx)
    c11 = lerp(values[0, 1, 1], values[1, 1, 1], fx)
    out = lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz)
    if not with_range:
        return out
    corners = list(values.values())
    low, high = corners[0], corners[0]
    for v in corners[1:]:
        low, high = ops.minimum(low, v), ops.maximum(high, v)
    return out, low, high


def sample_aligned(ops, field, layout: Layout, at: Layout):
    """:func:`sample` of ``field`` at every sample of ``at``, whose samples sit on
    ``layout``'s or halfway between two of them along each axis (a face component at another
    component's faces or at the cell centres): the mean of the 1, 2, 4 or 8 values around,
    indices clamped (the edge value extended, as :func:`sample`). Equal to the trilinear sample
    up to rounding; it gathers only the values with a weight and computes no weights (at 128³
    the velocity's samples at the faces cost half as much, at the centres a third)."""
    ijk = indices(ops, at)
    spans = [_span(ops, ijk[a], layout.shape[a], at.shape[a], at.offset[a] - layout.offset[a])
             for a in range(3)]  # fmt: skip
    values = [ops.gather(field, flat_index(layout, i, j, k))
              for i in spans[0] for j in spans[1] for k in spans[2]]  # fmt: skip
    total = values[0]
    for value in values[1:]:
        total = total + value
    return total if len(values) == 1 else total * (1.0 / len(values))


def _span(ops, index, n: int, points: int, shift: float) -> list:
    """The indices along one axis that a point ``shift`` cells from sample ``index`` lies
    between (one when it sits on a sample), clamped to [0, n − 1] where they could leave it."""
    if n == 1:
        return [index * 0]
    steps: tuple[int, ...] = (0,)
    if abs(shift) == 0.5:
        steps = (0, 1) if shift > 0 else (-1, 0)
    elif shift != 0.0:
        raise ValueError(f"a shift of {shift} cells is not on or halfway between samples")
    out = []
    for step in steps:
        moved = index + step if step else index
        out.append(moved if 0 <= step and points - 1 + step <= n - 1 else ops.clip(moved, 0, n - 1))
    return out


def neighbour(ops, layout: Layout, i, j, k, axis: int, step: int):
    """(flat index clamped into the field, inside?) of the sample ``step`` along ``axis``."""
    ijk = [i, j, k]
    moved = ijk[axis] + step
    n = layout.shape[axis]
    inside = (moved >= 0) & (moved < n)
    ijk[axis] = ops.clip(moved, 0, n - 1)
    return flat_index(layout, *ijk), inside
