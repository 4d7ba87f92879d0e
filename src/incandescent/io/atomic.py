"""Writing outputs safely: checked before any work, written atomically, only regular files replaced.

Every output goes through :func:`atomic_write`: the data is written to a hidden temporary file
``.<name>.<pid>.<random>.tmp`` beside the target and then moved into place (``os.link`` when
overwriting is not allowed, so an existing file is never clobbered even by a concurrent writer;
``os.replace`` otherwise). A failed or interrupted write removes its temporary file; temporary
files left by a process that was killed (SIGKILL, power loss) carry its pid and are swept by the
next write of the same output once that pid is gone.

:func:`check_output` is what every command runs on its outputs *before* rendering: suffix
supported, folder present and writable, and the target — if it exists — a regular file (or a
symlink to one, which is resolved: the link stays and its file is replaced). Devices, FIFOs,
sockets and folders are never replaced, whatever ``overwrite`` says.

:func:`all_or_nothing` groups several writes (an image and its ``--stats`` JSON): each is staged
to its temporary file, and only when all are staged are they moved into place, so a failure
(full disk, read-only folder) leaves neither a half set of outputs nor temporary files.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import stat
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

PathLike = str | os.PathLike


class OutputError(OSError):
    """An output that cannot be written; the message names the path and the reason."""

    def __str__(self) -> str:  # OSError(msg) prints msg; keep it one line without errno noise
        return str(self.args[0]) if self.args else super().__str__()


# --- checks before any work -------------------------------------------------------------------


def _kind(mode: int) -> str:
    for test, name in (
        (stat.S_ISCHR, "character device"),
        (stat.S_ISBLK, "block device"),
        (stat.S_ISFIFO, "FIFO (named pipe)"),
        (stat.S_ISSOCK, "socket"),
        (stat.S_ISDIR, "folder"),
    ):
        if test(mode):
            return name
    return "special file"


def _resolved(target: Path) -> Path:
    """``target`` with a symlink (chain) resolved to the file it names (which may not exist)."""
    if target.is_symlink():
        return Path(os.path.realpath(target))
    return target


def _check_parent(target: Path) -> None:
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.exists():
        raise FileNotFoundError(f"cannot write {target}: folder {parent} does not exist")
    if not parent.is_dir():
        raise NotADirectoryError(f"cannot write {target}: {parent} is not a folder")
    if os.statvfs(parent).f_flag & os.ST_RDONLY:
        raise OutputError(f"cannot write {target}: folder {parent} is on a read-only file system")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write {target}: folder {parent} is not writable")


def _check_existing(target: Path, overwrite: bool, shown: Path) -> None:
    try:
        mode = os.stat(target).st_mode
    except (FileNotFoundError, NotADirectoryError):  # the folder check says what is wrong
        return
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(f"cannot write {shown}: it is a folder")
    if not stat.S_ISREG(mode):
        raise OutputError(
            f"cannot write {shown}: it is a {_kind(mode)}, not a regular file; only regular "
            "files are ever replaced"
        )
    if not overwrite:
        raise FileExistsError(
            f"{shown} already exists; pass --overwrite (overwrite=True) to replace it"
        )


def check_output(
    path: PathLike,
    overwrite: bool = False,
    suffixes: Sequence[str] | None = None,
    what: str = "output",
    inputs: Sequence[PathLike] = (),
) -> Path:
    """The file to write for output ``path``, checked before any work (see module doc).

    Raises ``ValueError`` for an unsupported suffix, ``FileExistsError`` for an existing file
    without ``overwrite``, ``FileNotFoundError``/``NotADirectoryError`` for a missing folder,
    ``IsADirectoryError`` for a folder, and :class:`OutputError` for a device, FIFO, socket or a
    read-only or unwritable folder — and also when the output is one of ``inputs`` (by any
    name: a symlink, a hard link, ``./``), whatever ``overwrite`` says: a run never replaces
    what it reads. Returns the path to write (a symlink resolved).
    """
    _validate_flag(overwrite, "overwrite")
    shown = Path(os.fspath(path))
    if suffixes is not None and shown.suffix.lower() not in suffixes:
        got = repr(shown.suffix) if shown.suffix else "no suffix"
        raise ValueError(
            f"{shown}: unsupported {what} format ({got}); expected {', '.join(suffixes)}"
        )
    target = _resolved(shown)
    _check_not_input(target, shown, inputs)
    _check_existing(target, overwrite, shown)
    _check_parent(target)
    return target


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether ``a`` and ``b`` name one file (symlinks, hard links and ``..`` seen through)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): compare where they would be
        return os.path.realpath(a) == os.path.realpath(b)


def _check_not_input(target: Path, shown: Path, inputs: Sequence[PathLike]) -> None:
    for source in inputs:
        if same_file(target, source):
            named = "" if os.fspath(source) == os.fspath(shown) else f" (as {source})"
            raise OutputError(
                f"cannot write {shown}: it is this run's input{named}; an input is never "
                "replaced, even with --overwrite — write to another file"
            )


def _validate_flag(value: object, name: str) -> None:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False; got {type(value).__name__} {value!r}")


# --- temporary files ----------------------------------------------------------------------------


def _temp_path(target: Path) -> Path:
    return target.with_name(f".{target.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def sweep_stale_temps(target: Path) -> list[Path]:
    """Remove temporary files of ``target`` left by processes that no longer run; returns them."""
    removed = []
    prefix = f".{target.name}."
    with contextlib.suppress(OSError):
        for entry in os.scandir(target.parent if str(target.parent) else "."):
            parts = entry.name[len(prefix) :].split(".")
            if not entry.name.startswith(prefix) or len(parts) != 3 or parts[2] != "tmp":
                continue
            if parts[0].isdigit() and not _pid_alive(int(parts[0])):
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(entry.path)
                    removed.append(Path(entry.path))
    return removed


# --- staging and committing ---------------------------------------------------------------------


@dataclass
class _Staged:
    target: Path
    tmp: Path
    overwrite: bool
    committed: bool = False


Verify = Callable[[Path], None]


def _verified(target: Path, tmp: Path, verify: Verify | None) -> None:
    """Run ``verify(tmp)`` (a read-back of the written file); any failure is an OutputError.

    This is what catches writers that do not report a failed write (a library that ignores a
    full disk): the staged file must read back before it may replace anything."""
    if not tmp.is_file():
        raise OutputError(f"cannot write {target}: the writer produced no file")
    if verify is None:
        return
    try:
        verify(tmp)
    except KeyboardInterrupt:
        raise
    except Exception as error:
        raise OutputError(
            f"cannot write {target}: the written file does not read back ({error}); the disk "
            "may be full — nothing was replaced"
        ) from None


def _stage(
    path: PathLike, write: Callable[[Path], None], overwrite: bool, verify: Verify | None = None
) -> _Staged:
    target = check_output(path, overwrite)
    sweep_stale_temps(target)
    tmp = _temp_path(target)
    try:
        write(tmp)
        _verified(target, tmp, verify)
    except OSError as error:
        tmp.unlink(missing_ok=True)
        if isinstance(error, OutputError):
            raise
        raise OutputError(f"cannot write {target}: {error.strerror or error}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return _Staged(target, tmp, overwrite)


def _commit(item: _Staged) -> None:
    """Move the staged file into place; without ``overwrite`` never clobber a file."""
    tmp, target = item.tmp, item.target
    if item.overwrite:
        _check_existing(target, True, target)  # still a regular file (or gone)
        os.replace(tmp, target)
        return
    try:
        os.link(tmp, target)  # fails atomically if the target appeared meanwhile
    except FileExistsError:
        raise FileExistsError(
            f"{target} already exists; pass --overwrite (overwrite=True) to replace it"
        ) from None
    except OSError as error:
        if error.errno in (errno.ENOSPC, errno.EROFS, errno.EACCES):
            raise OutputError(f"cannot write {target}: {error.strerror}") from None
        if target.exists():  # a file system without hard links: check, then rename
            raise FileExistsError(f"{target} exists; pass --overwrite (overwrite=True)") from None
        os.replace(tmp, target)
        return
    tmp.unlink()


class OutputBatch:
    """Outputs staged together and committed together (:func:`all_or_nothing`)."""

    def __init__(self) -> None:
        self.staged: list[_Staged] = []

    def commit(self) -> None:
        try:
            for item in self.staged:
                _commit(item)
                item.committed = True
        except BaseException:
            self.discard(undo=True)
            raise

    def discard(self, undo: bool = False) -> None:
        """Remove every temporary file; with ``undo``, also new files this batch created."""
        for item in self.staged:
            item.tmp.unlink(missing_ok=True)
            if undo and item.committed and not item.overwrite:
                item.target.unlink(missing_ok=True)


_BATCH: contextvars.ContextVar[OutputBatch | None] = contextvars.ContextVar("batch", default=None)


@contextlib.contextmanager
def all_or_nothing() -> Iterator[OutputBatch]:
    """Within this block, :func:`atomic_write` only stages; the block's end commits every staged
    output, or — on any exception, Ctrl-C included — none (temporary files removed)."""
    batch = OutputBatch()
    token = _BATCH.set(batch)
    try:
        yield batch
    except BaseException:
        batch.discard()
        raise
    finally:
        _BATCH.reset(token)
    batch.commit()


def atomic_write(
    path: PathLike,
    write: Callable[[Path], None],
    overwrite: bool = False,
    verify: Verify | None = None,
) -> Path:
    """Call ``write(tmp_path)`` then move the result to ``path``; clean up on any failure.

    ``verify(tmp_path)``, when given, reads the written file back before it is committed and
    raises if it is damaged; writers whose library may not report a failed write (OpenVDB on a
    full disk) pass one, so a truncated file never replaces anything.

    Returns the final path (a symlink resolved). Raises as :func:`check_output` does, and
    :class:`OutputError` naming the path when writing fails (disk full, I/O error). Inside
    :func:`all_or_nothing` the file is only staged, and committed at the end of the block.
    """
    item = _stage(path, write, overwrite, verify)
    batch = _BATCH.get()
    if batch is not None:
        batch.staged.append(item)
        return item.target
    try:
        _commit(item)
    finally:
        item.tmp.unlink(missing_ok=True)
    return item.target


# --- one writer at a time ---------------------------------------------------------------------


@contextlib.contextmanager
def exclusive_lock(path: PathLike, what: str) -> Iterator[None]:
    """Hold an exclusive lock on the file ``path`` (created if missing) for the block, or fail at
    once with :class:`OutputError` naming ``what`` and the owner's pid.

    The lock is ``flock(2)``: the kernel releases it when its process ends, however it ends, so
    a lock file left by a killed run is stale by construction and simply taken over. The file is
    never deleted (deleting it would let two runs lock two different files of the same name).
    """
    import fcntl

    fd = os.open(os.fspath(path), os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            owner = os.read(fd, 64).decode("ascii", "replace").strip() or "unknown"
            raise OutputError(
                f"{what} is being written by another incandescent run (pid {owner}); wait for "
                "it to finish or stop it, or write to another output"
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield
    finally:
        os.close(fd)  # releases the lock
