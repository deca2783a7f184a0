"""Per-candidate result cache: what makes an interrupted run resumable.

``bayesnsi identify/select/diagnose CONFIG --out DIR`` store each candidate's outcome (its
results.json record, the :class:`~bayesnsi.nsi.NSIResult` and the evidence results) in
``DIR/.cache/<key>.pkl`` as soon as the candidate finishes, atomically (temporary file, then
rename). A rerun into the same folder loads every entry whose key matches and computes only the
rest, so a run killed at any moment (SIGINT, SIGKILL, a crashed machine) loses at most the
candidates that were running.

The key (:func:`candidate_key`) is the SHA-256 of everything the outcome depends on: the
estimation data (:func:`signals_fingerprint`: every array, fs, DOFs and names), the candidate
(name, prior, terms, prior scales), the NSI and evidence settings, the candidate's seed
sequence, and the code (:func:`code_fingerprint`: bayesnsi's version, a digest of its source
files and the versions of numpy, scipy, pandas and emcee). Any change gives a new key, so a
stale entry is never used; old entries are simply not read (delete ``DIR/.cache`` to reclaim
the space).

Entries are pickles read by a restricted unpickler (:func:`load_entry`) that only accepts the
classes and functions bayesnsi, numpy and pandas results are built from; anything else (e.g. a
file planted to run code on load) is refused with a :class:`~bayesnsi.exceptions.CacheWarning`
and the candidate is recomputed. This is defence in depth, not a sandbox: keep output folders
writable only by people you trust.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.metadata
import io
import json
import os
import pickle
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import CacheWarning
from .results import atomic_open, to_jsonable

__all__ = [
    "CACHE_DIRNAME",
    "CACHE_FORMAT",
    "ResultCache",
    "candidate_key",
    "code_fingerprint",
    "load_entry",
    "signals_fingerprint",
]

CACHE_DIRNAME = ".cache"
"""Name of the cache folder inside an output directory."""

CACHE_FORMAT = 1
"""Layout version of a cache entry; entries of another layout are ignored."""

_KEYED_PACKAGES = ("numpy", "scipy", "pandas", "emcee")
_STALE_TEMPORARY_S = 60.0

# Globals a cache entry may reference (module prefix -> allowed names; None: any class).
_ALLOWED_FUNCTIONS = {
    ("bayesnsi.models.expressions", "parse_expression"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.numeric", "_frombuffer"),
    ("numpy.core.numeric", "_frombuffer"),
    ("pandas._libs.internals", "_unpickle_block"),
    ("pandas.core.indexes.base", "_new_Index"),
    ("pandas.core.internals.blocks", "new_block"),
    ("copyreg", "_reconstructor"),
    ("collections", "OrderedDict"),
}
_ALLOWED_BUILTINS = {"complex", "slice", "frozenset", "set", "range", "bytearray", "object", "tuple", "list", "dict"}
_CLASS_MODULES = ("bayesnsi.", "numpy", "pandas")
_DENIED_MODULE_PARTS = ("testing", "f2py", "distutils", "ctypeslib", ".io", "_pickle", "compat")


def signals_fingerprint(signals) -> str:
    """SHA-256 of a :class:`~bayesnsi.signals.Signals`: every array's bytes, fs, DOFs and names.

    Parameters
    ----------
    signals : Signals

    Returns
    -------
    str
        64 hex digits; equal for equal data, whatever the memory layout of the arrays.
    """
    digest = hashlib.sha256(b"bayesnsi-signals-1")
    for item in dataclasses.fields(signals):
        value = getattr(signals, item.name)
        digest.update(item.name.encode())
        if isinstance(value, np.ndarray):
            array = np.ascontiguousarray(value, dtype=float)
            digest.update(repr(array.shape).encode())
            digest.update(array.tobytes())
        else:
            digest.update(json.dumps(to_jsonable(value)).encode())
    return digest.hexdigest()


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """SHA-256 of bayesnsi's version, its source files and the numerical packages' versions.

    Computed once per process. A changed line anywhere in the package (e.g. a bug fix without a
    version bump) gives a new fingerprint, so cached results of the old code are not reused.

    Returns
    -------
    str
        64 hex digits.
    """
    from .. import __version__

    package = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256(f"bayesnsi {__version__}".encode())
    for name in _KEYED_PACKAGES:
        digest.update(f"{name} {_version(name)}".encode())
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def candidate_key(data_fingerprint: str, candidate, nsi_options, evidence_options, seed_sequence) -> str:
    """Cache key of one candidate's outcome (SHA-256 of everything it depends on).

    Parameters
    ----------
    data_fingerprint : str
        :func:`signals_fingerprint` of the estimation data.
    candidate : CandidateModel
    nsi_options : mapping
        Keyword arguments of :func:`bayesnsi.nsi.identify`.
    evidence_options : mapping or None
        Evidence settings (None: no evidence is computed).
    seed_sequence : numpy.random.SeedSequence
        The candidate's seed sequence.

    Returns
    -------
    str
        64 hex digits.
    """
    definition = {
        "format": CACHE_FORMAT,
        "data": data_fingerprint,
        "code": code_fingerprint(),
        "candidate": {
            "name": candidate.name,
            "prior": candidate.prior,
            "terms": [[t.expr.text, t.at_value] for t in candidate.terms],
            "prior_scales": list(candidate.coefficient_prior_scales),
        },
        "nsi": dict(nsi_options),
        "evidence": None if evidence_options is None else dict(evidence_options),
        "seed": {
            "entropy": seed_sequence.entropy,
            "spawn_key": list(seed_sequence.spawn_key),
            "pool_size": seed_sequence.pool_size,
        },
    }
    text = json.dumps(to_jsonable(definition), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


class ResultCache:
    """Cache entries of one output directory (``DIR/.cache``).

    Parameters
    ----------
    folder : str or path-like
        The cache folder; created on the first :meth:`store`.
    read : bool
        Use stored entries (False: recompute everything, but still store fresh entries, so a
        later rerun can resume - what ``--no-cache`` does).

    Examples
    --------
    >>> import tempfile
    >>> cache = ResultCache(tempfile.mkdtemp())
    >>> cache.store("ab" * 32, {"value": 1.5})
    >>> cache.load("ab" * 32)
    {'value': 1.5}
    """

    def __init__(self, folder: str | os.PathLike, read: bool = True):
        self.folder = Path(folder)
        self.read = read
        self._remove_stale_temporaries()

    def path(self, key: str) -> Path:
        """File of the entry ``key``."""
        if len(key) != 64 or any(c not in "0123456789abcdef" for c in key):
            raise ValueError(f"cache key must be 64 lower-case hex digits, got {key!r}")
        return self.folder / f"{key}.pkl"

    def keys(self) -> list[str]:
        """Keys of the entries on disk (valid or not)."""
        if not self.folder.is_dir():
            return []
        return sorted(p.stem for p in self.folder.glob("*.pkl") if len(p.stem) == 64)

    def load(self, key: str) -> Any | None:
        """The stored outcome of ``key``, or None when absent, unreadable or reading is off.

        An entry that cannot be read (truncated, corrupt, another layout, or referencing a
        class outside the allowed set) gives a :class:`~bayesnsi.exceptions.CacheWarning` and
        None, so the candidate is recomputed and its entry rewritten.
        """
        path = self.path(key)
        if not self.read or not path.is_file():
            return None
        try:
            return load_entry(path, key)
        except Exception as exc:  # noqa: BLE001 - any unreadable entry is recomputed
            warnings.warn(
                f"ignoring cache entry {path.name} ({type(exc).__name__}: {exc}); the candidate is recomputed",
                CacheWarning,
                stacklevel=2,
            )
            return None

    def store(self, key: str, outcome: Any) -> None:
        """Write ``outcome`` under ``key`` atomically (temporary file in the folder, then rename)."""
        path = self.path(key)
        self.folder.mkdir(parents=True, exist_ok=True)
        entry = {"format": CACHE_FORMAT, "key": key, "outcome": outcome}
        with atomic_open(path, "wb") as fh:
            pickle.dump(entry, fh, protocol=pickle.HIGHEST_PROTOCOL)

    def _remove_stale_temporaries(self) -> None:
        """Delete temporary files left by a killed run (older than a minute)."""
        if not self.folder.is_dir():
            return
        now = time.time()
        for tmp in self.folder.glob(".*.tmp"):
            try:
                if now - tmp.stat().st_mtime > _STALE_TEMPORARY_S:
                    tmp.unlink()
            except FileNotFoundError:
                pass


def load_entry(path: str | os.PathLike, key: str | None = None) -> Any:
    """Read one cache entry with the restricted unpickler and return its outcome.

    Parameters
    ----------
    path : str or path-like
        The entry file.
    key : str, optional
        Expected key; an entry that records another key is refused.

    Returns
    -------
    object
        The stored outcome.

    Raises
    ------
    pickle.UnpicklingError
        If the entry references a global outside the allowed set, or is not an entry of
        this layout or key. Truncated files raise EOFError or UnpicklingError.
    """
    data = Path(path).read_bytes()
    entry = _RestrictedUnpickler(io.BytesIO(data)).load()
    if not isinstance(entry, dict) or entry.get("format") != CACHE_FORMAT or "outcome" not in entry:
        raise pickle.UnpicklingError(f"not a bayesnsi cache entry of layout {CACHE_FORMAT}")
    if key is not None and entry.get("key") != key:
        raise pickle.UnpicklingError(f"entry is stored for key {str(entry.get('key'))[:12]}..., not {key[:12]}...")
    return entry["outcome"]


class _RestrictedUnpickler(pickle.Unpickler):
    """Unpickler that resolves only the globals results are made of (see the module notes)."""

    def find_class(self, module: str, name: str):
        if _allowed(module, name):
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"global {module}.{name} is not allowed in a cache entry")


def _allowed(module: str, name: str) -> bool:
    if (module, name) in _ALLOWED_FUNCTIONS:
        return True
    if module == "builtins":
        return name in _ALLOWED_BUILTINS
    if module.startswith("pandas._libs") and name.startswith("__pyx_unpickle_"):
        return True
    in_scope = module == "numpy" or module == "pandas" or module.startswith(_CLASS_MODULES)
    if not in_scope or any(part in module for part in _DENIED_MODULE_PARTS) or name.startswith("_"):
        return False
    try:
        found = pickle.Unpickler.find_class(pickle.Unpickler(io.BytesIO()), module, name)
    except (ImportError, AttributeError):
        return False
    return isinstance(found, type) and not issubclass(found, BaseException)


def _version(name: str) -> str:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"
