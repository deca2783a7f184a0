"""Evidence by formula: exact quadrature for affine models and the Laplace approximation (docs/method.md §6).

``Z = ∫ L(θ) π(θ) dθ`` over ``θ = (λ, log σ_1..log σ_l[, φ])``:

* **exact** (for tests and reports): with a Gaussian prior and an affine model the integral over
  ``λ`` is closed-form for fixed noise parameters, and the remaining integral over
  ``η = (log σ_j[, ρ_j])`` is done by tensor Gauss-Legendre quadrature. Available when ``η`` has at
  most 4 dimensions: white noise with ``l <= 4`` channels (one ``σ`` per channel; the channels are
  coupled through ``λ``), or AR(1) with ``l <= 2``;
* **Laplace** approximation at the posterior mode, a free cross-check of bridge sampling.
"""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from ..exceptions import InputDataError
from ._target import _LOG_2PI, Target
from .likelihood import SufficientStatistics
from .priors import Priors

__all__ = ["closed_form_log_evidence", "laplace_log_evidence"]

# quadrature dimension -> (half-width in Laplace sd, Gauss-Legendre nodes per dimension); the
# 1-D error of n nodes on ±w sd of a Gaussian is ≈ 1e-12 (12, 72), 2e-6 (12, 32), 1e-8 (10, 32);
# in 3-D (9, 36) is within 2e-11 nat of the quadrature over the coefficients (.quadrature), (12, 32) was 5e-6
_QUAD_RULE = {1: (12.0, 160), 2: (12.0, 72), 3: (9.0, 36), 4: (10.0, 32)}
_QUAD_CHUNK = 50_000


def closed_form_log_evidence(stats: SufficientStatistics, priors: Priors, likelihood: str = "white") -> float:
    """Exact ``log Z`` of the affine model: λ analytically, noise parameters by quadrature.

    Parameters
    ----------
    stats : SufficientStatistics
    priors : Priors
    likelihood : {"white", "ar1"}
        White noise with ``l <= 4`` channels, or exact AR(1) with ``l <= 2``.

    Returns
    -------
    float
        ``log Z`` [nat].

    Raises
    ------
    InputDataError
        When the noise parameters have more than 4 dimensions (no quadrature offered).

    Notes
    -----
    For fixed ``η`` the log-likelihood is ``-½(c - 2bᵀδ + δᵀPδ) + κ(η)`` with
    ``(c, b, P)`` from ``Σ_j σ_j⁻² M_j(ρ_j)`` and ``δ = λ - λ_c``; with ``δ ~ N(m, S)``,
    ``m = -λ_c``, ``S = diag s²``:

    .. math:: \\log\\int = -\\tfrac12 c - \\tfrac12 mᵀS⁻¹m + \\tfrac12 \\tilde bᵀA⁻¹\\tilde b
              - \\tfrac12\\log|A| - \\tfrac12\\log|S|,\\quad A = S⁻¹ + P,\\ \\tilde b = b + S⁻¹m.

    The remaining integral over ``η`` (uniform prior in ``log σ`` and ``ρ``) uses tensor
    Gauss-Legendre nodes on ``η* ± 12 sd`` (Laplace marginal; ± 9 sd in 3-D, ± 10 sd in 4-D), clipped to the prior
    support and widened until the integrand at the box faces is below ``e⁻³⁰`` of its maximum.
    Cost: milliseconds up to 2-D, ≈ 0.1 s in 3-D, seconds in 4-D, whatever N.
    """
    target = Target.build(stats, priors, likelihood)
    dim = target.l * (1 + target.order)
    if (target.order > 1) or dim > 4:
        raise InputDataError(
            f"no quadrature for {likelihood!r} with {target.l} channel(s): the noise parameters have {dim} "
            "dimensions (supported: white noise with l <= 4, AR(1) with l <= 2)"
        )
    mode, _, hess, _ = target.find_mode(target.initial_theta())
    q = target.q
    try:
        cov = np.linalg.inv(-0.5 * (hess + hess.T))
        sd = np.sqrt(np.diag(cov)[q:])
        if not np.all(np.isfinite(sd) & (sd > 0)):
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        sd = np.concatenate([np.full(target.l, 1.0 / np.sqrt(2 * target.n_eff)), np.full(dim - target.l, 0.1)])
    lower, upper = _eta_support(target)
    centre = np.clip(mode[q:], lower, upper)  # a mode beyond the support (AR(1) of a drifting residual): its edge
    width = _QUAD_RULE[dim][0]
    for _ in range(6):
        lo = np.maximum(centre - width * sd, lower)
        hi = np.minimum(centre + width * sd, upper)
        value, edge_ok = _gauss_legendre(target, lo, hi, lower, upper)
        if edge_ok:
            return value
        width *= 2.0
    return value


def _eta_support(target: Target):
    lo = np.log(target.priors.noise.lower)
    hi = np.log(target.priors.noise.upper)
    if target.order:
        lo = np.concatenate([lo, np.full(target.l, target.priors.ar.lower)])
        hi = np.concatenate([hi, np.full(target.l, target.priors.ar.upper)])
    return lo, hi


def _gauss_legendre(target: Target, lo, hi, lower, upper):
    """Tensor Gauss-Legendre ``log ∫ exp(h(η)) dη`` on the box; also whether the faces are negligible."""
    dim = lo.size
    n = _QUAD_RULE[dim][1]
    x, w = np.polynomial.legendre.leggauss(n)
    nodes = [0.5 * (b - a) * x + 0.5 * (b + a) for a, b in zip(lo, hi)]
    logw = [np.log(0.5 * (b - a) * w) for a, b in zip(lo, hi)]
    grid = np.stack(np.meshgrid(*nodes, indexing="ij"), axis=-1).reshape(-1, dim)
    lw = np.sum(np.meshgrid(*logw, indexing="ij"), axis=0).reshape(-1)
    chunks = range(0, len(grid), _QUAD_CHUNK)
    h = np.concatenate([_lambda_integrated(target, grid[i : i + _QUAD_CHUNK]) for i in chunks])
    value = float(logsumexp(h + lw))
    peak = float(np.max(h))
    # integrand on the faces of the box that are not prior bounds
    shape = (n,) * dim
    hg = h.reshape(shape)
    edge_ok = True
    for axis in range(dim):
        for side, bound, limit in ((0, lo[axis], lower[axis]), (n - 1, hi[axis], upper[axis])):
            if np.isclose(bound, limit):
                continue
            face = np.take(hg, side, axis=axis)
            if np.max(face) > peak - 30.0:
                edge_ok = False
    return value, edge_ok


def _lambda_integrated(target: Target, eta: np.ndarray) -> np.ndarray:
    """``log ∫ L(λ, η) π(λ) dλ + log π(η)`` for rows of ``η = (u_1..u_l[, ρ_1..ρ_l])``."""
    l, q = target.l, target.q
    u = eta[:, :l]
    if target.order:
        rho = eta[:, l:].reshape(-1, l, 1)
    else:
        rho = np.zeros((len(eta), l, 0))
    taps = np.concatenate([np.ones((len(eta), l, 1)), -rho], axis=-1)
    mats = np.einsum("Mji,jikab,Mjk->Mjab", taps, target.window, taps)
    weights = np.exp(-2.0 * u)
    mw = np.einsum("Mj,Mjab->Mab", weights, mats)
    c = mw[:, 0, 0]
    out = -0.5 * c
    if q:
        s2 = target.priors.coefficients.scale ** 2
        m0 = -target.stats.center
        a = mw[:, 1:, 1:] + np.diag(1.0 / s2)
        bt = mw[:, 1:, 0] + m0 / s2
        chol = np.linalg.cholesky(a)
        z = np.linalg.solve(chol, bt[..., None])[..., 0]
        logdet = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
        out = out - 0.5 * np.sum(m0**2 / s2) + 0.5 * np.sum(z**2, axis=-1) - 0.5 * logdet - 0.5 * np.sum(np.log(s2))
    n = target.n_eff
    out = out + np.sum(-0.5 * n * _LOG_2PI - n * u, axis=-1)
    out = out - np.sum(np.log(target.priors.noise.log_width))
    if target.order:
        out = out + np.sum(0.5 * np.log1p(-rho[..., 0] ** 2), axis=-1)
        out = out - l * np.log(target.priors.ar.upper - target.priors.ar.lower)
    return out


def laplace_log_evidence(stats: SufficientStatistics, priors: Priors, likelihood: str = "white", start=None) -> float:
    """Laplace approximation of ``log Z`` in ``θ = (λ, log σ[, φ])``.

    Parameters
    ----------
    stats : SufficientStatistics
    priors : Priors
    likelihood : {"white", "ar1", "arP"}
    start : array_like, shape (q,), optional
        Coefficients where the Newton search for the mode starts (default: NSI estimate).

    Returns
    -------
    float
        ``log p(θ*) + log L(θ*) + (d/2) log 2π - ½ log|-H(θ*)|``; NaN when ``-H`` is not positive
        definite or the mode lies outside the prior support.
    """
    target = Target.build(stats, priors, likelihood)
    return _laplace(target, start)[0]


def _laplace(target: Target, start=None, found=None):
    """Laplace log evidence, mode and convergence; ``found``: the caller's ``find_mode`` result from ``start``."""
    mode, value, hess, converged = found if found is not None else target.find_mode(target.initial_theta(start))
    neg = -0.5 * (hess + hess.T)
    try:
        chol = np.linalg.cholesky(neg)
    except np.linalg.LinAlgError:
        return float("nan"), mode, converged
    if not np.isfinite(target.log_prior(mode)):
        return float("nan"), mode, converged
    logdet = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return float(value + 0.5 * target.ndim * _LOG_2PI - 0.5 * logdet), mode, converged
