"""What the viewer shows: the inputs it was started with, the view the page asks for (scene
overrides over them) and the render of that view — the steps of ``api.render_scene`` (scene →
volume, camera, settings, integrator → ``render`` → the display pipeline), so that the viewer's
image is the one ``incandescent render`` writes for the same flags.

The page sends only scene overrides from :data:`VIEW_KEYS` and a frame index: nothing it sends
is a path, and the server reads only the files of :class:`Inputs`.
"""

from __future__ import annotations

import io
import json
import threading
from collections import OrderedDict
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.api import start_backend
from incandescent.budget import Limits
from incandescent.config import Scene, load_scene, merge_overrides, scene_from_dict
from incandescent.config.assemble import volume_from_section
from incandescent.imaging.pipeline import display_pixels
from incandescent.io.formats import SCENE_SUFFIXES
from incandescent.renderer import HDRImage, render
from incandescent.volume import Volume
from incandescent.volume.sparse import SparseVolume

#: The scene keys the page may set (dotted), and nothing else: no path, no output.
VIEW_KEYS = frozenset({
    "camera.eye", "camera.target", "camera.fov_deg",
    "render.width", "render.height", "render.step_voxels", "render.supersample",
    "display.exposure_ev", "display.auto_exposure", "display.tonemap",
    "volume.temperature.offset", "volume.temperature.scale", "volume.temperature.cutoff_K",
    "volume.temperature.range", "volume.preset", "volume.absorption", "volume.species",
    "volume.soot_alpha", "volume.albedo", "volume.phase_g",
    "integrator.spectral_bins", "integrator.spp", "light",
})  # fmt: skip
#: The keys a ``light`` of the page may have: one sun (a directional light), as ``--sun`` gives.
SUN_KEYS = frozenset({"type", "direction", "illuminance_lux"})
#: The preview's pixels per side are the image's divided by this (a quarter of the pixels).
PREVIEW_DIVISOR = 2
#: Volumes kept read (frame, volume section): scrubbing back and forth reads no file again.
VOLUMES_KEPT = 4
#: Bins of the temperature histogram.
HISTOGRAM_BINS = 48


#: Characters that make INPUT a pattern of files (a glob or a #### frame pattern).
PATTERN = "#*?["


@dataclass(frozen=True)
class Inputs:
    """The files the viewer was started with: ``frames`` (one volume file, or a sequence's),
    and ``scene_file`` when INPUT was a scene file; ``given``: INPUT as typed; ``sequence``:
    whether each frame is its own file (a pattern, a series, a simulation's folder)."""

    given: str
    frames: tuple[Path, ...]
    scene_file: Path | None = None
    sequence: bool = False

    @property
    def is_sequence(self) -> bool:
        return self.sequence or len(self.frames) > 1


def open_inputs(given: str) -> Inputs:
    """INPUT as ``render``/``animate`` take it: a volume file (an OpenFOAM time folder too), a
    sequence (a glob or #### pattern, a ParaView .pvd, an OpenFOAM case), a scene file (whose
    ``[volume] path`` may be a sequence), or a folder written by ``incandescent simulate`` (its
    ``fire_####`` frames)."""
    from incandescent.animation import expand_sequence
    from incandescent.io.vtk import is_openfoam, sequence_frames

    path = Path(given)
    if path.suffix.lower() in SCENE_SUFFIXES:
        pattern = str(load_scene(path).volume.path)
        series = any(c in pattern for c in PATTERN) or sequence_frames(pattern) is not None
        frames = expand_sequence(pattern) if series else [Path(pattern)]
        return Inputs(given, tuple(frames), path, series)
    if path.is_dir() and not is_openfoam(path):
        return Inputs(given, tuple(_simulation_frames(path)), sequence=True)
    if any(c in given for c in PATTERN) or sequence_frames(given) is not None:
        return Inputs(given, tuple(expand_sequence(given)), sequence=True)
    if not path.exists():
        raise FileNotFoundError(f"{given}: no such volume file")
    return Inputs(given, (path,))


def _simulation_frames(folder: Path) -> list[Path]:
    """The frames ``simulate`` wrote in ``folder`` (fire_####.npz, or .vdb)."""
    for suffix in (".npz", ".vdb"):
        frames = sorted(folder.glob(f"fire_[0-9][0-9][0-9][0-9]{suffix}"))
        if frames:
            return frames
    raise FileNotFoundError(f"{folder}: a folder without fire_####.npz/.vdb frames (simulate's)")


def check_view(overrides: Any) -> dict:
    """The page's overrides, refused (naming the key) unless every key is one of
    :data:`VIEW_KEYS` and a light is a sun: nothing the page sends names a file."""
    if not isinstance(overrides, dict):
        raise ValueError(f"view: expected a table of scene keys; got {type(overrides).__name__}")
    for key in _dotted(overrides):
        if key not in VIEW_KEYS:
            raise ValueError(f"view: the viewer does not set {key!r}")
    for light in overrides.get("light", []):
        if not (isinstance(light, dict) and set(light) <= SUN_KEYS):
            raise ValueError(f"view: a light is one sun ({', '.join(sorted(SUN_KEYS))})")
        if light.get("type") != "directional":
            raise ValueError("view: a light of the viewer is a sun (type directional)")
    return overrides


def _dotted(table: dict, prefix: str = "") -> list[str]:
    """The dotted keys of the leaves of ``table`` (a species table and a light list are leaves)."""
    out = []
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and name not in VIEW_KEYS:
            out.extend(_dotted(value, name + "."))
        else:
            out.append(name)
    return out


@dataclass(frozen=True)
class Request:
    """What the page asks for: ``overrides`` (checked) over the inputs at ``frame``; a
    ``preview`` is rendered at 1/PREVIEW_DIVISOR of the pixels per side, then at full size when
    no other request comes within ``refine_after_s`` (None: the worker's default; 0: at once,
    as the page's first view)."""

    overrides: dict
    frame: int = 0
    preview: bool = False
    seq: int = 0
    refine_after_s: float | None = None


@dataclass(frozen=True)
class Frame:
    """A rendered view: the image, its display pixels, its camera and scene."""

    request: Request
    scene: Scene
    image: HDRImage
    pixels: NDArray[np.uint8]
    camera: Any
    volume: Volume | SparseVolume

    def png(self) -> bytes:
        """The display pixels as PNG (fast compression: a stream, not an archive)."""
        from PIL import Image

        out = io.BytesIO()
        Image.fromarray(self.pixels).save(out, format="PNG", compress_level=1)
        return out.getvalue()


class Session:
    """The inputs, the base overrides given on the command line, and renders of views; one
    render at a time (``lock``), volumes kept by frame and ``[volume]`` section."""

    def __init__(self, inputs: Inputs, base: dict | None = None, backend: str | None = None,
                 limits: Limits | None = None) -> None:  # fmt: skip
        self.inputs, self.base, self.limits = inputs, base or {}, limits or Limits()
        self.backend = start_backend(inputs.frames[0], backend)
        self.lock = threading.Lock()
        self._volumes: OrderedDict[str, Volume | SparseVolume] = OrderedDict()

    def scene(self, frame: int, overrides: dict) -> Scene:
        """The scene of ``frame`` with the base and the page's overrides: what ``render`` reads
        for the same flags (its volume file the frame's)."""
        if not 0 <= frame < len(self.inputs.frames):
            raise ValueError(f"frame {frame} is not one of 0..{len(self.inputs.frames) - 1}")
        merged = merge_overrides(self.base, overrides)
        if self.inputs.is_sequence:
            merged = merge_overrides(merged, {"volume": {"path": str(self.inputs.frames[frame])}})
        if self.inputs.scene_file is not None:
            return load_scene(self.inputs.scene_file, merged)
        data = {"volume": {"path": str(self.inputs.frames[frame])}}
        return scene_from_dict(data, None, merged, source=str(self.inputs.frames[frame]))

    def volume(self, scene: Scene) -> Volume | SparseVolume:
        """The scene's volume as ``render_scene`` reads it, kept for the next views."""
        settings = scene.render_settings()
        blur_fps = settings.fps if settings.shutter is not None else None
        key = json.dumps([scene.volume.model_dump(mode="json"), repr(scene.remap()),
                          settings.layout, blur_fps], sort_keys=True)  # fmt: skip
        if key not in self._volumes:
            self._volumes[key] = volume_from_section(
                scene.volume, scene.remap(), self.limits, settings.layout, blur_fps
            )
            while len(self._volumes) > VOLUMES_KEPT:
                self._volumes.popitem(last=False)
        self._volumes.move_to_end(key)
        return self._volumes[key]

    def render(self, request: Request) -> Frame:
        """``request`` rendered: the steps of ``api.render_scene``, at the preview's size when
        it is one; the display pixels through the scene's display settings."""
        scene = self.scene(request.frame, check_view(request.overrides))
        settings = scene.render_settings()
        if request.preview:
            settings = replace(settings, width=max(1, settings.width // PREVIEW_DIVISOR),
                               height=max(1, settings.height // PREVIEW_DIVISOR))  # fmt: skip
        with self.lock:
            volume = self.volume(scene)
            camera = scene.camera_for(volume)  # type: ignore[arg-type]
            image = render(volume, camera, settings, self.backend, self.limits,
                           integrator=scene.render_integrator())  # fmt: skip
        pixels = display_pixels(image, scene.display_settings())
        return Frame(request, scene, image, pixels, camera, volume)


def histogram(volume: Volume | SparseVolume, bins: int = HISTOGRAM_BINS) -> dict:
    """The temperature histogram of the volume's gas (voxels with T > 0 K): bin edges in K and
    counts."""
    values = _temperatures(volume)
    values = values[values > 0.0]
    if values.size == 0:
        return {"edges_K": [], "counts": []}
    counts, edges = np.histogram(values, bins=bins)
    return {"edges_K": edges.tolist(), "counts": counts.tolist()}


def _temperatures(volume: Volume | SparseVolume) -> NDArray[np.float32]:
    if isinstance(volume, SparseVolume):
        return volume.leaf_temperature_K.ravel()
    return volume.temperature_K.ravel()


def probe(frame: Frame, column: int, row: int) -> dict:
    """What the render gives at pixel (``column``, ``row``) of ``frame``: XYZ (Y: luminance in
    cd/m²), linear RGB, transmittance, and the hottest voxel temperature along the pixel's
    centre ray (K)."""
    image = frame.image
    if not (0 <= column < image.width and 0 <= row < image.height):
        raise ValueError(f"probe: pixel ({column}, {row}) is outside the {image.width}×"
                         f"{image.height} image")  # fmt: skip
    out: dict[str, Any] = {"column": column, "row": row,
           "transmittance": float(image.transmittance[row, column]),
           "hottest_K": hottest_along_ray(frame, column, row)}  # fmt: skip
    if image.xyz is not None:
        out["xyz"] = [float(v) for v in image.xyz[row, column]]
        out["luminance_cd_m2"] = float(image.xyz[row, column, 1])
        out["rgb"] = [float(v) for v in image.rgb()[row, column]]
    else:
        out["display_rgb"] = [float(v) for v in image.display_rgb[row, column]]  # type: ignore[index]
    return out


def hottest_along_ray(frame: Frame, column: int, row: int, per_voxel: int = 4) -> float:
    """The hottest voxel (K) that the centre ray of pixel (``column``, ``row``) passes through,
    sampled ``per_voxel`` times per voxel side (nearest voxel); 0 where it misses the gas."""
    image, volume = frame.image, frame.volume
    origins, directions = frame.camera.generate_rays(image.width, image.height, 1)
    ray = column * image.height + row  # the canonical column-major ray order
    origin, direction = origins[ray], directions[ray]
    lo, hi = (np.asarray(b, dtype=np.float64) for b in volume.bounds_m)
    near, far = _slab(origin, direction, lo, hi)
    if not far > near:
        return 0.0
    step = volume.voxel_size_m / per_voxel
    points = origin + np.arange(near + step / 2, far, step)[:, None] * direction
    index = np.floor((points - lo) / volume.voxel_size_m).astype(np.int64)
    index = np.clip(index, 0, np.asarray(volume.shape) - 1)
    return float(np.max(_temperature_at(volume, index), initial=0.0))


def _slab(origin: NDArray, direction: NDArray, lo: NDArray, hi: NDArray) -> tuple[float, float]:
    """Distances (m) along the ray where it enters and leaves the box lo–hi (slab test)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - origin) / direction, (hi - origin) / direction
    near = np.nanmax(np.minimum(t0, t1))
    far = np.nanmin(np.maximum(t0, t1))
    return max(float(near), 0.0), float(far)


def _temperature_at(volume: Volume | SparseVolume, index: NDArray[np.int64]) -> NDArray:
    """T (K) of the voxels ``index`` (n, 3); a sparse volume's unoccupied leaves are 0 K."""
    if not isinstance(volume, SparseVolume):
        return volume.temperature_K[index[:, 0], index[:, 1], index[:, 2]]
    leaves = {tuple(c): i for i, c in enumerate(volume.leaf_coords.tolist())}
    out = np.zeros(len(index), dtype=np.float32)
    for n, (x, y, z) in enumerate(index.tolist()):
        leaf = leaves.get((x // 8, y // 8, z // 8))
        if leaf is not None:
            out[n] = volume.leaf_temperature_K[leaf, x % 8, y % 8, z % 8]
    return out
