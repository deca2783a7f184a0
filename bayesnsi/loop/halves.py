"""The record-halves check of the loop: is an effect's coefficient the same on both halves of the record?

docs/method.md §7 ("the stability of the coefficient across data segments" guards against terms that
only absorb model-form error). The enlarged model is identified on each half of the record and the
effect's two estimates must share the sign of the whole record's and lie within
``LoopOptions.stability_factor`` of each other. When a half is too short for the block rows (each
half needs j >= 2 i k samples), the halves are identified with the most block rows a half allows
(:func:`half_block_rows`); when the forces of the two halves excite different bands (a sweep,
:func:`half_overlap`), the check is skipped. A free body's halves are read in the force view its
evidence scores (:func:`half_coefficients_force`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np

from ..exceptions import BayesNSIError, BayesNSIWarning, BlockRowsError
from ..models import CandidateModel, Term
from ..nsi import force_affine, identify
from .scoring import shared_correlations

__all__ = [
    "MIN_HALF_OVERLAP", "TOO_SHORT", "force_view_estimate", "half_block_rows", "half_check", "half_coefficients",
    "half_coefficients_force", "half_overlap", "stable", "without",
]

TOO_SHORT = "record too short for the halves"
"""Start of the reason of an effect rejected because the record halves cannot be identified."""

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
    coefficients then come from two different experiments (a beam swept 10-400 Hz, measured by
    accelerometers: the cubic spring at the tip 5.4e7 on the first half, -1.2e10 on the second, whose
    band holds no resonance of that DOF).

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


def stable(halves, value: float, factor: float) -> bool:
    """Both halves finite, of the sign of ``value``, within ``factor`` of each other."""
    if not all(np.isfinite(halves)) or not np.sign(halves[0]) == np.sign(halves[1]) == np.sign(value):
        return False
    return max(abs(h) for h in halves) < factor * min(abs(h) for h in halves)


def half_check(halves, value: float, factor: float, too_short: bool, skipped: bool, note: str, samples: int,
                  rows: int):
    """The record-halves check: ratio of the two estimates (inf when they differ in sign or one failed)."""
    if skipped:
        return "record halves", 1.0, factor, True, f"record halves not compared ({note})"
    if too_short:
        return "record halves", math.inf, factor, False, f"{TOO_SHORT} ({samples} samples each for {rows} block rows)"
    same_sign = all(np.isfinite(halves)) and np.sign(halves[0]) == np.sign(halves[1]) == np.sign(value)
    ratio = max(abs(h) for h in halves) / min(abs(h) for h in halves) if same_sign and min(np.abs(halves)) > 0 \
        else math.inf
    passed = stable(halves, value, factor)
    text = (f"record halves {halves[0]:.4g} vs {halves[1]:.4g}: ratio {ratio:.3g} < {factor:g}, same sign" if passed
            else f"coefficient unstable across record halves: {halves[0]:.4g} vs {halves[1]:.4g} "
                 f"(ratio {ratio:.3g}, limit {factor:g}, same sign required)")
    return "record halves", float(ratio), factor, passed, text


def force_view_estimate(signals, result) -> float:
    """The last coefficient of a one-DOF model by least squares in the force view, linear part profiled."""
    try:
        affine = force_affine(result, signals, profile=True)
    except (BayesNSIError, np.linalg.LinAlgError):
        return math.nan
    columns, measured = affine.signatures[:, 0, :], affine.measured[:, 0]
    if not (np.all(np.isfinite(columns)) and np.all(np.isfinite(measured))):
        return math.nan
    return float(np.linalg.lstsq(columns, measured, rcond=None)[0][-1])


def half_coefficients_force(signals, result) -> tuple[float, float]:
    """A free body's last coefficient on each half of the record, in the view its evidence scores.

    The evidence of a free body scores the force it predicts from the measured motion with the inverse
    model's linear part ``[a, v, x, 1]`` profiled out (:func:`bayesnsi.nsi.force_affine`,
    ``profile=True``); the coefficients it infers are the least-squares ones of that view (IDIM-LS).
    Their record-half estimates are compared here, as NSI's are for a grounded structure: on the EMPS
    axis NSI reads the coefficient of ``|v|`` in the band of the virtual spring (0.2-0.4 Hz) where
    λ(ω) is not consistent (|Im|/|Re| 1.07; docs/measurements.md, "One acceptance rule").

    Parameters
    ----------
    signals : Signals
        The estimation data.
    result : NSIResult
        The enlarged one-DOF model (its terms and physical parameters).

    Returns
    -------
    (float, float)
        The estimates on the first and second half (NaN where one cannot be computed).
    """
    n = signals.n_samples // 2
    return tuple(  # type: ignore[return-value]
        force_view_estimate(part, result) for part in (signals.segment(0, n), signals.segment(n, signals.n_samples))
    )
