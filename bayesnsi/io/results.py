"""Writing results safely: atomic files, JSON conversion, version records, output folders.

Every file bayesnsi writes goes through :func:`atomic_open` (or the two helpers built on it),
that is :func:`bayesnsi.io._safe_write.safe_open`: the content is written to a new temporary file
with a random name in the target's folder (created exclusively, never through a link, mode 0644
less the umask), flushed to disk and then renamed over the target with :func:`os.replace`, so a
reader never sees a half-written file and an interrupted run leaves the previous file intact
(STYLE section 3, item 14). Inside an output folder held by :func:`output_folder`, linked
sub-folders are refused and only files bayesnsi wrote (its manifest) are replaced without ``force``.

``results.json`` (docs/method.md §9) holds plain JSON only: :func:`to_jsonable` converts numpy
scalars and arrays, tuples, paths and dataclasses, and writes NaN and ±Inf as ``null``
(JSON has no NaN).
"""

from __future__ import annotations

import contextlib
import dataclasses
import enum
import functools
import importlib.metadata
import json
import math
import os
import platform
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np

from ..exceptions import ConfigError, OutputExistsError
from ._safe_write import owned_by_bayesnsi, read_manifest, register_root, safe_open, unregister_root

__all__ = [
    "RESULTS_FILENAME",
    "atomic_open",
    "atomic_write_text",
    "atomic_write_json",
    "to_jsonable",
    "versions",
    "prepare_output_dir",
    "output_folder",
]

RESULTS_FILENAME = "results.json"
"""Name of the results file that ``bayesnsi select`` and ``bayesnsi diagnose`` write."""

_OUTPUT_FILENAMES = (RESULTS_FILENAME, "report.html")
"""Files whose presence marks a folder as holding the outputs of an earlier run."""

_OUTPUT_SUBFOLDERS = ("posterior",)
"""Folders inside an output folder that bayesnsi writes files into (:data:`bayesnsi.io.posterior.POSTERIOR_DIRNAME`)."""

_CACHE_DIRNAME = ".cache"
"""Folder of the candidate cache (:data:`bayesnsi.io.cache.CACHE_DIRNAME`, which imports this module)."""

_OPTIONAL_PACKAGES = (
    "pandas",
    "emcee",
    "arviz",
    "arviz-base",
    "arviz-stats",
    "arviz-plots",
    "xarray",
    "h5netcdf",
    "matplotlib",
    "joblib",
    "dask",
    "distributed",
)


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", encoding: str = "utf-8") -> Iterator[IO]:
    """Open a temporary file that replaces ``path`` only when the block ends without error.

    Parameters
    ----------
    path : str or path-like
        Target file. Its folder must exist.
    mode : {"w", "wb"}
        Text or binary writing.
    encoding : str
        Text encoding (ignored in binary mode).

    Yields
    ------
    file object
        Write to it inside the ``with`` block. On success the data are flushed, fsync'ed and
        the temporary file is renamed over ``path`` (:func:`os.replace`, atomic on POSIX and
        Windows); on an exception the temporary file is removed and ``path`` is untouched.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "note.txt"
    >>> with atomic_open(target) as fh:
    ...     _ = fh.write("done")
    >>> target.read_text()
    'done'
    """
    with safe_open(path, mode, encoding) as fh:
        yield fh


def atomic_write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (temporary file in the same folder, then rename).

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist.
    text : str
        Content. Line endings are written exactly as given.
    encoding : str
        Text encoding.

    Returns
    -------
    Path
        The path written.
    """
    with atomic_open(path, "w", encoding=encoding) as fh:
        fh.write(text)
    return Path(path)


def atomic_write_json(path: str | os.PathLike, obj: Any, indent: int | None = 2) -> Path:
    """Write ``obj`` as JSON atomically, after :func:`to_jsonable` (NaN/Inf become ``null``).

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist.
    obj : object
        Anything :func:`to_jsonable` accepts.
    indent : int or None
        Indentation of the JSON text.

    Returns
    -------
    Path
        The path written.
    """
    text = json.dumps(to_jsonable(obj), indent=indent, allow_nan=False, ensure_ascii=False)
    return atomic_write_text(path, text + "\n")


def to_jsonable(obj: Any) -> Any:
    """Convert results to plain JSON values, recursively.

    Parameters
    ----------
    obj : object
        Built from dicts (any mapping), lists, tuples, sets, str, bool, int, float, None,
        numpy scalars and arrays, :class:`pathlib.Path`, enums, dataclass instances and
        objects with a ``to_dict()`` method.

    Returns
    -------
    object
        Only dict (str keys), list, str, int, float, bool and None. NaN and ±Inf become
        ``None``; complex numbers become ``{"real": ..., "imag": ...}``; arrays become nested
        lists; sets become sorted lists; paths become POSIX strings.

    Raises
    ------
    TypeError
        For any other type, naming where in ``obj`` it was found.

    Examples
    --------
    >>> import numpy as np
    >>> to_jsonable({"x": np.array([1.0, np.nan]), "n": np.int64(3)})
    {'x': [1.0, None], 'n': 3}
    """
    return _convert(obj, "obj")


def versions() -> dict[str, str]:
    """Versions of Python, the platform, bayesnsi and its numerical dependencies.

    Optional packages (pandas, emcee, arviz*, xarray, matplotlib, joblib, dask, distributed)
    are listed when installed;
    they are looked up with :mod:`importlib.metadata` and never imported.

    Returns
    -------
    dict of str to str
        Keys ``python``, ``platform``, ``bayesnsi``, ``numpy``, ``scipy`` and any installed
        optional package.
    """
    from .. import __version__

    found = {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "bayesnsi": __version__,
        "numpy": np.__version__,
        "scipy": _distribution_version("scipy") or "not installed",
    }
    for name in _OPTIONAL_PACKAGES:
        version = _distribution_version(name)
        if version is not None:
            found[name] = version
    return found


def prepare_output_dir(path: str | os.PathLike, force: bool = False) -> Path:
    """Create an output directory, refusing to overwrite earlier outputs unless forced.

    Parameters
    ----------
    path : str or path-like
        Directory to create (with its parents).
    force : bool
        When True existing outputs (``results.json``, ``report.html``) may be overwritten later;
        nothing is deleted here.

    Returns
    -------
    Path
        The directory, absolute.

    Raises
    ------
    OutputExistsError
        If ``path`` (or one of its parents, or ``path/.cache``) is a file, or ``path`` already
        holds ``results.json``, ``report.html`` or posterior files and ``force`` is False, or
        ``path/posterior`` is a file or a symbolic link. A ``report.html`` and posterior files
        that the folder's manifest records as written by bayesnsi, without a ``results.json``
        beside them (a run that failed before its last file, which is ``results.json``), do not
        count: such a folder is resumed.
    ConfigError
        If ``path`` starts with ``~user`` for a user that does not exist.
    """
    folder = _resolve_output(path)
    _check_outputs(folder, force)
    _make_folder(folder)
    return folder


@contextlib.contextmanager
def output_folder(
    path: str | os.PathLike, force: bool = False, *, config: str | os.PathLike | None = None
) -> Iterator[Path]:
    """Create and lock an output directory for one run; refuse earlier outputs unless forced.

    Does what :func:`prepare_output_dir` does while holding an exclusive lock on the folder
    (``DIR/.bayesnsi.lock``, see :func:`bayesnsi.io._lock.folder_lock`), so two runs started at
    once into the same folder cannot both write it: the second stops with one line. The check
    for earlier outputs is made under the lock. A lock left by a killed run is taken over.

    Parameters
    ----------
    path : str or path-like
        Directory to create (with its parents).
    force : bool
        When True existing outputs may be overwritten.
    config : str or path-like, optional
        The run's config, recorded in the lock file for the message a second run prints.

    Yields
    ------
    Path
        The directory, absolute; the lock is released when the block ends (also on error).

    Raises
    ------
    OutputExistsError
        As :func:`prepare_output_dir`, or when another live bayesnsi run holds the folder.
    OSError
        If the folder or its lock cannot be written (read-only file system, full disk).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with output_folder(pathlib.Path(tempfile.mkdtemp()) / "run") as out:
    ...     _ = atomic_write_text(out / "note.txt", "done")
    """
    from ._lock import folder_lock

    folder = _resolve_output(path)
    _make_folder(folder)
    with folder_lock(folder, config):
        _check_outputs(folder, force)
        register_root(folder, force)
        try:
            yield folder
        finally:
            unregister_root(folder)


def _resolve_output(path: str | os.PathLike) -> Path:
    from .._text import check_path_text

    if not str(path).strip():
        raise ConfigError("the output folder is an empty path; give a folder with --out (e.g. --out results)")
    check_path_text(path, "output folder")
    try:
        folder = Path(path).expanduser().resolve()
    except RuntimeError as exc:  # "~user" that names no user
        raise ConfigError(f"output path {str(path)!r}: {exc}; write the path without '~'") from exc
    for part in (folder, *folder.parents):
        if part.exists() and not part.is_dir():
            raise OutputExistsError(f"output path {part} exists and is a file, not a directory; choose another --out")
    return folder


def _check_outputs(folder: Path, force: bool) -> None:
    cache = folder / _CACHE_DIRNAME
    if cache.exists() and not cache.is_dir():
        raise OutputExistsError(
            f"{cache} is a file, but bayesnsi keeps its candidate cache in a folder of that name; "
            "move the file away or choose another --out"
        )
    for name in _OUTPUT_SUBFOLDERS:
        sub = folder / name
        if sub.is_symlink() or (sub.exists() and not sub.is_dir()):
            raise OutputExistsError(
                f"{sub} is a symbolic link or a file, but bayesnsi writes its {name} files into a real folder of "
                "that name; move it away or choose another --out"
            )
    if force:
        return
    for name in _OUTPUT_FILENAMES:
        if os.path.lexists(folder / name) and not _resumable(folder, name):
            raise OutputExistsError(
                f"output directory {folder} already holds {name}; pass --force to overwrite it, "
                "or choose another directory with --out"
            )
    manifest = read_manifest(folder)
    for name in _OUTPUT_SUBFOLDERS:
        if not (folder / name).is_dir():
            continue
        for entry in sorted((folder / name).iterdir()):
            relative = f"{name}/{entry.name}"
            if not owned_by_bayesnsi(folder, relative, manifest):
                raise OutputExistsError(
                    f"output directory {folder} holds {relative}, not written by bayesnsi; pass --force to "
                    "overwrite it, or choose another directory with --out"
                )


def _resumable(folder: Path, name: str) -> bool:
    """True for a report bayesnsi wrote (its manifest says so) without results.json: a run that failed at the end."""
    if name != "report.html" or os.path.lexists(folder / RESULTS_FILENAME):
        return False
    return owned_by_bayesnsi(folder, name)


def _make_folder(folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError) as exc:
        raise OutputExistsError(
            f"cannot create output directory {folder}: {exc.strerror}; choose another --out"
        ) from exc


def _convert(obj: Any, where: str) -> Any:
    if obj is None or isinstance(obj, (str, bool)):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, complex):
        return {"real": _convert(obj.real, where), "imag": _convert(obj.imag, where)}
    if isinstance(obj, np.generic):
        return _convert(obj.item(), where)
    if isinstance(obj, np.ndarray):
        return _convert(obj.tolist(), where)
    if isinstance(obj, Mapping):
        return {_key(k, where): _convert(v, f"{where}[{k!r}]") for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_convert(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    if isinstance(obj, (set, frozenset)):
        return [_convert(v, f"{where}[{i}]") for i, v in enumerate(sorted(obj, key=repr))]
    if isinstance(obj, os.PathLike):
        return Path(obj).as_posix()
    if isinstance(obj, enum.Enum):
        return _convert(obj.value, where)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _convert(getattr(obj, f.name), f"{where}.{f.name}") for f in dataclasses.fields(obj)}
    if callable(getattr(obj, "to_dict", None)):
        return _convert(obj.to_dict(), f"{where}.to_dict()")
    raise TypeError(
        f"cannot convert {type(obj).__name__} at {where} to JSON; convert it to numbers, "
        "strings, lists or dicts first (or give its class a to_dict() method)"
    )


def _key(key: Any, where: str) -> str:
    if isinstance(key, str):
        return key
    if isinstance(key, (bool, int, float, np.generic)) or key is None:
        return str(_convert(key, where))
    if isinstance(key, os.PathLike):
        return Path(key).as_posix()
    raise TypeError(f"cannot use a {type(key).__name__} as a JSON key at {where}; use strings")


@functools.cache  # results.json and the report list them: looked up once per process
def _distribution_version(name: str) -> str | None:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return None
