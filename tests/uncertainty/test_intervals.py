"""Intervals that include the uncertainty of the identified linear part (docs/intervals.md).

Reference: the seed-to-seed scatter of the estimates on the two-DOF case (SPEC 8.1, paper
settings), i.e. an independent Monte-Carlo of the whole identification; the true α = 20 and the
exact modes of the simulator's M, C, K. The full study (>= 100 seeds per case) is
benchmarks/calibration_intervals.py.
"""

import json
import warnings

import numpy as np
import pytest

from bayesnsi.evidence import candidate_evidence
from bayesnsi.exceptions import IntervalWarning, SpuriousPoleWarning
from bayesnsi.io._outcome import outcome_from_plain, outcome_to_plain
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions
from bayesnsi.run import run_candidates
from bayesnsi.simulate import simulate_case, simulate_cases
from bayesnsi.uncertainty import candidate_intervals, segment_estimates
from bayesnsi.uncertainty.windows import scatter_sd

FAST = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=())
SEG = FAST.replace(interval="segments")


@pytest.fixture(scope="module")
def two_dof_seeds():
    """12 seeds of the two-DOF case: full-record α and modes, and the segment sd of each."""
    cases = simulate_cases("two-dof", range(12))
    rows = []
    for case in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SpuriousPoleWarning)
            result = identify(case.signals, case.candidates[0], case.recommended)
        samples, coefs, freqs, _, failures = segment_estimates(result, case.signals, case.recommended)
        assert not failures
        f_full = np.array([m.frequency_hz for m in result.modes])
        rows.append((
            result.coefficient_values[0],
            scatter_sd(coefs, result.coefficient_values, samples, case.signals.n_samples)[0],
            f_full,
            scatter_sd(freqs, f_full, samples, case.signals.n_samples),
        ))
    return cases, rows


def test_segment_sd_matches_the_seed_to_seed_scatter(two_dof_seeds):
    """Mean segment sd of α within [0.6, 2] x the seed scatter (60 seeds measured: 1.22 x)."""
    _, rows = two_dof_seeds
    alpha = np.array([r[0] for r in rows])
    sd = np.array([r[1] for r in rows])
    ratio = sd.mean() / alpha.std(ddof=1)
    assert 0.6 < ratio < 2.0, ratio
    assert np.sum(np.abs(alpha - 20.0) < 1.96 * sd) >= 9  # 95 % intervals: at least 9 of 12 cover α = 20


def test_modal_intervals_cover_the_exact_modes(two_dof_seeds):
    """Frequencies: segment sd near the seed scatter, and the exact modes covered on most seeds."""
    cases, rows = two_dof_seeds
    f = np.array([r[2] for r in rows])
    sd = np.array([r[3] for r in rows])
    ratio = sd.mean(axis=0) / f.std(axis=0, ddof=1)
    assert np.all((ratio > 0.6) & (ratio < 2.5)), ratio
    exact = cases[0].exact_frequencies_hz
    assert np.sum(np.abs(f - exact) < 1.96 * sd) >= 0.75 * f.size


@pytest.fixture(scope="module")
def two_dof_evidence():
    case = simulate_case("two-dof", seed=3)
    result = identify(case.signals, case.candidates[0], case.recommended)
    evidence = candidate_evidence(result, case.signals, FAST, np.random.SeedSequence(1), warn=False)["white"]
    return case, result, evidence


def test_segments_widen_the_posterior(two_dof_evidence):
    case, result, evidence = two_dof_evidence
    intervals = candidate_intervals(result, case.signals, evidence, SEG, case.recommended)
    assert intervals.method == "segments" and intervals.n_segments == 8
    (alpha,) = intervals.coefficients
    posterior = evidence.ci95[0]
    assert alpha.ci95[0] < posterior[0] and alpha.ci95[1] > posterior[1]
    assert alpha.sd > 5 * alpha.posterior_sd  # the linear part dominates (~10x on this case)
    assert alpha.ci50[0] > alpha.ci95[0] and alpha.ci50[1] < alpha.ci95[1]
    assert len(intervals.frequencies) == len(result.modes) == len(intervals.damping_ratios)
    assert all(z.ci95[0] < z.estimate < z.ci95[1] for z in intervals.damping_ratios)
    posterior_only = candidate_intervals(result, case.signals, evidence, FAST.replace(interval="posterior"))
    assert posterior_only.method == "posterior" and not posterior_only.frequencies
    assert posterior_only.coefficients[0].sd == pytest.approx(alpha.posterior_sd)


def test_windows_are_lengthened_to_what_the_block_rows_need(two_dof_evidence):
    """30 % of 1000 samples is below the 599 that 60 block rows need: the windows grow to 600."""
    case, result, evidence = two_dof_evidence
    intervals = candidate_intervals(result, case.signals, evidence, SEG.replace(segment_fraction=0.3),
                                    case.recommended)
    assert intervals.method == "segments" and intervals.segment_samples == 600 and intervals.n_segments == 8


def test_too_short_record_warns_and_falls_back():
    """Even 90 % of the record is below what the block rows need: an IntervalWarning, posterior intervals."""
    case = simulate_case("two-dof", seed=3)
    short = case.signals.segment(0, 640)  # 60 block rows need 599 samples; 90 % is 576
    result = identify(short, case.candidates[0], case.recommended)
    evidence = candidate_evidence(result, short, FAST, np.random.SeedSequence(1), warn=False)["white"]
    with pytest.warns(IntervalWarning, match="too narrow"):
        intervals = candidate_intervals(result, short, evidence, SEG, case.recommended)
    assert intervals.method == "posterior"
    assert len([f for f in intervals.findings if f.kind == "interval.fallback"]) == 1


def test_results_record_and_cache_carry_the_intervals():
    from bayesnsi.io.schema import _intervals

    case = simulate_case("two-dof", seed=0)
    (outcome,) = run_candidates(case.signals, case.candidates[:1], case.recommended, FAST)
    assert outcome.intervals is not None and outcome.intervals.method == "noise"  # the default
    record = json.loads(json.dumps(_intervals(outcome, outcome.evidences["white"]), allow_nan=True))
    coefficient = record["coefficients"][0]
    assert coefficient["ci95"] == list(outcome.intervals.coefficients[0].ci95)
    assert coefficient["ci95_given_linear_part"] == pytest.approx(list(outcome.evidences["white"].ci95[0]))
    assert "ci50" in coefficient and len(record["modes"]) == 2 and "damping_ci95" in record["modes"][0]
    again = outcome_from_plain(*outcome_to_plain(outcome))
    assert again.intervals == outcome.intervals
