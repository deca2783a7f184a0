"""The one acceptance rule of the loop: the checks of a proposed effect (docs/method.md §7, step 4).

Every check reads a property of the proposed effect itself, in the model enlarged by it, and
records its value and limit (:class:`~bayesnsi.loop.results.Check`, ``LoopStep.checks``); an
effect is added when it passes every check, and a rejection names the first check it failed, in
the order of :data:`CHECK_ORDER`:

* **log Bayes factor** (Laplace) of the enlarged model against the current one above
  ``LoopOptions.threshold``; the full evidence (emcee + bridge sampling) then gives its credible
  interval;
* **quality index** |Im λ|/|Re λ| of its coefficient below ``max_imag_ratio``: λ(ω) consistent over
  the band, a coefficient and not a filter; where the enlarged model misfits its data beyond
  ``EvidenceOptions.max_band_ratio``, an index above the limit fails only when the frequency
  dependence of λ(ω) is resolved against that misfit (:mod:`bayesnsi.loop.quality`; the step then
  says the index could not judge it, ``LoopStep.index_unresolved``);
* **record halves**: identified on each half of the record its coefficient keeps its sign and stays
  within a factor ``stability_factor`` (:mod:`bayesnsi.loop.halves`; a free body's in the force
  view its evidence scores);
* **separable** from the effects the loop added before: the squared partial correlation of its
  column with each of theirs, given the linear part and the other terms, at most ``max_shared``
  (:mod:`bayesnsi.loop.separable`);
* **force prediction** (free bodies): the enlarged model's own force-prediction error does not rise;
* **dissipation**: a pure velocity term that is odd in the velocity and dissipative in shape
  (``n(v)·v >= 0`` with v the velocity at its location, relative for an element: ``v|v|``,
  ``v^3``, ``sign(v)``, ``tanh(v/eps)``) adds the force ``-λ l n`` (the equation of motion
  ``M ẅ + C ẇ + K w + λ l n = F f``, extended input ``[f; -n]``), whose power ``-λ n(v)·v`` is
  positive for every motion when ``λ < 0`` (:func:`bayesnsi.checks.dissipation.injects_energy`).
  This is the physics, not a tolerance: a negative quadratic damping fitted to a Coulomb joint on
  one level diverges on a stronger one (the simulated GVT, ``benchmarks/gvt_loop.py``).

The quality index and the dissipation judge whether the effect's own coefficient is a physical one
(:data:`ADMISSIBILITY`): an effect that fails one of them first does not use up one of the loop's
``n_tries`` (the next effect is checked in its place), so that effects the evidence favours for
model-form reasons cannot hide one that passes (Silverbox: three velocity terms with |Im|/|Re|
0.58-2.37 kept x² from being checked; docs/measurements.md, "One acceptance rule"). An effect whose
only failed check is the quality index (the evidence favours it, its halves agree) is marked
``quality_only``; ``LoopOptions.accept_quality_only`` accepts it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..checks.dissipation import dissipative_shape, injects_energy
from ..evidence import candidate_evidence
from ..exceptions import BayesNSIError, BayesNSIWarning
from ..nsi import is_free_body, short_horizon_nrmse
from .forces import residual_force
from .halves import (
    MIN_HALF_OVERLAP,
    TOO_SHORT,
    force_view_estimate,
    half_block_rows,
    half_check,
    half_coefficients,
    half_coefficients_force,
    half_overlap,
    without,
)
from .quality import MisfitReading, misfit_reading, quality_check
from .results import Check, EffectScore, LoopStep
from .separable import shared_fraction
from .state import Baseline, LoopContext, measured_nrmse

__all__ = [
    "ADMISSIBILITY", "CHECK_ORDER", "MIN_HALF_OVERLAP", "NEGATIVE_DISSIPATION", "TOO_SHORT", "Verdict",
    "about_estimates", "check_effect", "documented", "half_block_rows", "half_coefficients",
    "half_coefficients_force", "half_overlap", "without",
]

NEGATIVE_DISSIPATION = "negative dissipation"
"""Start of the reason of a dissipative-shaped velocity effect whose coefficient feeds energy in."""

@dataclass(frozen=True)
class Verdict:
    """The outcome of :func:`check_effect`.

    Attributes
    ----------
    step : LoopStep
    log_evidence : float
        Laplace log-evidence of the enlarged model.
    ci95 : ndarray or None
        Credible intervals of all its coefficients when it was sampled (accepted effects), moved onto
        their NSI estimates (:func:`about_estimates`).
    quality_only : bool
        True when the effect passed every guard but the quality index |Im|/|Re|.
    """

    step: LoopStep
    log_evidence: float
    ci95: np.ndarray | None
    quality_only: bool


def about_estimates(evidence, estimates) -> np.ndarray:
    """The coefficients' 95 % posterior intervals moved onto the NSI estimates: the posterior's spread about them.

    The posterior is conditional on the identified linear part and centred on its own mean, which can lie
    outside its narrow interval from the NSI estimate the loop reports (one loop step: estimate 1.92647e8,
    posterior interval [1.92726e8, 1.92768e8]); moved by ``estimate - posterior mean``, as the final
    intervals' posterior-only column is (:mod:`bayesnsi.uncertainty.intervals`). The final model's
    intervals carry the linear part's uncertainty.

    Parameters
    ----------
    evidence : EvidenceResult
    estimates : array_like, shape (q,)
        NSI estimates (their real parts are used).

    Returns
    -------
    ndarray, shape (q, 2)
    """
    means = np.mean(evidence.posterior.coefficients, axis=(0, 1))
    shift = np.real(np.asarray(estimates)) - means
    return np.asarray(evidence.ci95, dtype=float) + shift[:, None]


CHECK_ORDER = ("log Bayes factor", "quality index", "record halves", "separable", "force prediction", "dissipation")
"""The checks of :func:`check_effect`, in the order a rejection names the first one failed."""
ADMISSIBILITY = ("quality index", "dissipation")
"""Checks of the effect's own coefficient in the enlarged model (is it a physical, consistent
coefficient?); an effect failing one of them first does not use up one of the loop's ``n_tries``."""


def _checks(context, entry, baseline, log_bf, coef, quality, with_halves, halves_args, shared, rho2, feeds_energy,
            free_body):
    """Every check of one effect (module notes), in :data:`CHECK_ORDER`; ``quality`` is its quality-index check."""
    options = context.options
    threshold = options.threshold
    out = [Check("log Bayes factor", float(log_bf), threshold, bool(log_bf > threshold),
                 f"log Bayes factor {log_bf:.2f} {'>' if log_bf > threshold else '<='} threshold {threshold:.2f}")]
    if not log_bf > threshold:  # the other checks are not made (they cost identifications)
        return tuple(out)
    out.append(quality)
    if with_halves:
        out.append(Check(*half_check(*halves_args)))
    if shared:
        passed = rho2 <= options.max_shared
        out.append(Check(
            "separable", float(rho2), options.max_shared, passed,
            f"separable from {shared}: squared partial correlation {rho2:.2f} <= max_shared {options.max_shared:g}"
            if passed else
            f"not separable from {shared}: {shared} already explains {100 * rho2:.0f} % of its column beyond the "
            f"linear part (squared partial correlation {rho2:.2f} > max_shared {options.max_shared:g}; "
            f"it would inflate the variance of {shared}'s coefficient {1 / (1 - min(rho2, 0.999999)):.1f}x)"))
    if free_body and np.isfinite(entry.nrmse):  # the field's error for a free body: its own force prediction
        passed = not entry.nrmse > baseline.nrmse
        out.append(Check(
            "force prediction", float(entry.nrmse), float(baseline.nrmse), passed,
            f"force-prediction NRMSE {baseline.nrmse:.4g} -> {entry.nrmse:.4g} (free body, IDIM view)" if passed
            else f"force-prediction NRMSE rises from {baseline.nrmse:.4g} to {entry.nrmse:.4g} (free body, IDIM view)"))
    if dissipative_shape(entry.effect.term):
        out.append(Check(
            "dissipation", float(np.real(coef.value)), 0.0, not feeds_energy,
            f"{NEGATIVE_DISSIPATION}: coefficient {coef.value:.4g} < 0 of a dissipative velocity term feeds energy "
            "into every motion" if feeds_energy else f"dissipative coefficient {coef.value:.4g} >= 0"))
    return tuple(out)


def _quality(context, trial, coef, needed: bool) -> tuple[Check, bool, MisfitReading]:
    """The quality-index check of the effect (:func:`bayesnsi.loop.quality.quality_check`), whether it passed as
    not resolved against the misfit, and the misfit reading (read only when ``needed`` and the index is at or
    above ``max_imag_ratio``: one reconstruction of the enlarged model)."""
    options = context.options
    reading = MisfitReading()
    if needed and not coef.imag_ratio < options.max_imag_ratio:
        reading = misfit_reading(trial, context.signals, seed=context.evidence.seed)
    check, unresolved = quality_check(coef.imag_ratio, options.max_imag_ratio, context.evidence.max_band_ratio,
                                      reading)
    return check, unresolved, reading


def _decision(checks, accept_quality_only: bool) -> tuple[str, bool]:
    """The reason (``"accepted"`` or the first failed check's text) and whether only the quality index failed."""
    failed = [c for c in checks if not c.passed]
    complete = any(c.name == "record halves" for c in checks)
    quality_only = complete and len(failed) == 1 and failed[0].name == "quality index"
    if not failed:
        return "accepted", False
    if quality_only and accept_quality_only:
        return (f"accepted: only the quality index objects ({failed[0].text}) and accept_quality_only = true; "
                "the evidence favours it and its record halves agree"), True
    return failed[0].text, quality_only


def check_effect(
    context: LoopContext, entry: EffectScore, baseline: Baseline, seed, half_cache=None, accepted=(),
    search: int | None = None, halves_if_unsound: bool = True,
) -> Verdict:
    """Log Bayes factor (Laplace) and the checks of one proposed effect (module notes).

    Every check reads the proposed effect itself in the model enlarged by it (:data:`CHECK_ORDER`); a
    rejection names the first it failed with its value and limit (:class:`~bayesnsi.loop.results.Check`,
    ``LoopStep.checks``). An effect whose only failed check is the quality index is marked
    ``quality_only``; ``LoopOptions.accept_quality_only`` accepts it. The decision uses the Laplace
    log-evidence ``entry`` was ranked by; the full emcee evidence runs only for an effect that passes,
    to give its credible interval (one kept only with a second effect, ``lookahead``, gets its interval
    from the pair's evidence). The record-half estimates (two identifications; for a free body the
    force-view least-squares estimates, :func:`half_coefficients_force`) are computed only for an effect
    whose Bayes factor clears the threshold.

    Parameters
    ----------
    context : LoopContext
    entry : EffectScore
        The effect with its enlarged model (``entry.result``) and its Laplace log-evidence.
    baseline : Baseline
        The model it is checked against.
    seed : SeedSequence
        Seed of the full evidence (sampled only when the effect passes).
    half_cache : dict, optional
        As ``cache`` of :func:`half_coefficients`.
    accepted : sequence of Term
        The terms of the current model the loop added (the "separable" guard checks against them).
    search : int, optional
        Index of the search that proposed the effect (:attr:`LoopStep.search`).
    halves_if_unsound : bool
        Compute the record halves of an effect that fails its quality index too (to tell whether
        that is the only check it fails: ``quality_only``). The loop asks for them only while it
        can use the answer (``accept_quality_only``, or no look-ahead candidate found yet).

    Returns
    -------
    Verdict
    """
    options, signals, trial = context.options, context.signals, entry.identified
    threshold = options.threshold
    log_bf = entry.log_evidence - baseline.log_evidence
    coef = trial.coefficients[-1]
    free_body = is_free_body(trial)
    halves: tuple[float, float] = (math.nan, math.nan)
    too_short, rows, note = False, context.nsi.block_rows, ""
    feeds_energy = injects_energy(entry.effect.term, float(np.real(coef.value)))
    quality, unresolved, reading = _quality(context, trial, coef, log_bf > threshold)
    sound = quality.passed
    if log_bf > threshold and not sound and not (halves_if_unsound or options.accept_quality_only):
        log_bf_checked = False  # the quality index decides; the halves (two identifications) are not needed
    else:
        log_bf_checked = log_bf > threshold
    overlap = half_overlap(signals) if log_bf_checked else 1.0
    if log_bf_checked and overlap >= MIN_HALF_OVERLAP and free_body:
        halves = half_coefficients_force(signals, trial)
    elif log_bf_checked and overlap >= MIN_HALF_OVERLAP:  # the halves cost two identifications
        halves, too_short, rows = half_coefficients(signals, trial.candidate, context.nsi, half_cache, trial)
        if rows != context.nsi.block_rows:
            note = (
                f"{TOO_SHORT} at {context.nsi.block_rows} block rows ({signals.n_samples // 2} samples each): "
                + (f"identified with {rows}" if not too_short else "not identified")
            )
    elif log_bf_checked:
        note = (
            f"record halves not compared: their forces excite different bands (spectral overlap {overlap:.2f} < "
            f"{MIN_HALF_OVERLAP:g}, e.g. a sweep), so they are two different experiments"
        )
    skipped = log_bf_checked and overlap < MIN_HALF_OVERLAP
    # a free body's halves are read in the force view, where its evidence is scored
    reference = force_view_estimate(signals, trial) if free_body and log_bf_checked else coef.value
    shared, rho2 = "", 0.0
    if log_bf > threshold and accepted:
        terms = trial.candidate.terms
        shared, rho2 = shared_fraction(signals, terms[:-1], terms[-1], accepted, free_body)
    checks = _checks(
        context, entry, baseline, log_bf, coef, quality, log_bf_checked,
        (halves, reference, options.stability_factor, too_short, skipped, note, signals.n_samples // 2, rows),
        shared, rho2, feeds_energy, free_body,
    )
    reason, quality_only = _decision(checks, options.accept_quality_only)
    if reason == "accepted" and unresolved:
        reason = f"accepted; {quality.text}"
    accepted_now = reason.startswith("accepted")
    ci95, intervals = (math.nan, math.nan), None
    if accepted_now:  # emcee only for what is kept: its credible intervals
        full = candidate_evidence(trial, signals, context.evidence, seed, warn=False)[context.evidence.likelihood]
        intervals = about_estimates(full, trial.coefficient_values)
        ci95 = (float(intervals[-1][0]), float(intervals[-1][1]))
    step = LoopStep(
        effect=entry.effect,
        accepted=accepted_now,
        reason=reason,
        coefficient=coef.value,
        ci95=ci95,
        imag_ratio=coef.imag_ratio,
        half_coefficients=halves,
        half_block_rows=rows if log_bf_checked and not skipped and not free_body else None,
        half_note=note,
        log_bayes_factor=float(log_bf),
        nrmse_before=baseline.nrmse,
        nrmse_after=_nrmse_after(entry, trial, signals),
        candidate=trial.candidate,
        error_quantity="force" if free_body else getattr(signals, "measured", "displacement"),
        search=search,
        checks=checks,
        quality_only=quality_only,
        index_unresolved=unresolved and log_bf > threshold,
        misfit_ratio=reading.misfit_ratio,
        memory_resolution=reading.resolution,
    )
    return Verdict(step, float(entry.log_evidence), intervals, quality_only)


def _nrmse_after(entry: EffectScore, trial, signals) -> float:
    """The enlarged model's open-loop NRMSE (the measured quantity; the force's for a free body)."""
    in_displacement = getattr(signals, "measured", "displacement") == "displacement"
    if np.isfinite(entry.nrmse) and (is_free_body(trial) or in_displacement):
        return float(entry.nrmse)
    return measured_nrmse(trial.reconstruct(signals), signals)


def _closed_loop_nrmse(result, signals) -> float:
    """Closed-loop NRMSE on the estimation data (measured quantity), NaN when the simulation diverges."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BayesNSIWarning)
            return measured_nrmse(result.reconstruct(signals, closed_loop=True), signals)
    except (BayesNSIError, np.linalg.LinAlgError, FloatingPointError):
        return float("nan")


def documented(step: LoopStep, before, after, signals) -> LoopStep:
    """``step`` with its closed-loop errors and residual-force view (accepted steps, docs/method.md §7)."""
    short = (step.short_horizon_nrmse_before, step.short_horizon_nrmse_after)
    if after.virtual_stiffness:  # a free body (any number of DOFs) drifts open loop: windows of one second
        horizon = max(4, int(round(signals.fs)))
        short = (_short_horizon(before, signals, horizon), _short_horizon(after, signals, horizon))
    return replace(
        step,
        closed_loop_nrmse_before=_closed_loop_nrmse(before, signals),
        closed_loop_nrmse_after=_closed_loop_nrmse(after, signals),
        residual_force=residual_force(before, after, signals, step.term),
        short_horizon_nrmse_before=short[0],
        short_horizon_nrmse_after=short[1],
    )


def _short_horizon(result, signals, horizon: int) -> float:
    """Short-horizon simulation NRMSE, NaN when it cannot be computed."""
    try:
        return short_horizon_nrmse(result, signals, horizon)
    except (BayesNSIError, np.linalg.LinAlgError):
        return float("nan")
