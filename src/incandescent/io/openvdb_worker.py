"""The OpenVDB worker: reads ``.vdb`` files with OpenVDB's own Python module, in another process.

Debian/Ubuntu's ``python3-openvdb`` (module ``pyopenvdb``, OpenVDB 10) is built for the operating
system's Python and its NumPy 1.x, so it cannot be imported into the project's environment.
:mod:`incandescent.io.openvdb` runs *this file* under that interpreter (it imports only the
standard library, NumPy and pyopenvdb — never the ``incandescent`` package) and talks to it in
JSON lines on stdin/stdout. Dense arrays come back as ``.npy`` files in a folder the client gives
and removes (read with ``allow_pickle=False``: nothing is ever unpickled).

Requests: ``{"op": "describe", "path": P}`` → ``{"grids": [...]}`` (name, type, active voxel
count including active tiles, inclusive index box, value range — vector grids: of the magnitude —,
background, index→world matrix, metadata, and why a grid cannot be read where it cannot);
``{"op": "dense", "path": P, "names": [...], "lo": [i, j, k], "hi": [i, j, k], "out": DIR}`` →
``{"files": {name: file}}``: each grid on the inclusive box, background outside its active
values, tiles expanded by OpenVDB (``copyToArray``); vec3 grids as (nx, ny, nz, 3).
``{"op": "leaves", "path": P, "names": [...], "lo": …, "hi": …, "z_up": bool, "out": DIR}`` →
``{"files": {name: file}, "coords": file, "shape": [nx, ny, nz]}``: the same box cut into 8³
leaves from its low corner (after turning a z-up box y-up: (x, y, z) ↦ (x, z, ny − 1 − y)),
keeping every leaf where any grid differs from its background and the 26 leaves around each
(trilinear sampling reads one voxel into them; ``"rings"``: that many more rings, for motion
blur); never the whole box at once — it is copied in
slabs of 8 voxels along x, twice (find the leaves, then copy them).
Every reply has ``"ok"``; failures carry ``"error"``.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from typing import Any

import numpy as np

#: pyopenvdb, imported by :func:`main` (this file is also importable, e.g. by doctest collection,
#: where pyopenvdb is absent).
vdb: Any = None

#: Value types this build of pyopenvdb can read (Debian's has float, bool and vec3s grids).
READABLE = {"float", "vec3s", "bool"}


#: The grids of the last file read: a read describes the grids, then densifies them, and
#: OpenVDB should decompress each grid once. Keyed by path, size and modification time.
_LAST: dict = {"key": None, "grids": {}}


def _grid(path: str, name: str):
    """Grid ``name`` of ``path``, read once while the file is unchanged."""
    info = os.stat(path)
    key = (path, info.st_size, info.st_mtime_ns)
    if _LAST["key"] != key:
        _LAST.update(key=key, grids={})
    grids = _LAST["grids"]
    if name not in grids:
        grids[name] = vdb.read(path, name)
    return grids[name]


def _jsonable(value):
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    if isinstance(value, (tuple, list)):
        return [_jsonable(v) for v in value]
    return str(value)


def _matrix(transform) -> list[list[float]]:
    """4×4 index→world matrix (column vectors) from three unit steps and the origin."""
    origin = np.asarray(transform.indexToWorld((0, 0, 0)), dtype=np.float64)
    columns = [
        np.asarray(transform.indexToWorld(e), dtype=np.float64) - origin
        for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))
    ]
    m = np.eye(4)
    m[:3, :3] = np.stack(columns, axis=1)
    m[:3, 3] = origin
    return m.tolist()


def _value_range(grid, value_type: str):
    """(min, max) of the active values, tiles included; of the magnitude for vectors (OpenVDB's
    own evalMinMax orders vectors lexicographically, which is no range)."""
    if value_type == "vec3s":
        magnitude = np.array([np.linalg.norm(item["value"]) for item in grid.citerOnValues()])
        return float(magnitude.min()), float(magnitude.max())
    low, high = grid.evalMinMax()
    return float(low), float(high)


def _describe_grid(path: str, meta, ranges: bool = True) -> dict:
    metadata = {str(k): _jsonable(v) for k, v in dict(meta.metadata).items()}
    info = {"name": meta.name, "type": meta.valueTypeName, "metadata": metadata}
    if meta.valueTypeName not in READABLE:
        info["unreadable"] = (
            f"holds {meta.valueTypeName} values, which OpenVDB's Python module (pyopenvdb) "
            "does not read; only float, half (read as float) and vec3s grids are read"
        )
        return info
    grid = _grid(path, meta.name)
    count = int(grid.activeVoxelCount())
    info.update(
        active_voxels=count,
        matrix=_matrix(grid.transform),
        voxel_size=list(grid.transform.voxelSize()),
        linear=bool(grid.transform.isLinear),
    )
    background = grid.background
    info["background"] = list(background) if isinstance(background, tuple) else float(background)
    if count:
        lo, hi = grid.evalActiveVoxelBoundingBox()
        info.update(index_min=list(lo), index_max=list(hi))
        if ranges and meta.valueTypeName != "bool":
            info["min"], info["max"] = _value_range(grid, meta.valueTypeName)
    return info


def describe(request: dict) -> dict:
    path = request["path"]
    ranges = request.get("ranges", True)
    grids = [_describe_grid(path, meta, ranges) for meta in vdb.readAllGridMetadata(path)]
    if request.get("sums"):
        for info in grids:
            if info["type"] == "float" and "unreadable" not in info:
                grid = _grid(path, info["name"])  # tiles count once per voxel they cover
                info["sum"] = float(sum(v["value"] * v["count"] for v in grid.citerOnValues()))
    return {"grids": grids}


def dense(request: dict) -> dict:
    path, lo, hi = request["path"], tuple(request["lo"]), tuple(request["hi"])
    shape = tuple(int(h) - int(l) + 1 for l, h in zip(lo, hi, strict=True))
    files = {}
    for i, name in enumerate(request["names"]):
        grid = _grid(path, name)
        vector = grid.valueTypeName == "vec3s"
        background = grid.background
        array = np.empty(shape + ((3,) if vector else ()), dtype=np.float32)
        array[...] = background
        grid.copyToArray(array, ijk=lo)
        target = os.path.join(request["out"], f"grid_{i}.npy")
        np.save(target, array, allow_pickle=False)
        files[name] = target
    return {"files": files}


LEAF = 8


def _slab(grid, lo, x0: int, shape, z_up: bool) -> np.ndarray:
    """Voxels x0 … x0 + 7 of the box (background where inactive or past the box), turned y-up
    when ``z_up``, padded with background to whole leaves."""
    nx, ny, nz = shape
    vector = grid.valueTypeName == "vec3s"
    width = min(LEAF, nx - x0)
    array = np.empty((width, ny, nz) + ((3,) if vector else ()), dtype=np.float32)
    array[...] = grid.background
    grid.copyToArray(array, ijk=(lo[0] + x0, lo[1], lo[2]))
    if z_up:  # (x, y, z) -> (x, z, ny - 1 - y); vectors turn with the grid
        array = np.swapaxes(array, 1, 2)[:, :, ::-1]
        if vector:
            array = np.stack([array[..., 0], array[..., 2], -array[..., 1]], axis=-1)
    whole = tuple(-(-n // LEAF) * LEAF for n in array.shape[:3])
    out = np.empty(whole + array.shape[3:], dtype=np.float32)
    out[...] = grid.background
    out[: array.shape[0], : array.shape[1], : array.shape[2]] = array
    return out


def _occupied_by_values(grids, lo, shape, z_up: bool, leaf_shape) -> np.ndarray:
    """Leaves (of the turned box) holding an active value or tile of any grid: from OpenVDB's
    iterator over active values, so the cost is the active count, not the box's voxels."""
    occupied = np.zeros(leaf_shape, dtype=bool)
    top = np.asarray(shape) - 1
    for grid in grids:
        for item in grid.citerOnValues():
            a = np.maximum(np.asarray(item.min) - lo, 0)
            b = np.minimum(np.asarray(item.max) - lo, top)
            if np.any(b < a):
                continue
            if z_up:  # turned (x, z, ny - 1 - y)
                a, b = (a[0], a[2], top[1] - b[1]), (b[0], b[2], top[1] - a[1])
            occupied[tuple(slice(i // LEAF, j // LEAF + 1) for i, j in zip(a, b, strict=True))] = (
                True
            )
    return occupied


def _leaf(grid, lo, leaf, shape, z_up: bool) -> np.ndarray:
    """The turned box's leaf at leaf index ``leaf`` (8³[, 3]), background outside the box."""
    vector = grid.valueTypeName == "vec3s"
    t = [LEAF * int(c) for c in leaf]
    start = np.array((t[0], shape[1] - LEAF - t[2], t[1]) if z_up else t)
    block = np.empty((LEAF,) * 3 + ((3,) if vector else ()), dtype=np.float32)
    block[...] = grid.background
    a, b = np.maximum(start, 0), np.minimum(start + LEAF, shape)
    if np.all(b > a):
        part = np.empty(tuple(b - a) + block.shape[3:], dtype=np.float32)
        part[...] = grid.background
        grid.copyToArray(part, ijk=tuple(int(v) for v in np.asarray(lo) + a))
        block[tuple(slice(i, j) for i, j in zip(a - start, b - start, strict=True))] = part
    if z_up:  # as _slab turns its slab
        block = np.swapaxes(block, 1, 2)[:, :, ::-1]
        if vector:
            block = np.stack([block[..., 0], block[..., 2], -block[..., 1]], axis=-1)
    return block


def _leaf_view(slab: np.ndarray) -> np.ndarray:
    """(ly, lz, 8, 8, 8[, 3]) leaves of one whole-leaf slab."""
    _, ny, nz = slab.shape[:3]
    rest = slab.shape[3:]
    view = slab.reshape((LEAF, ny // LEAF, LEAF, nz // LEAF, LEAF) + rest)
    return np.moveaxis(view, (1, 3), (0, 1))


def _differs(grid, slab) -> np.ndarray:
    """Per leaf of the slab: does any voxel differ from the grid's background?"""
    leaves = _leaf_view(slab)
    differ = np.any(leaves != np.asarray(grid.background, dtype=np.float32), axis=(2, 3, 4))
    return differ.reshape(differ.shape[:2] + (-1,)).any(axis=-1) if slab.ndim == 4 else differ


def _dilate(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one leaf in all 26 directions (``volume.macrocells.dilate_cells``: this
    file runs under the system Python and cannot import the package)."""
    out = mask.copy()
    for axis in range(3):
        grown = np.moveaxis(out.copy(), axis, 0)
        view = np.moveaxis(out, axis, 0)
        grown[1:] |= view[:-1]
        grown[:-1] |= view[1:]
        out = np.moveaxis(grown, 0, axis)
    return out


def leaves(request: dict) -> dict:
    path, lo, hi = request["path"], tuple(request["lo"]), tuple(request["hi"])
    shape = tuple(int(h) - int(l) + 1 for l, h in zip(lo, hi, strict=True))
    z_up = bool(request.get("z_up"))
    grids = [_grid(path, name) for name in request["names"]]
    turned = (shape[0], shape[2], shape[1]) if z_up else shape
    leaf_shape = tuple(-(-n // LEAF) for n in turned)
    few = sum(g.activeVoxelCount() for g in grids) * LEAF < np.prod(shape, dtype=np.float64)
    if few:  # a few voxels over a huge box: walk the active values, never copy the box
        occupied = _occupied_by_values(grids, lo, shape, z_up, leaf_shape)
    else:
        occupied = np.zeros(leaf_shape, dtype=bool)
        for cx, x0 in enumerate(range(0, shape[0], LEAF)):
            for grid in grids:
                occupied[cx] |= _differs(grid, _slab(grid, lo, x0, shape, z_up))
    keep = _dilate(occupied)
    for _ in range(int(request.get("rings", 0))):  # motion blur reads farther: more rings
        keep = _dilate(keep)
    coords = np.argwhere(keep).astype(np.int32)
    files = {}
    for i, grid in enumerate(grids):
        if few:
            parts = (
                [np.stack([_leaf(grid, lo, c, shape, z_up) for c in coords])] if len(coords) else []
            )
        else:
            parts = [
                _leaf_view(_slab(grid, lo, cx * LEAF, shape, z_up))[keep[cx]]
                for cx in range(leaf_shape[0])
                if keep[cx].any()
            ]
        values = np.concatenate(parts) if parts else np.zeros((0, LEAF, LEAF, LEAF), np.float32)
        files[grid.name] = os.path.join(request["out"], f"leaves_{i}.npy")
        np.save(files[grid.name], values, allow_pickle=False)
    coords_file = os.path.join(request["out"], "coords.npy")
    np.save(coords_file, coords, allow_pickle=False)
    return {"files": files, "coords": coords_file, "shape": list(turned)}


def write(request: dict) -> dict:
    """Write grids (dense ``.npy`` files) as one sparse ``.vdb``: voxels equal to the background
    (0) inactive, pruned (constant regions become tiles), index (0, 0, 0) centred at
    ``translation``, cubic voxels; each grid's metadata as given."""
    grids = []
    for spec in request["grids"]:
        values = np.load(spec["file"], allow_pickle=False)
        vector = values.ndim == 4
        grid = vdb.Vec3SGrid() if vector else vdb.FloatGrid()
        grid.name = spec["name"]
        grid.copyFromArray(values, ijk=(0, 0, 0), tolerance=(0.0, 0.0, 0.0) if vector else 0.0)
        grid.prune(tolerance=(0.0, 0.0, 0.0) if vector else 0.0)
        grid.transform = vdb.createLinearTransform(voxelSize=float(spec["voxel_size"]))
        grid.transform.translate(tuple(float(v) for v in spec["translation"]))
        grid.gridClass = vdb.GridClass.FOG_VOLUME
        for key, value in spec.get("metadata", {}).items():
            grid[key] = value
        grids.append(grid)
    vdb.write(request["path"], grids=grids)
    _LAST.update(key=None, grids={})
    return {"written": request["path"], "grids": [g.name for g in grids]}


OPS = {"describe": describe, "dense": dense, "leaves": leaves, "write": write}


def main() -> None:  # noqa: D103
    global vdb
    try:
        import pyopenvdb as vdb
    except ImportError as error:
        print(json.dumps({"ok": False, "error": f"cannot import pyopenvdb: {error}"}), flush=True)
        sys.exit(3)
    version = list(vdb.LIBRARY_VERSION)
    budget = _limit_memory()
    print(json.dumps({"ok": True, "ready": True, "openvdb": version}), flush=True)
    for line in sys.stdin:
        try:
            request = json.loads(line)
            with _request_memory(request.get("max_bytes")):
                reply = OPS[request["op"]](request)
            reply["ok"] = True
        except MemoryError:  # OpenVDB's std::bad_alloc too: a corrupt header claims huge sizes
            reply = {"ok": False, "error": f"needs more than the {budget} MiB allowed", "memory": 1}
        except Exception as error:  # every failure goes back to the client as text
            reply = {"ok": False, "error": f"{type(error).__name__}: {error}"}
        print(json.dumps(reply), flush=True)


#: The client's memory budget for this worker's work, bytes (``--max-memory`` or what is free).
BUDGET_ENV = "INCANDESCENT_OPENVDB_MAX_BYTES"


@contextlib.contextmanager
def _request_memory(max_bytes):
    """For one request, a tighter soft RLIMIT_AS: what is mapped now plus ``max_bytes`` (a
    read-back of a file just written needs about its grids' size; a truncated one may make
    OpenVDB allocate without bound). The soft limit returns to the hard one afterwards."""
    import resource

    if not max_bytes:
        yield
        return
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = _mapped_bytes() + int(max_bytes)
    resource.setrlimit(resource.RLIMIT_AS, (cap if hard < 0 else min(cap, hard), hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _mapped_bytes() -> int:
    with open("/proc/self/status", encoding="ascii") as status:
        return next(int(x.split()[1]) * 1024 for x in status if x.startswith("VmSize:"))


def _limit_memory() -> int:
    """Cap this process's address space at what it maps now plus the budget (RLIMIT_AS), so a
    corrupt file that makes OpenVDB allocate without bound fails with MemoryError instead of
    taking the machine; returns the budget in MiB (0: no budget given, no cap)."""
    import resource

    budget = int(float(os.environ.get(BUDGET_ENV) or 0))
    if budget <= 0:
        return 0
    mapped = _mapped_bytes()
    resource.setrlimit(resource.RLIMIT_AS, (mapped + budget, mapped + budget))
    return budget >> 20


if __name__ == "__main__":
    main()
