"""Marginal evidence of a candidate model with its posterior and diagnostics (docs/method.md §6; paper Eqs. 1-4).

``Z = ∫ L(θ) π(θ) dθ`` over ``θ = (λ, log σ_1..log σ_l[, φ])``, estimated three ways:

* **bridge sampling** on the posterior draws (:mod:`.bridge`): the reported estimate. For white and
  AR(1) residuals the noise parameters are integrated out first (:mod:`.collapsed`, docs/method.md
  §6 Eq. 6.4) and only ``λ`` is sampled and bridged (Monte-Carlo error ≈ 1e-4 nat); for AR(P), P > 1,
  or with ``collapse=False`` emcee samples all of ``θ`` (RMSE ≈ 0.002 nat on affine stand-ins);
* **Laplace** approximation at the posterior mode (:mod:`.analytic`), a free cross-check (a
  disagreement > 0.1 nat is flagged); an approximation with no Monte-Carlo error: its error is
  stated as its distance to the exact value, or to the sampled estimate (``laplace_error``);
* **exact** by quadrature over the coefficients of the collapsed integrand (:mod:`.quadrature`):
  white and AR(1) residuals, at most 3 coefficients, any number of channels; computed by default;
* **exact** (:mod:`.analytic`): closed form in ``λ`` and quadrature over the noise parameters,
  where those have at most 4 dimensions; computed by default up to 3 dimensions.

Stepping-stone sampling over power posteriors is the documented fallback for multimodal or
strongly non-Gaussian posteriors; it is not implemented here because bridge sampling was more
accurate and cheaper on these problems.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ..exceptions import ConvergenceWarning
from ._collapsed_run import collapsed_summary, sample_collapsed
from ._target import Target, parse_likelihood
from .analytic import _laplace, closed_form_log_evidence
from .bridge import BridgeEstimate, _bridge, bridge_sampling
from .collapsed import collapsible
from .convergence import ConvergenceReport, convergence_report, posterior_summary
from .likelihood import SufficientStatistics, _beta, sufficient_statistics
from .pointwise import BlockStatistics, pointwise_log_likelihood
from .posterior import PosteriorSamples, SamplerRecord
from .priors import Priors
from .quadrature import MAX_QUADRATURE_COEFFICIENTS, QuadratureEvidence, quadrature_log_evidence
from .sampling import _sample

__all__ = ["EvidenceResult", "evidence_from_statistics", "marginal_evidence"]

_AUTO_QUAD_DIM = 3  # "auto" computes the exact value up to this dimension (4-D takes seconds)
DISAGREEMENT_NAT = 0.1


@dataclass(frozen=True)
class EvidenceResult:
    """Evidence of one candidate with the draws and diagnostics behind it (docs/method.md §6).

    Attributes
    ----------
    log_evidence : float
        Bridge-sampling estimate of ``log Z`` [nat].
    log_evidence_se : float
        Its Monte-Carlo standard error [nat].
    laplace_log_evidence : float
        Laplace approximation, no Monte-Carlo estimate (NaN when the mode's Hessian is not negative
        definite); its error is :attr:`laplace_error`.
    closed_form_log_evidence : float or None
        Exact value by quadrature over the noise parameters where available (see module notes), else None.
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
    quadrature : QuadratureEvidence or None
        Exact value by quadrature over the coefficients (:func:`~bayesnsi.evidence.quadrature_log_evidence`:
        white or AR(1) residuals, at most 3 coefficients), else None.
    blocks : BlockStatistics or None
        Statistics of the record's blocks, for the pointwise log-likelihood of the draws
        (:meth:`pointwise_log_likelihood`; set by :func:`~bayesnsi.evidence.candidate_evidence`).
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
    quadrature: QuadratureEvidence | None = None
    blocks: BlockStatistics | None = field(default=None, repr=False, compare=False)

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(
            self, likelihood=self.likelihood, log_evidence=self.log_evidence, log_evidence_se=self.log_evidence_se,
            coefficient_names=self.coefficient_names, rhat_max=self.rhat_max, ess_min=self.ess_min,
            posterior=self.posterior.samples, warnings=len(self.warnings),
        )

    @property
    def sampler(self) -> SamplerRecord | None:
        """The sampler that drew :attr:`posterior` (name, version, moves, walkers, steps)."""
        return self.posterior.sampler

    @property
    def exact_log_evidence(self) -> float | None:
        """The exact value where one was computed: by quadrature over the coefficients, else the closed form."""
        if self.quadrature is not None:
            return self.quadrature.log_evidence
        return self.closed_form_log_evidence

    @property
    def laplace_error(self) -> float:
        """Error of the Laplace approximation [nat]: its distance to the exact value, else to the sampled estimate.

        Against the sampled estimate the distance holds that estimate's Monte-Carlo error
        (:attr:`log_evidence_se`, about 1e-4 nat) as well. NaN when the Laplace value is NaN.
        """
        reference = self.exact_log_evidence
        return abs(self.laplace_log_evidence - (self.log_evidence if reference is None else reference))

    def pointwise_log_likelihood(self) -> np.ndarray | None:
        """Log-likelihood of each record block at each posterior draw (:mod:`~bayesnsi.evidence.pointwise`).

        Returns
        -------
        ndarray, shape (chain, draw, B), or None
            None without block statistics (an evidence computed from statistics alone).
        """
        if self.blocks is None:
            return None
        return pointwise_log_likelihood(self.posterior, self.blocks)

    @property
    def coefficient_mean(self) -> np.ndarray:
        """Posterior mean of ``λ``, shape (q,)."""
        return self.posterior.coefficients.mean(axis=(0, 1))

    def to_dict(self) -> dict:
        """JSON-ready digest (no draws).

        Returns
        -------
        dict
            Evidence estimates (the Laplace one with ``laplace_error`` and ``laplace_is_approximation``),
            exact values where computed, the sampler that ran (:meth:`SamplerRecord.to_dict`),
            coefficient means and HDIs, diagnostics, settings, priors, warnings.
        """
        quadrature = self.quadrature
        return {
            "likelihood": self.likelihood,
            "log_evidence": self.log_evidence,
            "log_evidence_se": self.log_evidence_se,
            "laplace_log_evidence": self.laplace_log_evidence,
            "laplace_error": self.laplace_error,
            "laplace_is_approximation": True,
            "quadrature_log_evidence": None if quadrature is None else quadrature.log_evidence,
            "quadrature_error": None if quadrature is None else quadrature.error,
            "closed_form_log_evidence": self.closed_form_log_evidence,
            "sampler": None if self.sampler is None else self.sampler.to_dict(),
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


def marginal_evidence(
    affine,
    priors: Priors,
    likelihood: str = "white",
    rng=None,
    *,
    n_walkers: int = 32,
    n_steps: int = 1500,
    n_burn: int = 300,
    closed_form: bool | str = "auto",
    warn: bool = True,
    collapse: bool = True,
) -> EvidenceResult:
    """Marginal evidence of one candidate from its affine reconstruction (docs/method.md §6).

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
    n_walkers, n_steps, n_burn : int
        emcee settings (see :func:`~bayesnsi.evidence.sample_posterior`; defaults 32, 1500, 300).
    closed_form : {"auto", True, False}
        Compute the exact evidence by quadrature (see :func:`evidence_from_statistics`).
    warn : bool
        Issue :class:`~bayesnsi.exceptions.ConvergenceWarning` (the messages are kept in the
        result either way).
    collapse : bool
        Integrate the noise parameters out and sample the coefficients alone (white and AR(1);
        see :func:`evidence_from_statistics`).

    Returns
    -------
    EvidenceResult
        Its ``settings["time_statistics_s"]`` is the time of the sufficient statistics.

    See Also
    --------
    evidence_from_statistics : the same from precomputed statistics, with the start of the mode
        search, the emcee moves, the bridge proposal and the convergence thresholds.
    """
    t0 = time.perf_counter()
    order, _ = parse_likelihood(likelihood)
    stats = sufficient_statistics(affine, ar_order=order)
    t_stats = time.perf_counter() - t0
    result = evidence_from_statistics(
        stats, priors, likelihood, rng, n_walkers=n_walkers, n_steps=n_steps, n_burn=n_burn, closed_form=closed_form,
        warn=warn, collapse=collapse,
    )
    return replace(result, settings={**result.settings, "time_statistics_s": t_stats})


def evidence_from_statistics(
    stats: SufficientStatistics, priors: Priors, likelihood: str = "white", rng=None, *,
    n_walkers: int = 32, n_steps: int = 1500, n_burn: int = 300, start=None, moves: str = "mixed",
    closed_form: bool | str = "auto", proposal: str = "normal",
    rhat_threshold: float = 1.01, ess_threshold: float = 400.0, disagreement_tol: float = DISAGREEMENT_NAT,
    warn: bool = True, collapse: bool = True,
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
        emcee moves (see :func:`~bayesnsi.evidence.sample_posterior`). With ``collapse``, ``"mixed"``
        is mostly emcee's independence move with the stretch move, on a wide ensemble and a run
        shortened while the independence move mixes well (:mod:`bayesnsi.evidence._collapsed_run`);
        the run that happened is ``result.sampler``.
    start : array_like, shape (q,), optional
        Coefficients where the mode search starts (default: NSI estimate).
    closed_form : {"auto", True, False}
        Compute the exact evidence by quadrature over the noise parameters: ``"auto"`` where it
        takes at most a 3-D quadrature (white noise with l <= 3, AR(1) with l = 1), ``True``
        wherever available (raises elsewhere; AR(1) with l = 2 takes seconds), ``False`` never.
        The exact value by quadrature over the coefficients (``quadrature``) is computed with
        ``"auto"`` and ``True`` wherever it is available (white and AR(1), at most 3 coefficients).
    proposal : {"normal", "t"}
        Bridge-sampling proposal.
    rhat_threshold, ess_threshold : float
        Convergence criteria (docs/method.md §6: 1.01, 400).
    disagreement_tol : float
        Bridge-vs-Laplace difference [nat] above which a warning is issued (0.1).
    warn : bool
        Issue :class:`~bayesnsi.exceptions.ConvergenceWarning` (the messages are kept in the
        result either way).
    collapse : bool
        ``True`` (default): for white and AR(1) residuals integrate ``σ`` and ``ρ`` out in closed form
        and by quadrature (docs/method.md §6, Eq. 6.4; :mod:`bayesnsi.evidence.collapsed`), sample ``λ``
        alone with emcee and bridge-sample its evidence; ``σ`` and ``ρ`` are drawn from their
        posterior given each draw. ``False``: emcee and bridge sampling over all of
        ``θ = (λ, log σ[, ρ])`` (the joint estimator; always used for AR(P), P > 1).

    Returns
    -------
    EvidenceResult
    """
    seed = int(rng) if isinstance(rng, (int, np.integer)) else None
    rng = np.random.default_rng(rng)
    target = Target.build(stats, priors, likelihood)
    collapsed = collapse and collapsible(target)
    t0 = time.perf_counter()
    found = target.find_mode(target.initial_theta(start)) if collapsed else None  # shared with the Laplace estimate
    if collapsed:
        posterior, reduced = sample_collapsed(target, rng, n_walkers, n_steps, n_burn, start, moves, found)
    else:
        posterior = _sample(target, rng, n_walkers, n_steps, n_burn, start, moves)
    t_sample = time.perf_counter() - t0

    t0 = time.perf_counter()
    if not collapsed:
        bridge = bridge_sampling(posterior, stats, priors, rng=rng, proposal=proposal)
    elif target.q:
        bridge = _bridge(reduced.log_posterior, posterior.samples[..., : target.q], rng, proposal)
    else:  # nothing left to sample: the integral is the value
        n_draws = posterior.samples.shape[0] * posterior.samples.shape[1]
        bridge = BridgeEstimate(float(reduced.log_posterior(np.zeros((1, 0)))[0]), 0.0, n_draws, 0, float(n_draws),
                                0, True, "none (closed form)")
    laplace, _, _ = _laplace(target, start, found)
    quadrature = None
    if closed_form is not False and collapsible(target) and target.q <= MAX_QUADRATURE_COEFFICIENTS:
        q = target.q
        centre, cov = posterior.mode[:q], posterior.mode_covariance[:q, :q]
        quadrature = quadrature_log_evidence(stats, priors, likelihood, centre=centre, covariance=cov)
    exact = None
    dim = target.l * (1 + target.order)
    if closed_form is True or (closed_form == "auto" and target.order <= 1 and dim <= _AUTO_QUAD_DIM):
        exact = closed_form_log_evidence(stats, priors, likelihood)
    t_evidence = time.perf_counter() - t0

    t0 = time.perf_counter()
    if collapsed:  # diagnostics of the sampled coefficients; σ, ρ drawn exactly given them
        summary, report = collapsed_summary(posterior, rhat_threshold, ess_threshold)
    else:
        summary = posterior_summary(posterior.to_datatree(), ci_prob=0.95)
        report = convergence_report(summary, rhat_threshold, ess_threshold, n_chains=posterior.samples.shape[0],
                                    n_draws=posterior.samples.shape[1])
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
            "estimator": "collapsed" if collapsed else "joint",
            "time_statistics_s": 0.0,
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
        quadrature=quadrature,
    )
