"""Frame sequences: frame files, their manifest, the folder's lock, resume and read-ahead.

A sequence renders into a folder of ``frame_00000.png, frame_00001.png, …`` — each PNG written
atomically, so an interrupted run leaves only whole frames, and recorded in ``manifest.json``
under the key of what made it (:func:`frame_key`), so a rerun renders only the frames that are
missing, unreadable or made otherwise. One run at a time holds a frame folder's lock. The next
frame's volume is read and prepared on a helper thread while one renders (:func:`_ahead`);
:func:`keep_frame_memory` keeps freed frame buffers in the C heap for the next frame (glibc).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from incandescent.camera import Camera
from incandescent.imaging import DisplaySettings
from incandescent.io.atomic import check_output, exclusive_lock
from incandescent.io.formats import VIDEO_SUFFIXES
from incandescent.io.images import write_png
from incandescent.io.output import write_json
from incandescent.io.video import _check_frame
from incandescent.renderer import Integrator, RenderSettings
from incandescent.volume import Volume
from incandescent.volume.sparse import LEAF


def frame_key(
    frame_input: str,
    camera: Camera,
    settings: RenderSettings,
    display: DisplaySettings,
    integrator: Integrator | None = None,
) -> str:
    """Digests of everything that makes a frame's pixels: ``JOB:INPUT``, the job (version,
    camera, render and display settings, the integrator with its emission models) and the
    frame's input (its file's identity). A frame whose input alone changed is rendered again;
    one from another job is refused."""
    import hashlib

    from incandescent._version import __version__
    from incandescent.renderer import EmissionAbsorption

    transport = repr(integrator or EmissionAbsorption())
    job = "\n".join((__version__, repr(camera), repr(settings), repr(display), transport))

    def digest(text: str) -> str:
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    return f"{digest(job)}:{digest(frame_input)}"


def _same_job(recorded: str | None, wanted: str) -> bool:
    """Were both keys made by :func:`frame_key` for the same job (only the input differs)?"""
    if not recorded or ":" not in recorded or ":" not in wanted:
        return False
    return recorded.split(":", 1)[0] == wanted.split(":", 1)[0]


def file_identity(path: str | Path) -> str:
    """A file's resolved path, size and modification time (ns): changes when the file does. A
    folder (an OpenFOAM time folder): the same of each file in it."""
    path = Path(path)
    if path.is_dir():
        return " ".join(file_identity(p) for p in sorted(path.iterdir()) if p.is_file())
    info = path.stat()
    return f"{path.resolve()} {info.st_size} {info.st_mtime_ns}"


def expand_sequence(pattern: str) -> list[Path]:
    """Files of a sequence: a glob (``cache/*.vdb``) or a ``####`` frame pattern, sorted; or a
    series in one path — a ParaView ``.pvd`` (its files in time order) or an OpenFOAM case (its
    time folders; ``io.vtk.sequence_frames``)."""
    import glob

    from incandescent.io.vtk import sequence_frames

    series = sequence_frames(pattern) if "*" not in pattern and "#" not in pattern else None
    if series is not None:
        return series

    glob_pattern = pattern.replace("#", "[0-9]") if "#" in pattern else pattern
    paths = sorted(Path(p) for p in glob.glob(glob_pattern))
    if not paths:
        raise FileNotFoundError(f"no files match {pattern!r}")
    return paths


def key_frame(paths: Sequence[Path]) -> int:
    """The middle frame: a reasonable exposure key for a sequence we know nothing else about."""
    return len(paths) // 2


# --- frame sequences: resumable, keyed, locked ------------------------------------------------

PathLike = str | os.PathLike
#: Name of frame i in a sequence folder.
FRAME_NAME = "frame_{:05d}.png"

RenderFrame = Callable[[Volume], NDArray[np.uint8]]
VolumeSource = Iterable[Volume] | Callable[[int], Volume]


def frame_path(frame_dir: PathLike, index: int) -> Path:
    """``frame_dir/frame_00042.png`` for ``index`` 42."""
    return Path(os.fspath(frame_dir)) / FRAME_NAME.format(index)


def _check_count(n_frames: int) -> int:
    if isinstance(n_frames, bool) or not isinstance(n_frames, (int, np.integer)):
        raise TypeError(f"n_frames must be an integer; got {type(n_frames).__name__} {n_frames!r}")
    if n_frames < 1:
        raise ValueError(f"n_frames must be >= 1; got {n_frames!r}")
    return int(n_frames)


def _png_size(path: Path) -> tuple[int, int] | None:
    """(width, height) of a readable PNG file, None if it is missing, truncated or corrupt."""
    from PIL import Image

    if not path.is_file():
        return None
    try:
        with Image.open(path) as image:
            size = image.size
            image.verify()  # reads every chunk and checks its CRC: catches truncation
    except Exception:  # Pillow raises OSError, SyntaxError, ValueError… for bad files
        return None
    return size if image.format == "PNG" else None


def _existing_frames(frame_dir: Path, n_frames: int) -> dict[int, tuple[int, int]]:
    """Readable frames already in the folder, index → (width, height)."""
    done = {}
    for i in range(n_frames):
        size = _png_size(frame_path(frame_dir, i))
        if size is not None:
            done[i] = size
    return done


#: The record of what made each frame of a sequence, beside the frames.
MANIFEST_NAME = "manifest.json"
#: The lock file in a frame folder that one run holds while it writes there.
LOCK_NAME = ".lock"


def _read_manifest(frame_dir: Path) -> dict[str, str]:
    """Frame index (as text) → the key of what made it; {} if there is no readable manifest."""
    import json

    try:
        data = json.loads((frame_dir / MANIFEST_NAME).read_text(encoding="utf-8"))
        frames = data["frames"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    ok = isinstance(frames, dict) and all(isinstance(v, str) for v in frames.values())
    return frames if ok else {}


def _write_manifest(frame_dir: Path, keys: dict[str, str]) -> None:
    from incandescent._version import __version__

    data = {"format": 1, "written_by": f"incandescent {__version__}", "frames": keys}
    write_json(frame_dir / MANIFEST_NAME, data, overwrite=True)


def record_frames(frame_dir: PathLike, keys: dict[int, str]) -> None:
    """Add frames rendered elsewhere (their PNGs already in ``frame_dir``) to its manifest under
    ``keys`` (:func:`frame_key`), so that a render of the sequence reuses them."""
    folder = Path(os.fspath(frame_dir))
    manifest = _read_manifest(folder)
    manifest.update({str(i): key for i, key in keys.items()})
    _write_manifest(folder, manifest)


def _reusable(frame_dir: Path, n_frames: int, key_of: Callable[[int], str], rerender: bool):
    """(frames to keep: index → (width, height), manifest entries to keep); frames made with
    another key are refused unless ``rerender``, which discards every frame."""
    if rerender:
        return {}, {}
    manifest = _read_manifest(frame_dir)
    present = _existing_frames(frame_dir, n_frames)
    changed = [i for i in present if manifest.get(str(i)) != key_of(i)]
    stale = [i for i in changed if not _same_job(manifest.get(str(i)), key_of(i))]
    for i in changed:  # the same job on a changed input: render it again
        del present[i]
    if stale:
        raise FileExistsError(
            f"{frame_dir} holds {len(stale)} frame(s) (first: {FRAME_NAME.format(stale[0])}) "
            "rendered from other input, settings or version; pass --overwrite (overwrite=True) "
            "to render every frame again, or use another output"
        )
    return present, {str(i): manifest[str(i)] for i in present}


def _volume_stream(volumes: VolumeSource, n_frames: int, todo: set[int]) -> Iterator[tuple]:
    """(index, volume) for the indices in ``todo``; an iterable is advanced through every frame.
    Each volume is read and prepared (``_prepare``) on a helper thread while the previous
    frame renders (``_ahead``)."""
    return _ahead(_volumes_in_order(volumes, n_frames, todo))


def _volumes_in_order(volumes: VolumeSource, n_frames: int, todo: set[int]) -> Iterator[tuple]:
    if callable(volumes):
        for i in sorted(todo):
            yield i, _prepare(volumes(i))
        return
    count = 0
    for i, volume in zip(range(n_frames), volumes, strict=False):  # stop at n
        count += 1
        if i in todo:
            yield i, _prepare(volume)
    if count < n_frames:
        raise ValueError(f"volumes ran out after {count} frame(s); expected n_frames={n_frames}")


#: Blocks up to this size stay in the C heap when freed (``keep_frame_memory``): a 256³ float32
#: grid is 67 MB, so the grids of 256³ frames are kept; bigger ones come and go as before.
FRAME_HEAP_BYTES = 256 << 20
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)


def keep_frame_memory() -> bool:
    """Let each frame of a sequence reuse the memory the frame before freed (glibc; elsewhere a
    no-op returning False). By default glibc gives every freed block above ~32 MB back to the
    system, so the next frame's arrays (its file read, its absorption) fault fresh pages in, which
    the kernel zeroes — on the VMs measured, a first touch of 57 MB took 7 ms or, at random,
    136–165 ms. With blocks up to FRAME_HEAP_BYTES kept in the heap (at most that much held when
    idle): 162 → 130 ms per 192³ frame of ``animate`` (``benchmarks/animate_cost.py``, four
    alternating process pairs). For processes that render sequences (the CLI's ``animate``), not
    for a library's host."""
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError, TypeError):  # no C library by that name (Windows: TypeError)
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    kept = mallopt(_M_MMAP_THRESHOLD, FRAME_HEAP_BYTES) == 1
    return kept and mallopt(_M_TRIM_THRESHOLD, FRAME_HEAP_BYTES) == 1


def _prepare(item):
    """What a new dense volume costs before its first ray and is kept with it: the hottest
    voxel, the two-valued κ test and the leaf-size macrocells (the layout choice and the
    default skipping read them). ``item``: a volume, or a (volume, camera) pair as
    :func:`render_video` streams them."""
    volume = item[0] if isinstance(item, tuple) else item
    if isinstance(volume, Volume):
        _ = volume.max_temperature_K, volume.two_valued_absorption_per_m  # cached on the volume
        volume.macrocells(LEAF)
    return item


_END = object()


def _ahead(items: Iterator[Any]) -> Iterator[Any]:
    """``items`` in order, each made on a helper thread while the caller uses the one before it;
    an error is raised at its item's turn. The helper is a daemon: Ctrl-C or an early exit never
    waits for a read in progress."""

    def start() -> tuple[threading.Thread, dict]:
        box: dict = {}

        def make() -> None:
            try:
                box["item"] = next(items, _END)
            except BaseException as error:  # handed to the caller at this item's turn
                box["error"] = error

        helper = threading.Thread(target=make, name="incandescent-read-ahead", daemon=True)
        helper.start()
        return helper, box

    helper, box = start()
    while True:
        helper.join()
        if "error" in box:
            raise box["error"]
        if box["item"] is _END:
            return
        item = box["item"]
        helper, box = start()
        yield item


def _progress(enabled: bool, total: int, done: int):
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    bar = Progress(
        TextColumn("[bold]rendering[/] {task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        disable=not enabled,
    )
    reused = f"({done} already done)" if done else ""
    return bar, bar.add_task(reused, total=total, rate="– frames/s")


def _rate(task) -> str:
    return "– frames/s" if task.speed is None else f"{task.speed:.2f} frames/s"


class FramesFailed(RuntimeError):
    """Some frames of a distributed render failed (``failures``: index → reason); the others
    are done and recorded, so a rerun renders only these."""

    def __init__(self, failures: dict[int, str]) -> None:
        self.failures = failures
        first = min(failures)
        super().__init__(
            f"{len(failures)} frame(s) failed; first: frame {first} ({failures[first]}); "
            "the others are done — run again to retry these"
        )


#: ``(frame indices, on_done(index, image shape)) → failures``: renders frames elsewhere (a Dask
#: cluster, ``incandescent.cluster``), each writing its own PNG to ``frame_path``.
Distribute = Callable[[list[int], Callable[[int, tuple], None]], dict[int, str]]


def _render_missing(
    volumes: VolumeSource,
    n_frames: int,
    frame_dir: Path,
    render_frame: RenderFrame,
    progress: bool,
    frame_key: Callable[[int], str] | None = None,
    rerender: bool = False,
    distribute: Distribute | None = None,
) -> tuple[list[Path], int]:
    """Render the frames not yet in ``frame_dir`` (or made from another key); returns all frame
    paths and how many were rendered. The caller holds the folder's lock."""
    key_of = frame_key or (lambda _: "")
    done, keys = _reusable(frame_dir, n_frames, key_of, rerender)
    todo = set(range(n_frames)) - done.keys()
    sizes = set(done.values())
    shape = None if len(sizes) != 1 else tuple(reversed(sizes.pop())) + (3,)
    bar, task = _progress(progress, len(todo), len(done))
    if distribute is not None:
        with bar:
            _render_elsewhere(distribute, sorted(todo), frame_dir, keys, key_of, shape, bar)
        return [frame_path(frame_dir, i) for i in range(n_frames)], len(todo)
    with bar:
        for i, volume in _volume_stream(volumes, n_frames, todo):
            image = _check_frame(render_frame(volume), i, shape)
            shape = image.shape
            _claim(frame_dir, keys, key_of, [i])  # before the frame: any frame has its entry
            write_png(frame_path(frame_dir, i), image, metadata={"frame": str(i)})
            bar.advance(task)
            bar.update(task, rate=_rate(bar.tasks[0]))
    return [frame_path(frame_dir, i) for i in range(n_frames)], len(todo)


def _claim(frame_dir: Path, keys: dict[str, str], key_of, indices) -> None:
    """Record the keys of frames about to be written *before* any is committed — a killed run
    then leaves every frame on disk under its own key (one with an entry but no PNG is simply
    rendered again) — after removing the older frames they replace, so no old PNG ever stands
    under a new key."""
    for i in indices:
        frame_path(frame_dir, i).unlink(missing_ok=True)
        keys[str(i)] = key_of(i)
    _write_manifest(frame_dir, keys)


def _render_elsewhere(distribute, todo, frame_dir, keys, key_of, shape, bar) -> None:
    """Frames rendered by ``distribute``; the manifest entries of all are written here first
    (:func:`_claim`), as the workers write the PNGs. Raises :class:`FramesFailed` after the
    others finished."""
    sizes = {shape} if shape is not None else set()
    _claim(frame_dir, keys, key_of, todo)

    def on_done(index: int, frame_shape: tuple) -> None:
        sizes.add(tuple(frame_shape))
        if len(sizes) > 1:
            raise ValueError(f"frame {index} has shape {frame_shape}; the others {sizes}")
        bar.advance(bar.task_ids[0])
        bar.update(bar.task_ids[0], rate=_rate(bar.tasks[0]))

    failures = distribute(todo, on_done)
    if failures:
        raise FramesFailed(failures)


def _frame_folder(frame_dir: Path) -> Path:
    """Create the frame folder if needed; refuse anything that is not a writable folder."""
    if frame_dir.exists() and not frame_dir.is_dir():
        raise NotADirectoryError(f"frame folder {frame_dir} exists and is not a folder")
    if not frame_dir.exists():
        check_output(frame_dir, what="frame folder")  # its parent exists and is writable
        frame_dir.mkdir()
    check_output(frame_dir / MANIFEST_NAME, overwrite=True)  # the folder is writable
    return frame_dir


def render_sequence(
    volumes: VolumeSource,
    n_frames: int,
    frame_dir: PathLike,
    render_frame: RenderFrame,
    progress: bool = True,
    frame_key: Callable[[int], str] | None = None,
    overwrite: bool = False,
) -> list[Path]:
    """Render frames 0 … n_frames − 1 to ``frame_dir/frame_00000.png`` …, resuming.

    Parameters
    ----------
    volumes:
        The frames' volumes: an iterable (advanced through every frame, also those skipped, and
        read no further than ``n_frames``) or a function ``index → Volume`` (called only for the
        frames to render).
    n_frames:
        Number of frames.
    frame_dir:
        Folder for the PNG frames; created if missing.
    render_frame:
        ``Volume → uint8 RGB (H, W, 3)``, e.g. ``render`` followed by ``imaging.to_display``
        with a fixed exposure (auto exposure per frame makes a video flicker).
    progress:
        Show a progress bar (frames/s, ETA) on stderr.
    frame_key:
        ``index → str``: what makes frame i (input identity, settings, camera; see
        :func:`incandescent.animation.render_video`), recorded in ``manifest.json`` beside the
        frames. None: every frame has the key "".
    overwrite:
        Render every frame again, whatever is in the folder.

    Returns
    -------
    The paths of all n_frames PNG files, in order.

    Notes
    -----
    A frame is reused only when its PNG is readable and the manifest records the same key for
    it; a missing, truncated or corrupt one is (re)rendered, and one made from another key is
    refused (``FileExistsError``) unless ``overwrite``. Each PNG is written to a temporary file
    first and moved into place, and its manifest entry is written *before* it (the frame it
    replaces removed first), so an interrupted run (exception, Ctrl-C, SIGKILL — on a cluster
    too) leaves every whole frame recorded under its key, and no partial or old frame under a
    new key: a rerun reuses what was finished and renders the rest.
    One run at a time writes a folder: a second one fails at once (:class:`OutputError` naming
    the owner's pid). New frames must have the size of the frames kept (``ValueError``).
    """
    n_frames = _check_count(n_frames)
    folder = _frame_folder(Path(os.fspath(frame_dir)))
    with exclusive_lock(folder / LOCK_NAME, str(folder)):
        paths, _ = _render_missing(
            volumes, n_frames, folder, render_frame, progress, frame_key, overwrite
        )
    return paths


def plan_output(
    output: Path, frame_dir: PathLike | None, overwrite: bool
) -> tuple[Path, str | None]:
    """(frame folder, video suffix or None); checks the video destination before any rendering."""
    output = Path(os.fspath(output))
    suffix = output.suffix.lower()
    if output.is_dir() or not suffix:
        if frame_dir is not None and Path(os.fspath(frame_dir)) != output:
            raise ValueError(
                f"output {output} is a folder, so the frames go there; do not also pass "
                f"frame_dir={frame_dir}"
            )
        _probe_lock(output, output)
        return output, None
    if suffix not in VIDEO_SUFFIXES:
        raise ValueError(
            f"{output}: unsupported animation format {output.suffix!r}; expected "
            f"{', '.join(VIDEO_SUFFIXES)} or a folder (no suffix) for PNG frames"
        )
    check_output(output, overwrite, VIDEO_SUFFIXES, "animation")  # now, not after hours
    folder = output.with_name(f"{output.stem}_frames") if frame_dir is None else frame_dir
    _probe_lock(Path(os.fspath(folder)), output)
    return Path(os.fspath(folder)), suffix


def _probe_lock(folder: Path, output: Path) -> None:
    """Fail now, before any reading or rendering, if another run holds the folder's lock (the
    lock itself is taken later, by :func:`animate`)."""
    if (folder / LOCK_NAME).is_file():
        with exclusive_lock(folder / LOCK_NAME, str(output)):
            pass
