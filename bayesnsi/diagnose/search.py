"""Closing the loop: from the residual of a model to an effect it lacks (SPEC section 7).

Greedy forward search with a backward check: every effect of a dictionary (type × location) is
first ranked by a cheap frequency-domain screen (:func:`bayesnsi.diagnose.screen.screen_effects`:
how much of the outputs the effect's input explains, with nothing assumed about the linear
model); the best ``screen`` of them are added in turn to the current candidate, identified by NSI
(sharing the current model's Hankel products, :func:`bayesnsi.nsi.hankel_correlations`) and
scored by their Laplace log-evidence (a free, accurate approximation of the marginal evidence,
EVIDENCE.md); clearances among the best have their gap refined off the grid
(:func:`refine_gap`); the best ``n_tries`` are then checked in turn and the first is kept only if

* its log Bayes factor (Laplace) against the current model exceeds ``threshold`` (default log
  100); the full evidence (emcee + bridge sampling) then gives its credible interval,
* its coefficient is physically sound: quality index |Im λ|/|Re λ| below ``max_imag_ratio``,
* its coefficient is stable: identified on each half of the record it keeps its sign and stays
  within a factor ``stability_factor`` (SPEC 7: "the stability of the coefficient across data
  segments" guards against terms that only absorb model-form error).

An effect that fails only the quality index may owe it to a second missing effect: the search
then looks one effect ahead (``lookahead``) and adds the pair when both pass. After each
addition, effects added earlier that the new one made redundant, or whose coefficient moved
(sign or more than ``stability_factor``), are removed. The search repeats from the enlarged
model until no effect passes or ``max_steps`` effects were added. A final model that holds a
friction-like term (``sign()`` of a velocity) is identified once more on an upsampled grid for its
reported coefficients (``refine_final``). The effects of a step can be scored in worker processes
or on a Dask cluster (``jobs``, ``scheduler``) with the same result. Every accepted step carries
its open- and closed-loop errors before and after, and the residual of both models as a force at
the effect's location (:mod:`bayesnsi.diagnose.forces`, SPEC 7.5).

Measured on :mod:`bayesnsi.simulate.undeclared` by ``benchmarks/diagnose_suite.py``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from ..options import EvidenceOptions, NSIOptions, parse_likelihood
from ..evidence import (
    candidate_affine,
    candidate_evidence,
    candidate_priors,
    laplace_log_evidence,
    sufficient_statistics,
)
from ..exceptions import BayesNSIError, BayesNSIWarning, InputDataError
from ..models import CandidateModel, Term, default_gaps, effect_dictionary
from ..models.dictionary import clearance_effect, clearance_gap, effect_base_type
from ..nsi import hankel_correlations, identify, nrmse
from .forces import ResidualForce, residual_force
from .screen import screen_effects

LOOP_EVIDENCE_DEFAULTS = None
"""Evidence settings of the loop. The loop scores effects on the open-loop reconstruction
residual. With the velocity noise estimated by high-order differences (4× too large at the driven
DOF), scoring on the innovations ranked velocity look-alikes at DOF 2 (v2³, v2|v2|) first and found
both missing effects in 3/5 two-missing runs at 1 % noise, against 5/5; with the consistency
estimate (:func:`bayesnsi.nsi._eiv.measured_noise_std`) both residuals give the same counts in every
row of ``benchmarks/diagnose_suite.py`` (``--residual innovations``, 5 seeds, 1 and 5 % noise)."""

__all__ = ["LOOP_EVIDENCE_DEFAULTS", "LoopResult", "LoopStep", "close_the_loop", "refine_gap", "score_effects"]


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
        Estimates on the first and the second half of the record (NaN when the effect failed
        the Bayes-factor threshold: they are then not computed).
    log_bayes_factor : float
        ``log Z(with effect) - log Z(without)``, both by the Laplace approximation.
    nrmse_before, nrmse_after : float
        Open-loop NRMSE of the current and the enlarged model.
    candidate : CandidateModel
        The enlarged candidate.
    closed_loop_nrmse_before, closed_loop_nrmse_after : float
        NRMSE of the closed-loop simulation (SPEC 5) on the estimation data of the model without
        and with the effect (for an effect accepted in exchange, "without" is the model holding
        the effect it replaced, as for ``nrmse_before`` and ``log_bayes_factor``); NaN when that
        simulation diverges (chaotic or unstable in feedback, SPEC 10) and for rejected effects
        (not computed).
    residual_force : ResidualForce or None
        The residual of the models without and with the effect as a force at its location
        (:func:`bayesnsi.diagnose.forces.residual_force`); accepted steps only.
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
    closed_loop_nrmse_before: float = float("nan")
    closed_loop_nrmse_after: float = float("nan")
    residual_force: ResidualForce | None = None


@dataclass(frozen=True)
class LoopResult:
    """Outcome of :func:`close_the_loop`.

    Attributes
    ----------
    start, final : NSIResult
        Identified starting and final models. The final model is re-identified on an upsampled
        grid when it holds a term that switches with velocity (see ``refine_final`` of
        :func:`close_the_loop`); ``settings["final_nsi"]`` holds the settings it was identified with.
    steps : tuple of LoopStep
        Accepted steps in the order they were added, then every rejected (or later removed)
        effect that was checked, in the order checked (``ci95`` is NaN for effects that failed a
        guard: they were not sampled).
    scores : tuple of list of (str, Term, float)
        Per step, every effect with its Laplace log-evidence, best first: −inf when
        identification failed, NaN (after the scored ones, in screen order) when the screen left
        it out (see ``screen`` of :func:`close_the_loop`).
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


class _Entry(NamedTuple):
    """An effect scored by :func:`_score_one`."""

    kind: str
    term: Term
    score: float  # Laplace log-evidence of the enlarged model; -inf failed, NaN screened out
    result: object  # NSIResult of the enlarged model, or None
    nrmse: float  # its open-loop NRMSE, NaN when not known


def _laplace(result, signals, options) -> tuple[float, float]:
    """Laplace log-evidence of ``result`` and, from the same affine model, its open-loop NRMSE.

    The NRMSE is NaN unless the evidence scores the open-loop reconstruction residual (then
    the affine model at the NSI estimate is that reconstruction, SPEC 5).
    """
    residual = options.residual
    affine = candidate_affine(result, signals, residual)
    priors = candidate_priors(result, signals, affine, options)
    order = parse_likelihood(options.likelihood)[0]
    stats = sufficient_statistics(affine, ar_order=order)
    score = laplace_log_evidence(stats, priors, options.likelihood)
    error = nrmse(affine.measured, affine.predict(affine.estimate))[1] if residual == "reconstruction" else np.nan
    return score, error


def _shared_correlations(signals, candidate, nsi_options):
    """Hankel products of ``candidate`` that every ``candidate + effect`` shares (None if unusable)."""
    try:
        return hankel_correlations(signals, candidate, nsi_options)
    except (BayesNSIError, np.linalg.LinAlgError):
        return None


def _score_one(signals, candidate, kind, term, nsi_options, evidence_options, correlations=None):
    """(kind, term, Laplace log-evidence or -inf, NSIResult or None) of ``candidate + term``.

    ``correlations``: :func:`_shared_correlations` of ``candidate`` (saves most of the Hankel
    products; the result is the same).
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            result = identify(signals, candidate.with_term(term), nsi_options, correlations=correlations)
            score, error = _laplace(result, signals, evidence_options)
    except (BayesNSIError, np.linalg.LinAlgError):
        return _Entry(kind, term, -np.inf, None, np.nan)
    return _Entry(kind, term, float(score) if np.isfinite(score) else -np.inf, result, float(error))


def _score_task(context, kind, term):
    """:func:`_score_one` for :func:`bayesnsi.run.dispatch` (context: data, model, settings, products)."""
    return _score_one(context[0], context[1], kind, term, context[2], context[3], context[4])


def _new_effects(candidate, effects, exclude=()) -> list:
    """The effects not in ``candidate`` whose (base type, location) is not in ``exclude``."""
    present = {t.name for t in candidate.terms}
    exclude = set(exclude)
    return [
        (kind, term)
        for kind, term in effects
        if term.name not in present and (effect_base_type(kind), tuple(term.at)) not in exclude
    ]


def score_effects(
    signals, candidate, effects, nsi_options, evidence_options, exclude=(), jobs: int = 1, scheduler=None,
    correlations=None,
):
    """Identify ``candidate + effect`` for every effect and score it by Laplace log-evidence.

    Parameters
    ----------
    signals, candidate, effects, nsi_options, evidence_options
        As in :func:`close_the_loop`.
    exclude : iterable of (str, tuple of int)
        ``(base type, location)`` pairs to skip (effects the loop already added: a second
        clearance at the same location, whatever its gap, only absorbs the first one's misfit).
    jobs, scheduler
        Local worker processes or a Dask scheduler (:func:`bayesnsi.run.dispatch`); the scores
        do not depend on them.
    correlations : HankelCorrelations, optional
        :func:`bayesnsi.nsi.hankel_correlations` of ``candidate`` with these NSI settings, when
        already computed (computed here otherwise).

    Returns
    -------
    list of (effect type, Term, log-evidence, NSIResult or None, open-loop NRMSE)
        Best first (ties in dictionary order); named fields ``kind, term, score, result, nrmse``.
    """
    from ..run import dispatch

    tasks = _new_effects(candidate, effects, exclude)
    scored = [None] * len(tasks)
    if correlations is None:
        correlations = _shared_correlations(signals, candidate, nsi_options)
    context = (signals, candidate, nsi_options, evidence_options, correlations)
    for index, value in dispatch(_score_task, tasks, context=context, jobs=jobs, scheduler=scheduler):
        scored[index] = value
    scored.sort(key=lambda item: item[2], reverse=True)
    return scored


def refine_gap(signals, candidate, entry, effects, nsi_options, evidence_options, points: int = 9, correlations=None):
    """Refine the gap of a clearance effect between its neighbours on the dictionary's grid.

    SPEC 7 offers clearances "on a grid of g"; the coefficient of a clearance spring is only
    meaningful with the right gap (a gap 10 % too large inflates the stiffness by far more), so
    the gap of a promising clearance is refined by two rounds of a ``points``-point grid search
    of the Laplace log-evidence: first between the neighbouring grid gaps at the same location
    (down to half the smallest, up to 1.5 times the largest), then within one spacing of the best.

    Parameters
    ----------
    entry : (str, Term, float, NSIResult, float)
        A clearance entry of :func:`score_effects`.
    correlations : HankelCorrelations, optional
        As in :func:`score_effects`.

    Returns
    -------
    (str, Term, float, NSIResult, float)
        The best entry found (``entry`` itself when nothing beats it).
    """
    kind, term = entry[0], entry[1]
    gap = clearance_gap(kind)
    if gap is None:
        return entry
    grid = sorted({clearance_gap(k) for k, t in effects if clearance_gap(k) is not None and tuple(t.at) == tuple(term.at)})
    lower = max((g for g in grid if g < gap), default=0.5 * gap)
    upper = min((g for g in grid if g > gap), default=1.5 * gap)
    best = entry
    if correlations is None:
        correlations = _shared_correlations(signals, candidate, nsi_options)
    for _ in range(2):
        for g in np.linspace(lower, upper, points):
            if g <= 0:
                continue
            trial = _score_one(
                signals, candidate, *clearance_effect(term.at, float(g)), nsi_options, evidence_options, correlations
            )
            if trial[2] > best[2]:
                best = trial
        centre, step = clearance_gap(best[0]), (upper - lower) / (points - 1)
        lower, upper = max(centre - step, 0.5 * step), centre + step
    return best


def _halves(signals, candidate, nsi_options, cache=None):
    """The last coefficient of ``candidate`` identified on each half of the record.

    ``cache``: a dict kept across calls; the Hankel products of each half for the candidate
    without its last term are stored in it, so that the effects checked against one model share
    them (:func:`_shared_correlations`).
    """
    n = signals.n_samples // 2
    parts = (signals.segment(0, n), signals.segment(n, signals.n_samples))
    shared = (None, None)
    if cache is not None and candidate.terms:
        base = _without(candidate, candidate.terms[-1])
        key = tuple(t.name for t in base.terms)
        if key not in cache:
            cache[key] = tuple(_shared_correlations(part, base, nsi_options) for part in parts)
        shared = cache[key]
    values = []
    for part, correlations in zip(parts, shared):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                values.append(identify(part, candidate, nsi_options, correlations=correlations).coefficient_values[-1])
        except (BayesNSIError, np.linalg.LinAlgError):
            values.append(np.nan)
    return tuple(float(v) for v in values)


@dataclass(frozen=True)
class _Score:
    """Laplace log-evidence of a model and, when it was sampled, the credible intervals."""

    log_evidence: float
    ci95: np.ndarray | None


def _check(
    kind, term, trial, z_trial, nrmse_before, current_z, signals, nsi_options, evidence_options, seed, *guards,
    nrmse_after=np.nan, half_cache=None,
):
    """Log Bayes factor (Laplace) and the guards of one proposed effect.

    The decision uses the Laplace log-evidence, within 0.006 nat of exact on affine-Gaussian
    candidates (EVIDENCE.md) and cross-checked against bridge sampling in every full evidence;
    the full emcee evidence runs only for an effect that passes, to give its credible interval
    (one kept only with a second effect, ``lookahead``, gets its interval from the pair's
    evidence). This keeps the emcee runs off the effects that are rejected, which were 74 % of a
    loop step (two-DOF, ``benchmarks/diagnose.py``). The record-half estimates (two
    identifications) are computed only for an effect whose Bayes factor clears the threshold.

    Returns
    -------
    step : LoopStep
    evidence : _Score
        Of the enlarged model (primary likelihood).
    quality_only : bool
        True when the effect passed every guard but the quality index |Im|/|Re|.
    """
    threshold, max_imag_ratio, stability_factor = guards
    log_bf = z_trial - current_z  # z_trial: the Laplace log-evidence the effect was ranked by
    coef = trial.coefficients[-1]
    # the halves cost two identifications: only for an effect whose Bayes factor clears the threshold
    halves = _halves(signals, trial.candidate, nsi_options, half_cache) if log_bf > threshold else (np.nan, np.nan)
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
    quality_only = log_bf > threshold and stable and coef.imag_ratio >= max_imag_ratio
    ci95 = (np.nan, np.nan)
    ev = _Score(float(z_trial), None)
    if reason == "accepted":  # emcee only for what is kept: its credible intervals
        full = candidate_evidence(trial, signals, evidence_options, seed, warn=False)[evidence_options.likelihood]
        ev = _Score(float(z_trial), full.ci95)
        ci95 = tuple(float(c) for c in full.ci95[-1])
    step = LoopStep(
        effect_type=kind,
        term=term,
        accepted=reason == "accepted",
        reason=reason,
        coefficient=coef.value,
        ci95=ci95,
        imag_ratio=coef.imag_ratio,
        half_coefficients=halves,
        log_bayes_factor=float(log_bf),
        nrmse_before=nrmse_before,
        nrmse_after=float(nrmse_after) if np.isfinite(nrmse_after) else trial.reconstruct(signals).nrmse,
        candidate=trial.candidate,
    )
    return step, ev, quality_only


def _closed_loop_nrmse(result, signals) -> float:
    """Closed-loop NRMSE on the estimation data, NaN when the simulation diverges."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            return float(result.reconstruct(signals, closed_loop=True).nrmse)
    except (BayesNSIError, np.linalg.LinAlgError, FloatingPointError):
        return float("nan")


def _documented(step, before, after, signals):
    """``step`` with its closed-loop errors and residual-force view (accepted steps, SPEC 7.5)."""
    return replace(
        step,
        closed_loop_nrmse_before=_closed_loop_nrmse(before, signals),
        closed_loop_nrmse_after=_closed_loop_nrmse(after, signals),
        residual_force=residual_force(before, after, signals, step.term),
    )


def step_result(step, scored):
    """The NSIResult of the effect a step accepted."""
    return next(entry.result for entry in scored if entry.term == step.term)


def _screened(signals, candidate, effects, nsi_options, exclude, screen):
    """Split ``effects`` into the best ``screen[0]`` by :func:`screen_effects` and the rest.

    ``screen`` is ``(count, max_frequency_hz)``. Effects already in the model or excluded are
    dropped first. Returns ``(kept effects, entries of the rest)``; the rest carry a NaN score
    (screened out, not re-identified), in screen order.
    """
    count, max_frequency_hz = screen
    effects = _new_effects(candidate, effects, exclude)
    if len(effects) <= count:
        return effects, []
    try:
        ranked = screen_effects(
            signals,
            candidate,
            effects,
            max_frequency_hz=max_frequency_hz,
            velocity_method=nsi_options.velocity_method,
        )
    except BayesNSIError:
        return effects, []  # too short a record to screen: score them all
    return [(k, t) for k, t, _ in ranked[:count]], [_Entry(k, t, np.nan, None, np.nan) for k, t, _ in ranked[count:]]


def _ranked(signals, candidate, effects, nsi_options, evidence_options, exclude, n_tries, jobs=1, scheduler=None, screen=None):
    """Scores of the effects, with the gaps of the clearances among the best refined.

    With ``screen = (count, max_frequency_hz)`` only the best ``count`` effects of
    :func:`screen_effects` are re-identified and scored; the others follow with a NaN score.
    """
    kept, rest = effects, []
    if screen is not None:
        kept, rest = _screened(signals, candidate, effects, nsi_options, exclude, screen)
    correlations = _shared_correlations(signals, candidate, nsi_options)
    scored = score_effects(
        signals, candidate, kept, nsi_options, evidence_options, exclude, jobs, scheduler, correlations
    )
    head = [
        refine_gap(signals, candidate, entry, effects, nsi_options, evidence_options, correlations=correlations)
        if np.isfinite(entry[2]) and clearance_gap(entry[0]) is not None
        else entry
        for entry in scored[:n_tries]
    ]
    return sorted(head + scored[n_tries:], key=lambda item: item[2], reverse=True) + rest


def close_the_loop(
    signals,
    candidate: CandidateModel,
    *,
    nsi_options: dict | None = None,
    evidence_options: dict | None = None,
    effects=None,
    threshold: float = float(np.log(100.0)),
    max_imag_ratio: float = 0.3,
    stability_factor: float = 1.4,
    max_steps: int = 3,
    n_tries: int = 3,
    lookahead: bool = True,
    exchange: bool = False,
    refine_final: int | None = 4,
    screen: int | None = 6,
    seed: int = 0,
    jobs: int = 1,
    scheduler=None,
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
        As :data:`bayesnsi.evidence.EVIDENCE_DEFAULTS`; defaults :data:`LOOP_EVIDENCE_DEFAULTS`
        (AR(1) likelihood of the open-loop reconstruction residual).
    effects : list of (str, Term), optional
        The dictionary; default :func:`bayesnsi.models.effect_dictionary` over the measured
        DOFs with clearance gaps at 0.5, 1 and 1.5 displacement standard deviations (refined by
        :func:`refine_gap` when a clearance ranks among the best ``n_tries``).
    threshold : float
        Minimum log Bayes factor to accept an effect (default log 100 ≈ 4.6, "decisive").
    max_imag_ratio : float
        Largest accepted |Im λ|/|Re λ| of the new coefficient.
    stability_factor : float
        The half-record estimates must share the sign and differ by less than this factor
        (default 1.4). Measured on ``benchmarks/diagnose_suite.py`` (3 seeds, 1 and 5 % noise):
        true effects ≤ 1.22, the spurious even terms that passed every other guard after a
        Coulomb friction was added (x1², x2², absorbing its discretisation error) 1.45-1.65;
        the former default 2 let them in. Tuned on that suite: a guard, not a law.
    max_steps : int
        Most effects added.
    n_tries : int
        Per step, the best ``n_tries`` effects by Laplace evidence are checked in turn; the first
        that passes every guard is added.
    lookahead : bool
        When no effect passes but one failed only the quality index, search one effect further
        from the model holding it: with two effects missing, λ(ω) of the first is distorted by
        the second (measured: x1³ found first with |Im|/|Re| = 0.58 while Coulomb friction was
        still missing, 0.02 once both were in). The pair is added when the second effect passes
        every guard against the first-enlarged model and the first one's quality index, in the
        model with both, is below ``max_imag_ratio``. The pair's first effect was chosen while
        the second was missing, so it is then re-examined against the other effects at its
        location in the model holding the second (:func:`_exchange`): a clearance or x|x| taken
        for a missing x1³ while Coulomb friction at DOF 2 was missing is exchanged for x1³ once
        the friction is in (``benchmarks/diagnose_suite.py``, two-missing, 10 seeds: found with
        the right type in 10/10 runs at 1 % noise and 9/10 at 5 %, against 9/10 and 6/10
        without; the look-alike's Laplace log-evidence was 1105 nat below x1³'s in the model
        with the friction, seed 8 at 1 %).
    exchange : bool
        After each addition, every effect added before is exchanged for another effect at the
        same location when that is decisively better (see :func:`_exchange`); after a pair
        (``lookahead``) the pair's first effect is always re-examined so. Off by default: the
        general exchange is not measured on ``benchmarks/diagnose_suite.py``.
    refine_final : int or None
        When the loop ran at the data rate (no ``upsample`` in ``nsi_options``) and the final
        model holds a term that switches with velocity (``sign()`` of a velocity: friction), the
        final model is identified once more with ``upsample = refine_final`` (block rows scaled
        alike) and that identification is the reported ``final``: such terms jump between
        samples, which biases their coefficients at the data rate (SPEC 10). Measured on
        ``benchmarks/diagnose_suite.py`` (coulomb-dof2, 5 seeds): the Coulomb coefficient was off
        by up to 12 % at the data rate; after this re-identification it is within 3.1 % at 1 %
        noise and 8 % at 5 % (a loop run wholly at ``upsample = 4``: within 1 %, at about 20× the
        cost). Decisions stay at the data rate. None: off.
    screen : int or None
        Per step, rank every effect first by the frequency-domain screen of
        :func:`bayesnsi.diagnose.screen.screen_effects` (up to 1.6 × the start model's highest
        natural frequency) and re-identify and score by evidence only the best ``screen`` of
        them; None re-identifies every effect. Measured on the undeclared-effect cases (4 seeds
        × 1 and 5 % noise): the missing effect was within the screen's best 3 in 39/40 runs and
        5th once. Cost of a beam loop step: see ``benchmarks/diagnose.py``.
    seed : int
        Seed of the evidence computations.
    jobs, scheduler
        Score the effects of a step in ``jobs`` local worker processes or on a Dask scheduler
        (:func:`bayesnsi.run.dispatch`); the result does not depend on them.

    Returns
    -------
    LoopResult

    Notes
    -----
    Effects of the type and location of one already added (e.g. a second clearance at the same
    DOF with another gap) are not proposed again.
    """
    if screen is not None and (isinstance(screen, bool) or not isinstance(screen, (int, np.integer)) or screen < 1):
        raise InputDataError(f"screen must be a positive number of effects or None (no screening), got {screen!r}")
    nsi_options = nsi_options or NSIOptions()
    evidence_options = (evidence_options or EvidenceOptions(residual="reconstruction")).replace(compare=())
    if effects is None:
        std = {d: signals.displacement[:, c].std() for c, d in enumerate(signals.output_dofs)}
        gaps = {(d,): default_gaps(s) for d, s in std.items()}
        effects = effect_dictionary(signals.output_dofs, gaps=gaps)
    seeds = _seed_stream(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNSIWarning)
        current = identify(signals, candidate, nsi_options)
    start = current
    current_z = _laplace(current, signals, evidence_options)[0]
    guards = (threshold, max_imag_ratio, stability_factor)
    steps, all_scores, added = [], [], []
    half_cache = {}  # Hankel products of the record halves, per base model (stability guard)
    screening = None if screen is None else (int(screen), 1.6 * max(m.frequency_hz for m in start.modes))
    ranked = lambda cand, exclude: _ranked(
        signals, cand, effects, nsi_options, evidence_options, exclude, n_tries, jobs, scheduler, screening
    )
    while len(added) < max_steps:
        scored = ranked(current.candidate, added)
        all_scores.append([(e.kind, e.term, e.score) for e in scored])
        if not scored or not np.isfinite(scored[0][2]):
            break
        nrmse_before = current.reconstruct(signals).nrmse
        accepted, pending = None, None
        for kind, term, score, trial, nrmse_after in scored[:n_tries]:
            if not np.isfinite(score):
                break
            step, ev, quality_only = _check(
                kind, term, trial, score, nrmse_before, current_z, signals, nsi_options, evidence_options, next(seeds), *guards,
                nrmse_after=nrmse_after, half_cache=half_cache,
            )
            steps.append(step)
            if step.accepted:
                accepted = (step, trial, ev)
                break
            if quality_only and pending is None:
                pending = (step, trial, ev)
        if accepted is not None:
            step, trial, ev = accepted
            steps[next(i for i, s in enumerate(steps) if s is step)] = step = _documented(step, current, trial, signals)
            current, current_z = trial, ev.log_evidence
            added.append((effect_base_type(step.effect_type), tuple(step.term.at)))
            current, current_z = _prune(current, current_z, [step.term], steps, signals, nsi_options, evidence_options, guards)
            if exchange:
                current, current_z = _exchange(
                    current, current_z, [step.term], steps, effects, signals, nsi_options, evidence_options, seeds, guards, n_tries
                )
            continue
        if not (lookahead and pending is not None and len(added) + 2 <= max_steps):
            break
        pair = _look_ahead(
            pending, added, ranked, signals, nsi_options, evidence_options, seeds, guards, steps, all_scores, n_tries, half_cache
        )
        if pair is None:
            break
        first, second, pair_model, ev = pair
        first = _documented(first, current, pending[1], signals)
        second_index = next(i for i, s in enumerate(steps) if s is second)
        steps[second_index] = second = _documented(second, pending[1], pair_model, signals)
        current, current_z = pair_model, ev.log_evidence
        steps[next(i for i, s in enumerate(steps) if s is pending[0])] = first
        added += [(effect_base_type(s.effect_type), tuple(s.term.at)) for s in (first, second)]
        new_terms = [first.term, second.term]
        current, current_z = _prune(current, current_z, new_terms, steps, signals, nsi_options, evidence_options, guards)
        # the pair's first effect was chosen while the second was missing: re-examine it against
        # the other effects at its location in the model that holds the second (all earlier
        # effects too with ``exchange``)
        current, current_z = _exchange(
            current, current_z, [second.term], steps, effects, signals, nsi_options, evidence_options, seeds, guards,
            n_tries, examine=None if exchange else [first.term],
        )
    final_nsi = nsi_options
    if refine_final and nsi_options.upsample == 1 and any(t.expr.switches_with_velocity for t in current.terms):
        fine = nsi_options.replace(upsample=int(refine_final), block_rows=nsi_options.block_rows * int(refine_final))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                current = identify(signals, current.candidate, fine)
            final_nsi = fine
        except (BayesNSIError, np.linalg.LinAlgError) as err:
            warnings.warn(
                f"the final model could not be re-identified with upsample = {refine_final} ({err}); "
                "its coefficients are from the data-rate identification",
                BayesNSIWarning,
                stacklevel=2,
            )
    settings = dict(
        threshold=threshold,
        max_imag_ratio=max_imag_ratio,
        stability_factor=stability_factor,
        max_steps=max_steps,
        n_tries=n_tries,
        lookahead=lookahead,
        exchange=exchange,
        refine_final=refine_final,
        screen=screen,
        final_nsi=final_nsi.to_dict(),
        jobs=jobs,
        n_effects=len(effects),
        nsi=nsi_options.to_dict(),
        evidence=evidence_options.to_dict(),
        seed=seed,
    )
    # accepted steps first (in order), then the rejected ones
    ordered = [s for s in steps if s.accepted] + [s for s in steps if not s.accepted]
    return LoopResult(start=start, final=current, steps=tuple(ordered), scores=tuple(all_scores), settings=settings)


def _seed_stream(seed):
    """Children of ``SeedSequence(seed)``, one at a time, as many as needed."""
    sequence = np.random.SeedSequence(seed)
    while True:
        yield sequence.spawn(1)[0]


def _look_ahead(
    pending, added, ranked, signals, nsi_options, evidence_options, seeds, guards, steps, all_scores, n_tries, half_cache=None
):
    """Search the next effect from the model holding ``pending`` (see ``lookahead``).

    Returns
    -------
    (first step, second step, NSIResult with both, EvidenceResult with both) or None
    """
    threshold, max_imag_ratio, _ = guards
    p_step, p_trial, p_ev = pending
    exclude = list(added) + [(effect_base_type(p_step.effect_type), tuple(p_step.term.at))]
    scored = ranked(p_trial.candidate, exclude)
    all_scores.append([(e.kind, e.term, e.score) for e in scored])
    for kind, term, score, trial, nrmse_after in scored[:n_tries]:
        if not np.isfinite(score):
            break
        step, ev, _ = _check(
            kind, term, trial, score, p_step.nrmse_after, p_ev.log_evidence, signals, nsi_options, evidence_options, next(seeds), *guards,
            nrmse_after=nrmse_after, half_cache=half_cache,
        )
        first_coef = trial.coefficients[-2]
        if step.accepted and first_coef.imag_ratio >= max_imag_ratio:
            step = replace(
                step,
                accepted=False,
                reason=f"passes, but {p_step.term.name} keeps |Im|/|Re| = {first_coef.imag_ratio:.2f} with it",
            )
        steps.append(step)
        if step.accepted:
            first = replace(
                p_step,
                accepted=True,
                reason=f"accepted with {term.name}: |Im|/|Re| {p_step.imag_ratio:.2f} alone, "
                f"{first_coef.imag_ratio:.2f} with it",
                coefficient=first_coef.value,
                imag_ratio=first_coef.imag_ratio,
                ci95=tuple(float(c) for c in ev.ci95[-2]),
            )
            return first, step, trial, ev
    return None


def _without(candidate: CandidateModel, term: Term) -> CandidateModel:
    keep = [k for k, t in enumerate(candidate.terms) if t != term]
    return CandidateModel(
        name=f"{candidate.name} - {term.name}",
        terms=tuple(candidate.terms[k] for k in keep),
        prior=candidate.prior,
        coefficient_prior_scales=tuple(candidate.coefficient_prior_scales[k] for k in keep),
    )


def _prune(current, current_z, new_terms, steps, signals, nsi_options, evidence_options, guards):
    """Backward step: drop earlier added effects that the newly added ones made redundant.

    Forward selection can take an effect that mimics a missing one (measured: a clearance at
    DOF 1 taken for the hardening of a missing x1³, which was then added as well). After each
    addition, every effect the loop added before is removed in turn (Laplace log-evidence of
    the model without it); it is dropped when keeping it is no longer worth ``threshold``
    (log Bayes factor of keeping it ≤ threshold), or when its coefficient, re-identified with the
    new effects, changed sign or by more than the stability factor (in the example above the
    clearance stiffness went from +393 to -10 N/m); its step is then marked rejected.

    Returns
    -------
    (NSIResult, float)
        The current model and its (Laplace) log-evidence.
    """
    threshold, _, stability_factor = guards
    for index, step in enumerate(steps):
        if not step.accepted or step.term in new_terms or step.term not in current.terms:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                reduced = identify(signals, _without(current.candidate, step.term), nsi_options)
                z_without = _laplace(reduced, signals, evidence_options)[0]
                z_with = _laplace(current, signals, evidence_options)[0]
        except (BayesNSIError, np.linalg.LinAlgError):
            continue
        value = current.coefficients[current.terms.index(step.term)].value
        ratio = abs(value / step.coefficient) if step.coefficient else np.inf
        moved = np.sign(value) != np.sign(step.coefficient) or not 1 / stability_factor < ratio < stability_factor
        redundant = np.isfinite(z_without) and np.isfinite(z_with) and z_with - z_without <= threshold
        if moved or redundant:
            why = (
                f"its coefficient moved from {step.coefficient:.4g} to {value:.4g}"
                if moved
                else f"log Bayes factor of keeping it {z_with - z_without:.2f} <= {threshold:.2f}"
            )
            steps[index] = replace(
                step, accepted=False, reason=f"removed once {', '.join(t.name for t in new_terms)} was added: {why}"
            )
            current = reduced
            current_z = current_z - (z_with - z_without)
    return current, current_z


def _exchange(
    current, current_z, new_terms, steps, effects, signals, nsi_options, evidence_options, seeds, guards, n_tries,
    examine=None,
):
    """Exchange step: replace an earlier added effect by a better one at the same location.

    For every effect the loop added before ``new_terms``, the model without it is enlarged by
    each other dictionary effect at the same location (types other than its own, clearance
    gaps refined) and scored by Laplace log-evidence. The best ``n_tries`` replacements whose
    Laplace log-evidence beats the current model's by ``threshold`` are checked in turn like any
    proposed effect (:func:`_check`, log Bayes factor, quality index, stability across record
    halves) *against the current model* (so its log Bayes factor is against the model with the
    earlier effect); the first that passes replaces the earlier effect. The replacement then takes the
    earlier effect's place in the accepted steps; the earlier step is marked rejected with the
    reason. ``examine``: only these earlier effects (default: every one).

    Returns
    -------
    (NSIResult, float)
        The current model and its full log-evidence.
    """
    threshold, _, _ = guards
    for index, step in enumerate(list(steps)):
        if not step.accepted or step.term in new_terms or step.term not in current.terms:
            continue
        if examine is not None and step.term not in examine:
            continue
        base = _without(current.candidate, step.term)
        present = {t.name for t in base.terms}
        own = effect_base_type(step.effect_type)
        alternatives = [
            (k, t)
            for k, t in effects
            if tuple(t.at) == tuple(step.term.at) and effect_base_type(k) != own and t.name not in present
        ]
        if not alternatives:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                z_current = _laplace(current, signals, evidence_options)[0]
        except (BayesNSIError, np.linalg.LinAlgError):
            continue
        scored = _ranked(signals, base, alternatives, nsi_options, evidence_options, (), n_tries)
        nrmse_before = current.reconstruct(signals).nrmse
        new = None
        for kind, term, score, trial, nrmse_after in scored[:n_tries]:
            if not score - z_current > threshold:
                break
            new, ev, _ = _check(
                kind, term, trial, score, nrmse_before, current_z, signals, nsi_options, evidence_options, next(seeds), *guards,
                nrmse_after=nrmse_after,
            )
            if new.accepted:
                break
        if new is None or not new.accepted:
            continue
        new = replace(
            new,
            reason=f"accepted in exchange for {step.term.name} once {', '.join(t.name for t in new_terms)} was added "
            f"(log Bayes factor against the model with it {new.log_bayes_factor:.2f})",
        )
        # "before" is the model it replaces, as for its Bayes factor and open-loop NRMSE
        steps[index] = _documented(new, current, trial, signals)
        steps.append(replace(step, accepted=False, reason=f"exchanged for {term.name} once {', '.join(t.name for t in new_terms)} was added"))
        current, current_z = trial, ev.log_evidence
    return current, current_z
