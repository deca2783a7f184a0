"""The guards an effect must pass to be added (docs/method.md §7, step 4).

An effect proposed against the current model is kept only if

* its log Bayes factor (Laplace) against the current model exceeds ``LoopOptions.threshold``;
  the full evidence (emcee + bridge sampling) then gives its credible interval,
* its coefficient is physically sound: quality index |Im λ|/|Re λ| below ``max_imag_ratio``,
* its coefficient is stable: identified on each half of the record it keeps its sign and stays
  within a factor ``stability_factor`` (docs/method.md §7: "the stability of the coefficient across data
  segments" guards against terms that only absorb model-form error). When a half is too short
  for the block rows (each half needs j >= 2 i k samples), the halves are identified with the
  most block rows a half allows, and the step's ``half_note`` says so ("record too short for the
  halves at 60 block rows: identified with 41"); only when not even that works is the effect
  rejected with the reason "record too short for the halves". The check needs halves that are the
  same experiment: when the forces of the two halves excite different bands (spectral overlap
  below :data:`MIN_HALF_OVERLAP`, :func:`half_overlap`: a sweep), it is skipped and ``half_note``
  says why.
* it does not feed energy in: a pure velocity term that is odd in the velocity and dissipative
  in shape (``n(v)·v >= 0`` with v the velocity at its location, relative for an element:
  ``v|v|``, ``v^3``, ``sign(v)``, ``tanh(v/eps)``) adds the force ``-λ l n`` (the equation of
  motion ``M ẅ + C ẇ + K w + λ l n = F f``, extended input ``[f; -n]``), whose power
  ``-λ n(v)·v`` is positive for every motion when ``λ < 0``. An effect that passes every other
  guard but this one is rejected with the reason "negative dissipation" (:func:`injects_energy`;
  checked last, so the other guards' reasons are unchanged); the loop does not count it among its
  ``n_tries`` (it is not a candidate, so the next effect is checked in its place; the look-ahead
  and exchange moves of :mod:`bayesnsi.diagnose.moves` do count it). This is the physics, not a
  tolerance: a negative quadratic damping fitted to a Coulomb joint on one level diverges on a
  stronger one (the simulated GVT, ``benchmarks/gvt_loop.py``).
* it is separable from the effects the loop added before: the squared partial correlation of its
  column with each of theirs, given the linear part and the other terms, is at most
  ``max_shared`` (:mod:`bayesnsi.diagnose.separable`); otherwise the reason reads "not separable
  from ...".
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..evidence import candidate_evidence
from ..exceptions import BayesNSIError, BayesNSIWarning, BlockRowsError
from ..models import CandidateModel, Term
from ..nsi import identify, is_free_body, short_horizon_nrmse
from .forces import residual_force
from .results import EffectScore, LoopStep
from .scoring import shared_correlations
from .separable import shared_fraction
from .state import Baseline, LoopContext, measured_nrmse

__all__ = [
    "MIN_HALF_OVERLAP", "NEGATIVE_DISSIPATION", "TOO_SHORT", "Verdict", "about_estimates", "check_effect",
    "dissipative_shape", "documented", "half_block_rows", "half_coefficients", "half_overlap", "injects_energy",
    "without",
]

TOO_SHORT = "record too short for the halves"
"""Start of the reason of an effect rejected because the record halves cannot be identified."""
NEGATIVE_DISSIPATION = "negative dissipation"
"""Start of the reason of a dissipative-shaped velocity effect whose coefficient feeds energy in."""
_PROBE = np.random.default_rng(20_261_126).choice([-1.0, 1.0], (4, 64)) * 10.0 ** np.random.default_rng(
    20_261_127).uniform(-6.0, 3.0, (4, 64))


def dissipative_shape(term: Term) -> bool:
    """True for a pure velocity term, odd in the velocity, with ``n(v)·v >= 0`` at its location.

    Checked on a fixed probe of velocities of both signs spanning 1e-6 to 1e3 (v the DOF's
    velocity for a grounded term, ``v_j - v_k`` for an element between j and k).

    Parameters
    ----------
    term : Term

    Returns
    -------
    bool
        True for ``v|v|``, ``v^3``, ``sign(v)``, ``tanh(v/eps)`` (and their element forms); False
        for any term that reads a displacement, reads velocities off its location, or is not odd
        (``sign(v)+``, ``v+``).
    """
    expr = term.expr
    if expr.displacement_dofs or not expr.velocity_dofs or not set(expr.velocity_dofs) <= set(term.at):
        return False
    dofs = sorted(set(term.at))
    if len(dofs) > _PROBE.shape[0]:
        return False
    v = {d - 1: _PROBE[i] for i, d in enumerate(dofs)}
    n = expr.evaluate({}, v)
    n_minus = expr.evaluate({}, {k: -a for k, a in v.items()})
    relative = v[term.at[0] - 1] - (v[term.at[1] - 1] if len(term.at) == 2 else 0.0)
    power = n * relative
    scale = np.abs(n) * np.abs(relative)
    odd = np.allclose(n_minus, -n, rtol=1e-9, atol=0.0)
    return bool(odd and np.all(np.isfinite(power)) and np.all(power >= -1e-12 * scale) and np.any(power > 0))


def injects_energy(term: Term, coefficient: float) -> bool:
    """True when ``term`` with ``coefficient`` λ does positive work on every motion (module notes).

    Parameters
    ----------
    term : Term
    coefficient : float
        Its identified coefficient λ (real part).

    Returns
    -------
    bool
        ``λ < 0`` for a term of :func:`dissipative_shape`; False otherwise.
    """
    return bool(np.isfinite(coefficient) and coefficient < 0 and dissipative_shape(term))


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
    outside its narrow interval from the NSI estimate the loop reports (a trial: 1.92647e8 against
    [1.92726e8, 1.92768e8]); moved by ``estimate - posterior mean``, as the final intervals' posterior-only
    column is (:mod:`bayesnsi.evidence.intervals`). The final model's intervals carry the linear part's
    uncertainty.

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


def without(candidate: CandidateModel, term: Term) -> CandidateModel:
    """``candidate`` without ``term`` (and its prior scale)."""
    keep = [k for k, t in enumerate(candidate.terms) if t != term]
    return CandidateModel(
        name=f"{candidate.name} - {term.name}",
        terms=tuple(candidate.terms[k] for k in keep),
        prior=candidate.prior,
        coefficient_prior_scales=tuple(candidate.coefficient_prior_scales[k] for k in keep),
    )


def half_block_rows(n_half: int, block_rows: int, n_channels: int) -> int:
    """The block rows for a record half: ``block_rows``, or the most that ``n_half`` samples allow.

    Parameters
    ----------
    n_half : int
        Samples in the shorter half.
    block_rows : int
        The block rows of the whole record (``NSIOptions.block_rows``).
    n_channels : int
        k, inputs (force and nonlinear terms) plus outputs of the extended-input system.

    Returns
    -------
    int
        ``min(block_rows, (n_half + 1) // (2 (k + 1)))``: the largest i with
        ``n_half >= 2 i (k + 1) - 1`` (:func:`bayesnsi.nsi.order.check_block_rows`).
    """
    return int(min(block_rows, (n_half + 1) // (2 * (n_channels + 1))))


def half_coefficients(signals, candidate, nsi, cache=None, start=None) -> tuple[tuple[float, float], bool, int]:
    """The last coefficient of ``candidate`` identified on each half of the record.

    Parameters
    ----------
    signals : Signals
    candidate : CandidateModel
    nsi : NSIOptions
    cache : dict, optional
        Kept across calls; the Hankel products of each half for the candidate without its last
        term are stored in it, so that the effects checked against one model share them.
    start : NSIResult, optional
        The candidate identified on the whole record: on the frequency route each half is refined
        from it (:func:`bayesnsi.nsi.identify`'s ``start``), a local re-identification.

    Returns
    -------
    ((float, float), bool, int)
        The two estimates (NaN where the identification failed), whether a half was too short
        even for the reduced block rows, and the block rows the halves were identified with
        (``nsi.block_rows``, or fewer when a half is too short for them: :func:`half_block_rows`).
    """
    n = signals.n_samples // 2
    realisations = getattr(signals, "realisations", 1)
    if realisations > 1:  # halves of whole realisations (a cut inside one would not be periodic)
        n = realisations // 2 * (signals.n_samples // realisations)
    parts = (signals.segment(0, n), signals.segment(n, signals.n_samples))
    n_channels = signals.force.shape[1] + len(candidate.terms) + signals.displacement.shape[1]
    rows = half_block_rows(n, nsi.block_rows, n_channels)
    if rows < 2:
        return (math.nan, math.nan), True, rows
    if rows != nsi.block_rows:
        nsi = replace(nsi, block_rows=rows)
    shared = (None, None)
    if cache is not None and candidate.terms:
        base = without(candidate, candidate.terms[-1])
        key = (rows, *(t.name for t in base.terms))
        if key not in cache:
            cache[key] = tuple(shared_correlations(part, base, nsi) for part in parts)
        shared = cache[key]
    values, too_short = [], False
    for part, correlations in zip(parts, shared):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", BayesNSIWarning)
                found = identify(part, candidate, nsi, correlations=correlations, start=start)
                values.append(found.coefficient_values[-1])
        except BlockRowsError:
            values.append(np.nan)
            too_short = True
        except (BayesNSIError, np.linalg.LinAlgError):
            values.append(np.nan)
    return (float(values[0]), float(values[1])), too_short, rows


MIN_HALF_OVERLAP = 0.5
"""Least spectral overlap of the two halves' forces for the half-record check to compare like with like."""


def half_overlap(signals) -> float:
    """Overlap of the force spectra of the record's two halves: 1 for a stationary test, near 0 for a sweep.

    ``Σ_f min(p₁(f), p₂(f))`` of the halves' force power spectra (Welch, summed over the forces), each
    normalised to unit sum. A sweep drives its first half in one band and its second in another: their
    coefficients then come from two different experiments (a trial's swept beam: the cubic spring at the
    tip 5.4e7 on the first half, -1.2e10 on the second, whose band holds no resonance of that DOF).

    Parameters
    ----------
    signals : Signals

    Returns
    -------
    float
        In [0, 1]; 1 for a record too short to tell.
    """
    f = np.asarray(signals.force, dtype=float).reshape(signals.n_samples, -1)
    n = len(f) // 2
    segment = int(2 ** np.floor(np.log2(max(n // 8, 16))))
    if n < 64:
        return 1.0
    window = np.hanning(segment)
    spectra = []
    for half in (f[:n], f[n : 2 * n]):
        power = np.zeros(segment // 2 + 1)
        for start in range(0, n - segment + 1, segment // 2):
            piece = half[start : start + segment]
            power += (np.abs(np.fft.rfft(window[:, None] * (piece - piece.mean(axis=0)), axis=0)) ** 2).sum(axis=1)
        spectra.append(power / max(float(power.sum()), np.finfo(float).tiny))
    return float(np.minimum(*spectra).sum())


def _stable(halves, value: float, factor: float) -> bool:
    """Both halves finite, of the sign of ``value``, within ``factor`` of each other."""
    if not all(np.isfinite(halves)) or not np.sign(halves[0]) == np.sign(halves[1]) == np.sign(value):
        return False
    return max(abs(h) for h in halves) < factor * min(abs(h) for h in halves)


def check_effect(
    context: LoopContext, entry: EffectScore, baseline: Baseline, seed, half_cache=None, accepted=(),
    search: int | None = None,
) -> Verdict:
    """Log Bayes factor (Laplace) and the guards of one proposed effect (module notes).

    The decision uses the Laplace log-evidence ``entry`` was ranked by; the full emcee evidence
    runs only for an effect that passes, to give its credible interval (one kept only with a second
    effect, ``lookahead``, gets its interval from the pair's evidence). The record-half estimates
    (two identifications) are computed only for an effect whose Bayes factor clears the threshold.

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

    Returns
    -------
    Verdict
    """
    options, signals, trial = context.options, context.signals, entry.result
    threshold, max_imag_ratio = options.threshold, options.max_imag_ratio
    log_bf = entry.log_evidence - baseline.log_evidence
    coef = trial.coefficients[-1]
    halves: tuple[float, float] = (math.nan, math.nan)
    too_short, rows, note = False, context.nsi.block_rows, ""
    feeds_energy = injects_energy(entry.effect.term, float(np.real(coef.value)))
    overlap = half_overlap(signals) if log_bf > threshold else 1.0
    if log_bf > threshold and overlap >= MIN_HALF_OVERLAP:  # the halves cost two identifications
        halves, too_short, rows = half_coefficients(signals, trial.candidate, context.nsi, half_cache, trial)
        if rows != context.nsi.block_rows:
            note = (
                f"{TOO_SHORT} at {context.nsi.block_rows} block rows ({signals.n_samples // 2} samples each): "
                + (f"identified with {rows}" if not too_short else "not identified")
            )
    elif log_bf > threshold:
        note = (
            f"record halves not compared: their forces excite different bands (spectral overlap {overlap:.2f} < "
            f"{MIN_HALF_OVERLAP:g}, e.g. a sweep), so they are two different experiments"
        )
    skipped = log_bf > threshold and overlap < MIN_HALF_OVERLAP
    stable = skipped or _stable(halves, coef.value, options.stability_factor)
    shared, rho2 = "", 0.0
    if log_bf > threshold and accepted:
        terms = trial.candidate.terms
        shared, rho2 = shared_fraction(signals, terms[:-1], terms[-1], accepted, is_free_body(trial))
    if log_bf <= threshold:
        reason = f"log Bayes factor {log_bf:.2f} <= threshold {threshold:.2f}"
    elif coef.imag_ratio >= max_imag_ratio:
        reason = f"quality index |Im|/|Re| = {coef.imag_ratio:.2f} >= {max_imag_ratio}"
    elif too_short:
        reason = f"{TOO_SHORT} ({signals.n_samples // 2} samples each for {rows} block rows)"
    elif not stable:
        reason = f"coefficient unstable across record halves: {halves[0]:.4g} vs {halves[1]:.4g}"
    elif rho2 > options.max_shared:
        reason = (
            f"not separable from {shared}: {shared} already explains {100 * rho2:.0f} % of its column beyond the "
            f"linear part (squared partial correlation {rho2:.2f} > max_shared {options.max_shared:g}; "
            f"it would inflate the variance of {shared}'s coefficient {1 / (1 - min(rho2, 0.999999)):.1f}x)"
        )
    elif is_free_body(trial) and np.isfinite(entry.nrmse) and entry.nrmse > baseline.nrmse:
        # the field's error for a free body: the identified model's own force prediction must improve
        reason = f"force-prediction NRMSE rises from {baseline.nrmse:.4g} to {entry.nrmse:.4g} (free body, IDIM view)"
    elif feeds_energy:  # last: it rejects only what every other guard would accept
        reason = (
            f"{NEGATIVE_DISSIPATION}: coefficient {coef.value:.4g} < 0 of a dissipative velocity term feeds energy "
            "into every motion"
        )
    else:
        reason = "accepted"
    quality_only = log_bf > threshold and stable and coef.imag_ratio >= max_imag_ratio and not feeds_energy
    ci95, intervals = (math.nan, math.nan), None
    if reason == "accepted":  # emcee only for what is kept: its credible intervals
        full = candidate_evidence(trial, signals, context.evidence, seed, warn=False)[context.evidence.likelihood]
        intervals = about_estimates(full, trial.coefficient_values)
        ci95 = (float(intervals[-1][0]), float(intervals[-1][1]))
    step = LoopStep(
        effect=entry.effect,
        accepted=reason == "accepted",
        reason=reason,
        coefficient=coef.value,
        ci95=ci95,
        imag_ratio=coef.imag_ratio,
        half_coefficients=halves,
        half_block_rows=rows if log_bf > threshold and not skipped else None,
        half_note=note,
        log_bayes_factor=float(log_bf),
        nrmse_before=baseline.nrmse,
        nrmse_after=_nrmse_after(entry, trial, signals),
        candidate=trial.candidate,
        error_quantity="force" if is_free_body(trial) else getattr(signals, "measured", "displacement"),
        search=search,
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
