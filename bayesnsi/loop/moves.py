"""The moves of the search besides adding an effect: prune, look ahead, re-examine a pair's first.

* Prune (:func:`prune`): after each addition, effects added earlier that the new one made
  redundant, or whose coefficient moved (sign, or more than ``stability_factor``), are removed.
* Look ahead (:func:`look_ahead`): an effect that fails only the quality index may owe it to a
  second missing effect: the search looks one effect further from the model holding it and adds
  the pair when both pass (``LoopOptions.lookahead``).
* Re-examine (:func:`reexamine`): the pair's first effect was chosen while the second was
  missing; once the second is in, it is exchanged for a decisively better effect at its location
  if one passes every guard.

Each move changes the :class:`~bayesnsi.loop.state.LoopState` it is given.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np

from ..exceptions import BayesNSIError, BayesNSIWarning
from ..nsi import identify
from .guards import Verdict, check_effect, documented, without
from .quality import misfit_reading, quality_check
from .results import EffectScore
from .scoring import laplace_score, rank_effects
from .state import Baseline, LoopContext, LoopState

__all__ = ["accept_pair", "look_ahead", "prune", "reexamine"]


def _names(terms) -> str:
    return ", ".join(t.name for t in terms)


def prune(context: LoopContext, state: LoopState, new_terms) -> None:
    """Backward step: drop earlier added effects that the newly added ones made redundant.

    Forward selection can take an effect that mimics a missing one (a clearance at DOF 1 taken
    for the hardening of a missing x1³, which was then added as well). After each addition,
    every effect the loop added before is removed in turn (Laplace log-evidence of the model
    without it); it is dropped when keeping it is no longer worth ``threshold`` (log Bayes factor
    of keeping it ≤ threshold), or when its coefficient, re-identified with the new effects,
    changed sign or by more than the stability factor; its step is then marked rejected.

    Parameters
    ----------
    context : LoopContext
    state : LoopState
        Its current model, log-evidence and steps are updated.
    new_terms : list of Term
        The effects just added (not pruned).
    """
    threshold, factor, signals = context.options.threshold, context.options.stability_factor, context.signals
    for index, step in enumerate(state.steps):
        current = state.current
        if not step.accepted or step.term in new_terms or step.term not in current.terms:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                reduced = identify(signals, without(current.candidate, step.term), context.nsi)
                z_without = laplace_score(reduced, signals, context.evidence)[0]
                z_with = laplace_score(current, signals, context.evidence)[0]
        except (BayesNSIError, np.linalg.LinAlgError):
            continue
        value = current.coefficients[current.terms.index(step.term)].value
        ratio = abs(value / step.coefficient) if step.coefficient else np.inf
        moved = np.sign(value) != np.sign(step.coefficient) or not 1 / factor < ratio < factor
        redundant = np.isfinite(z_without) and np.isfinite(z_with) and z_with - z_without <= threshold
        if moved or redundant:
            why = (
                f"its coefficient moved from {step.coefficient:.4g} to {value:.4g}"
                if moved
                else f"log Bayes factor of keeping it {z_with - z_without:.2f} <= {threshold:.2f}"
            )
            state.steps[index] = replace(
                step, accepted=False, reason=f"removed once {_names(new_terms)} was added: {why}"
            )
            state.current = reduced
            state.log_z = state.log_z - (z_with - z_without)


def _loop_added(state, entry) -> tuple:
    """The terms of ``entry``'s model the loop added (accepted steps and the pending first of a pair)."""
    added = {s.term.name for s in state.steps if s.accepted} | {entry.term.name}
    return tuple(t for t in entry.result.candidate.terms if t.name in added)


def look_ahead(context: LoopContext, state: LoopState, pending: tuple[Verdict, EffectScore]):
    """Search the next effect from the model holding ``pending`` (``LoopOptions.lookahead``).

    The second effect must pass every guard against the model holding the first, and the
    first one's quality index, in the model with both, must pass its check (below ``max_imag_ratio``, or not
    resolved against the misfit, :func:`bayesnsi.loop.quality.quality_check`). Every
    effect checked is appended to ``state.steps``, the search's scores to ``state.scores``. A second
    effect that passes its own checks while the first still fails its quality index is not rejected:
    its step keeps its checks (all passed) and says that the pair was declined for the first's index.

    Parameters
    ----------
    context : LoopContext
    state : LoopState
    pending : (Verdict, EffectScore)
        The effect that failed only the quality index, with its enlarged model.

    Returns
    -------
    (LoopStep, Verdict, EffectScore) or None
        The first step (accepted with the second), the second's verdict and the pair's model.
    """
    verdict, entry = pending
    p_step = verdict.step
    added = [*state.added, (p_step.effect.base, p_step.effect.location)]
    scored = rank_effects(context, entry.identified.candidate, added)
    search = state.record_scores(scored, verdict.log_evidence)
    baseline = Baseline(verdict.log_evidence, p_step.nrmse_after)
    for trial in scored[: context.options.n_tries]:
        if not np.isfinite(trial.log_evidence):
            break
        second = check_effect(
            context, trial, baseline, state.next_seed(), state.half_cache, _loop_added(state, entry), search=search
        )
        first_coef = trial.identified.coefficients[-2]
        step = second.step
        first_check = _first_quality(context, trial, first_coef) if step.accepted else None
        if first_check is not None and not first_check.passed:
            # not a rejection of this effect (it failed none of its own checks): the pair is declined
            step = replace(
                step, accepted=False,
                reason=f"not added: checked only beside {p_step.term.name} (look-ahead), where it passes its own "
                f"checks; the pair is declined because {p_step.term.name} still fails its {first_check.text} with it",
            )
        state.steps.append(step)
        if step.accepted:
            first = replace(
                p_step,
                accepted=True,
                reason=f"accepted with {trial.term.name}: |Im|/|Re| {p_step.imag_ratio:.2f} alone, "
                f"{first_coef.imag_ratio:.2f} with it",
                coefficient=first_coef.value,
                imag_ratio=first_coef.imag_ratio,
                ci95=_interval(second.ci95, -2),
            )
            return first, second, trial
    return None


def _first_quality(context: LoopContext, trial: EffectScore, coef):
    """The quality-index check of a pair's first effect in the model with both (:mod:`bayesnsi.loop.quality`)."""
    options = context.options
    reading = None
    if not coef.imag_ratio < options.max_imag_ratio:
        reading = misfit_reading(trial.identified, context.signals, index=-2, seed=context.evidence.seed)
    return quality_check(coef.imag_ratio, options.max_imag_ratio, context.evidence.max_band_ratio, reading)[0]


def accept_pair(context: LoopContext, state: LoopState, pending, pair) -> None:
    """Add the pair found by :func:`look_ahead`, prune, then re-examine the pair's first effect.

    Parameters
    ----------
    context : LoopContext
    state : LoopState
    pending : (Verdict, EffectScore)
        As in :func:`look_ahead`.
    pair : (LoopStep, Verdict, EffectScore)
        What :func:`look_ahead` returned.
    """
    first, second, model = pair
    middle = pending[1].result
    first = documented(first, state.current, middle, context.signals)
    state.replace_step(second.step, documented(second.step, middle, model.result, context.signals))
    second_term = second.step.term
    state.current, state.log_z = model.result, second.log_evidence
    state.replace_step(pending[0].step, first)
    state.mark_added(first)
    state.mark_added(second.step)
    prune(context, state, [first.term, second_term])
    reexamine(context, state, [second_term], [first.term])


def _alternatives(context: LoopContext, step, base):
    """Dictionary effects at ``step``'s location, of another type, not in ``base``."""
    present = {t.name for t in base.terms}
    return [
        e for e in context.effects
        if e.location == step.effect.location and e.base != step.effect.base and e.term.name not in present
    ]


def reexamine(context: LoopContext, state: LoopState, new_terms, examine) -> None:
    """Exchange each effect of ``examine`` for a better one at its location, if one passes.

    The model without the examined effect is enlarged by each other dictionary effect at the
    same location (types other than its own, clearance gaps refined) and scored by Laplace
    log-evidence. The best ``n_tries`` replacements whose log-evidence beats the current model's
    by ``threshold`` are checked in turn like any proposed effect (:func:`check_effect`)
    *against the current model*; the first that passes takes the examined effect's place in the
    accepted steps, and the examined step is marked rejected ("exchanged for ...").

    Parameters
    ----------
    context : LoopContext
    state : LoopState
    new_terms : list of Term
        The effects whose addition prompted the re-examination (named in the reasons).
    examine : list of Term
        The earlier effects re-examined.
    """
    threshold, signals = context.options.threshold, context.signals
    for index, step in enumerate(list(state.steps)):
        current = state.current
        if not step.accepted or step.term in new_terms or step.term not in current.terms or step.term not in examine:
            continue
        base = without(current.candidate, step.term)
        alternatives = _alternatives(context, step, base)
        if not alternatives:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                z_current = laplace_score(current, signals, context.evidence)[0]
        except (BayesNSIError, np.linalg.LinAlgError):
            continue
        scored = rank_effects(context, base, (), alternatives, screen=False)
        baseline = state.baseline(signals)
        new = None
        for trial in scored[: context.options.n_tries]:
            if not trial.log_evidence - z_current > threshold:
                break
            new = check_effect(context, trial, baseline, state.next_seed())
            if new.step.accepted:
                break
        if new is None or not new.step.accepted:
            continue
        accepted = replace(
            new.step,
            reason=f"accepted in exchange for {step.term.name} once {_names(new_terms)} was added "
            f"(log Bayes factor against the model with it {new.step.log_bayes_factor:.2f})",
        )
        # "before" is the model it replaces, as for its Bayes factor and open-loop NRMSE
        state.steps[index] = documented(accepted, current, trial.result, signals)
        state.steps.append(
            replace(step, accepted=False, reason=f"exchanged for {trial.term.name} once {_names(new_terms)} was added")
        )
        state.current, state.log_z = trial.result, new.log_evidence


def _interval(intervals: np.ndarray | None, index: int) -> tuple[float, float]:
    """Row ``index`` of a verdict's credible intervals (NaN when it was not sampled)."""
    if intervals is None:
        return (math.nan, math.nan)
    low, high = intervals[index]
    return (float(low), float(high))
