"""Scoring the effects of a dictionary against a model: Laplace evidence, screen, clearance gaps, Bouc-Wen shapes.

Every effect ``e`` is added to the current candidate, the enlarged model is identified by NSI
(sharing the current model's Hankel products, :func:`bayesnsi.nsi.hankel_correlations`) and scored
by its Laplace log-evidence (a free, accurate approximation of the marginal evidence, docs/method.md §6).
With the screen on, only the best ``LoopOptions.screen`` effects of the frequency-domain screen
(:func:`bayesnsi.loop.screen.screen_effects`) are identified; clearances among the best have
their gap refined off the grid (:func:`refine_gap`), Bouc-Wen elements their shape (:func:`refine_shape`,
:mod:`bayesnsi.loop.shapes`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from typing import cast

import numpy as np

from .._dispatch import dispatch
from ..checks.misfit import index_judgement, misfit_reading
from ..evidence import candidate_affine, candidate_priors, laplace_log_evidence, sufficient_statistics
from ..evidence.boundary import collapsed_laplace_log_evidence
from ..exceptions import BayesNSIError, BayesNSIWarning
from ..models import Effect
from ..models.dictionary import clearance_effect
from ..nsi import force_affine, hankel_correlations, identify, is_free_body, nrmse
from ..options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions, parse_likelihood
from .localise import screen_effects_periodic
from .results import EffectScore
from .screen import best_locations_first, screen_effects, second_widths_last
from .screen_force import screen_effects_force
from .shapes import (
    SEARCH_INDEX_FACTOR,
    SHAPE_MIN_GAIN,
    displacement_spread,
    screened_shapes,
    search_shape,
    shape_fallbacks,
)
from .state import LoopContext
from .widths import search_width

__all__ = ["laplace_score", "rank_effects", "refine_gap", "refine_shape", "score_effects"]


def laplace_score(result, signals, evidence: EvidenceOptions) -> tuple[float, float]:
    """Laplace log-evidence of ``result`` and, from the same affine model, its open-loop NRMSE.

    Parameters
    ----------
    result : NSIResult
    signals : Signals
    evidence : EvidenceOptions
        Residual, likelihood and priors of the evidence.

    Returns
    -------
    (float, float)
        The log-evidence (primary likelihood; where the Laplace approximation over every parameter
        is not finite, e.g. an AR(1) mode beyond the prior bound, the one in the coefficients alone
        with the noise parameters integrated out, :mod:`bayesnsi.evidence.boundary`) and the NRMSE,
        NaN unless the evidence scores the open-loop reconstruction residual (then the affine model
        at the NSI estimate is that reconstruction, docs/method.md §5); for a free body the NRMSE of
        the force it predicts from the measured motion at the NSI estimate
        (:func:`bayesnsi.nsi.force_affine`).
    """
    affine = candidate_affine(result, signals, evidence.residual)
    priors = candidate_priors(result, signals, affine, evidence)
    stats = sufficient_statistics(affine, ar_order=parse_likelihood(evidence.likelihood)[0])
    score = laplace_log_evidence(stats, priors, evidence.likelihood)
    if not np.isfinite(score):  # e.g. an AR(1) mode beyond the prior bound: a drifting residual
        score = collapsed_laplace_log_evidence(stats, priors, evidence.likelihood)
    if is_free_body(result):  # the error of the model's own force prediction (IDIM view)
        affine = force_affine(result, signals)
    elif evidence.residual != "reconstruction":
        return score, np.nan
    return score, nrmse(affine.measured, affine.predict(affine.estimate))[1]


def shared_correlations(signals, candidate, nsi: NSIOptions):
    """Hankel products of ``candidate`` that every ``candidate + effect`` shares (None if unusable)."""
    try:
        return hankel_correlations(signals, candidate, nsi)
    except (BayesNSIError, np.linalg.LinAlgError):
        return None


def score_one(signals, candidate, effect: Effect, nsi: NSIOptions, evidence: EvidenceOptions, correlations=None,
              start=None):
    """``candidate + effect`` identified and scored (:class:`EffectScore`, −inf when it fails).

    ``correlations``: :func:`shared_correlations` of ``candidate`` (saves most of the Hankel
    products; the result is the same). ``start``: an identified neighbour (``identify``'s ``start``: on the
    frequency route refined from it alone).
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            result = identify(signals, candidate.with_term(effect.term), nsi, correlations=correlations, start=start)
            score, error = laplace_score(result, signals, evidence)
    except (BayesNSIError, np.linalg.LinAlgError) as err:
        return EffectScore(effect, -math.inf, error=f"{type(err).__name__}: {err}")
    if not np.isfinite(score):
        return EffectScore(effect, -math.inf, float(error), result, error=f"Laplace log-evidence is {score}")
    return EffectScore(effect, float(score), float(error), result)


def _score_task(context, effect):
    """:func:`score_one` for :func:`bayesnsi._dispatch.dispatch` (context: data, model, settings, products)."""
    return score_one(*context[:2], effect, *context[2:])


def new_effects(candidate, effects, exclude=()) -> list[Effect]:
    """The effects not in ``candidate`` whose (base type, location) is not in ``exclude``."""
    present = {t.name for t in candidate.terms}
    exclude = set(exclude)
    return [e for e in effects if e.term.name not in present and (e.base, e.location) not in exclude]


def _loop_evidence(evidence: EvidenceOptions | None) -> EvidenceOptions:
    return evidence or EvidenceOptions(residual=LoopOptions().residual, compare=())


def score_effects(
    signals, candidate, effects, nsi: NSIOptions | None = None, evidence: EvidenceOptions | None = None, *,
    exclude=(), execution: ExecutionOptions | None = None, correlations=None,
) -> list[EffectScore]:
    """Identify ``candidate + effect`` for every effect and score it by Laplace log-evidence.

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidate : CandidateModel
        The model the effects are added to.
    effects : sequence of Effect
        Effects to score (those already in ``candidate`` are skipped).
    nsi : NSIOptions, optional
    evidence : EvidenceOptions, optional
        Default: the loop's residual (``LoopOptions().residual``), no compared likelihoods.
    exclude : iterable of (str, tuple of int)
        ``(base type, location)`` pairs to skip (effects the loop already added: a second
        clearance at the same location, whatever its gap, only absorbs the first one's misfit).
    execution : ExecutionOptions, optional
        ``jobs`` local worker processes or a Dask ``scheduler``; the scores do not depend on them.
    correlations : HankelCorrelations, optional
        :func:`bayesnsi.nsi.hankel_correlations` of ``candidate`` with these NSI settings, when
        already computed (computed here otherwise).

    Returns
    -------
    list of EffectScore
        Best first (ties in dictionary order).
    """
    nsi, evidence, execution = nsi or NSIOptions(), _loop_evidence(evidence), execution or ExecutionOptions()
    tasks = [(e,) for e in new_effects(candidate, effects, exclude)]
    scored: list[EffectScore] = [EffectScore(e, -math.inf) for (e,) in tasks]
    if correlations is None:
        correlations = shared_correlations(signals, candidate, nsi)
    context = (signals, candidate, nsi, evidence, correlations)
    jobs, scheduler = execution.jobs, execution.scheduler
    for index, value in dispatch(_score_task, tasks, context=context, jobs=jobs, scheduler=scheduler):
        scored[index] = value
    scored.sort(key=lambda item: item.log_evidence, reverse=True)
    return scored


def refine_gap(
    signals, candidate, entry: EffectScore, effects, nsi: NSIOptions | None = None,
    evidence: EvidenceOptions | None = None, *, points: int = 9, correlations=None,
) -> EffectScore:
    """Refine the gap of a clearance effect between its neighbours on the dictionary's grid.

    docs/method.md §7 offers clearances "on a grid of g"; the coefficient of a clearance spring is only
    meaningful with the right gap (a gap 10 % too large inflates the stiffness by far more), so
    the gap of a promising clearance is refined by two rounds of a ``points``-point grid search
    of the Laplace log-evidence: first between the neighbouring grid gaps at the same location
    (up to 1.5 times the largest), then within one spacing of the best; never below the smallest
    grid gap. A clearance's force is a linear spring less a relay, ``x - g sign(x)`` outside the gap:
    as the gap shrinks it becomes the linear spring at its location, which a linear part with model
    error favours for what it absorbs, not for a clearance (the F-16: the evidence rose towards 0.25
    standard deviations, where 98 % of the column is the relative displacement; below the smallest grid
    gap, 0.5 standard deviations, the share exceeds 90 % for Gaussian motion, 95 % for a sine).

    Parameters
    ----------
    signals, candidate, nsi, evidence
        As in :func:`score_effects`.
    entry : EffectScore
        A scored clearance (any other effect is returned as it is).
    effects : sequence of Effect
        The dictionary whose clearance gaps at ``entry``'s location form the grid.
    points : int
        Gaps tried per round.
    correlations : HankelCorrelations, optional
        As in :func:`score_effects`.

    Returns
    -------
    EffectScore
        The best entry found (``entry`` itself when nothing beats it).
    """
    gap, at = entry.effect.gap, entry.effect.location
    if gap is None:
        return entry
    nsi, evidence = nsi or NSIOptions(), _loop_evidence(evidence)
    grid = sorted({e.gap for e in effects if e.gap is not None and e.location == at})
    floor = min(grid, default=gap)  # below the grid a clearance is a linear spring to the data (docstring)
    lower = max((g for g in grid if g < gap), default=floor)
    upper = min((g for g in grid if g > gap), default=1.5 * gap)
    best = entry
    if correlations is None:
        correlations = shared_correlations(signals, candidate, nsi)
    for _ in range(2):
        for g in np.linspace(lower, upper, points):
            if g <= 0:
                continue
            scored = score_one(signals, candidate, clearance_effect(at, float(g)), nsi, evidence, correlations)
            if scored.log_evidence > best.log_evidence:
                best = scored
        centre, step = best.effect.gap or gap, (upper - lower) / (points - 1)
        lower, upper = max(centre - step, 0.5 * step, floor), centre + step
    return best


def refine_shape(
    signals, candidate, entry: EffectScore, nsi: NSIOptions | None = None, evidence: EvidenceOptions | None = None,
    *, correlations=None, budget: int = 30, base_log_evidence: float | None = None,
) -> EffectScore:
    """Refine the shape of a Bouc-Wen effect off the grid by its Laplace log-evidence (docs/method.md §12).

    The compass search of :func:`bayesnsi.loop.shapes.search_shape` over the element's loading and
    unloading branches, each shape scored as :func:`score_effects` scores an effect; on the frequency route
    each shape tried is identified from the best shape's model so far (``identify``'s ``start``), a shape reached
    back up to the rounding is not identified again, and only the shape found is identified in full.

    Parameters
    ----------
    signals, candidate, nsi, evidence, correlations
        As in :func:`refine_gap`.
    entry : EffectScore
        A scored Bouc-Wen effect (any other effect is returned as it is).
    budget : int
        Most identifications.
    base_log_evidence : float, optional
        Log-evidence of ``candidate`` itself: on the frequency route a move of the search must gain
        :data:`~bayesnsi.loop.shapes.SHAPE_MIN_GAIN` of the grid point's log Bayes factor over it.

    Returns
    -------
    EffectScore
        The best entry found (``entry`` itself when nothing beats it).
    """
    if entry.effect.shape is None:
        return entry
    nsi, evidence = nsi or NSIOptions(), _loop_evidence(evidence)
    if correlations is None:
        correlations = shared_correlations(signals, candidate, nsi)
    def full(effect):
        return score_one(signals, candidate, effect, nsi, evidence, correlations)

    def near(effect, best: EffectScore):
        if nsi.domain != "frequency" or best.result is None:
            return full(effect)
        return score_one(signals, candidate, effect, nsi, evidence, correlations, start=best.result)

    factor = entry.log_evidence - base_log_evidence if base_log_evidence is not None else 0.0
    min_gain = SHAPE_MIN_GAIN * factor if nsi.domain == "frequency" and np.isfinite(factor) and factor > 0 else 0.0
    return search_shape(entry, near, displacement_spread(signals, entry.effect), budget, confirm=full,
                        rounded_revisits=nsi.domain != "frequency", min_gain=min_gain)


def _screened(context: LoopContext, candidate, effects, exclude):
    """Split ``effects`` into the best ``screen`` by the screen (module notes) and the rest.

    Effects already in the model or excluded are dropped first. The ``screen`` places go to the
    effects without memory of the screen's best locations, one friction width per location before any
    second one (:func:`bayesnsi.loop.screen.best_locations_first`,
    :func:`bayesnsi.loop.screen.second_widths_last`); the best ranked Bouc-Wen grid point of each of a
    few locations is kept besides them (nine variants of one effect, ranked high by a screen that reads
    the residual's phase, would crowd out the others; :func:`bayesnsi.loop.shapes.screened_shapes`).
    Returns ``(kept effects, scores of the rest, screen)``; the rest carry a NaN score (screened out, not
    re-identified), in screen order; ``screen`` maps each kept effect's term name to its ``(rank, score,
    view, location level)`` (the
    data-only distortion level of its location on the periodic view, NaN otherwise).
    """
    effects = new_effects(candidate, effects, exclude)
    count = len(effects) if context.options.screen is None else context.options.screen  # None: all
    located: dict[str, float] = {}
    try:
        if context.nsi.virtual_stiffness not in ("auto", 0.0, 0):  # a free body: screen in the force view
            view, ranked = "force", screen_effects_force(context.signals, candidate, effects)
        elif context.nsi.domain == "frequency" and context.signals.period and context.signals.force.shape[1] == 1:
            view, found = "periodic", screen_effects_periodic(  # where the data show the distortion first
                context.signals, candidate, effects, max_frequency_hz=context.screen_hz,
                velocity_method=context.nsi.velocity_method,
            )
            ranked = [(e, score) for e, score, _ in found]
            located = {e.term.name: level for e, _, level in found}
        else:
            view, ranked = "frequency", screen_effects(
                context.signals, candidate, effects, max_frequency_hz=context.screen_hz,
                velocity_method=context.nsi.velocity_method,
            )
    except BayesNSIError:
        return effects, [], {}  # too short a record to screen: score them all
    screen = {e.term.name: (rank, float(score), view, located.get(e.term.name, math.nan))
              for rank, (e, score) in enumerate(ranked, start=1)}
    ordered = cast("list[Effect]", [e for e, _ in ranked])
    kept = screened_shapes(best_locations_first(second_widths_last(ordered), count), count)
    rest = [
        EffectScore(e, math.nan, screen_rank=rank, screen_score=float(score), screen_view=view,
                    screen_location=located.get(e.term.name, math.nan))
        for rank, (e, (_, score)) in enumerate(zip(ordered, ranked), start=1) if e not in kept
    ]
    if len(effects) <= count:  # all re-identified, in dictionary order as without a screen
        return effects, [], screen
    return kept, rest, screen


def _with_screen(entry: EffectScore, screen: dict, name: str | None = None) -> EffectScore:
    """``entry`` with the screen rank, score and view of ``name`` (default its own term's)."""
    found = screen.get(entry.term.name if name is None else name)
    if found is None:
        return entry
    return replace(entry, screen_rank=found[0], screen_score=found[1], screen_view=found[2],
                   screen_location=found[3])


def rank_effects(context: LoopContext, candidate, exclude=(), effects=None, screen: bool = True) -> list[EffectScore]:
    """Scores of the effects against ``candidate``, with the gaps of the clearances among the best refined.

    So are the shapes of the Bouc-Wen elements among the best: at each location the best grid point,
    when it beats ``candidate`` itself (a log Bayes factor above 0) and every effect without memory
    (:func:`refine_shape`): a two-parameter family searched off the grid fits model-form error too,
    so its shape is searched where the grid already says memory explains the data best, and not where
    its quality index fails the loop's check by a wide margin (:func:`_worth_searching`). So is the width
    of the best ``tanh(v/ε)`` friction of each location among the best, when it beats ``candidate``
    (:func:`bayesnsi.loop.widths.search_width`).

    Parameters
    ----------
    context : LoopContext
    candidate : CandidateModel
    exclude : iterable of (str, tuple of int)
        As in :func:`score_effects`.
    effects : sequence of Effect, optional
        Default: the loop's dictionary. Also the grid of the clearance gaps.
    screen : bool
        Apply the frequency-domain screen when the loop has one (``context.screen_hz``).

    Returns
    -------
    list of EffectScore
        Best first; the screened-out effects follow with a NaN score.
    """
    effects = context.effects if effects is None else effects
    kept, rest, ranks = effects, [], {}
    if screen and context.screen_hz is not None:
        kept, rest, ranks = _screened(context, candidate, effects, exclude)
    correlations = shared_correlations(context.signals, candidate, context.nsi)
    scored = score_effects(
        context.signals, candidate, kept, context.nsi, context.evidence, exclude=exclude,
        execution=context.execution, correlations=correlations,
    )
    scored = [_with_screen(entry, ranks) for entry in scored]
    if rest:
        scored, rest = shape_fallbacks(scored, rest, lambda effect: score_one(
            context.signals, candidate, effect, context.nsi, context.evidence, correlations))
    n_tries = context.options.n_tries
    searched: set = set()  # (kind, location) refined: the best grid point's search stands for the location's
    current: list[float] = []  # the candidate's own Laplace log-evidence, computed when first needed
    memoryless = max((e.log_evidence for e in scored if e.effect.shape is None), default=-math.inf)

    def first_better(entry, kind: str, rival: float) -> bool:
        """The best grid point of its kind at its location, and better than the candidate and ``rival``."""
        key = (kind, entry.effect.location)
        if key in searched:
            return False
        searched.add(key)
        if not current:
            current.append(_log_evidence(context, candidate))
        return entry.log_evidence > max(current[0], rival)

    def refinable(entry) -> bool:
        if not np.isfinite(entry.log_evidence):
            return False
        if entry.effect.shape is not None:  # Bouc-Wen: also better than every effect without memory
            return first_better(entry, "shape", memoryless) and _worth_searching(context, entry)
        if entry.effect.eps is not None:  # a friction's width
            return first_better(entry, "width", -math.inf)
        return entry.effect.gap is not None

    head = [  # a refined clearance (Bouc-Wen shape) keeps the screen rank of the grid point it was refined from
        _with_screen(_refined(context, candidate, entry, effects, correlations, current), ranks, entry.term.name)
        if refinable(entry) else entry
        for entry in scored[:n_tries]
    ]
    ranked = sorted(head + scored[n_tries:], key=lambda item: item.log_evidence, reverse=True)
    unique = {entry.term.name: entry for entry in reversed(ranked)}  # two grid points refined to one shape: once
    return [entry for entry in ranked if unique[entry.term.name] is entry] + rest


def _log_evidence(context: LoopContext, candidate) -> float:
    """The Laplace log-evidence of ``candidate`` itself (−inf when it cannot be identified)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            return float(laplace_score(identify(context.signals, candidate, context.nsi), context.signals,
                                       context.evidence)[0])
    except (BayesNSIError, np.linalg.LinAlgError):
        return -math.inf


def _worth_searching(context: LoopContext, entry: EffectScore) -> bool:
    """Whether a Bouc-Wen grid point's quality index leaves its shape search a chance (module notes of
    :mod:`bayesnsi.loop.shapes`: :data:`~bayesnsi.loop.shapes.SEARCH_INDEX_FACTOR`).

    False when the index is at least that factor times ``max_imag_ratio`` and fails the loop's check
    (:func:`bayesnsi.checks.misfit.index_judgement`, against the enlarged model's misfit, as
    :func:`bayesnsi.loop.guards.check_effect` judges it).
    """
    coef = entry.identified.coefficients[-1]
    limit = context.options.max_imag_ratio
    if coef.imag_ratio < SEARCH_INDEX_FACTOR * limit:
        return True
    reading = misfit_reading(entry.identified, context.signals, seed=context.evidence.seed)
    return index_judgement(coef.imag_ratio, limit, context.evidence.max_band_ratio, reading)[0]


def _refined(context: LoopContext, candidate, entry: EffectScore, effects, correlations, current) -> EffectScore:
    """``entry`` with its clearance gap, Bouc-Wen shape or friction width refined off the grid.

    ``current``: ``[candidate's own log-evidence]`` once computed (the shape search's least gain), else empty.
    """
    if entry.effect.eps is not None:
        grid = [e.eps for e in effects if e.eps is not None and e.location == entry.effect.location]
        return search_width(entry, lambda effect: score_one(context.signals, candidate, effect, context.nsi,
                                                            context.evidence, correlations), grid)
    if entry.effect.shape is not None:
        return refine_shape(context.signals, candidate, entry, context.nsi, context.evidence, correlations=correlations,
                            base_log_evidence=current[0] if current else None)
    return refine_gap(context.signals, candidate, entry, effects, context.nsi, context.evidence,
                      correlations=correlations)
