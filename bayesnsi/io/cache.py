"""Per-candidate result cache: what makes an interrupted run resumable.

``bayesnsi identify/select/diagnose CONFIG --out DIR`` store each candidate's outcome (a
:class:`~bayesnsi.run.batch.CandidateOutcome`: NSI result, evidences, errors, warnings, time) in
``DIR/.cache/<key>.npz`` as soon as the candidate finishes, atomically (temporary file in the
folder, then :func:`os.replace`). A rerun into the same folder loads every entry whose key
matches and computes only the rest, so a run killed at any moment loses at most the candidates
that were running.

The key (:meth:`ResultCache.key`, :func:`candidate_key`) is the SHA-256 of everything the outcome
depends on: the estimation data (:func:`bayesnsi._fingerprint.signals_fingerprint`), the
candidate (name, prior, terms, prior scales), the NSI and evidence options (``to_dict()``), the
candidate's seed sequence, the entry format and the code
(:func:`bayesnsi._fingerprint.code_fingerprint`). Any change gives a new key, so a stale entry is
never used; old entries are simply not read (delete ``DIR/.cache`` to reclaim the space).

An entry cannot run code: it is JSON (structure and scalars) plus ``.npy`` arrays in one ZIP
(:mod:`bayesnsi.io._store`), read with ``numpy.load(..., allow_pickle=False)`` after every size,
dtype and shape has been checked against the memory limit (:func:`bayesnsi._limits.max_memory_bytes`,
``BAYESNSI_MAX_MEMORY``) and the schema of the result classes (:mod:`bayesnsi.io._outcome`).
The entry records its key, compared when read. Any entry that is not valid - truncated, corrupt,
foreign, of an older format (including the pickles of earlier versions), for another key or
candidate, or a symbolic link - is ignored with a :class:`~bayesnsi.exceptions.CacheWarning`
naming it, and the candidate is recomputed and its entry rewritten.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from .._fingerprint import code_fingerprint, signals_fingerprint
from .._limits import check_allocation
from ..exceptions import BayesNSIError, CacheWarning
from ._outcome import outcome_from_plain, outcome_to_plain
from ._store import EntryError, read_container, write_container
from .results import _CACHE_DIRNAME, atomic_open, to_jsonable

if TYPE_CHECKING:
    from ..models import CandidateModel

__all__ = ["CACHE_DIRNAME", "CACHE_FORMAT", "ENTRY_SUFFIX", "ResultCache", "candidate_key", "load_entry"]

CACHE_DIRNAME = _CACHE_DIRNAME
"""Name of the cache folder inside an output directory."""

CACHE_FORMAT = 4
"""Layout version of a cache entry (entries of other versions are not read)."""

ENTRY_SUFFIX = ".npz"
"""File suffix of an entry."""

_LEGACY_SUFFIX = ".pkl"
_STALE_TEMPORARY_S = 60.0
_HEX = frozenset("0123456789abcdef")


def candidate_key(data_fingerprint: str, candidate, nsi, evidence, seed_sequence) -> str:
    """Cache key of one candidate's outcome (SHA-256 of everything it depends on).

    Parameters
    ----------
    data_fingerprint : str
        :func:`~bayesnsi._fingerprint.signals_fingerprint` of the estimation data.
    candidate : CandidateModel
    nsi : NSIOptions
        Settings of the identification.
    evidence : EvidenceOptions or None
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
        "nsi": nsi.to_dict(),
        "evidence": None if evidence is None else evidence.to_dict(),
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
        The cache folder; created on the first :meth:`store`. A folder that is a symbolic link
        is not used (a warning says so), so entries are never read or written elsewhere.
    read : bool
        Use stored entries (False: recompute everything, but still store fresh entries, so a
        later rerun can resume - what ``--no-cache`` does).

    Examples
    --------
    >>> import tempfile
    >>> cache = ResultCache(tempfile.mkdtemp())
    >>> cache.load("ab" * 32) is None
    True
    """

    def __init__(self, folder: str | os.PathLike, read: bool = True):
        self.folder = Path(folder)
        self.read = read
        self._expected: dict[str, CandidateModel] = {}
        self._fingerprints: dict[int, tuple[object, str]] = {}
        self._remove_stale_temporaries()

    def key(self, signals, candidate, nsi, evidence, seed_sequence) -> str:
        """Key of a candidate's outcome (see :func:`candidate_key`); remembers the candidate.

        Parameters
        ----------
        signals : Signals
            Estimation data (its fingerprint is computed once per object).
        candidate : CandidateModel
        nsi : NSIOptions
        evidence : EvidenceOptions or None
        seed_sequence : numpy.random.SeedSequence

        Returns
        -------
        str
            64 hex digits. :meth:`load` of this key refuses an entry for another candidate.
        """
        held = self._fingerprints.get(id(signals))
        if held is None or held[0] is not signals:
            held = self._fingerprints[id(signals)] = (signals, signals_fingerprint(signals))
        key = candidate_key(held[1], candidate, nsi, evidence, seed_sequence)
        self._expected[key] = candidate
        return key

    def path(self, key: str) -> Path:
        """File of the entry ``key``.

        Raises
        ------
        ValueError
            If ``key`` is not 64 lower-case hex digits (so it can never name another folder).
        """
        if not isinstance(key, str) or len(key) != 64 or not set(key) <= _HEX:
            raise ValueError(f"cache key must be 64 lower-case hex digits, got {key!r}")
        return self.folder / f"{key}{ENTRY_SUFFIX}"

    def keys(self) -> list[str]:
        """Keys of the entries on disk (valid or not)."""
        if not self._usable():
            return []
        return sorted(p.stem for p in self.folder.glob(f"*{ENTRY_SUFFIX}") if len(p.stem) == 64 and set(p.stem) <= _HEX)

    def load(self, key: str):
        """The stored outcome of ``key``, or None when absent, not valid or reading is off.

        Parameters
        ----------
        key : str
            From :meth:`key`.

        Returns
        -------
        CandidateOutcome or None
            With ``cached = True``. An entry that is not valid (see the module notes) gives a
            :class:`~bayesnsi.exceptions.CacheWarning` naming it and None, so the candidate is
            recomputed and its entry rewritten.
        """
        path = self.path(key)
        if not self.read or not self._usable():
            return None
        legacy = path.with_suffix(_LEGACY_SUFFIX)
        if os.path.lexists(legacy):
            _warn(f"ignoring cache entry {legacy.name}: an older format (pickle), never read")
        if not os.path.lexists(path):
            return None
        try:
            outcome = load_entry(path, key)
            expected = self._expected.get(key)
            if expected is not None and outcome.candidate != expected:
                raise EntryError(f"{path.name} holds candidate {outcome.candidate.name!r}, not {expected.name!r}")
        except Exception as exc:  # noqa: BLE001 - any entry that cannot be used is recomputed
            _warn(f"ignoring cache entry {path.name} ({type(exc).__name__}: {exc})")
            return None
        return outcome

    def store(self, key: str, outcome) -> None:
        """Write ``outcome`` under ``key`` atomically (temporary file in the folder, then rename).

        Parameters
        ----------
        key : str
            From :meth:`key`.
        outcome : CandidateOutcome
            Stored with everything it holds except ``cached``.

        Notes
        -----
        An outcome that cannot be stored (a value the schema does not describe, a full disk)
        gives a :class:`~bayesnsi.exceptions.CacheWarning` and is not cached; the run goes on.
        """
        path = self.path(key)
        if self.folder.is_symlink():
            self._usable()  # warns
            return
        try:
            document, arrays = outcome_to_plain(outcome)
            self.folder.mkdir(parents=True, exist_ok=True)
            with atomic_open(path, "wb") as fh:
                write_container(fh, {"format": CACHE_FORMAT, "key": key, "outcome": document}, arrays)
        except (TypeError, ValueError, OSError) as exc:
            name = getattr(outcome, "name", "?")
            _warn(f"candidate {name!r} not cached in {path.name} ({type(exc).__name__}: {exc})", recomputed=False)

    def _usable(self) -> bool:
        """True when the folder is a real folder (not a symbolic link); warns otherwise."""
        if self.folder.is_symlink():
            _warn(f"cache folder {self.folder} is a symbolic link; it is not used", recomputed=False)
            return False
        return self.folder.is_dir()

    def _remove_stale_temporaries(self) -> None:
        """Delete temporary files left by a killed run (older than a minute)."""
        if not self.folder.is_dir() or self.folder.is_symlink():
            return
        now = time.time()
        for tmp in self.folder.glob(".*.tmp"):
            try:
                info = tmp.lstat()
                if stat.S_ISREG(info.st_mode) and now - info.st_mtime > _STALE_TEMPORARY_S:
                    tmp.unlink()
            except FileNotFoundError:
                pass


def load_entry(path: str | os.PathLike, key: str | None = None):
    """Read one cache entry and return its outcome.

    Parameters
    ----------
    path : str or path-like
        The entry file. A symbolic link, or anything but a regular file, is refused.
    key : str, optional
        Expected key; an entry that records another key is refused.

    Returns
    -------
    CandidateOutcome
        With ``cached = True``.

    Raises
    ------
    EntryError
        If the file is not a valid entry of this format and key (what is wrong is said).
    InputDataError
        If the file is larger than the memory limit (:func:`bayesnsi._limits.max_memory_bytes`).
    OSError
        If the file cannot be opened (e.g. it is a symbolic link).
    """
    path = Path(path)
    data = _read_regular_file(path)
    document, arrays = read_container(data, path.name)
    if not isinstance(document, dict) or set(document) != {"format", "key", "outcome"}:
        raise EntryError(f"{path.name} is not a bayesnsi cache entry")
    if document["format"] != CACHE_FORMAT or isinstance(document["format"], bool):
        raise EntryError(f"{path.name} has entry format {str(document['format'])[:20]}, not {CACHE_FORMAT}")
    if key is not None and document["key"] != key:
        raise EntryError(f"{path.name} is stored for key {str(document['key'])[:12]}..., not {key[:12]}...")
    try:
        return outcome_from_plain(document["outcome"], arrays)
    except BayesNSIError:
        raise
    except (TypeError, ValueError, KeyError, IndexError, AttributeError, ArithmeticError, RecursionError) as err:
        raise EntryError(f"{path.name}: invalid outcome ({type(err).__name__}: {err})") from None


def _read_regular_file(path: Path) -> bytes:
    """The bytes of a regular file that is not a symbolic link, after checking its size."""
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    if path.is_symlink():
        raise EntryError(f"{path.name} is a symbolic link")
    fd = os.open(path, flags)
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise EntryError(f"{path.name} is not a regular file")
        check_allocation(info.st_size, f"cache entry {path.name}")
        chunks, remaining = [], info.st_size + 1
        while remaining > 0:
            chunk = os.read(fd, min(remaining, 2**24))
            if not chunk:
                break
            chunks.append(chunk)
            remaining -= len(chunk)
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if len(data) != info.st_size:
        raise EntryError(f"{path.name} changed size while it was read")
    return data


def _warn(message: str, recomputed: bool = True) -> None:
    suffix = "; the candidate is recomputed" if recomputed else ""
    warnings.warn(message + suffix, CacheWarning, stacklevel=3)
