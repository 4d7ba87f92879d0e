"""Regenerate the small reference ``.vdb`` files in this folder with OpenVDB's own writer.

Run with Debian 12's system Python and its ``python3-openvdb`` package (OpenVDB 10.0)::

    apt-get install -y python3-openvdb && /usr/bin/python3 tests/data/make_reference_vdbs.py

These files are written by libopenvdb (not by tinyvdb, which the package reads them with), so the
tests cross-check the reader against the reference implementation. Every value is a formula of the
index coordinate (see ``pattern``) so the tests can recompute it. pyopenvdb writes with its
default compression (BLOSC + active mask where libopenvdb has Blosc, as Debian's does).

- ``openvdb_two_grids.vdb``: float grids ``temperature`` (active box i,j,k in [-3,1]×[5,10]×[10,16])
  and ``density`` (box [0,6]×[4,8]×[12,20]), voxel 0.25 m, translation (1, -2, 0.5) m, background
  0 and 7.5 (temperature).
- ``openvdb_half.vdb``: the same ``temperature`` grid saved as half float.
- ``openvdb_nonuniform.vdb``: a float grid with voxel size (0.1, 0.2, 0.1) (unsupported here).
- ``openvdb_rotated.vdb``: a float grid with a rotated (affine) transform (unsupported here).
- ``openvdb_types.vdb``: a BoolGrid ``mask``, a Vec3SGrid ``velocity``, FloatGrids ``density``
  (voxel 0.5 m), ``coarse`` (voxel 1 m) and ``empty`` (no active voxels).
- ``openvdb_tiles.vdb``: a FloatGrid ``tiles`` whose active region is stored as tiles.
- ``nanovdb_two_grids.nvdb``, ``nanovdb_fp16.nvdb``, ``nanovdb_blosc.nvdb``,
  ``nanovdb_rotated.nvdb``: ``openvdb_two_grids.vdb`` (and the rotated grid) converted by
  ``nanovdb_convert`` (Debian's ``libnanovdb-tools``): ZIP codec; ZIP with 16-bit quantisation;
  BLOSC codec; ZIP.
"""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pyopenvdb as vdb

HERE = Path(__file__).resolve().parent


def pattern(lo, hi):
    """i + 10 j + 12.5 k over [lo, hi] inclusive (exact in float32 and half for these boxes)."""
    i, j, k = np.meshgrid(
        *(np.arange(a, b + 1) for a, b in zip(lo, hi, strict=True)), indexing="ij"
    )
    return (i + 10.0 * j + 100.0 * k / 8.0).astype(np.float32)


def float_grid(name, lo, hi, transform, background=0.0):
    grid = vdb.FloatGrid(background)
    grid.copyFromArray(pattern(lo, hi), ijk=lo, tolerance=-1.0)
    grid.name = name
    grid.transform = transform
    return grid


def translated():
    matrix = [[0.25, 0, 0, 0], [0, 0.25, 0, 0], [0, 0, 0.25, 0], [1.0, -2.0, 0.5, 1]]
    return vdb.createLinearTransform(matrix)


def main():
    temperature = float_grid("temperature", (-3, 5, 10), (1, 10, 16), translated(), 7.5)
    density = float_grid("density", (0, 4, 12), (6, 8, 20), translated())
    vdb.write(str(HERE / "openvdb_two_grids.vdb"), [temperature, density])

    half = temperature.deepCopy()
    half.saveFloatAsHalf = True
    vdb.write(str(HERE / "openvdb_half.vdb"), [half])

    nonuniform = [[0.1, 0, 0, 0], [0, 0.2, 0, 0], [0, 0, 0.1, 0], [0, 0, 0, 1]]
    grid = float_grid("density", (0, 0, 0), (3, 3, 3), vdb.createLinearTransform(nonuniform))
    vdb.write(str(HERE / "openvdb_nonuniform.vdb"), [grid])

    c, s = math.cos(0.3), math.sin(0.3)
    rotated = [[0.1 * c, 0.1 * s, 0, 0], [-0.1 * s, 0.1 * c, 0, 0], [0, 0, 0.1, 0], [0, 0, 0, 1]]
    grid = float_grid("density", (0, 0, 0), (3, 3, 3), vdb.createLinearTransform(rotated))
    vdb.write(str(HERE / "openvdb_rotated.vdb"), [grid])

    mask = vdb.BoolGrid(False)
    mask.copyFromArray(np.ones((2, 2, 2), dtype=bool))
    mask.name = "mask"
    velocity = vdb.Vec3SGrid()
    velocity.copyFromArray(np.ones((2, 2, 2, 3), dtype=np.float32))
    velocity.name = "velocity"
    density = float_grid("density", (0, 0, 0), (1, 1, 1), vdb.createLinearTransform(0.5))
    coarse = float_grid("coarse", (0, 0, 0), (1, 1, 1), vdb.createLinearTransform(1.0))
    empty = vdb.FloatGrid()
    empty.name = "empty"
    vdb.write(str(HERE / "openvdb_types.vdb"), [mask, velocity, density, coarse, empty])

    tiles = vdb.FloatGrid()
    tiles.fill((0, 0, 0), (15, 15, 15), 2.0, True)  # eight leaf-sized active tiles
    tiles.name = "tiles"
    vdb.write(str(HERE / "openvdb_tiles.vdb"), [tiles])

    nano("nanovdb_two_grids.nvdb", "openvdb_two_grids.vdb", "-z")
    nano("nanovdb_fp16.nvdb", "openvdb_two_grids.vdb", "-z", "--fp16", "-g", "temperature")
    nano("nanovdb_blosc.nvdb", "openvdb_two_grids.vdb", "-b", "-g", "temperature")
    nano("nanovdb_rotated.nvdb", "openvdb_rotated.vdb", "-z")


def nano(target, source, *options):
    command = ["nanovdb_convert", "-f", *options, str(HERE / source), str(HERE / target)]
    subprocess.run(command, check=True)


if __name__ == "__main__":
    main()
