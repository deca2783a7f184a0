"""Output-error refinement of B, D and x₀ with A, C fixed (SPEC sections 3 and 10).

``y_k = C A^k x₀ + Σ_{τ<k} C A^{k-1-τ} B u_τ + D u_k`` is linear in (x₀, B, D). In modal
coordinates (``A = V Λ V⁻¹``) every regressor of every output channel is a fixed real linear
combination of a few basis signals: the real and imaginary parts of each input filtered by each
mode (``z_{k+1} = λ z_k + u_k``), of the free responses ``λ^k``, and the inputs themselves.
So one Gram matrix of those basis signals, accumulated in chunks (the recursive filters carry
their state across chunks), gives the normal equations of all outputs: time O(N (nm)²), memory
independent of N.
"""

from __future__ import annotations

import numpy as np
from scipy import signal as _signal
from scipy.linalg import blas as _blas

__all__ = ["refine_output_error"]

_CHUNK = 8192


def _basis_gram(lam: np.ndarray, u: np.ndarray, y: np.ndarray):
    """Gram of the basis signals ``S = [Re F, Im F, Re P, Im P, u]`` and ``Sᵀ y``.

    ``F[:, c·n + p]`` is input c filtered by mode p (zero initial state), ``P[:, p] = λ_p^k``.
    """
    n, m = len(lam), u.shape[1]  # n: modes kept
    width = 2 * n * m + 2 * n + m
    gram = np.zeros((width, width), order="F")
    cross = np.zeros((width, y.shape[1]))
    state = np.zeros((m, n), dtype=complex)
    step_powers = np.exp(np.arange(_CHUNK)[:, None] * np.log(lam.astype(complex))[None, :])
    chunk_start = np.ones(n, dtype=complex)  # λ^start
    a = np.array([1.0, 0.0], dtype=complex)
    basis = np.empty((_CHUNK, width), order="F")
    filtered = np.empty(_CHUNK, dtype=complex)
    for start in range(0, len(u), _CHUNK):
        size = min(_CHUNK, len(u) - start)
        uc = u[start : start + size]
        for c in range(m):
            for p, lp in enumerate(lam):
                a[1] = -lp
                filtered[:size], zf = _signal.lfilter([0.0, 1.0], a, uc[:, c], zi=state[c, p : p + 1])
                state[c, p] = zf[0]
                basis[:size, c * n + p] = filtered[:size].real
                basis[:size, n * m + c * n + p] = filtered[:size].imag
        powers = step_powers[:size] * chunk_start
        basis[:size, 2 * n * m : 2 * n * m + n] = powers.real
        basis[:size, 2 * n * m + n : 2 * n * m + 2 * n] = powers.imag
        basis[:size, 2 * n * m + 2 * n :] = uc
        chunk_start = chunk_start * lam**size
        view = basis[:size]
        gram = _blas.dsyrk(1.0, view, beta=1.0, c=gram, trans=1, lower=0, overwrite_c=1)  # Sᵀ S, upper
        cross += view.T @ y[start : start + size]
    return np.triu(gram) + np.triu(gram, 1).T, cross


def refine_output_error(A, C, u, y, dt, zero_feedthrough=True, output_weights=None):
    """Least-squares B, D, x₀ minimising the simulation error with A, C fixed.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C : ndarray, shape (l, n)
    u : ndarray, shape (N, m)
    y : ndarray, shape (N, l)
    dt : float
        Sampling interval [s] (unused by the algebra; kept for a uniform signature).
    zero_feedthrough : bool
        Impose D = 0 (displacement outputs).
    output_weights : ndarray, shape (l,), optional
        Weight of each output channel's squared error (e.g. 1/var(y_o) so channels of different
        size count alike); default 1.

    Returns
    -------
    B : ndarray, shape (n, m)
    D : ndarray, shape (l, m)
    x0 : ndarray, shape (n,)
    """
    n, m, l = A.shape[0], u.shape[1], y.shape[1]
    lam_all, vec = np.linalg.eig(A)
    vinv_all = np.linalg.inv(vec)
    cm_all = C @ vec
    # A real system's complex modes come in conjugate pairs whose contributions are complex
    # conjugates: keep one of each pair with weight 2 (halves the basis).
    keep = lam_all.imag > 0
    real = np.abs(lam_all.imag) <= 1e-12 * np.abs(lam_all)
    keep |= real
    factor = np.where(real[keep], 1.0, 2.0)
    lam, vinv, cm = lam_all[keep], vinv_all[keep] * factor[:, None], cm_all[:, keep]
    gram, cross = _basis_gram(lam, np.asarray(u, dtype=float), np.asarray(y, dtype=float))
    n_modes = len(lam)
    n_b, n_d = n * m, (0 if zero_feedthrough else l * m)
    size = n_b + n_d + n
    width = gram.shape[0]
    normal = np.zeros((size, size))
    rhs = np.zeros(size)
    for o in range(l):
        # Regressor of output o = basis @ weights: Re(F_c w) = Re(F_c) Re(w) - Im(F_c) Im(w).
        weights = np.zeros((width, size))
        modal = cm[o][:, None] * vinv  # (modes, n states): d y_o / d B[r, c] per mode p
        k = n_modes
        for c in range(m):
            cols = np.arange(n) * m + c  # parameter index r*m + c <-> B[r, c]
            weights[c * k : (c + 1) * k, cols] = modal.real
            weights[k * m + c * k : k * m + (c + 1) * k, cols] = -modal.imag
        free = 2 * k * m
        weights[free : free + k, n_b + n_d :] = modal.real
        weights[free + k : free + 2 * k, n_b + n_d :] = -modal.imag
        if n_d:
            weights[free + 2 * k + np.arange(m), n_b + o * m + np.arange(m)] = 1.0
        w = 1.0 if output_weights is None else output_weights[o]
        normal += w * (weights.T @ gram @ weights)
        rhs += w * (weights.T @ cross[:, o])
    scale = np.sqrt(np.diag(normal))
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(normal / np.outer(scale, scale), rhs / scale, rcond=None)[0] / scale
    B = theta[:n_b].reshape(n, m)
    D = np.zeros((l, m)) if zero_feedthrough else theta[n_b : n_b + n_d].reshape(l, m)
    x0 = theta[n_b + n_d :]
    return B, D, x0
