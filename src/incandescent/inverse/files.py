"""Tomography from files (``incandescent reconstruct``): EXR radiance views and a file of their
cameras in; the volume, each view's residual image and the loss curve out.

The cameras file (.toml or .json) lists one camera per view, in the views' order::

    [[camera]]
    eye = [0.25, 0.0, 0.0]       # m
    target = [0.0, 0.0, 0.0]
    fov_deg = 30.0               # and up, projection, ortho_height_m as incandescent.Camera
    width = 128                  # optional: the film size the view must have
    height = 128

A scene file (``[camera]`` with ``eye`` and ``target``; ``[render] width``/``height``) gives
one camera: a single view, e.g. ``--axisymmetric``.

The grid is a volume file's (``like``: its box, voxels and absorption; its T is ignored) or a
box (``bounds_m``) of ``size`` voxels along its longest side with a constant absorption.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from incandescent.camera import Camera
from incandescent.inverse.reconstruct import Result, View
from incandescent.renderer import RenderSettings

#: The keys of a camera entry that are not :class:`Camera`'s.
FILM_KEYS = ("width", "height")


def read_cameras(path: Path) -> list[dict]:
    """The camera entries of a .toml (``[[camera]]``) or .json (``{"camera": [...]}`` or a
    list) file, or the one camera of a scene file (its ``[camera]``; width and height from its
    ``[render]``)."""
    from incandescent.io.textfiles import parse_json, parse_toml

    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"cannot read the cameras file {path}: {error}") from None
    parse = parse_toml if path.suffix.lower() == ".toml" else parse_json
    data = parse(text, path)
    entries = data.get("camera") if isinstance(data, dict) else data
    if isinstance(entries, dict):  # a scene file: its [camera], its [render] film
        film = data.get("render", {})
        entries = [{**entries, **{k: film[k] for k in FILM_KEYS if k in film}}]
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise ValueError(f"{path}: expected a list of cameras ([[camera]] tables)")
    return entries


def camera_of(entry: dict, where: str) -> tuple[Camera, tuple[int, int] | None]:
    """The Camera of one entry, and the film (width, height) it states (None: any)."""
    given = {k: v for k, v in entry.items() if k not in FILM_KEYS}
    try:
        camera = Camera(**{k: tuple(v) if isinstance(v, list) else v for k, v in given.items()})  # type: ignore[arg-type]
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None
    if all(k in entry for k in FILM_KEYS):
        return camera, (int(entry["width"]), int(entry["height"]))
    return camera, None


def read_view(path: Path, camera: Camera, film: tuple[int, int] | None) -> View:
    """An EXR radiance image (absolute linear RGB, as ``render`` writes it) as a View."""
    from incandescent.colorimetry import rgb_to_xyz
    from incandescent.io.images import read_exr

    rgb, meta, _ = read_exr(path)
    if "display" in meta.get("units", ""):
        raise ValueError(f"{path}: display-referred, not radiance; give absolute EXR views")
    xyz = rgb_to_xyz(rgb, meta.get("colour_space", "srgb"))
    height, width = xyz.shape[:2] if film is None else (film[1], film[0])
    settings = RenderSettings(width=width, height=height, jitter=False)
    return View(xyz, camera, settings, str(path))


def read_views(images: Sequence[Path], cameras_path: Path) -> list[View]:
    """The views, each with its camera (one per image, in order)."""
    entries = read_cameras(cameras_path)
    if len(entries) != len(images):
        raise ValueError(f"{cameras_path}: {len(entries)} cameras for {len(images)} views; "
                         "give one camera per view, in the views' order")  # fmt: skip
    views = []
    for k, (path, entry) in enumerate(zip(images, entries, strict=True)):
        camera, film = camera_of(entry, f"{cameras_path}: camera {k + 1} (for {path})")
        views.append(read_view(Path(path), camera, film))
    return views


def grid_from(like: Path | None, bounds_m: str | None, size: int, absorption_per_m: float):
    """The grid to solve on: ``like``'s (a dense volume file), or the box ``bounds_m``
    ("x0,y0,z0:x1,y1,z1" in m) at ``size`` voxels along its longest side, κ constant."""
    from incandescent.volume import Volume

    if like is not None:
        from incandescent.config.assemble import load_volume

        given = load_volume(like, layout="dense")
        if not isinstance(given, Volume):
            raise ValueError(f"--like {like}: a sparse volume; give a dense grid")
        kappa, voxel = given.absorption_per_m, given.voxel_size_m
        return Volume.from_arrays(given.temperature_K, kappa, voxel_size_m=voxel,
                                  origin_m=given.origin_m)  # fmt: skip
    if bounds_m is None:
        raise ValueError("give the grid: --like VOLUME or --bounds x0,y0,z0:x1,y1,z1 (m)")
    lo, hi = _bounds(bounds_m)
    voxel = float(np.max(hi - lo)) / size
    shape = tuple(max(1, int(round(s / voxel))) for s in hi - lo)
    kappa = np.full(shape, absorption_per_m)  # a grid: the adjoint's κ is its own
    return Volume.from_arrays(np.full(shape, 300.0), absorption=kappa, voxel_size_m=voxel,
                              origin_m=lo)  # fmt: skip


def _bounds(text: str) -> tuple[np.ndarray, np.ndarray]:
    try:
        lo, hi = (np.array([float(x) for x in part.split(",")]) for part in text.split(":"))
    except ValueError:
        lo = hi = np.zeros(0)
    if lo.size != 3 or hi.size != 3 or not np.all(hi > lo):
        raise ValueError(f"--bounds {text!r}: expected x0,y0,z0:x1,y1,z1 in m with x1 > x0 …")
    return lo, hi


def checkpoint_path(output: Path) -> Path:
    """Where the run's checkpoint lives: beside the output, ``NAME.checkpoint.npz``."""
    return output.with_name(output.stem + ".checkpoint.npz")


def write_result(result: Result, views: Sequence[View], output: Path, overwrite: bool):
    """The volume (``output``: .npz or .vdb), each view's residual (rendered − input, linear
    RGB as the inputs; ``NAME.residual-K.exr``) and the loss curve and per-view errors
    (``NAME.loss.json``), all or none."""
    from incandescent.colorimetry import xyz_to_rgb
    from incandescent.io.atomic import all_or_nothing
    from incandescent.io.images import write_exr
    from incandescent.io.output import save_volume, write_json

    written = []
    with all_or_nothing():
        written.append(save_volume(result.volume, output, overwrite))
        for k, (residual, view) in enumerate(zip(result.residuals, views, strict=True)):
            path = output.with_name(f"{output.stem}.residual-{k + 1}.exr")
            meta = {"view": view.name, "units": "rendered − input, XYZ Y in cd/m^2; RGB linear",
                    "colour_space": "srgb"}  # fmt: skip
            written.append(write_exr(path, xyz_to_rgb(residual), meta, overwrite))
        report = {"loss": result.losses, "views": view_errors(result, views)}
        written.append(write_json(output.with_name(output.stem + ".loss.json"), report, overwrite))
    return written


def view_errors(result: Result, views: Sequence[View]) -> list[dict]:
    """Per view: its name and the residual relative to the input, L1 and L2 (over XYZ)."""
    out = []
    for residual, view in zip(result.residuals, views, strict=True):
        l1 = float(np.abs(residual).sum() / max(np.abs(view.xyz).sum(), 1e-300))
        l2 = float(np.sqrt((residual**2).sum() / max((view.xyz**2).sum(), 1e-300)))
        out.append({"view": view.name, "relative_l1": l1, "relative_l2": l2})
    return out
