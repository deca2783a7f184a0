"""Output-error refinement of B, D and x₀ with A, C fixed (SPEC sections 3 and 10).

``y_k = C A^k x₀ + Σ_{τ<k} C A^{k-1-τ} B u_τ + D u_k`` is linear in (x₀, B, D). The regressors
are built in modal coordinates (``A = V Λ V⁻¹``): each input drives n first-order filters
(``scipy.signal.lfilter``), so the cost is O(N n (n + m)) per output channel and the normal
equations are accumulated channel by channel (memory O(N n m), independent of l).
"""

from __future__ import annotations

import numpy as np
from scipy import signal as _signal

__all__ = ["refine_output_error"]


def refine_output_error(A, C, u, y, dt, zero_feedthrough=True):
    """Least-squares B, D, x₀ minimising the simulation error with A, C fixed.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C : ndarray, shape (l, n)
    u : ndarray, shape (N, m)
    y : ndarray, shape (N, l)
    dt : float
    zero_feedthrough : bool
        Impose D = 0 (displacement outputs).

    Returns
    -------
    B : ndarray, shape (n, m)
    D : ndarray, shape (l, m)
    x0 : ndarray, shape (n,)
    """
    n, m, l = A.shape[0], u.shape[1], y.shape[1]
    lam, vec = np.linalg.eig(A)
    vinv = np.linalg.inv(vec)
    cm = C @ vec
    filtered = np.empty((m, len(u), n), dtype=complex)
    for c in range(m):
        for p, lp in enumerate(lam):
            filtered[c, :, p] = _signal.lfilter([0.0, 1.0], [1.0, -lp], u[:, c])
    powers = np.exp(np.arange(len(u))[:, None] * np.log(lam.astype(complex))[None, :])
    n_b, n_d = n * m, (0 if zero_feedthrough else l * m)
    size = n_b + n_d + n
    normal = np.zeros((size, size))
    rhs = np.zeros(size)
    for o in range(l):
        blocks = [((filtered[c] * cm[o]) @ vinv).real for c in range(m)]  # each (N, n): d y_o / d B[:, c]
        phi_b = np.stack(blocks, axis=2).reshape(len(u), n_b)  # column r*m + c <-> B[r, c]
        parts = [phi_b]
        if n_d:
            phi_d = np.zeros((len(u), n_d))
            phi_d[:, o * m : (o + 1) * m] = u
            parts.append(phi_d)
        parts.append(((powers * cm[o]) @ vinv).real)
        phi = np.hstack(parts)
        normal += phi.T @ phi
        rhs += phi.T @ y[:, o]
    scale = np.sqrt(np.diag(normal))
    scale[scale == 0] = 1.0
    theta = np.linalg.lstsq(normal / np.outer(scale, scale), rhs / scale, rcond=None)[0] / scale
    B = theta[:n_b].reshape(n, m)
    D = np.zeros((l, m)) if zero_feedthrough else theta[n_b : n_b + n_d].reshape(l, m)
    x0 = theta[n_b + n_d :]
    return B, D, x0
