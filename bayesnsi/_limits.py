"""Memory limits: of what bayesnsi reads from files it does not trust (cache entries, data files), of what a run builds.

A reader states how many bytes it is about to allocate and calls :func:`check_allocation` before
allocating them, so that a small file claiming a huge array (or a huge file) is refused with a
one-line error instead of exhausting the machine. The limit is :data:`DEFAULT_MAX_MEMORY`,
overridable with the environment variable ``BAYESNSI_MAX_MEMORY`` (bytes, or with a suffix
``K``, ``M``, ``G``: ``BAYESNSI_MAX_MEMORY=2G``).
"""

from __future__ import annotations

import os

from .exceptions import InputDataError

__all__ = ["DEFAULT_MAX_MEMORY", "DEFAULT_RUN_MEMORY", "MEMORY_ENV", "check_allocation", "max_memory_bytes"]

DEFAULT_MAX_MEMORY = 512 * 2**20
"""Default largest allocation [bytes] a reader of an untrusted file may make (512 MiB)."""

DEFAULT_RUN_MEMORY = 8 * 2**30
"""Default limit [bytes] of what a run builds (8 GiB): the sampler's chains and the local workers
together (:func:`bayesnsi._dispatch.worker_count`, :func:`bayesnsi.evidence.sampling.chain_bytes`), as
for a simulation (:data:`bayesnsi.simulate.MAX_SIMULATION_BYTES`)."""

MEMORY_ENV = "BAYESNSI_MAX_MEMORY"
"""Environment variable that overrides :data:`DEFAULT_MAX_MEMORY`."""

_SUFFIXES = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def max_memory_bytes(default: int = DEFAULT_MAX_MEMORY) -> int:
    """The allocation limit [bytes]: ``BAYESNSI_MAX_MEMORY`` when set, else ``default``.

    Parameters
    ----------
    default : int
        Limit when the variable is unset (a caller whose arrays are built, not read, such as a
        simulation, may allow more than :data:`DEFAULT_MAX_MEMORY`).

    Returns
    -------
    int
        A positive number of bytes.

    Raises
    ------
    InputDataError
        If ``BAYESNSI_MAX_MEMORY`` is not a positive number (``8e9`` or an integer with an
        optional K/M/G/T suffix).

    Examples
    --------
    >>> max_memory_bytes() > 0
    True
    """
    text = os.environ.get(MEMORY_ENV, "").strip()
    if not text:
        return int(default)
    digits, suffix = (text[:-1], text[-1].upper()) if text[-1].upper() in _SUFFIXES else (text, "")
    if not digits.isdigit() and not suffix:
        try:  # plain number of bytes in float notation, e.g. "8e9"
            digits = str(int(float(text))) if float(text) >= 1 else ""
        except (ValueError, OverflowError):
            digits = ""
    if not digits.isdigit() or int(digits) <= 0:
        raise InputDataError(
            f"{MEMORY_ENV} must be a positive number of bytes (optionally with K, M, G or T), got {text!r}"
        )
    return int(digits) * _SUFFIXES[suffix]


def check_allocation(n_bytes: int, what: str, default: int = DEFAULT_MAX_MEMORY) -> None:
    """Refuse to allocate ``n_bytes`` for ``what`` when that exceeds :func:`max_memory_bytes`.

    Parameters
    ----------
    n_bytes : int
        Bytes about to be allocated.
    what : str
        What would be allocated, for the message (e.g. ``"cache entry 3fa9....npz"``).
    default : int
        Limit when ``BAYESNSI_MAX_MEMORY`` is unset (:func:`max_memory_bytes`).

    Raises
    ------
    InputDataError
        If ``n_bytes`` is negative or above the limit; the message names ``what``, the size,
        the limit and how to raise it.
    """
    limit = max_memory_bytes(default)
    if n_bytes < 0 or n_bytes > limit:
        raise InputDataError(
            f"{what} needs {n_bytes} bytes, above the limit of {limit} bytes; "
            f"set {MEMORY_ENV} (e.g. {MEMORY_ENV}=4G) to allow more"
        )
