"""The one way bayesnsi writes a file: exclusive random temporary, fixed mode, rename, never through a link.

:func:`safe_open` writes every file of the package (results.json, report.html, the posterior
netCDF files, cache entries, the lock's content):

- the temporary file is created beside the target with a random name, ``O_CREAT | O_EXCL |
  O_NOFOLLOW`` (a file or link planted under any name is never opened, let alone followed), mode
  ``0o644`` less the umask (the mode of a file it replaces, set-uid bits included, is never copied);
- it is flushed, fsync'ed, then renamed over the target with :func:`os.replace` (a link planted
  under the target's name is replaced, its target is left untouched), and the folder is fsync'ed;
- the folder is opened once and used through its descriptor (``dir_fd``), so it cannot be
  swapped for another one between the checks and the write.

Inside an output folder held by :func:`bayesnsi.io.results.output_folder` (:func:`register_root`),
two more rules hold: every sub-folder below the output folder is opened with ``O_NOFOLLOW`` (a
sub-folder that is a symbolic link, e.g. ``DIR/posterior -> /elsewhere``, is refused with
:class:`~bayesnsi.exceptions.OutputExistsError`), and a file is replaced only when the folder's
manifest (:data:`MANIFEST_FILENAME`) records it, with its SHA-256, as written by bayesnsi - or
with ``--force``. What a user put in the folder is never overwritten without ``--force``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import secrets
import stat
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from ..exceptions import OutputExistsError

__all__ = ["FILE_MODE", "MANIFEST_FILENAME", "create_temporary", "owned_by_bayesnsi", "read_bounded", "read_manifest",
           "register_root", "safe_open", "unregister_root"]

FILE_MODE = 0o644
"""Mode of every file written (less the umask)."""

MANIFEST_FILENAME = ".bayesnsi-manifest.json"
"""Record, inside an output folder, of the files bayesnsi wrote there (relative path -> SHA-256)."""

MAX_MANIFEST_BYTES = 4 * 2**20
"""Largest manifest read (a manifest above it is treated as foreign: nothing counts as ours)."""

_UNTRACKED = (".cache", ".bayesnsi.lock", MANIFEST_FILENAME)
"""Names directly inside an output folder that the manifest does not track."""

_DIR_FLAGS = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_CLOEXEC", 0)
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_DIR_FD = os.open in os.supports_dir_fd and os.replace in os.supports_dir_fd


@dataclass
class _Root:
    folder: Path
    force: bool
    files: dict[str, str] = field(default_factory=dict)
    guard: threading.Lock = field(default_factory=threading.Lock)


_ROOTS: dict[Path, _Root] = {}


def register_root(folder: Path, force: bool) -> None:
    """Apply the output-folder rules (no linked sub-folder, manifest) to writes below ``folder``.

    Parameters
    ----------
    folder : Path
        An absolute, resolved output folder (its lock is held by the caller).
    force : bool
        Whether files not written by bayesnsi may be replaced.
    """
    _ROOTS[folder] = _Root(folder, force, read_manifest(folder))


def unregister_root(folder: Path) -> None:
    """Stop applying the output-folder rules to ``folder`` (its lock is being released).

    Parameters
    ----------
    folder : Path
    """
    _ROOTS.pop(folder, None)


def owned_by_bayesnsi(folder: Path, relative: str, manifest: dict[str, str] | None = None) -> bool:
    """True when ``folder/relative`` is a regular file that the folder's manifest records with its content.

    Parameters
    ----------
    folder : Path
        An output folder.
    relative : str
        Path inside it, with ``/``.
    manifest : dict, optional
        The folder's manifest when already read (:func:`read_manifest`).

    Returns
    -------
    bool
    """
    recorded = (read_manifest(folder) if manifest is None else manifest).get(relative)
    return recorded is not None and _digest(folder / relative) == recorded


@contextlib.contextmanager
def safe_open(path: str | os.PathLike, mode: str = "wb", encoding: str = "utf-8") -> Iterator[IO]:
    """Open a new temporary file that replaces ``path`` when the block ends without error.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist (inside a registered output folder, missing
        sub-folders are created).
    mode : {"w", "wb"}
        Text or binary.
    encoding : str
        Text encoding (text mode).

    Yields
    ------
    file object
        On success the data are fsync'ed and renamed over ``path``; on any exception the
        temporary file is removed and ``path`` is untouched.

    Raises
    ------
    OutputExistsError
        A folder on the way is a symbolic link or not a folder, or ``path`` exists, is not
        recorded as written by bayesnsi and the output folder was not forced.
    OSError
        A write fault (full disk, file size limit, permissions): nothing is left behind.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    target = Path(os.path.abspath(path))
    root = _root_of(target)
    dir_fd = _open_folder(target.parent, root)
    try:
        if root is not None:
            _check_replaceable(root, target, dir_fd)
        tmp_name, fd = create_temporary(target.name, dir_fd, target.parent)
        try:
            opened: IO = os.fdopen(fd, "wb") if "b" in mode else os.fdopen(fd, "w", encoding=encoding, newline="")
            with opened as fh:
                yield fh
                fh.flush()
                os.fsync(fh.fileno())
            digest = _digest(tmp_name if dir_fd is not None else target.parent / tmp_name, dir_fd) if root else None
            _replace(tmp_name, target, dir_fd)
        except BaseException:
            with contextlib.suppress(OSError):
                _unlink(tmp_name, dir_fd, target.parent)
            raise
        _fsync(dir_fd)
        if root is not None and digest is not None:
            _record(root, target, digest)
    finally:
        if dir_fd is not None:
            os.close(dir_fd)


def create_temporary(name: str, dir_fd: int | None, folder: Path, readable: bool = False) -> tuple[str, int]:
    """Create ``.<name>.<random>.tmp`` exclusively, never through a link; return its name and descriptor.

    Parameters
    ----------
    name : str
        Target file name.
    dir_fd : int or None
        Descriptor of the folder (None where ``dir_fd`` is not supported: ``folder`` is used).
    folder : Path
        The folder.
    readable : bool
        Open it for reading too.

    Returns
    -------
    (str, int)
        The temporary file's name (relative to the folder) and a descriptor open for writing.
    """
    access = os.O_RDWR if readable else os.O_WRONLY
    flags = access | os.O_CREAT | os.O_EXCL | _NOFOLLOW | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0)
    for _ in range(100):
        tmp = f".{name[:200]}.{secrets.token_hex(8)}.tmp"
        try:
            if dir_fd is not None:
                return tmp, os.open(tmp, flags, FILE_MODE, dir_fd=dir_fd)
            return tmp, os.open(folder / tmp, flags, FILE_MODE)
        except FileExistsError:
            continue
    raise FileExistsError(f"could not create a temporary file beside {folder / name}")


def read_bounded(path: Path, limit: int, dir_fd: int | None = None) -> bytes | None:
    """The bytes of a regular file (never through a link); None when absent, larger than ``limit`` or not regular.

    Parameters
    ----------
    path : Path
        The file (its name only when ``dir_fd`` is given).
    limit : int
        Largest size read [bytes].
    dir_fd : int, optional
        Folder descriptor.

    Returns
    -------
    bytes or None
    """
    flags = os.O_RDONLY | _NOFOLLOW | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        info = os.stat(path, dir_fd=dir_fd, follow_symlinks=False) if dir_fd is not None else os.lstat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size > limit:
            return None
        fd = os.open(path, flags, dir_fd=dir_fd) if dir_fd is not None else os.open(path, flags)
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        data = os.read(fd, limit + 1)
    except OSError:
        return None
    finally:
        os.close(fd)
    return data if len(data) <= limit else None


def _root_of(target: Path) -> _Root | None:
    for folder, root in _ROOTS.items():
        if target.parent == folder or folder in target.parent.parents:
            return root
    return None


def _open_folder(folder: Path, root: _Root | None) -> int | None:
    """A descriptor of ``folder``; below an output folder each step is opened without following a link."""
    if not _DIR_FD:
        if root is not None:
            for part in [folder, *folder.parents]:
                if part == root.folder:
                    break
                if part.is_symlink() or (part.exists() and not part.is_dir()):
                    raise _not_a_folder(part, root)
        if root is not None:
            folder.mkdir(parents=True, exist_ok=True)
        return None
    if root is None:
        if not folder.is_dir():
            raise FileNotFoundError(f"cannot write into {folder}: the folder does not exist; create it first")
        return os.open(folder, _DIR_FLAGS)
    fd = os.open(root.folder, _DIR_FLAGS | _NOFOLLOW)
    current = root.folder
    try:
        for step in folder.relative_to(root.folder).parts:
            current = current / step
            with contextlib.suppress(FileExistsError):
                os.mkdir(step, 0o755, dir_fd=fd)
            try:
                child = os.open(step, _DIR_FLAGS | _NOFOLLOW, dir_fd=fd)
            except OSError as exc:
                if exc.errno in (getattr(os, "ELOOP", -1), getattr(os, "ENOTDIR", -1)):
                    raise _not_a_folder(current, root) from None
                raise
            os.close(fd)
            fd = child
    except BaseException:
        os.close(fd)
        raise
    return fd


def _not_a_folder(path: Path, root: _Root) -> OutputExistsError:
    return OutputExistsError(
        f"{path} is a symbolic link or a file, not a folder; bayesnsi writes only into real folders inside "
        f"{root.folder}: move it away or choose another --out"
    )


def _check_replaceable(root: _Root, target: Path, dir_fd: int | None) -> None:
    relative = target.relative_to(root.folder).as_posix()
    if root.force or relative.split("/")[0] in _UNTRACKED:
        return
    try:
        os.stat(target.name, dir_fd=dir_fd, follow_symlinks=False) if dir_fd is not None else os.lstat(target)
    except FileNotFoundError:
        return
    with root.guard:
        recorded = root.files.get(relative)
    if recorded is None or _digest(target) != recorded:
        raise OutputExistsError(
            f"{target} exists and was not written by bayesnsi; pass --force to overwrite it, or choose another --out"
        )


def _record(root: _Root, target: Path, digest: str) -> None:
    relative = target.relative_to(root.folder).as_posix()
    if relative.split("/")[0] in _UNTRACKED:
        return
    with root.guard:
        root.files[relative] = digest
        document = {"format": 1, "files": dict(sorted(root.files.items()))}
    with safe_open(root.folder / MANIFEST_FILENAME, "w") as fh:
        json.dump(document, fh, indent=1)


def read_manifest(folder: Path) -> dict[str, str]:
    """The files the manifest of ``folder`` records (relative path -> SHA-256); empty when absent or not valid.

    Parameters
    ----------
    folder : Path

    Returns
    -------
    dict of str to str
    """
    data = read_bounded(folder / MANIFEST_FILENAME, MAX_MANIFEST_BYTES)
    if data is None:
        return {}
    try:
        document = json.loads(data.decode("utf-8"))
    except (ValueError, RecursionError):
        return {}
    files = document.get("files") if isinstance(document, dict) else None
    if not isinstance(files, dict):
        return {}
    return {k: v for k, v in files.items() if isinstance(k, str) and isinstance(v, str) and len(v) == 64}


def _digest(path: Path | str, dir_fd: int | None = None) -> str | None:
    """SHA-256 of a regular file read without following a link (None for anything else)."""
    flags = os.O_RDONLY | _NOFOLLOW | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags, dir_fd=dir_fd) if dir_fd is not None else os.open(path, flags)
    except OSError:
        return None
    digest = hashlib.sha256()
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        while chunk := os.read(fd, 2**20):
            digest.update(chunk)
    except OSError:
        return None
    finally:
        os.close(fd)
    return digest.hexdigest()


def _replace(tmp_name: str, target: Path, dir_fd: int | None) -> None:
    if dir_fd is not None:
        os.replace(tmp_name, target.name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
    else:
        os.replace(target.parent / tmp_name, target)


def _unlink(tmp_name: str, dir_fd: int | None, folder: Path) -> None:
    if dir_fd is not None:
        os.unlink(tmp_name, dir_fd=dir_fd)
    else:
        os.unlink(folder / tmp_name)


def _fsync(dir_fd: int | None) -> None:
    if dir_fd is None:
        return
    with contextlib.suppress(OSError):
        os.fsync(dir_fd)
