"""An exclusive lock on an output folder, so two runs never write into the same one at once.

The lock is a small JSON file, ``DIR/.bayesnsi.lock``, holding the owner's pid, host name,
config and start time. Where ``fcntl.flock`` exists (POSIX), the owner holds an exclusive
``flock`` on that file for as long as it runs; the kernel releases it when the owner exits,
however it exits (``kill -9`` included):

- taking a free folder: a temporary file (random name, ``O_EXCL | O_NOFOLLOW``) is locked, filled
  and then linked to the lock's name with :func:`os.link`, which fails if the name exists - so
  the lock file appears whole and already locked, never empty;
- taking over a stale lock: the existing file is opened (``O_NOFOLLOW``, a regular file only) and
  ``flock``-ed without waiting; only one of several takers can hold that ``flock``, and it keeps
  the lock only if the name still refers to the file it locked (a lock removed and created anew in
  the meantime is tried again). The file is rewritten in place, never removed, so no taker can
  remove the new owner's lock;
- a lock whose ``flock`` is held is in use: its fields (read with a size bound, printed with
  control characters escaped) name the run that holds it. A lock without ``flock`` that records
  a live pid on this host (an older bayesnsi), or another host, is in use too.

A lock that is not a regular file (a directory, a symbolic link, a FIFO, a device) is refused
without being opened for reading, with :class:`~bayesnsi.exceptions.OutputExistsError`.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import stat
import time
from collections.abc import Iterator
from pathlib import Path

from .._text import printable
from ..exceptions import OutputExistsError
from ._safe_write import create_temporary

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no takeover of stale locks
    fcntl = None  # type: ignore[assignment]

__all__ = ["LOCK_FILENAME", "MAX_LOCK_BYTES", "folder_lock"]

LOCK_FILENAME = ".bayesnsi.lock"
"""Name of the lock file inside an output folder."""

MAX_LOCK_BYTES = 4096
"""Most bytes read from a lock file (a larger one is read as unreadable, never whole)."""

_UNREADABLE_GRACE_S = 10.0
"""An unreadable lock younger than this is being written by its owner: it counts as held."""

_HELD: dict[Path, int] = {}
"""Locks held by this process: path -> descriptor (a nested ``folder_lock`` of the same folder re-enters)."""


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike, config: str | os.PathLike | None = None) -> Iterator[Path]:
    """Hold the lock of ``folder`` for the duration of the ``with`` block.

    Parameters
    ----------
    folder : str or path-like
        An existing directory.
    config : str or path-like, optional
        Recorded in the lock file, to tell the user which run holds it.

    Yields
    ------
    Path
        The lock file (removed when the block ends, if it is still ours).

    Raises
    ------
    OutputExistsError
        If another live bayesnsi run (on this or another host) holds the lock, or the lock's
        name is taken by something that is not a regular file.
    OSError
        If the lock file cannot be created (read-only folder, full disk).
    """
    path = Path(os.path.abspath(folder)) / LOCK_FILENAME
    if path in _HELD:
        yield path
        return
    owner = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "config": None if config is None else str(config),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    text = json.dumps(owner).encode("utf-8", "backslashreplace")
    fd = _acquire(path, text)
    _HELD[path] = fd
    try:
        yield path
    finally:
        del _HELD[path]
        _release(path, fd, text)


def _acquire(path: Path, text: bytes) -> int:
    for _ in range(50):
        fd = _create(path, text)
        if fd is not None:
            return fd
        fd = _take_over(path, text)
        if fd is not None:
            return fd
    raise OutputExistsError(f"{path.parent} is in use: could not take its lock {path.name}; retry in a moment")


def _create(path: Path, text: bytes) -> int | None:
    """Link a locked, filled temporary file to the lock's name; None when the name exists."""
    tmp, fd = create_temporary(path.name, None, path.parent, readable=True)
    tmp_path = path.parent / tmp
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.write(fd, text)
        os.fsync(fd)
        try:
            os.link(tmp_path, path)
        except FileExistsError:
            os.close(fd)
            return None
        except OSError:  # no hard links here (e.g. some network or FAT file systems): an exclusive create
            os.close(fd)
            return _create_exclusive(path, text)
        return fd
    except BaseException:
        with contextlib.suppress(OSError):
            os.close(fd)
        raise
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp_path)


def _create_exclusive(path: Path, text: bytes) -> int | None:
    """Create the lock in place (a taker that sees it empty waits out the grace of an unreadable lock)."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except FileExistsError:
        return None
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.write(fd, text)
    except BaseException:
        os.close(fd)
        with contextlib.suppress(OSError):
            path.unlink()
        raise
    return fd


def _take_over(path: Path, text: bytes) -> int | None:
    """The existing lock's descriptor, rewritten as ours, if its owner is gone; None to try again."""
    info = _lstat(path)
    if info is None:
        return None
    if not stat.S_ISREG(info.st_mode):
        raise OutputExistsError(
            f"{path} is not a regular file ({_kind(info.st_mode)}), so bayesnsi cannot tell whether a run holds "
            f"{path.parent}; remove it if no bayesnsi run is using that folder, or choose another --out"
        )
    flags = os.O_RDWR | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None
    except OSError as exc:  # replaced by a link or a FIFO in the meantime, or not writable
        raise OutputExistsError(
            f"{path} cannot be opened as a lock ({exc.strerror}); remove it or choose another --out"
        ) from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise OutputExistsError(f"{path} is not a regular file; remove it or choose another --out")
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise OutputExistsError(_in_use_message(path, _read_fd(fd))) from None
            if not _same_file(path, fd):
                os.close(fd)
                return None
        holder = _read_fd(fd)
        if not _stale(path, holder, socket.gethostname()):
            raise OutputExistsError(_in_use_message(path, holder))
        os.ftruncate(fd, 0)
        os.pwrite(fd, text, 0)
        os.fsync(fd)
        return fd
    except BaseException:
        with contextlib.suppress(OSError):
            os.close(fd)
        raise


def _release(path: Path, fd: int, text: bytes) -> None:
    try:
        if _same_file(path, fd) and _read_raw(fd) == text:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
    finally:
        os.close(fd)


def _lstat(path: Path) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None


def _same_file(path: Path, fd: int) -> bool:
    named, held = _lstat(path), os.fstat(fd)
    return named is not None and (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


def _read_raw(fd: int) -> bytes:
    return os.pread(fd, MAX_LOCK_BYTES + 1, 0)


def _read_fd(fd: int) -> dict | None:
    try:
        raw = _read_raw(fd)
        holder = json.loads(raw.decode("utf-8")) if len(raw) <= MAX_LOCK_BYTES else None
    except (OSError, ValueError, RecursionError):
        return None
    return holder if isinstance(holder, dict) else None


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISLNK, "a symbolic link"), (stat.S_ISFIFO, "a FIFO"),
                       (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a file"


def _stale(path: Path, holder: dict | None, host: str) -> bool:
    """True when the lock's owner is gone: a dead pid on this host, or an old unreadable file."""
    if holder is None:
        try:
            return time.time() - os.lstat(path).st_mtime > _UNREADABLE_GRACE_S
        except FileNotFoundError:
            return True
    pid = holder.get("pid")
    if holder.get("host") != host or not isinstance(pid, int) or isinstance(pid, bool) or pid <= 0:
        return False
    if os.name != "posix":  # os.kill would terminate the process there: never take a lock over
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OverflowError):  # alive, owned by another user; or no such pid at all
        return False
    return pid == os.getpid() and Path(path) not in _HELD  # our pid in an unlocked file: a lock we left


def _in_use_message(path: Path, holder: dict | None) -> str:
    folder = path.parent
    if holder is None:
        return f"{folder} is in use by another bayesnsi run (its lock {path.name} is being written); retry in a moment"
    host = holder.get("host")
    where = "" if host == socket.gethostname() else f" on host {_field(host)}"
    config = f", config {_field(holder['config'])}" if holder.get("config") else ""
    return (
        f"{folder} is in use by another bayesnsi run (pid {_field(holder.get('pid'))}{where}{config}, started "
        f"{_field(holder.get('started'))}); wait for it, choose another --out, or delete {path} if that run is gone"
    )


def _field(value: object) -> str:
    """A lock field as shown: control characters escaped, at most 200 characters."""
    text = printable(value, keep_newlines=False)
    return text if len(text) <= 200 else text[:197] + "..."
