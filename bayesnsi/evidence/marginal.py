"""Marginal evidence of a candidate model (SPEC 6; paper Eqs. 1-4 and beyond).

``Z = ∫ L(θ) π(θ) dθ`` over ``θ = (λ, log σ_1..log σ_l[, φ])``, estimated three ways:

* **bridge sampling** (Meng & Wong 1996, iterative scheme; Gronau et al. 2017 tutorial) on the
  emcee draws: a Gaussian (or multivariate-t) proposal fitted to half of the walkers, the
  other half used in the bridge; Monte-Carlo standard error from the relative mean-squared
  error of Frühwirth-Schnatter (2004), with the autocorrelation of the posterior draws. This is
  the reported estimate (EVIDENCE.md: RMSE ≈ 0.002 nat on affine stand-ins);
* **Laplace** approximation at the posterior mode, a free cross-check (a disagreement
  > 0.1 nat is flagged);
* **exact** (for tests and reports): with a Gaussian prior and an affine model the integral over
  ``λ`` is closed-form for fixed noise parameters, and the remaining integral over
  ``η = (log σ_j[, ρ_j])`` is done by tensor Gauss-Legendre quadrature. Available when ``η`` has at
  most 4 dimensions: white noise with ``l <= 4`` channels (one ``σ`` per channel; the channels are
  coupled through ``λ``), or AR(1) with ``l <= 2``. Computed by default up to 3 dimensions.

Stepping-stone sampling over power posteriors is the documented fallback for multimodal or
strongly non-Gaussian posteriors; it is not implemented here because bridge sampling was more
accurate and cheaper on these problems (EVIDENCE.md).

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

import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp

from ..exceptions import ConvergenceWarning, InputDataError
from ._target import Target, parse_likelihood
from .convergence import ConvergenceReport, convergence_report, posterior_summary
from .likelihood import SufficientStatistics, _beta, sufficient_statistics
from .priors import Priors
from .sampling import PosteriorSamples, _sample

__all__ = [
    "BridgeEstimate",
    "EvidenceResult",
    "bridge_sampling",
    "closed_form_log_evidence",
    "laplace_log_evidence",
    "marginal_evidence",
    "evidence_from_statistics",
]

_LOG_2PI = float(np.log(2.0 * np.pi))
# quadrature dimension -> (half-width in Laplace sd, Gauss-Legendre nodes per dimension); the
# 1-D error of n nodes on ±w sd of a Gaussian is ≈ 1e-12 (12, 72), 2e-6 (12, 32), 1e-8 (10, 32)
_QUAD_RULE = {1: (12.0, 160), 2: (12.0, 72), 3: (12.0, 32), 4: (10.0, 32)}
_QUAD_CHUNK = 50_000
_AUTO_QUAD_DIM = 3  # "auto" computes the exact value up to this dimension (4-D takes seconds)
DISAGREEMENT_NAT = 0.1


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


@dataclass(frozen=True)
class EvidenceResult:
    """Evidence of one candidate with the draws and diagnostics behind it (SPEC 6).

    Attributes
    ----------
    log_evidence : float
        Bridge-sampling estimate of ``log Z`` [nat].
    log_evidence_se : float
        Its Monte-Carlo standard error [nat].
    laplace_log_evidence : float
        Laplace approximation (NaN when the mode's Hessian is not negative definite).
    closed_form_log_evidence : float or None
        Exact value by quadrature where available (see module notes), else None.
    plain_log_likelihood : float
        The paper's Eq. 4 at the NSI estimate, ``Σ_j -(N/2)(log 2πσ̂_j² + 1)``.
    likelihood : str
        ``"white"``, ``"ar1"`` or ``"arP"``.
    coefficient_names : tuple of str
    posterior : PosteriorSamples
        The β = 1 (posterior) emcee draws.
    summary : pandas.DataFrame
        arviz summary: mean, sd, hdi95_lb/ub, ess_bulk, ess_tail, r_hat, mcse.
    convergence : ConvergenceReport
    rhat_max, ess_min : float
        Worst diagnostics over all parameters.
    ci95 : ndarray, shape (q, 2)
        95 % highest-density interval of each coefficient.
    bridge : BridgeEstimate
    settings : mapping
        Sampler settings, ``rng_seed`` (when an int was given) and emcee's derived ``seed``,
        timings ``time_*_s`` [s], acceptance, autocorrelation time, package versions.
    priors_text : str
        :meth:`Priors.describe` of the priors used.
    warnings : tuple of str
        Messages of the warnings issued.
    """

    log_evidence: float
    log_evidence_se: float
    laplace_log_evidence: float
    closed_form_log_evidence: float | None
    plain_log_likelihood: float
    likelihood: str
    coefficient_names: tuple[str, ...]
    posterior: PosteriorSamples
    summary: object
    convergence: ConvergenceReport
    rhat_max: float
    ess_min: float
    ci95: np.ndarray
    bridge: BridgeEstimate
    settings: Mapping = field(default_factory=dict)
    priors_text: str = ""
    warnings: tuple[str, ...] = ()

    @property
    def coefficient_mean(self) -> np.ndarray:
        """Posterior mean of ``λ``, shape (q,)."""
        return self.posterior.coefficients.mean(axis=(0, 1))

    def to_dict(self) -> dict:
        """JSON-ready digest (no draws)."""
        return {
            "likelihood": self.likelihood,
            "log_evidence": self.log_evidence,
            "log_evidence_se": self.log_evidence_se,
            "laplace_log_evidence": self.laplace_log_evidence,
            "closed_form_log_evidence": self.closed_form_log_evidence,
            "plain_log_likelihood": self.plain_log_likelihood,
            "coefficients": {
                name: {"mean": float(m), "hdi95": [float(lo), float(hi)]}
                for name, m, (lo, hi) in zip(self.coefficient_names, self.coefficient_mean, self.ci95)
            },
            "rhat_max": self.rhat_max,
            "ess_min": self.ess_min,
            "converged": self.convergence.converged,
            "settings": dict(self.settings),
            "priors": self.priors_text,
            "warnings": list(self.warnings),
        }


# ---------------------------------------------------------------------------------------------
# exact evidence by quadrature


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
    Gauss-Legendre nodes on ``η* ± 12 sd`` (Laplace marginal; ± 10 sd in 4-D), clipped to the prior
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
    centre = mode[q:]
    lower, upper = _eta_support(target)
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
    lw = sum(np.meshgrid(*logw, indexing="ij")).reshape(-1)
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


# ---------------------------------------------------------------------------------------------
# Laplace


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


def _laplace(target: Target, start=None):
    mode, value, hess, converged = target.find_mode(target.initial_theta(start))
    neg = -0.5 * (hess + hess.T)
    try:
        chol = np.linalg.cholesky(neg)
    except np.linalg.LinAlgError:
        return float("nan"), mode, converged
    if not np.isfinite(target.log_prior(mode)):
        return float("nan"), mode, converged
    logdet = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return float(value + 0.5 * target.ndim * _LOG_2PI - 0.5 * logdet), mode, converged


# ---------------------------------------------------------------------------------------------
# bridge sampling


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
    rng = np.random.default_rng(rng)
    target = Target.build(stats, priors, posterior.likelihood)
    draws = posterior.samples
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
    l1 = target.log_posterior(flat) - log_g(flat)
    l2 = target.log_posterior(prop) - log_g(prop)
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
    it = 0
    for it in range(1, max_iter + 1):
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
        n_iterations=int(it),
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


# ---------------------------------------------------------------------------------------------
# the complete evidence of one candidate


def marginal_evidence(
    affine,
    priors: Priors,
    likelihood: str = "white",
    rng=None,
    **options,
) -> EvidenceResult:
    """Marginal evidence of one candidate from its affine reconstruction (SPEC 6).

    Parameters
    ----------
    affine : AffineReconstruction
        From :func:`bayesnsi.nsi.affine_reconstruction`.
    priors : Priors
        Proper priors fixed before the fit (:func:`~bayesnsi.evidence.default_priors`).
    likelihood : {"white", "ar1", "arP"}
        Residual model: white; exact stationary AR(1); conditional AR(P).
    rng : int or numpy.random.Generator, optional
        Source of all randomness (walker start, emcee, bridge proposal).
    **options
        Passed to :func:`evidence_from_statistics` (``n_walkers``, ``n_steps``, ``n_burn``,
        ``start``, ``moves``, ``closed_form``, ``proposal``, ``warn``, thresholds).

    Returns
    -------
    EvidenceResult
    """
    t0 = time.perf_counter()
    order, _ = parse_likelihood(likelihood)
    stats = sufficient_statistics(affine, ar_order=order)
    t_stats = time.perf_counter() - t0
    return evidence_from_statistics(stats, priors, likelihood, rng, _t_stats=t_stats, **options)


def evidence_from_statistics(
    stats: SufficientStatistics,
    priors: Priors,
    likelihood: str = "white",
    rng=None,
    *,
    n_walkers: int = 32,
    n_steps: int = 1500,
    n_burn: int = 300,
    start=None,
    moves: str = "mixed",
    closed_form: bool | str = "auto",
    proposal: str = "normal",
    rhat_threshold: float = 1.01,
    ess_threshold: float = 400.0,
    disagreement_tol: float = DISAGREEMENT_NAT,
    warn: bool = True,
    _t_stats: float = 0.0,
) -> EvidenceResult:
    """Evidence, posterior and diagnostics from precomputed sufficient statistics.

    Parameters
    ----------
    stats : SufficientStatistics
    priors : Priors
    likelihood : {"white", "ar1", "arP"}
    rng : int or numpy.random.Generator, optional
    n_walkers, n_steps, n_burn : int
        emcee settings (see :func:`~bayesnsi.evidence.sample_posterior`; defaults 32, 1500, 300).
    moves : {"mixed", "stretch", "de"}
        emcee moves (see :func:`~bayesnsi.evidence.sample_posterior`).
    start : array_like, shape (q,), optional
        Coefficients where the mode search starts (default: NSI estimate).
    closed_form : {"auto", True, False}
        Compute the exact evidence by quadrature: ``"auto"`` where it takes at most a 3-D
        quadrature (white noise with l <= 3, AR(1) with l = 1), ``True`` wherever available
        (raises elsewhere; AR(1) with l = 2 takes seconds), ``False`` never.
    proposal : {"normal", "t"}
        Bridge-sampling proposal.
    rhat_threshold, ess_threshold : float
        Convergence criteria (SPEC 6: 1.01, 400).
    disagreement_tol : float
        Bridge-vs-Laplace difference [nat] above which a warning is issued (0.1).
    warn : bool
        Issue :class:`~bayesnsi.exceptions.ConvergenceWarning` (the messages are kept in the
        result either way).

    Returns
    -------
    EvidenceResult
    """
    seed = int(rng) if isinstance(rng, (int, np.integer)) else None
    rng = np.random.default_rng(rng)
    target = Target.build(stats, priors, likelihood)
    t0 = time.perf_counter()
    posterior = _sample(target, rng, n_walkers, n_steps, n_burn, start, moves)
    t_sample = time.perf_counter() - t0

    t0 = time.perf_counter()
    bridge = bridge_sampling(posterior, stats, priors, rng=rng, proposal=proposal)
    laplace, _, _ = _laplace(target, start)
    exact = None
    dim = target.l * (1 + target.order)
    if closed_form is True or (closed_form == "auto" and target.order <= 1 and dim <= _AUTO_QUAD_DIM):
        exact = closed_form_log_evidence(stats, priors, likelihood)
    t_evidence = time.perf_counter() - t0

    t0 = time.perf_counter()
    tree = posterior.to_datatree()
    summary = posterior_summary(tree, ci_prob=0.95)
    report = convergence_report(
        summary, rhat_threshold, ess_threshold, n_chains=posterior.samples.shape[0], n_draws=posterior.samples.shape[1]
    )
    q = target.q
    rows = [f"coefficient[{name}]" for name in stats.names]
    ci95 = summary.loc[rows, ["hdi95_lb", "hdi95_ub"]].to_numpy() if q else np.zeros((0, 2))
    t_summary = time.perf_counter() - t0

    messages = []
    context = f"evidence ({likelihood} likelihood, terms {list(stats.names)})"
    if not report.converged:
        messages.append(f"{context}: {report.message()}")
    if np.isfinite(laplace) and abs(bridge.log_evidence - laplace) > disagreement_tol:
        messages.append(
            f"{context}: bridge sampling (log Z = {bridge.log_evidence:.3f} ± {bridge.se:.3f}) and the Laplace "
            f"approximation ({laplace:.3f}) differ by {abs(bridge.log_evidence - laplace):.3f} nat > "
            f"{disagreement_tol} nat: the posterior is far from Gaussian or the chains are too short; "
            "inspect the draws and run longer (n_steps)."
        )
    if warn:
        for msg in messages:
            warnings.warn(msg, ConvergenceWarning, stacklevel=2)

    beta = _beta(np.zeros(q))
    rss = np.einsum("a,jab,b->j", beta, stats.gram, beta)
    n = stats.n_samples
    with np.errstate(divide="ignore"):
        plain = float(np.sum(-0.5 * n * (np.log(2.0 * np.pi * rss / n) + 1.0)))

    import arviz_base
    import arviz_stats

    settings = dict(posterior.settings)
    settings.update(
        {
            "rng_seed": seed,
            "numpy_version": np.__version__,
            "arviz_base_version": arviz_base.__version__,
            "arviz_stats_version": arviz_stats.__version__,
            "likelihood": likelihood,
            "n_samples": n,
            "proposal": proposal,
            "time_statistics_s": _t_stats,
            "time_sampling_s": t_sample,
            "time_evidence_s": t_evidence,
            "time_summary_s": t_summary,
            "acceptance_mean": float(np.mean(posterior.acceptance_fraction)),
            "autocorr_time_max": float(np.max(posterior.autocorr_time)),
        }
    )
    return EvidenceResult(
        log_evidence=bridge.log_evidence,
        log_evidence_se=bridge.se,
        laplace_log_evidence=laplace,
        closed_form_log_evidence=exact,
        plain_log_likelihood=plain,
        likelihood=likelihood,
        coefficient_names=tuple(stats.names),
        posterior=posterior,
        summary=summary,
        convergence=report,
        rhat_max=report.rhat_max,
        ess_min=report.ess_min,
        ci95=ci95,
        bridge=bridge,
        settings=settings,
        priors_text=priors.describe(include_ar=target.order > 0),
        warnings=tuple(messages),
    )
