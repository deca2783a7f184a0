"""Exact evidence of a candidate with at most three coefficients: quadrature over them (docs/method.md §6).

For white and exact AR(1) residuals the noise parameters integrate out of the posterior
(:class:`~bayesnsi.evidence.collapsed.CollapsedTarget`: ``σ_j`` in closed form, Eq. 6.4, ``ρ_j`` by
a series or Gauss-Hermite quadrature), so the evidence is a ``q``-dimensional integral over the
coefficients whatever the number of channels:

.. math:: Z = \\int \\tilde p(λ)\\, dλ, \\qquad \\tilde p(λ) = π(λ) \\prod_j \\iint L_j π(σ_j) π(ρ_j)\\, dσ_j dρ_j.

With ``q <= 3`` it is done by tensor Gauss-Hermite quadrature in coordinates whitened by the
posterior's mean and covariance, adapted in a few passes: the integrand divided by the Gaussian
weight is smooth and nearly constant (the collapsed posterior is a product of Student-t factors with
``n`` degrees of freedom and a normal prior), so a few dozen nodes per dimension reach 1e-10 nat. The
stated error is the change between two rules of different sizes at the final centre. Unlike the
closed form of :mod:`.analytic` (quadrature over the ``l(1+p)`` noise parameters, at most 4), the
cost grows with ``q`` and not with the number of channels: a few milliseconds at 16 channels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from ..exceptions import InputDataError
from ._target import Target
from .collapsed import CollapsedTarget, collapsible
from .likelihood import SufficientStatistics
from .priors import Priors

__all__ = ["MAX_QUADRATURE_COEFFICIENTS", "QuadratureEvidence", "quadrature_log_evidence"]

MAX_QUADRATURE_COEFFICIENTS = 3
"""Largest number of coefficients integrated by tensor quadrature."""

# nodes per dimension (rule, check rule) by the number of coefficients: at n >= 200 samples the smaller rule
# is within 1e-9 nat of a 32-node rule (20 in 3-D), 1e-12 at n >= 1000 (docs/measurements.md)
_NODES = {1: (24, 32), 2: (16, 24), 3: (12, 16)}
_MAX_PASSES = 8
_PASS_TOL = 1e-10  # nat: the centre and scale are adapted until the value moves less than this


@dataclass(frozen=True)
class QuadratureEvidence:
    """Result of :func:`quadrature_log_evidence`.

    Attributes
    ----------
    log_evidence : float
        ``log Z`` [nat].
    error : float
        Difference between two Gauss-Hermite rules of different sizes at the final centre [nat].
    n_nodes : int
        Integrand evaluations of the larger rule.
    n_passes : int
        Adaptation passes (centre and covariance from the previous rule's weights).
    """

    log_evidence: float
    error: float
    n_nodes: int
    n_passes: int


def quadrature_log_evidence(
    stats: SufficientStatistics, priors: Priors, likelihood: str = "white", *, centre=None, covariance=None
) -> QuadratureEvidence:
    """Exact ``log Z`` by quadrature over at most three coefficients of the collapsed posterior.

    Parameters
    ----------
    stats : SufficientStatistics
    priors : Priors
    likelihood : {"white", "ar1"}
        Residual models whose noise parameters integrate out (any number of channels).
    centre : array_like, shape (q,), optional
        Starting centre of the rule (default: the coefficients of the joint posterior mode).
    covariance : array_like, shape (q, q), optional
        Starting covariance of the rule (default: the Laplace covariance of the coefficients).

    Returns
    -------
    QuadratureEvidence

    Raises
    ------
    InputDataError
        For a conditional AR(P) likelihood (P > 1: the noise parameters do not integrate out) or
        more than :data:`MAX_QUADRATURE_COEFFICIENTS` coefficients.

    Notes
    -----
    Adaptive Gauss-Hermite: with ``λ = m + √2 L x`` (``L Lᵀ`` the covariance), ``x`` on the tensor
    Hermite nodes, ``log Z = logsumexp(log p̃(λ) + |x|² + log w) + log|√2 L|``; ``m`` and ``L Lᵀ``
    are replaced by the weighted mean and covariance of the nodes until the value moves less than
    1e-10 nat (docs/method.md §6).
    """
    target = Target.build(stats, priors, likelihood)
    if not collapsible(target):
        raise InputDataError(f"no quadrature over the coefficients for {likelihood!r}: its noise parameters do not "
                             "integrate out (white and ar1 only)")
    q = target.q
    if q > MAX_QUADRATURE_COEFFICIENTS:
        raise InputDataError(f"quadrature over the coefficients takes at most {MAX_QUADRATURE_COEFFICIENTS} of them, "
                             f"the candidate has {q}")
    collapsed = CollapsedTarget(target, series=False)  # ρ by quadrature: the series' O(n⁻³) remainder left out
    if q == 0:
        return QuadratureEvidence(float(collapsed.log_posterior(np.zeros((1, 0)))[0]), 0.0, 1, 0)
    if centre is None or covariance is None:
        from .sampling import _inside_support, _laplace_covariance

        theta0 = target.initial_theta()
        mode, _, hess, _ = target.find_mode(theta0)
        mode = _inside_support(target, mode, theta0)
        cov = _laplace_covariance(hess, target, mode)
        centre = mode[:q] if centre is None else centre
        covariance = cov[:q, :q] if covariance is None else covariance
    m = np.asarray(centre, dtype=float).reshape(q)
    cov = np.asarray(covariance, dtype=float).reshape(q, q)
    small, large = _NODES[q]
    value, m_next, cov_next = _hermite(collapsed, m, cov, small)
    passes = 1
    while np.isfinite(value) and passes < _MAX_PASSES:  # re-centre until the small rule stops moving
        m, cov = m_next, cov_next
        new, m_next, cov_next = _hermite(collapsed, m, cov, small)
        passes += 1
        moved, value = abs(new - value), new
        if moved < _PASS_TOL:
            break
    check = _hermite(collapsed, m, cov, large)[0]  # the same centre as the last small rule
    error = abs(check - value) if np.isfinite(check) else np.inf
    return QuadratureEvidence(float(check), float(error), large**q, passes)


def _hermite(collapsed: CollapsedTarget, centre: np.ndarray, cov: np.ndarray, n: int):
    """Tensor Gauss-Hermite ``log ∫ p̃`` with ``n`` nodes per dimension; also the weighted mean and covariance."""
    q = centre.size
    x, w = np.polynomial.hermite.hermgauss(n)
    grid = np.stack(np.meshgrid(*([x] * q), indexing="ij"), axis=-1).reshape(-1, q)
    logw = np.sum(np.log(np.stack(np.meshgrid(*([w] * q), indexing="ij"), axis=-1).reshape(-1, q)), axis=-1)
    sym = 0.5 * (cov + cov.T)
    try:
        chol = np.linalg.cholesky(sym)
    except np.linalg.LinAlgError:
        chol = np.diag(np.sqrt(np.maximum(np.abs(np.diag(sym)), 1e-300)))
    scale = np.sqrt(2.0) * chol
    lam = centre + grid @ scale.T
    log_f = collapsed.log_posterior(lam) + np.sum(grid**2, axis=-1) + logw
    log_det = float(np.sum(np.log(np.abs(np.diag(scale)))))
    total = float(logsumexp(log_f))
    if not np.isfinite(total):
        return total + log_det, centre, cov
    weights = np.exp(log_f - total)
    mean = weights @ lam
    dev = lam - mean
    return total + log_det, mean, (weights[:, None] * dev).T @ dev
