"""Typed fields of the fire solver: a backend array together with the MAC layout it lives on.

A :class:`Field` is one flat array (C order of ``layout.shape``, z fastest; see ``grid``) and
the layout that says where its samples sit: cell centres for scalars, the faces normal to one
axis for a velocity component. A :class:`StaggeredField` is the three face components of a
velocity. The solver works in *cell units*: lengths in cells, velocities in cells/s (m/s ÷ h),
accelerations in cells/s², temperatures in K, φ in cells, soot in unit density. The operators
(``operators``) take and return these, so a cell-centred value can never be read as a face one.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from incandescent.simulation.arrays import Array
from incandescent.simulation.grid import Layout, cells, faces


@dataclass(frozen=True)
class Field:
    """``values`` (a backend array, ``layout.size`` long) sampled where ``layout`` says; the
    unit is the quantity's own (K, cells, cells/s …), given where a field is made."""

    values: Array
    layout: Layout

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.layout.shape

    def like(self, values: Array) -> Field:
        """Other values on the same layout."""
        return Field(values, self.layout)


@dataclass(frozen=True)
class StaggeredField:
    """A MAC velocity (cells/s): component a on the faces normal to axis a (Harlow & Welch
    1965), on a grid of ``shape`` cells."""

    x: Field
    y: Field
    z: Field

    @classmethod
    def on(cls, shape: Sequence[int], values: Sequence[Array]) -> StaggeredField:
        """The three face components ``values`` of a grid of ``shape`` cells."""
        x, y, z = (Field(values[a], faces(shape, a)) for a in range(3))
        return cls(x, y, z)

    def __getitem__(self, axis: int) -> Field:
        return (self.x, self.y, self.z)[axis]

    def __iter__(self) -> Iterator[Field]:
        return iter((self.x, self.y, self.z))

    @property
    def shape(self) -> tuple[int, int, int]:
        """The grid's cells along x, y, z (each component has one more sample along its axis)."""
        nx, ny, nz = self.x.layout.shape
        return nx - 1, ny, nz

    @property
    def cells(self) -> Layout:
        """The layout of the grid's cell centres."""
        return cells(self.shape)

    @property
    def values(self) -> list[Array]:
        """The components' arrays, x, y, z."""
        return [c.values for c in self]
