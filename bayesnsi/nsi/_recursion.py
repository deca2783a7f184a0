"""The first-order recursive filter of the modal simulation as a banded triangular solve (LAPACK ``?tbtrs``).

It computes what ``scipy.signal.lfilter([0, 1], [1, -c])`` computes (the same recursion, term by
term, to rounding), without importing ``scipy.signal``: its import costs 0.3-0.7 s at the start of
every command; for complex poles it is also faster (0.77 against 1.03 ms for 1e5
samples). The recursion ``y[n] - c·y[n-1] = r[n]`` over ``N`` samples is the lower-bidiagonal system
``L y = r`` with a unit diagonal; forward substitution of that system is the recursion.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.linalg import lapack

__all__ = ["delayed_first_order"]


CACHED_SAMPLES = 16384
"""Longer inputs are filtered in chunks of this length, the state carried (the same recursion), so
that the band matrix of a pole is built once and reused for every chunk and every call with that
pole (building it costs a third of a solve). At most ``_band.cache_info().maxsize`` band
matrices are kept, 0.4-0.5 MB each."""


@functools.lru_cache(maxsize=32)
def _band(values: tuple, n: int, complex_: bool) -> np.ndarray:
    """LAPACK band storage (read-only) of the unit lower-triangular ``L`` with subdiagonals ``values``.

    Row k holds the k-th subdiagonal; its last k entries (outside L) and the diagonal row (unit
    diagonal) are not referenced.
    """
    ab = np.empty((len(values) + 1, n), dtype=np.complex128 if complex_ else np.float64, order="F")
    ab[1:] = np.array(values)[:, None]
    ab.flags.writeable = False
    return ab


def _solve_lower(band: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve ``L y = rhs`` for the unit lower-triangular banded ``L`` (``band``: its subdiagonals)."""
    complex_ = bool(np.iscomplexobj(band) or np.iscomplexobj(rhs))
    dtype = np.complex128 if complex_ else np.float64
    values, n = tuple(band.tolist()), rhs.shape[0]
    ab = _band(values, n, complex_)  # n <= CACHED_SAMPLES (_chunked)
    solve = lapack.ztbtrs if complex_ else lapack.dtbtrs
    rhs = np.asfortranarray(rhs, dtype=dtype)  # no copy when the callers built it so (they own it)
    y, info = solve(ab, rhs, uplo="L", trans="N", diag="U", overwrite_b=1)
    if info != 0:  # pragma: no cover - a unit diagonal is never singular
        raise np.linalg.LinAlgError(f"banded triangular solve failed (info = {info})")
    return y


def _chunked(block, x: np.ndarray, state):
    """``block`` over chunks of :data:`CACHED_SAMPLES` samples, the state carried (the same recursion)."""
    x = np.asarray(x)
    if x.shape[0] <= CACHED_SAMPLES:
        return block(x, state)
    parts = []
    for start in range(0, x.shape[0], CACHED_SAMPLES):
        part, state = block(x[start : start + CACHED_SAMPLES], state)
        parts.append(part)
    return np.concatenate(parts, axis=0), state


def delayed_first_order(coef, x: np.ndarray, zi=None) -> tuple[np.ndarray, np.ndarray]:
    """``lfilter([0, 1], [1, -coef], x, axis=0, zi=zi)``: ``y[n] = x[n-1] + coef·y[n-1]``, ``y[0] = zi``.

    Parameters
    ----------
    coef : float or complex
        The pole.
    x : ndarray, shape (N, ...)
        Input, filtered along the first axis.
    zi : ndarray, shape (1, ...), optional
        Initial state (default zero).

    Returns
    -------
    y : ndarray, shape (N, ...)
        Real for a real pole and real input, else complex.
    zf : ndarray, shape (1, ...)
        Final state ``x[N-1] + coef·y[N-1]``, for the next chunk (it is also the last output of
        ``lfilter([1], [1, -coef], x)``).
    """
    return _chunked(lambda chunk, state: _delayed_first_order(coef, chunk, state), x, zi)


def _delayed_first_order(coef, x: np.ndarray, zi) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x)
    shape = x.shape
    columns = x.reshape(shape[0], int(np.prod(shape[1:])))
    start = np.zeros((1, columns.shape[1])) if zi is None else np.asarray(zi).reshape(1, -1)
    if shape[0] == 0:
        return x.copy(), start.reshape((1,) + shape[1:]).copy()
    rhs = np.empty(columns.shape, dtype=np.result_type(columns, start, coef, float), order="F")
    rhs[0], rhs[1:] = start[0], columns[:-1]
    y = _solve_lower(np.array([-coef]), rhs)
    zf = columns[-1:] + coef * y[-1:]
    return y.reshape(shape), zf.reshape((1,) + shape[1:])
