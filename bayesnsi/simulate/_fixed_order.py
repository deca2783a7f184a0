"""Matrix arithmetic in a fixed order of operations: the same bits on every CPU (docs/method.md §8).

The beam reference case is chaotic (its spring has a second well and the response hops between
the two): a difference in the last bit of one product grows until, seconds into the record, the
trajectory is another one. BLAS and LAPACK pick their kernels for the CPU at run time (OpenBLAS:
Haswell, SkylakeX, Zen, ...), and the kernels order and fuse their multiply-adds differently; with
them one seed of the beam gave two records on two machines (seed 0: displacements apart by 28 % of
their range after 100 s with the SkylakeX against the Haswell kernels, on the same CPU). The
simulator builds its matrices and advances its state with the functions here instead: numpy's
elementwise multiplication (exactly rounded whatever its vector width), its reduction along a
contiguous axis (pairwise summation, whose order is set by the length alone), and scalar IEEE
arithmetic. Linear algebra is on matrices of a few dozen rows, where this costs little.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["cholesky", "generalized_eigh", "inverse", "product", "product_into"]

_JACOBI_SWEEPS = 60


def product_into(a: np.ndarray, b: np.ndarray, out: np.ndarray, work: np.ndarray) -> np.ndarray:
    """``out = a @ b`` in a fixed order: every ``out[i, k]`` sums ``a[i, :] * b[:, k]`` pairwise.

    Parameters
    ----------
    a : ndarray, shape (r, p)
    b : ndarray, shape (p, c)
    out : ndarray, shape (r, c)
        Written in place.
    work : ndarray, shape (c, r, p)
        Scratch space (C-contiguous), so that a time loop allocates nothing.

    Returns
    -------
    ndarray
        ``out``. Each column of the result is the same whatever ``c`` is (a realisation does not
        depend on the batch it is simulated in).
    """
    np.multiply(a[None], b.T[:, None, :], out=work)
    np.add.reduce(work, axis=2, out=out.T)
    return out


def product(a, b) -> np.ndarray:
    """``a @ b`` for 2-D arrays in a fixed order (:func:`product_into`).

    Parameters
    ----------
    a : array_like, shape (r, p)
    b : array_like, shape (p, c)

    Returns
    -------
    ndarray, shape (r, c)
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    out = np.empty((a.shape[0], b.shape[1]))
    if a.shape[1] == 0:
        out[:] = 0.0
        return out
    return product_into(a, b, out, np.empty((b.shape[1], a.shape[0], a.shape[1])))


def inverse(a) -> np.ndarray:
    """Inverse of a square matrix by Gauss-Jordan elimination with partial pivoting (fixed order).

    Parameters
    ----------
    a : array_like, shape (n, n)

    Returns
    -------
    ndarray, shape (n, n)

    Raises
    ------
    numpy.linalg.LinAlgError
        When a pivot is zero (a singular matrix).
    """
    a = np.array(a, dtype=float)
    n = a.shape[0]
    work = np.hstack([a, np.eye(n)])
    for j in range(n):
        pivot = j + int(np.argmax(np.abs(work[j:, j])))
        if work[pivot, j] == 0.0:
            raise np.linalg.LinAlgError("singular matrix")
        if pivot != j:
            work[[j, pivot]] = work[[pivot, j]]
        work[j] /= work[j, j]
        for i in range(n):
            if i != j and work[i, j] != 0.0:
                work[i] -= work[i, j] * work[j]
    return work[:, n:].copy()


def cholesky(a) -> np.ndarray:
    """Lower-triangular ``L`` with ``L Lᵀ = a`` (symmetric positive definite ``a``), fixed order.

    Parameters
    ----------
    a : array_like, shape (n, n)

    Returns
    -------
    ndarray, shape (n, n)

    Raises
    ------
    numpy.linalg.LinAlgError
        When ``a`` is not positive definite.
    """
    a = np.asarray(a, dtype=float)
    n = a.shape[0]
    low = np.zeros((n, n))
    for j in range(n):
        pivot = float(a[j, j]) - float(np.add.reduce(low[j, :j] * low[j, :j]))
        if not pivot > 0.0:
            raise np.linalg.LinAlgError("matrix is not positive definite")
        low[j, j] = math.sqrt(pivot)
        below = a[j + 1 :, j] - np.add.reduce(low[j + 1 :, :j] * low[j, :j], axis=1)
        low[j + 1 :, j] = below / low[j, j]
    return low


def generalized_eigh(K, M) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of ``K φ = λ M φ`` (symmetric K, symmetric positive definite M) in a fixed order.

    ``M = L Lᵀ`` (:func:`cholesky`), then cyclic Jacobi rotations diagonalise ``L⁻¹ K L⁻ᵀ``
    (Golub & Van Loan, "Matrix Computations", 4th ed., Alg. 8.5.3) until its off-diagonal part is
    below 1e-15 of its norm; ``Φ = L⁻ᵀ V``.

    Parameters
    ----------
    K, M : array_like, shape (n, n)

    Returns
    -------
    eigenvalues : ndarray, shape (n,)
        Ascending.
    vectors : ndarray, shape (n, n)
        Mass-normalised eigenvectors in columns (``Φᵀ M Φ = I``).

    Raises
    ------
    numpy.linalg.LinAlgError
        When M is not positive definite.
    """
    K = np.asarray(K, dtype=float)
    low_inv = inverse(cholesky(M))
    s = product(product(low_inv, 0.5 * (K + K.T)), low_inv.T)
    n = s.shape[0]
    v = np.eye(n)
    scale = math.sqrt(float(np.add.reduce((s * s).ravel()))) or 1.0
    for _ in range(_JACOBI_SWEEPS):
        off = s - np.diag(np.diag(s))
        if math.sqrt(float(np.add.reduce((off * off).ravel()))) <= 1e-15 * scale:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                _rotate(s, v, p, q)
    values = np.diag(s).copy()
    order = np.argsort(values, kind="stable")
    return values[order], product(low_inv.T, v)[:, order]


def _rotate(s: np.ndarray, v: np.ndarray, p: int, q: int) -> None:
    """One Jacobi rotation zeroing ``s[p, q]`` (in place on ``s`` and the accumulated ``v``)."""
    apq = float(s[p, q])
    if apq == 0.0:
        return
    theta = (float(s[q, q]) - float(s[p, p])) / (2.0 * apq)
    if abs(theta) > 1e150:
        t = 0.5 / theta
    else:
        t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
    c = 1.0 / math.sqrt(t * t + 1.0)
    sn = t * c
    for mat, rows in ((s, True), (s, False), (v, False)):
        first = mat[p].copy() if rows else mat[:, p].copy()
        second = mat[q].copy() if rows else mat[:, q].copy()
        new_p = c * first - sn * second
        new_q = sn * first + c * second
        if rows:
            mat[p], mat[q] = new_p, new_q
        else:
            mat[:, p], mat[:, q] = new_p, new_q
