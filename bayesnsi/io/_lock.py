"""An exclusive lock on an output folder, so two runs never write into the same one at once.

The lock is a small JSON file, ``DIR/.bayesnsi.lock``, created with ``O_CREAT | O_EXCL`` (atomic
on local file systems) and holding the owner's pid, host name, config and start time. A lock
left by a process that no longer exists on this host (a killed run; POSIX only) is taken over; a lock of a
live process, or of another host, makes the second run stop with one line.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

from ..exceptions import OutputExistsError

__all__ = ["LOCK_FILENAME", "folder_lock"]

LOCK_FILENAME = ".bayesnsi.lock"
"""Name of the lock file inside an output folder."""

_UNREADABLE_GRACE_S = 10.0
"""An unreadable lock younger than this is being written by its owner: it counts as held."""


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
        If another live bayesnsi run (on this or another host) holds the lock.
    OSError
        If the lock file cannot be created (read-only folder, full disk).
    """
    path = Path(folder) / LOCK_FILENAME
    owner = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "config": None if config is None else str(config),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    held = _read(path)
    if held is not None and held.get("pid") == owner["pid"] and held.get("host") == owner["host"]:
        yield path
        return
    _acquire(path, owner)
    try:
        yield path
    finally:
        if _read(path) == owner:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()


def _acquire(path: Path, owner: dict) -> None:
    for _ in range(20):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            holder = _read(path)
            if not _stale(path, holder, owner["host"]):
                raise OutputExistsError(_in_use_message(path, holder)) from None
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
            continue
        try:
            os.write(fd, json.dumps(owner).encode())
        except BaseException:
            os.close(fd)
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
            raise
        os.close(fd)
        return
    raise OutputExistsError(f"{path.parent} is in use: could not take its lock {path.name}; retry in a moment")


def _read(path: Path) -> dict | None:
    try:
        holder = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return holder if isinstance(holder, dict) else None


def _stale(path: Path, holder: dict | None, host: str) -> bool:
    """True when the lock's owner is gone: a dead pid on this host, or an old unreadable file."""
    if holder is None:
        try:
            return time.time() - path.stat().st_mtime > _UNREADABLE_GRACE_S
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
    except PermissionError:  # alive, owned by another user
        return False
    return False


def _in_use_message(path: Path, holder: dict | None) -> str:
    folder = path.parent
    if holder is None:
        return f"{folder} is in use by another bayesnsi run (its lock {path.name} is being written); retry in a moment"
    where = "" if holder.get("host") == socket.gethostname() else f" on host {holder.get('host')}"
    config = f", config {holder['config']}" if holder.get("config") else ""
    return (
        f"{folder} is in use by another bayesnsi run (pid {holder.get('pid')}{where}{config}, started "
        f"{holder.get('started')}); wait for it, choose another --out, or delete {path} if that run is gone"
    )
