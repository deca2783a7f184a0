"""Intervals of inadequate models, widened by their model error (docs/method.md §11).

The noise replicates carry the sensor noise only. A model whose residual is R times the noise it
passes on (:func:`bayesnsi.checks.model_checks`) has an error that moves its estimates from record
to record about R times as much: :func:`widen_inadequate` widens the intervals of every such
candidate of a selection by R, :func:`widen_final` those of a model outside a selection (the
loop's final model) the same way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from ..checks.adequacy import ModelCheck, model_checks, unsupported_terms
from ..findings import Finding
from ..noise import WhiteSensorNoise, noise_model
from .intervals import Intervals, ParameterInterval

__all__ = ["widen", "widen_final", "widen_inadequate"]


def widen(intervals: Intervals, factor: float, why: Finding) -> Intervals:
    """The same intervals with every sd and every interval's reach from its centre times ``factor``.

    For a model whose residual is ``factor`` times the sensor noise (docs/method.md §11, model
    adequacy): the noise replicates carry the sensor noise only, while the model error moves the
    estimates from one record to the next about as much more (a Birge ratio; on the simulated
    Bouc-Wen system the time route's coefficients scattered 3.8-7.6x their replicate sd over four
    realisations, with residuals 6.2-8.5x the noise). Each interval keeps its centre
    (``estimate - bias``, else its midpoint) and the reported estimate.

    Parameters
    ----------
    intervals : Intervals
    factor : float
        Widening factor (at least 1).
    why : Finding
        Why, added to ``findings``.

    Returns
    -------
    Intervals
    """
    factor = max(float(factor), 1.0)

    def stretch(p: ParameterInterval) -> ParameterInterval:
        centre = p.estimate - p.bias if math.isfinite(p.bias) else 0.5 * (p.ci50[0] + p.ci50[1])

        def scaled(bounds):
            low, high = centre + factor * (bounds[0] - centre), centre + factor * (bounds[1] - centre)
            return low, high

        low, high = scaled(p.ci95)
        return replace(p, sd=p.sd * factor, ci50=scaled(p.ci50), ci95=(min(low, p.estimate), max(high, p.estimate)))

    return replace(
        intervals, coefficients=tuple(map(stretch, intervals.coefficients)),
        frequencies=tuple(map(stretch, intervals.frequencies)),
        damping_ratios=tuple(map(stretch, intervals.damping_ratios)),
        findings=intervals.findings + (why,), widening=intervals.widening * factor,
    )


@dataclass(frozen=True)
class _Model:
    """A model as :func:`model_checks` and :func:`widen_inadequate` read a candidate's outcome."""

    name: str
    result: Any
    intervals: Any


def widen_final(result, intervals, signals, *, max_noise_ratio: float = 1.3, max_imag_ratio: float = 0.3,
                validation=()):
    """The intervals of a model outside a selection (the loop's final model), widened as ``select`` widens.

    Parameters
    ----------
    result : NSIResult
        The model, e.g. ``LoopResult.final``.
    intervals : Intervals
        Its intervals (:func:`bayesnsi.loop.final_intervals`).
    signals : Signals
        The estimation data.
    max_noise_ratio, max_imag_ratio : float
        As :func:`model_checks`.
    validation : tuple of SegmentError
        The model's errors on the validation segments (:func:`bayesnsi.checks.validation.validate`), for the
        check's ``validation_nrmse``.

    Returns
    -------
    intervals : Intervals
        Widened by the residual-to-noise ratio when the model is inadequate (:func:`widen_inadequate`),
        else as given.
    check : ModelCheck or None
        The model's adequacy figures (None when its residual cannot be computed).
    """
    model = _Model(name="final", result=result, intervals=intervals)
    checks = model_checks([model], signals, {"final": tuple(validation)} if validation else None,
                          max_noise_ratio=max_noise_ratio, max_imag_ratio=max_imag_ratio)
    (widened,), checks = widen_inadequate([model], checks, signals)
    return widened.intervals, checks.get("final")


def widen_inadequate(
    outcomes: Sequence, checks: Mapping[str, ModelCheck], signals=None,
) -> tuple[tuple, dict[str, ModelCheck]]:
    """Widen the intervals of every inadequate candidate by its residual-to-noise ratio.

    The noise replicates of :func:`bayesnsi.uncertainty.candidate_intervals` carry the sensor noise
    only. A model whose residual is R times the noise (R above ``max_noise_ratio``) has an error
    that moves its estimates from record to record about R times as much (docs/method.md §11):
    its intervals are widened by R (:func:`bayesnsi.uncertainty.widen`), with a note, and the
    coefficients whose widened 95 % interval holds zero are listed again. Not for a free body,
    whose ratio is its force-prediction error over the noise of the force channel: that noise is
    not what drives the residual (EMPS: 70x, where widening would give Coulomb friction
    [-29, 67] N for an estimate within 3 % of the published 20.4 N).

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
    checks : mapping of str to ModelCheck
        :func:`model_checks` of those outcomes.
    signals : Signals, optional
        The estimation data. Nothing is widened when they are integrated from a velocity or an
        acceleration on a record without whole periods unless the signals keep the accelerometers'
        noise and integration recipe (``acceleration_noise``, set by the loader): the noise the ratio
        divides by is otherwise that of the integrated signal, which the integration filter removes
        (a sweep of integrated accelerations read 18 000x; periodic records take the
        period-to-period scatter instead).

    Returns
    -------
    outcomes : tuple of CandidateOutcome
        With widened ``intervals`` where the model is inadequate.
    checks : dict of str to ModelCheck
        With ``unsupported`` of the widened intervals.
    """
    if signals is not None and signals.measured != "displacement" and isinstance(noise_model(signals),
                                                                                 WhiteSensorNoise):
        return tuple(outcomes), dict(checks)
    widened, new_checks = [], dict(checks)
    for outcome in outcomes:
        check = checks.get(outcome.name)
        intervals = getattr(outcome, "intervals", None)
        free = getattr(getattr(outcome, "result", None), "virtual_stiffness", 0.0)
        if (check is None or check.adequate or intervals is None or not math.isfinite(check.noise_ratio)
                or check.quantity != "displacement" or free):
            # a free body with several DOFs: its displacement residual is the stabilised model's, which rings
            # at the undamped virtual mode (free-free rig, true model: 1100x the 1 µm noise), not its error
            widened.append(outcome)
            continue
        why = Finding(
            "interval.widened",
            f"widened {check.noise_ratio:.2f}x: the model's residual is {check.noise_ratio:.2f}x the noise it passes "
            f"on ({check.quantity}), so its error, not the noise, sets how far its estimates move from record to "
            "record",
            outcome.name, "note", {"factor": float(check.noise_ratio), "quantity": check.quantity})
        intervals = widen(intervals, check.noise_ratio, why)
        widened.append(replace(outcome, intervals=intervals))
        new_checks[outcome.name] = replace(check, unsupported=unsupported_terms(intervals), widening=intervals.widening)
    return tuple(widened), new_checks
