"""Closing the loop: from the residual of a model to an effect it lacks (docs/method.md §7).

Greedy forward search with a backward check. Every effect of a dictionary (type × location,
:class:`bayesnsi.models.Effect`) is added in turn to the current candidate, identified by NSI and
scored by its Laplace log-evidence (:mod:`bayesnsi.loop.scoring`; a frequency-domain screen
first chooses which effects are identified). The best ``n_tries`` are checked in turn and the
first that passes the checks (:mod:`bayesnsi.loop.guards`, the one acceptance rule: Bayes factor,
quality index, stability across record halves, separability, no negative dissipation) is added; an
effect whose own coefficient is not physical (quality index, negative dissipation) does not use up
one of the ``n_tries``. Then effects added earlier that the new one made
redundant are pruned; an effect that failed only the quality index may be added with a second one
(look ahead), after which the pair's first effect is re-examined (:mod:`bayesnsi.loop.moves`).
The search repeats from the enlarged model until no effect passes or ``max_steps`` effects were
added. A final model that holds a friction-like term (``sign()`` of a velocity) is identified once
more on an upsampled grid for its reported coefficients (``refine_final``). The effects of a
search can be scored in worker processes or on a Dask cluster with the same result. Every accepted
step carries its open- and closed-loop errors before and after, and the residual of both models
as a force at the effect's location (:mod:`bayesnsi.loop.forces`, docs/method.md §7).

The measurements behind the defaults of :class:`bayesnsi.options.LoopOptions` are in
``docs/measurements.md`` (``benchmarks/diagnose_suite.py``, ``benchmarks/diagnose.py``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from ..exceptions import BayesNSIError, BayesNSIWarning, ConfigError, LoopError
from ..models import BoucWen, CandidateModel, default_gaps, default_shapes, default_widths, effect_dictionary
from ..models.dictionary import (
    CLEARANCE,
    DEFAULT_EFFECT_TYPES,
    DIRECTIONAL,
    EFFECT_TYPES,
    HYSTERESIS,
    MIN_REVERSALS,
    SMOOTH_FRICTION,
    Effect,
    velocity_reversals,
)
from ..nsi import identify
from ..options import EvidenceOptions, ExecutionOptions, LoopOptions, NSIOptions
from .free_view import free_body_start
from .friction import friction_reading, holds_friction
from .guards import ADMISSIBILITY, check_effect, documented
from .localise import DETECTION_REACH
from .moves import accept_pair, look_ahead, prune
from .results import LoopResult
from .scoring import laplace_score, rank_effects
from .state import LoopContext, LoopState

__all__ = ["close_the_loop", "close_the_loop_with", "loop_effects"]

SCREEN_BAND = 1.6
"""The screen uses frequencies up to this multiple of the start model's highest natural frequency."""


def loop_effects(signals, names=None) -> list[Effect]:
    """The loop's dictionary: effect types at the measured DOFs and across every pair of them.

    Parameters
    ----------
    signals : Signals
        Estimation data (its output DOFs, and their displacement spread for the clearance gaps).
    names : sequence of str, optional
        Keys of :data:`bayesnsi.models.EFFECT_TYPES`, ``"clearance"``, ``"tanh(v/eps)"`` and
        ``"boucwen"`` (``LoopOptions.effects``); default :data:`bayesnsi.models.dictionary.DEFAULT_EFFECT_TYPES`,
        clearances, tanh frictions and Bouc-Wen elements. Every type acts at each measured DOF and
        across every pair of them. Clearances are tried at every location with gaps of 0.5, 1 and 1.5
        standard deviations of the displacement they act on (the relative displacement for a pair;
        refined when one ranks among the best); the smoothed friction ``tanh(v/eps)`` with ε = 0.25
        and 0.5 standard deviations of the velocity it acts on, written with its numeric ε
        (:func:`bayesnsi.models.default_widths`); Bouc-Wen elements on the grid of
        :func:`bayesnsi.models.default_shapes` from the std of the displacement they act on (shape
        refined when one beats the model and every effect without memory; docs/method.md §12).
        The types that compare the two directions of motion
        (:data:`bayesnsi.models.dictionary.DIRECTIONAL`, e.g. ``|v|``) are kept only at locations
        whose velocity reverses at least ``MIN_REVERSALS`` times in each half of the record
        (:func:`bayesnsi.models.dictionary.velocity_reversals`).

    Returns
    -------
    list of Effect

    Raises
    ------
    ConfigError
        For a name that is neither an effect type nor ``"clearance"``.
    """
    special = (CLEARANCE, SMOOTH_FRICTION, HYSTERESIS)
    names = (*DEFAULT_EFFECT_TYPES, *special) if names is None else tuple(names)
    unknown = [n for n in names if n not in special and n not in EFFECT_TYPES]
    if unknown:
        raise ConfigError(f"[diagnose] effects: unknown type(s) {unknown}; choose from {[*EFFECT_TYPES, *special]}")
    gaps: dict[tuple[int, ...], Sequence[float]] | None = None
    if CLEARANCE in names:
        gaps = {at: tuple(default_gaps(float(np.std(x)))) for at, x in _location_motions(signals, "displacement")}
    widths: dict[tuple[int, ...], Sequence[float]] | None = None
    if SMOOTH_FRICTION in names:
        found = {at: tuple(default_widths(float(np.std(v)))) for at, v in _location_motions(signals, "velocity")}
        widths = {at: w for at, w in found.items() if all(np.isfinite(w)) and min(w) > 0}
    shapes: dict[tuple[int, ...], Sequence[BoucWen]] | None = None
    if HYSTERESIS in names:
        spread = {at: float(np.std(x)) for at, x in _location_motions(signals, "displacement")}
        shapes = {at: default_shapes(s) for at, s in spread.items() if np.isfinite(s) and s > 0}
    effects = effect_dictionary(signals.output_dofs, [t for t in EFFECT_TYPES if t in names], gaps=gaps, widths=widths,
                                shapes=shapes)
    if not any(e.base in DIRECTIONAL for e in effects):
        return effects
    half = signals.n_samples // 2
    reversing = {at for at, v in _location_motions(signals, "velocity")
                 if min(velocity_reversals(v[:half]), velocity_reversals(v[half:])) >= MIN_REVERSALS}
    return [e for e in effects if e.base not in DIRECTIONAL or e.location in reversing]


def _location_motions(signals, quantity: str):
    """``(location, motion)`` at each measured DOF and across each pair of them (as effect_dictionary)."""
    values = np.asarray(signals.displacement if quantity == "displacement" else signals.velocities(), dtype=float)
    dofs = [int(d) for d in signals.output_dofs]
    for c, d in enumerate(dofs):
        yield (d,), values[:, c]
    for i, j in enumerate(dofs):
        for k, other in enumerate(dofs[i + 1 :], start=i + 1):
            yield (j, other), values[:, i] - values[:, k]


def close_the_loop(
    signals,
    candidate: CandidateModel,
    options: LoopOptions | None = None,
    *,
    nsi: NSIOptions | None = None,
    evidence: EvidenceOptions | None = None,
    execution: ExecutionOptions | None = None,
) -> LoopResult:
    """Search the effects a candidate lacks and add those the data support (docs/method.md §7).

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidate : CandidateModel
        Starting model (e.g. the selected one, or a linear model with no terms).
    options : LoopOptions, optional
        The residual the effects are scored on, the guards (``threshold``: least log Bayes
        factor, default log 100; ``max_imag_ratio``: largest quality index |Im λ|/|Re λ|, whose
        failure alone is accepted with ``accept_quality_only``;
        ``stability_factor``: largest ratio of the record-half estimates, which must also share
        their sign), the search (``n_tries`` effects checked per step, best first, not counting those
        whose quality index or dissipation fails; ``screen``
        effects identified per step after the frequency-domain screen, None: all;
        ``lookahead``: when no effect passes but one failed only the quality index, search one
        effect further from the model holding it and add the pair; ``max_steps``), the final
        re-identification of friction-like models at ``upsample = refine_final``, and the
        dictionary (``effects``: type names tried at the measured DOFs, :func:`loop_effects`).
    nsi : NSIOptions, optional
        Identification settings (the loop's decisions are made at these).
    evidence : EvidenceOptions, optional
        Likelihood, priors, emcee settings and ``seed`` of the evidence; its residual is replaced
        by ``options.residual`` and only the primary likelihood is computed.
    execution : ExecutionOptions, optional
        ``jobs`` local worker processes or a Dask ``scheduler`` scoring the effects of a step;
        the result does not depend on them.

    Returns
    -------
    LoopResult

    Raises
    ------
    ConfigError
        When an options argument is not of its options class.

    Notes
    -----
    Effects of the type and location of one already added (e.g. a second clearance at the same
    DOF with another gap) are not proposed again. The guards' defaults and their measurements are
    in ``docs/measurements.md`` ("Closing the loop").

    References
    ----------
    R. Zhu, Q. Fei, D. Jiang, S. Marchesiello, D. Anastasio, "Bayesian Model Selection in
    Nonlinear Subspace Identification", AIAA Journal, doi:10.2514/1.J060782 (the candidates'
    identification and evidence that each step reuses); the search, the guards and the screen
    are bayesnsi's (docs/method.md §7). G. M. Ljung, G. E. P. Box, Biometrika 65(2), 1978, for the
    whiteness test of :func:`bayesnsi.checks.validation.residual_whiteness` that flags a missing effect.

    Examples
    --------
    A two-DOF chain whose quadratic damping at DOF 1 is missing from a linear model:

    >>> from bayesnsi import LoopOptions
    >>> from bayesnsi.simulate import undeclared_case
    >>> case = undeclared_case("quadratic-damping", seed=0)
    >>> loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1), nsi=case.nsi)
    >>> [(step.term.name, step.accepted) for step in loop.steps]
    [('v1*abs(v1)@1', True)]
    """
    options = _checked(options, LoopOptions, "options")
    return close_the_loop_with(
        signals, candidate, loop_effects(signals, options.effects), options, nsi=nsi, evidence=evidence,
        execution=execution,
    )


def _checked(value, cls, name: str):
    """``value`` or the default ``cls()``; ConfigError for anything but an instance of ``cls``."""
    if value is None:
        return cls()
    if not isinstance(value, cls):
        raise ConfigError(f"{name} must be a {cls.__name__} (or None), got {type(value).__name__}; "
                          f"build one with {cls.__name__}.from_mapping(...)")
    return value


def close_the_loop_with(
    signals,
    candidate: CandidateModel,
    effects,
    options: LoopOptions | None = None,
    *,
    nsi: NSIOptions | None = None,
    evidence: EvidenceOptions | None = None,
    execution: ExecutionOptions | None = None,
) -> LoopResult:
    """:func:`close_the_loop` over a dictionary of one's own (``options.effects`` is ignored).

    Parameters
    ----------
    signals, candidate, options, nsi, evidence, execution
        As in :func:`close_the_loop`.
    effects : sequence of Effect
        The dictionary, e.g. from :func:`bayesnsi.models.effect_dictionary` (element pairs,
        clearance gaps of one's choice) or :func:`loop_effects`.

    Returns
    -------
    LoopResult

    Raises
    ------
    ConfigError
        When an options argument is not of its options class or an effect is not an Effect.
    LoopError
        When the starting model's evidence is not finite, or no effect scored against the current
        model has a finite evidence (the message gives the first reason): the loop would otherwise
        end silently with nothing added.
    """
    options = _checked(options, LoopOptions, "options")
    nsi = _checked(nsi, NSIOptions, "nsi")
    execution = _checked(execution, ExecutionOptions, "execution")
    evidence = _checked(evidence, EvidenceOptions, "evidence").replace(residual=options.residual, compare=())
    effects = tuple(effects)
    if not all(isinstance(e, Effect) for e in effects):
        raise ConfigError("effects must be bayesnsi.models.Effect objects (see effect_dictionary)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNSIWarning)
        start = identify(signals, candidate, nsi)
    if start.virtual_stiffness and nsi.virtual_stiffness == "auto":  # a free body: keep the start's spring
        nsi = nsi.replace(virtual_stiffness=start.virtual_stiffness)
    top_hz = max([m.frequency_hz for m in start.modes] or [start.band_hz[1]])  # free bodies: no mode
    screen_hz = None if options.screen is None else SCREEN_BAND * top_hz
    if nsi.domain == "frequency":
        # every candidate at the start's order (the same linear dynamics, its order chosen once); the screen over
        # the fitted lines and the harmonics above them, where the data show the nonlinear forces
        nsi = nsi.replace(order=start.order) if nsi.order == "auto" else nsi
        fit_top = float((start.fit.fit_band_hz or start.band_hz)[1])
        screen_hz = None if options.screen is None else DETECTION_REACH * fit_top
    context = LoopContext(signals, effects, nsi, evidence, options, execution, screen_hz)
    context, start, first = free_body_start(context, start, SCREEN_BAND)  # one view: force or displacement
    start_score = laplace_score(start, signals, evidence)[0]
    if not np.isfinite(start_score):
        raise LoopError(
            f"the evidence of the starting model {start.candidate.name!r} is {start_score} "
            f"(Laplace, {evidence.likelihood}); check the [evidence] priors (noise_floor, reference_force_rms) "
            "against the residual"
        )
    state = LoopState(start, start_score, evidence.seed)
    while len(state.added) < options.max_steps and _step(context, state, first):
        first = None
    final, final_nsi = _refined(context, state.current)
    # accepted steps first (in order), then the rejected ones
    ordered = [s for s in state.steps if s.accepted] + [s for s in state.steps if not s.accepted]
    friction = _friction(final, signals)
    return LoopResult(start=start, final=final, steps=tuple(ordered), scores=tuple(state.scores), options=options,
                      nsi=context.nsi, final_nsi=final_nsi, evidence=evidence, n_effects=len(effects),
                      friction=friction)


def _friction(final, signals):
    """The final model's friction reading (:func:`bayesnsi.loop.friction_reading`), None without one."""
    try:
        return friction_reading(final, signals) if holds_friction(final) else None
    except (BayesNSIError, np.linalg.LinAlgError, ValueError):
        return None


def _step(context: LoopContext, state: LoopState, scored=None) -> bool:
    """One search from the current model; True when something was added (search again).

    ``scored``: the search's scores when already computed (the first, :func:`free_body_start`).
    """
    options = context.options
    scored = rank_effects(context, state.current.candidate, state.added) if scored is None else scored
    search = state.record_scores(scored, state.log_z)
    tried = [s for s in scored if not math.isnan(s.log_evidence)]  # NaN: left out by the screen
    if tried and not any(np.isfinite(s.log_evidence) for s in tried):
        reasons = sorted({s.error for s in tried if s.error}) or ["no reason recorded"]
        raise LoopError(
            f"no effect of the {len(tried)} scored against {state.current.candidate.name!r} has a finite evidence, "
            f"so the loop cannot decide anything: {reasons[0]}" + (f" (and {len(reasons) - 1} other reasons)"
                                                                   if len(reasons) > 1 else "")
        )
    if not scored or not np.isfinite(scored[0].log_evidence):
        return False
    baseline = state.baseline(context.signals)
    pending = None
    added = {s.term.name for s in state.steps if s.accepted}  # the "separable" guard checks against these
    accepted = tuple(t for t in state.current.candidate.terms if t.name in added)
    tries = 0
    for entry in scored:  # the n_tries best; an effect whose own coefficient is not physical does not count
        if tries >= options.n_tries or not np.isfinite(entry.log_evidence):
            break
        verdict = check_effect(context, entry, baseline, state.next_seed(), state.half_cache, accepted, search=search,
                               halves_if_unsound=options.lookahead and pending is None)
        state.steps.append(verdict.step)
        failed = verdict.step.failed_checks
        tries += not (failed and failed[0].name in ADMISSIBILITY)  # a coefficient that is not physical: no try
        if verdict.step.accepted:
            step = documented(verdict.step, state.current, entry.result, context.signals)
            state.replace_step(verdict.step, step)
            state.current, state.log_z = entry.result, verdict.log_evidence
            state.mark_added(step)
            prune(context, state, [step.term])
            return True
        if verdict.quality_only and pending is None:
            pending = (verdict, entry)
    if not (options.lookahead and pending is not None and len(state.added) + 2 <= options.max_steps):
        return False
    pair = look_ahead(context, state, pending)
    if pair is None:
        return False
    accept_pair(context, state, pending, pair)
    return True


def _refined(context: LoopContext, current):
    """The final model, re-identified upsampled when it holds a velocity-switching term.

    Such terms jump between samples, which biases their coefficients at the data rate
    (docs/method.md §10); decisions stay at the data rate. Returns ``(NSIResult, NSIOptions it was identified with)``.
    """
    nsi, factor = context.nsi, context.options.refine_final
    if not factor or nsi.upsample != 1 or not any(t.expr.switches_with_velocity for t in current.terms):
        return current, nsi
    fine = nsi.replace(upsample=int(factor), block_rows=nsi.block_rows * int(factor))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            return identify(context.signals, current.candidate, fine), fine
    except (BayesNSIError, np.linalg.LinAlgError) as err:
        warnings.warn(
            f"the final model could not be re-identified with upsample = {factor} ({err}); "
            "its coefficients are from the data-rate identification",
            BayesNSIWarning,
            stacklevel=4,
        )
    return current, nsi
