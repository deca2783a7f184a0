"""A Levenberg-Marquardt search for the frequency route's refinement (:func:`._modal_fit.refine`).

MINPACK's ``lmder`` factors the Jacobian by its own unblocked QR with column pivoting at every
iteration; on the F-16's models (1602 residuals, 40-60 parameters) that factorisation took two
thirds of the refinement's time (`docs/measurements.md`). Here the step solves the normal equations
``(JᵀJ + λ D²) δ = -Jᵀr`` by a Cholesky factorisation of the small ``p × p`` matrix (``JᵀJ`` one
BLAS product), with MINPACK's scaling ``D`` (the largest column norms of J met so far) and
Nielsen's update of the damping λ (H. B. Nielsen, "Damping parameter in Marquardt's method",
IMM-REP-1999-05). The search stops on a relative cost reduction below ``ftol``, a relative step
below ``xtol``, a scaled gradient below ``gtol``, or ``max_nfev`` residual evaluations; every
accepted iterate lowers the cost, so the last is the best.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg

__all__ = ["levenberg_marquardt"]


def levenberg_marquardt(residual: Callable[[np.ndarray], np.ndarray], jacobian: Callable[[np.ndarray], np.ndarray],
                        x0: np.ndarray, max_nfev: int = 200, ftol: float = 1e-7, xtol: float = 1e-7,
                        gtol: float = 1e-8) -> tuple[np.ndarray, float, int]:
    """Minimise ``|residual(x)|²`` from ``x0`` (module notes).

    Parameters
    ----------
    residual : callable
        ``x -> r`` (m,).
    jacobian : callable
        ``x -> J`` (m, p), the derivative of ``residual``.
    x0 : ndarray, shape (p,)
        Start.
    max_nfev : int
        Largest number of residual evaluations.
    ftol, xtol, gtol : float
        Relative cost reduction, relative step and scaled-gradient tolerances.

    Returns
    -------
    x : ndarray, shape (p,)
        The best point found.
    cost : float
        ``|residual(x)|²``.
    nfev : int
        Residual evaluations made.
    """
    x = np.array(x0, dtype=float)
    r = residual(x)
    cost, nfev = float(r @ r), 1
    if not np.isfinite(cost) or x.size == 0:
        return x, cost, nfev
    J = jacobian(x)
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    normal, gradient = J.T @ J, J.T @ r
    damping, growth = 1e-3, 2.0  # relative to D² ≈ diag(JᵀJ): the steps start near gradient descent's
    while nfev < max_nfev:
        if np.max(np.abs(gradient) / (scale * np.sqrt(cost) + 1e-300)) <= gtol:
            break
        try:
            factor = scipy.linalg.cho_factor(normal + damping * np.diag(scale**2), check_finite=False)
            step = -scipy.linalg.cho_solve(factor, gradient, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            damping, growth = damping * growth, growth * 2.0
            if damping > 1e16:
                break
            continue
        trial = x + step
        r_trial = residual(trial)
        nfev += 1
        cost_trial = float(r_trial @ r_trial)
        predicted = -(2.0 * gradient @ step + step @ normal @ step)
        if np.isfinite(cost_trial) and cost_trial < cost:
            gain = (cost - cost_trial) / predicted if predicted > 0 else 1.0
            small = (cost - cost_trial) <= ftol * cost
            tiny_step = np.linalg.norm(scale * step) <= xtol * (np.linalg.norm(scale * x) + xtol)
            x, r, cost = trial, r_trial, cost_trial
            if small or tiny_step:
                break
            J = jacobian(x)
            scale = np.maximum(scale, np.linalg.norm(J, axis=0))
            normal, gradient = J.T @ J, J.T @ r
            damping *= max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
            growth = 2.0
        else:
            damping, growth = damping * growth, growth * 2.0
            if damping > 1e16:  # no step lowers the cost: a minimum to the precision of the arithmetic
                break
    return x, cost, nfev
