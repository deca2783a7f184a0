"""Closing the loop: from the residual of a model to an effect it lacks (SPEC section 7).

Greedy forward search: every effect of a dictionary (type × location) is added in turn to the
current candidate, identified by NSI and scored by its Laplace log-evidence (a free, accurate
approximation of the marginal evidence, EVIDENCE.md); the best is then checked with the full
evidence (emcee + bridge sampling) and kept only if

* its log Bayes factor against the current model exceeds ``threshold`` (default log 100),
* its coefficient is physically sound: quality index |Im λ|/|Re λ| below ``max_imag_ratio``,
* its coefficient is stable: identified on each half of the record it keeps its sign and stays
  within a factor ``stability_factor`` (SPEC 7: "the stability of the coefficient across data
  segments" guards against terms that only absorb model-form error).

The search repeats from the enlarged model until no effect passes or ``max_steps`` is reached.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..evidence import EVIDENCE_DEFAULTS, candidate_evidence, candidate_priors, laplace_log_evidence, sufficient_statistics
from ..exceptions import BayesNSIError, BayesNSIWarning
from ..models import CandidateModel, Term, default_gaps, effect_dictionary
from ..nsi import affine_reconstruction, identify

__all__ = ["LoopStep", "LoopResult", "close_the_loop", "score_effects"]


@dataclass(frozen=True)
class LoopStep:
    """One accepted (or the best rejected) effect.

    Attributes
    ----------
    effect_type : str
        Key of :data:`bayesnsi.models.EFFECT_TYPES` or ``"clearance g=..."``.
    term : Term
        The effect with its location.
    accepted : bool
    reason : str
        Why it was accepted or rejected.
    coefficient : float
        NSI estimate of its coefficient.
    ci95 : (float, float)
        95 % highest-density interval of the coefficient (posterior).
    imag_ratio : float
    half_coefficients : (float, float)
        Estimates on the first and the second half of the record.
    log_bayes_factor : float
        ``log Z(with effect) - log Z(without)``.
    nrmse_before, nrmse_after : float
        Open-loop NRMSE of the current and the enlarged model.
    candidate : CandidateModel
        The enlarged candidate.
    """

    effect_type: str
    term: Term
    accepted: bool
    reason: str
    coefficient: float
    ci95: tuple[float, float]
    imag_ratio: float
    half_coefficients: tuple[float, float]
    log_bayes_factor: float
    nrmse_before: float
    nrmse_after: float
    candidate: CandidateModel


@dataclass(frozen=True)
class LoopResult:
    """Outcome of :func:`close_the_loop`.

    Attributes
    ----------
    start, final : NSIResult
        Identified starting and final models.
    steps : tuple of LoopStep
        Accepted steps in order, then the last rejected best effect (if any).
    scores : tuple of list of (str, Term, float)
        Per step, every effect with its Laplace log-evidence (−inf when identification failed),
        best first.
    settings : dict
    """

    start: object
    final: object
    steps: tuple[LoopStep, ...]
    scores: tuple[list, ...]
    settings: dict = field(default_factory=dict)

    @property
    def added(self) -> tuple[LoopStep, ...]:
        """The accepted steps."""
        return tuple(s for s in self.steps if s.accepted)


def _laplace(result, signals, options):
    affine = affine_reconstruction(result, signals)
    priors = candidate_priors(result, signals, affine, options)
    order = 0 if options["likelihood"] == "white" else int(options["likelihood"][2:])
    stats = sufficient_statistics(affine, ar_order=order)
    return laplace_log_evidence(stats, priors, options["likelihood"])


def score_effects(signals, candidate, effects, nsi_options, evidence_options):
    """Identify ``candidate + effect`` for every effect and score it by Laplace log-evidence.

    Returns
    -------
    list of (effect type, Term, log-evidence, NSIResult or None), best first
    """
    scored = []
    present = {t.name for t in candidate.terms}
    for kind, term in effects:
        if term.name in present:
            continue
        trial = candidate.with_term(term)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                result = identify(signals, trial, **nsi_options)
                score = _laplace(result, signals, evidence_options)
        except (BayesNSIError, np.linalg.LinAlgError):
            scored.append((kind, term, -np.inf, None))
            continue
        scored.append((kind, term, float(score) if np.isfinite(score) else -np.inf, result))
    scored.sort(key=lambda item: item[2], reverse=True)
    return scored


def _halves(signals, candidate, nsi_options):
    n = signals.n_samples // 2
    values = []
    for part in (signals.segment(0, n), signals.segment(n, signals.n_samples)):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                values.append(identify(part, candidate, **nsi_options).coefficient_values[-1])
        except (BayesNSIError, np.linalg.LinAlgError):
            values.append(np.nan)
    return tuple(float(v) for v in values)


def _check(kind, term, trial, nrmse_before, current_z, signals, nsi_options, evidence_options, seed, *guards):
    """Full evidence and the guards of one proposed effect -> (LoopStep, its log-evidence)."""
    threshold, max_imag_ratio, stability_factor = guards
    evidence = candidate_evidence(trial, signals, evidence_options, seed, warn=False)
    ev = evidence[evidence_options["likelihood"]]
    log_bf = ev.log_evidence - current_z
    coef = trial.coefficients[-1]
    halves = _halves(signals, trial.candidate, nsi_options)
    stable = all(np.isfinite(halves)) and np.sign(halves[0]) == np.sign(halves[1]) == np.sign(coef.value)
    stable = stable and max(abs(h) for h in halves) < stability_factor * min(abs(h) for h in halves)
    if log_bf <= threshold:
        reason = f"log Bayes factor {log_bf:.2f} <= threshold {threshold:.2f}"
    elif coef.imag_ratio >= max_imag_ratio:
        reason = f"quality index |Im|/|Re| = {coef.imag_ratio:.2f} >= {max_imag_ratio}"
    elif not stable:
        reason = f"coefficient unstable across record halves: {halves[0]:.4g} vs {halves[1]:.4g}"
    else:
        reason = "accepted"
    step = LoopStep(
        effect_type=kind,
        term=term,
        accepted=reason == "accepted",
        reason=reason,
        coefficient=coef.value,
        ci95=tuple(float(c) for c in ev.ci95[-1]),
        imag_ratio=coef.imag_ratio,
        half_coefficients=halves,
        log_bayes_factor=float(log_bf),
        nrmse_before=nrmse_before,
        nrmse_after=trial.reconstruct(signals).nrmse,
        candidate=trial.candidate,
    )
    return step, ev.log_evidence


def step_result(step, scored):
    """The NSIResult of the effect a step accepted."""
    return next(result for _, term, _, result in scored if term == step.term)


def close_the_loop(
    signals,
    candidate: CandidateModel,
    *,
    nsi_options: dict | None = None,
    evidence_options: dict | None = None,
    effects=None,
    threshold: float = float(np.log(100.0)),
    max_imag_ratio: float = 0.3,
    stability_factor: float = 2.0,
    max_steps: int = 3,
    n_tries: int = 3,
    seed: int = 0,
) -> LoopResult:
    """Search the effects a candidate lacks and add those the data support (SPEC section 7).

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidate : CandidateModel
        Starting model (e.g. the selected one, or a linear model with no terms).
    nsi_options : dict, optional
        Keyword arguments of :func:`bayesnsi.nsi.identify`.
    evidence_options : dict, optional
        As :data:`bayesnsi.evidence.EVIDENCE_DEFAULTS` (default likelihood AR(1)).
    effects : list of (str, Term), optional
        The dictionary; default :func:`bayesnsi.models.effect_dictionary` over the measured
        DOFs with clearance gaps at 0.5, 1 and 1.5 displacement standard deviations.
    threshold : float
        Minimum log Bayes factor to accept an effect (default log 100 ≈ 4.6, "decisive").
    max_imag_ratio : float
        Largest accepted |Im λ|/|Re λ| of the new coefficient.
    stability_factor : float
        The half-record estimates must share the sign and differ by less than this factor.
    max_steps : int
        Most effects added.
    n_tries : int
        Per step, the best ``n_tries`` effects by Laplace evidence are checked in turn; the first
        that passes every guard is added.
    seed : int
        Seed of the evidence computations.

    Returns
    -------
    LoopResult
    """
    nsi_options = dict(nsi_options or {})
    evidence_options = {**EVIDENCE_DEFAULTS, **(evidence_options or {}), "compare": []}
    if effects is None:
        std = {d: signals.displacement[:, c].std() for c, d in enumerate(signals.output_dofs)}
        gaps = {(d,): default_gaps(s) for d, s in std.items()}
        effects = effect_dictionary(signals.output_dofs, gaps=gaps)
    seeds = iter(np.random.SeedSequence(seed).spawn(n_tries * max_steps + 1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNSIWarning)
        current = identify(signals, candidate, **nsi_options)
    start = current
    current_z = candidate_evidence(current, signals, evidence_options, next(seeds), warn=False)
    current_z = current_z[evidence_options["likelihood"]].log_evidence
    steps, all_scores = [], []
    for _ in range(max_steps):
        scored = score_effects(signals, current.candidate, effects, nsi_options, evidence_options)
        all_scores.append([(k, t, s) for k, t, s, _ in scored])
        if not scored or not np.isfinite(scored[0][2]):
            break
        step = None
        nrmse_before = current.reconstruct(signals).nrmse
        for kind, term, score, trial in scored[:n_tries]:
            if not np.isfinite(score):
                break
            guards = (threshold, max_imag_ratio, stability_factor)
            step, log_z = _check(kind, term, trial, nrmse_before, current_z, signals, nsi_options, evidence_options, next(seeds), *guards)
            steps.append(step)
            if step.accepted:
                break
        if step is None or not step.accepted:
            break
        current, current_z = step_result(step, scored), log_z
    settings = dict(
        threshold=threshold,
        max_imag_ratio=max_imag_ratio,
        stability_factor=stability_factor,
        max_steps=max_steps,
        n_tries=n_tries,
        n_effects=len(effects),
        nsi=nsi_options,
        evidence=evidence_options,
        seed=seed,
    )
    return LoopResult(start=start, final=current, steps=tuple(steps), scores=tuple(all_scores), settings=settings)
