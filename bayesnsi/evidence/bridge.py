"""Bridge-sampling estimate of the marginal evidence from posterior draws (docs/method.md §6).

A Gaussian (or multivariate-t) proposal is fitted to half of the walkers, the other half is used
in the bridge (Meng & Wong 1996, iterative scheme; Gronau et al. 2017 tutorial); the Monte-Carlo
standard error comes from the relative mean-squared error of Frühwirth-Schnatter (2004), with
the autocorrelation of the posterior draws.

References
----------
Meng, X.-L., Wong, W. H. (1996). Simulating ratios of normalizing constants via a simple
identity. Statistica Sinica 6, 831-860, Eq. (4.1).
Frühwirth-Schnatter, S. (2004). Estimating marginal likelihoods for mixture and Markov switching
models using bridge sampling techniques. Econometrics Journal 7, 143-167, Sec. 3.4.
Gronau, Q. F. et al. (2017). A tutorial on bridge sampling. J. Math. Psychol. 81, 80-97,
Eqs. (9)-(10), (16)-(17).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from ..exceptions import InputDataError
from ._target import _LOG_2PI, Target
from .likelihood import SufficientStatistics
from .posterior import PosteriorSamples
from .priors import Priors

__all__ = ["BridgeEstimate", "bridge_sampling"]


@dataclass(frozen=True)
class BridgeEstimate:
    """Result of :func:`bridge_sampling`.

    Attributes
    ----------
    log_evidence : float
        ``log Z`` [nat].
    se : float
        Monte-Carlo standard error of ``log Z``, ``sqrt(RE²)`` (relative MSE of ``Z``).
    n_posterior, n_proposal : int
        Posterior draws used in the bridge and proposal draws.
    n_posterior_eff : float
        Effective number of posterior draws (autocorrelation of the bridge terms).
    n_iterations : int
        Iterations of the Meng-Wong fixed point.
    converged : bool
        Whether the fixed point converged to ``tol``.
    proposal : str
        ``"normal"`` or ``"t"``.
    """

    log_evidence: float
    se: float
    n_posterior: int
    n_proposal: int
    n_posterior_eff: float
    n_iterations: int
    converged: bool
    proposal: str


def bridge_sampling(
    posterior: PosteriorSamples,
    stats: SufficientStatistics,
    priors: Priors,
    rng=None,
    proposal: str = "normal",
    df: float = 10.0,
    tol: float = 1e-10,
    max_iter: int = 1000,
) -> BridgeEstimate:
    """Bridge-sampling estimate of ``log Z`` from posterior draws (Meng & Wong 1996).

    Parameters
    ----------
    posterior : PosteriorSamples
        Draws with at least 4 chains (walkers).
    stats : SufficientStatistics
    priors : Priors
        The priors the draws were sampled under.
    rng : int or numpy.random.Generator, optional
        For the proposal draws.
    proposal : {"normal", "t"}
        Proposal family fitted (mean, covariance) to the even-numbered walkers.
    df : float
        Degrees of freedom of the t proposal.
    tol : float
        Relative convergence tolerance on ``log Z`` of the fixed-point iteration (absolute below 1).
    max_iter : int
        Iteration limit.

    Returns
    -------
    BridgeEstimate

    Notes
    -----
    With ``l₁ = log q(θ_i) - log g(θ_i)`` on posterior draws (odd-numbered walkers,
    ``N₁`` of them, effective ``N₁'``), ``l₂`` the same on ``N₂ = N₁`` proposal draws and
    ``s₁ = N₁'/(N₁'+N₂)``, ``s₂ = 1 - s₁``, iterate (Gronau et al. 2017, Eq. 17)

    .. math:: \\hat Z^{(t+1)} = \\frac{N_2^{-1}\\sum_i e^{l_{2,i}} / (s_1 e^{l_{2,i}} + s_2 \\hat Z^{(t)})}
                                 {N_1^{-1}\\sum_j 1 / (s_1 e^{l_{1,j}} + s_2 \\hat Z^{(t)})}.

    Relative MSE (Frühwirth-Schnatter 2004): ``RE² = Var(f₁)/(N₂ E[f₁]²) + τ_{f₂} Var(f₂)/(N₁ E[f₂]²)``,
    ``f₁ = p/(s₁p + s₂g)`` on proposal draws, ``f₂ = g/(s₁p + s₂g)`` on posterior draws,
    ``τ_{f₂}`` the integrated autocorrelation time of ``f₂`` along the walkers. ``se = sqrt(RE²)``.
    """
    target = Target.build(stats, priors, posterior.likelihood)
    return _bridge(target.log_posterior, posterior.samples, rng, proposal, df, tol, max_iter)


def _bridge(log_posterior, draws: np.ndarray, rng=None, proposal: str = "normal", df: float = 10.0,
            tol: float = 1e-10, max_iter: int = 1000) -> BridgeEstimate:
    """:func:`bridge_sampling` of any vectorised unnormalised ``log_posterior`` on (chain, draw, d) ``draws``."""
    rng = np.random.default_rng(rng)
    if draws.shape[0] < 4:
        raise InputDataError(f"bridge sampling needs at least 4 chains (walkers), got {draws.shape[0]}")
    fit = draws[0::2].reshape(-1, draws.shape[-1])
    held = draws[1::2]  # (chain, draw, d)
    n_chain, n_draw, dim = held.shape
    mean = fit.mean(axis=0)
    cov = np.atleast_2d(np.cov(fit, rowvar=False))
    chol = np.linalg.cholesky(cov + 1e-12 * np.diag(np.diag(cov)))
    n1 = n_chain * n_draw
    n2 = n1
    z = rng.standard_normal((n2, dim))
    if proposal == "t":
        z = z / np.sqrt(rng.chisquare(df, size=(n2, 1)) / df)
    elif proposal != "normal":
        raise InputDataError(f"proposal must be 'normal' or 't', got {proposal!r}")
    prop = mean + z @ chol.T

    def log_g(x):
        y = np.linalg.solve(chol, (x - mean).T).T
        maha = np.sum(y**2, axis=-1)
        logdet = float(np.sum(np.log(np.diag(chol))))
        if proposal == "normal":
            return -0.5 * maha - logdet - 0.5 * dim * _LOG_2PI
        from scipy.special import gammaln

        return (
            gammaln(0.5 * (df + dim)) - gammaln(0.5 * df) - 0.5 * dim * np.log(df * np.pi) - logdet
            - 0.5 * (df + dim) * np.log1p(maha / df)
        )

    flat = held.reshape(-1, dim)
    l1 = log_posterior(flat) - log_g(flat)
    l2 = log_posterior(prop) - log_g(prop)
    tau1 = _tau(l1.reshape(n_chain, n_draw))
    n1_eff = n1 / tau1
    log_s1 = np.log(n1_eff / (n1_eff + n2))
    log_s2 = np.log(n2 / (n1_eff + n2))
    log_n1, log_n2 = np.log(n1), np.log(n2)

    # start from the importance-sampling estimate with the proposal
    log_z = float(logsumexp(l2) - log_n2)
    if not np.isfinite(log_z):
        log_z = float(np.median(l1))
    converged = False
    n_iterations = 0
    while n_iterations < max_iter:
        n_iterations += 1
        num = logsumexp(l2 - np.logaddexp(log_s1 + l2, log_s2 + log_z)) - log_n2
        den = logsumexp(-np.logaddexp(log_s1 + l1, log_s2 + log_z)) - log_n1
        new = float(num - den)
        if abs(new - log_z) < tol * max(1.0, abs(log_z)) + 1e-12:
            log_z = new
            converged = True
            break
        log_z = new

    # relative mean-squared error
    with np.errstate(over="ignore"):
        f1 = np.exp(-np.logaddexp(log_s1, log_s2 - (l2 - log_z)))  # p/(s1 p + s2 g), proposal draws
        f2 = np.exp(-np.logaddexp(log_s1 + (l1 - log_z), log_s2))  # g/(s1 p + s2 g), posterior draws
    tau2 = _tau(f2.reshape(n_chain, n_draw))
    re2 = np.var(f1) / (n2 * np.mean(f1) ** 2) + tau2 * np.var(f2) / (n1 * np.mean(f2) ** 2)
    return BridgeEstimate(
        log_evidence=log_z,
        se=float(np.sqrt(re2)),
        n_posterior=int(n1),
        n_proposal=int(n2),
        n_posterior_eff=float(n1 / tau2),
        n_iterations=n_iterations,
        converged=converged,
        proposal=proposal,
    )


def _tau(values: np.ndarray) -> float:
    """Integrated autocorrelation time of (chain, draw) values, at least 1 (emcee's estimator)."""
    from emcee.autocorr import AutocorrError, integrated_time

    values = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(values)) or np.ptp(values) == 0:
        return 1.0
    try:
        tau = integrated_time(values.T)
    except AutocorrError as err:
        tau = err.tau
    return float(max(1.0, np.max(tau)))
