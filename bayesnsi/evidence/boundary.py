"""Laplace evidence in the coefficients alone, for residuals whose AR(1) coefficient sits at its prior bound.

The loop of :mod:`bayesnsi.loop` scores each model by the Laplace approximation over all
parameters ``(λ, log σ, ρ)`` (:func:`bayesnsi.evidence.laplace_log_evidence`). When a model's
residual is close to a random walk its AR(1) coefficient's mode lies beyond the prior's bound
(0.9999) and that approximation is NaN (the mode is outside the support). It happened on a
free-free two-mass rig with the friction missing from the starting model: the open-loop and
innovations residuals of the linear model drift (ρ̂ = 0.99991), so ``bayesnsi diagnose --start
linear`` stopped before its first step although ``select`` (collapsed evidence) scored the same
model. Here ``σ`` and ``ρ`` are integrated out exactly as in the collapsed estimator
(:class:`~bayesnsi.evidence.collapsed.CollapsedTarget`: quadrature over the truncated ρ range),
and only the ``q`` coefficients are treated by Laplace, with a finite-difference Hessian; with
``q = 0`` the value is exact.
"""

from __future__ import annotations

import numpy as np

from ._target import _LOG_2PI, Target
from .collapsed import CollapsedTarget, collapsible

__all__ = ["collapsed_laplace_log_evidence"]


def _hessian(f, x: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Central finite-difference Hessian of a scalar function."""
    q = len(x)
    hess = np.empty((q, q))
    for i in range(q):
        for j in range(i, q):
            ei, ej = np.eye(q)[i] * step[i], np.eye(q)[j] * step[j]
            value = (f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)) / (4 * step[i] * step[j])
            hess[i, j] = hess[j, i] = value
    return hess


def collapsed_laplace_log_evidence(stats, priors, likelihood: str = "white") -> float:
    """``log Z`` with the noise parameters integrated out and Laplace in the coefficients only.

    Parameters
    ----------
    stats : SufficientStatistics
        Of the candidate's affine residual model.
    priors : Priors
        Coefficient, noise and AR priors.
    likelihood : {"white", "ar1"}
        Residual model (the ones whose noise parameters integrate out).

    Returns
    -------
    float
        ``log p*(λ*) + (q/2) log 2π - ½ log|-H(λ*)|`` with ``p*`` the collapsed posterior of the
        coefficients; NaN for other likelihoods, or when ``-H`` is not positive definite.
    """
    target = Target.build(stats, priors, likelihood)
    if not collapsible(target):
        return float("nan")
    collapsed = CollapsedTarget(target)

    def log_post(lam) -> float:
        return float(collapsed.log_posterior(np.asarray(lam, dtype=float)[None, :])[0])

    centre = np.asarray(stats.center, dtype=float)
    if target.q == 0:
        return log_post(centre)
    scale = np.maximum(np.abs(centre), np.asarray(priors.coefficients.scale, dtype=float) * 1e-6)
    from scipy.optimize import minimize  # here: scipy.optimize costs 0.2 s to import

    fit = minimize(lambda z: -log_post(centre + z * scale), np.zeros(target.q), method="Nelder-Mead",
                   options={"xatol": 1e-9, "fatol": 1e-9, "maxiter": 2000 * target.q})
    mode = centre + fit.x * scale
    neg = -_hessian(log_post, mode, 1e-4 * scale)
    try:
        chol = np.linalg.cholesky(0.5 * (neg + neg.T))
    except np.linalg.LinAlgError:
        return float("nan")
    logdet = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return float(log_post(mode) + 0.5 * target.q * _LOG_2PI - 0.5 * logdet)
