"""Fingerprints of the code that computes results and of the data it computes them from.

:func:`code_fingerprint` (bayesnsi's sources and the numerical packages) is part of every cache
key (:mod:`bayesnsi.io.cache`) and is compared between this process and the workers of a Dask
cluster (:mod:`bayesnsi._dispatch`), so that results computed by other code are neither reused
nor mixed in. :func:`signals_fingerprint` identifies the estimation data in a cache key. Both
live in this small module, below the library, because they need only numpy and the standard
library.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.metadata
import json
from pathlib import Path

import numpy as np

from ._version import __version__

__all__ = ["KEYED_PACKAGES", "code_fingerprint", "package_version", "signals_fingerprint"]

KEYED_PACKAGES = ("numpy", "scipy", "pandas", "emcee")
"""Packages whose versions enter the fingerprint (the numbers depend on them)."""


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
    package = Path(__file__).resolve().parent
    digest = hashlib.sha256(f"bayesnsi {__version__}".encode())
    for name in KEYED_PACKAGES:
        digest.update(f"{name} {package_version(name)}".encode())
    for path in sorted(package.rglob("*.py")):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def package_version(name: str) -> str:
    """Installed version of the distribution ``name``, or ``"not installed"``.

    Parameters
    ----------
    name : str
        Distribution name (e.g. ``"numpy"``).

    Returns
    -------
    str
    """
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


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
            digest.update(json.dumps(value, default=_plain_scalar).encode())
    return digest.hexdigest()


def _plain_scalar(value):
    if isinstance(value, np.generic):
        return value.item()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):  # Signals.acceleration_noise
        return dataclasses.asdict(value)
    raise TypeError(f"cannot fingerprint a value of type {type(value).__name__}")
