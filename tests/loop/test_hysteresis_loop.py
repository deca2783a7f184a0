"""A Bouc-Wen element in identification, closed-loop simulation, harmonic balance, replicates and the loop.

The records are simulated by :func:`bayesnsi.simulate.simulate_hysteretic_response` (RK4 of the
augmented state, independent of the identification's exact rule; docs/method.md §12).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi.loop import close_the_loop, scoring
from bayesnsi.loop.quality import MisfitReading
from bayesnsi.loop.results import EffectScore
from bayesnsi.loop.scoring import refine_shape, score_effects
from bayesnsi.loop.shapes import (
    SHAPE_LOCATIONS,
    SHAPE_MIN_GAIN,
    SHAPE_RESOLUTION,
    SHAPE_STEPS,
    screened_shapes,
    search_shape,
)
from bayesnsi.models import BoucWen, CandidateModel, Term, hysteresis_effect
from bayesnsi.models.dictionary import HYSTERESIS, clearance_effect
from bayesnsi.nsi import identify
from bayesnsi.nsi.closed_loop import closed_loop_response, divergence_bound
from bayesnsi.nsi.reconstruct import initial_state, nrmse
from bayesnsi.options import EvidenceOptions, LoopOptions, NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import simulate_hysteretic_response, undeclared_case
from bayesnsi.simulate.multisine import multisine
from bayesnsi.uncertainty.replicates import noise_replicates


@pytest.fixture(scope="module")
def case():
    return undeclared_case("hysteresis", seed=0, noise_percent=2.0, duration=20.0)


@pytest.fixture(scope="module")
def other():
    return undeclared_case("hysteresis", seed=1000, noise_percent=2.0, duration=20.0)


def test_the_true_element_is_identified_and_simulates_the_record(case):
    result = identify(case.signals, case.truth, case.nsi)
    coefficient = result.coefficients[0]
    assert coefficient.value == pytest.approx(300.0, rel=0.05) and coefficient.imag_ratio < 0.1
    bound = divergence_bound(case.clean.displacement)
    for hold in ("sample", "average"):  # point values, and the trapezoid interval means the model assumed
        clean = identify(case.clean, case.truth, case.nsi.replace(input_hold=hold))  # z: the model's state
        u = clean.extended_input(case.clean)
        x0 = initial_state(clean.model, u[:50], np.asarray(case.clean.displacement)[:50])
        simulated, _ = closed_loop_response(clean, case.clean.force, x0, bound, 2, case.clean.fs,
                                            interval_mean=hold == "average")
        assert nrmse(np.asarray(case.clean.displacement), simulated)[1] < 0.01


def test_a_refined_shape_beats_its_grid_point_and_approaches_the_truth(case):
    evidence = EvidenceOptions(residual=LoopOptions().residual, compare=())
    start = hysteresis_effect(1, BoucWen.from_branches(50.0, 300.0))  # the truth's loading ÷ 2, unloading × 1.5
    grid = score_effects(case.signals, case.declared, [start], case.nsi, evidence)[0]
    best = refine_shape(case.signals, case.declared, grid, case.nsi, evidence)
    assert best.log_evidence > grid.log_evidence + 100
    shape = best.effect.shape
    assert abs(np.log(shape.loading / 100.0)) < abs(np.log(50.0 / 100.0))
    assert abs(np.log(shape.unloading / 200.0)) < abs(np.log(300.0 / 200.0))
    assert best.result.coefficients[-1].value == pytest.approx(300.0, rel=0.1)


def test_the_screen_keeps_boucwen_grid_points_at_the_kept_locations_then_in_screen_order():
    soft, hard = BoucWen.from_branches(1.0, 2.0), BoucWen.from_branches(2.0, 4.0)
    pairs = [(1, 2), (3, 4), (5, 6), (7, 8), (9, 10), (11, 12), (2, 3), (4, 5)]
    ordered = [hysteresis_effect((1, 2), soft), clearance_effect((7, 8), 0.1), hysteresis_effect((7, 8), hard),
               hysteresis_effect((1, 2), hard), clearance_effect((1, 2), 0.1)]
    ordered += [hysteresis_effect(pair, soft) for pair in pairs[1:]]
    kept = screened_shapes(ordered, count=1, locations=3)  # one place: the clearance at 7-8
    assert kept == [ordered[1], ordered[0], ordered[2], ordered[5]]  # at 7-8 (kept), 1-2 and 3-4 (screen order)
    every = screened_shapes(ordered, count=2)
    assert [e.location for e in every if e.shape is not None] == [(1, 2), (7, 8), (3, 4), (5, 6), (9, 10), (11, 12)]
    assert len({e.location for e in every if e.shape is not None}) == SHAPE_LOCATIONS


@pytest.mark.parametrize(
    ("index", "reading", "searched"),
    [
        (0.9, None, True),  # below 4 x max_imag_ratio: searched whatever the misfit (the truth's grid points <= 0.92)
        (2.0, MisfitReading(misfit_ratio=7.0, resolution=2.5), False),  # fails, resolved against the misfit
        (2.0, MisfitReading(misfit_ratio=7.0, resolution=0.9), True),  # the misfit leaves the index unresolved
        (2.0, MisfitReading(misfit_ratio=1.5, resolution=0.5), False),  # a nearly adequate model: the index decides
    ],
)
def test_a_grid_point_whose_index_fails_by_a_wide_margin_is_not_searched(monkeypatch, index, reading, searched):
    read = []
    monkeypatch.setattr(scoring, "misfit_reading", lambda *args, **kwargs: read.append(1) or reading)
    context = SimpleNamespace(options=LoopOptions(), evidence=EvidenceOptions(), signals=None)
    entry = SimpleNamespace(identified=SimpleNamespace(coefficients=[SimpleNamespace(imag_ratio=index)]))
    assert scoring._worth_searching(context, entry) is searched
    assert len(read) == (reading is not None)  # the misfit is read only above the margin


@pytest.mark.parametrize("confirmed_gain", [5.0, -5.0])
def test_a_shape_search_starts_each_shape_from_the_best_so_far_and_identifies_the_one_found_in_full(confirmed_gain):
    # a concave log-evidence in the search's coordinates, peaked at (asinh((β+γ)σ), log((β-γ)σ)) = (1.1, 0.8)
    sigma = 1.0

    def evidence(shape):
        a, b = np.arcsinh(shape.loading * sigma), np.log(shape.unloading * sigma)
        return -100.0 * ((a - 1.1) ** 2 + (b - 0.8) ** 2)

    entry_effect = hysteresis_effect(1, BoucWen.from_branches(0.2, 1.0))
    entry = EffectScore(entry_effect, evidence(entry_effect.shape))
    nears, confirmed = [], []

    def score(effect, near):
        nears.append(near.log_evidence)
        return EffectScore(effect, evidence(effect.shape))

    def confirm(effect):
        confirmed.append(effect)
        return EffectScore(effect, evidence(effect.shape) + confirmed_gain)

    found = search_shape(entry, score, sigma, budget=30, confirm=confirm)
    # every trial starts from the best entry found before it: the near scores never fall along the search
    assert nears[0] == entry.log_evidence and all(b >= a for a, b in zip(nears, nears[1:]))
    assert len(nears) <= 30 and len(confirmed) == 1  # only the shape the search ends on is identified in full
    ended = confirmed[0].shape
    assert abs(np.arcsinh(ended.loading) - 1.1) < 0.1 and abs(np.log(ended.unloading) - 0.8) < 0.1
    # the full identification is kept when it beats the grid point (here it always does, by far)
    assert found.effect == confirmed[0] and found.log_evidence == evidence(ended) + confirmed_gain
    worse = search_shape(entry, score, sigma, budget=30, confirm=lambda effect: EffectScore(effect, -1e9))
    assert worse is entry  # a confirmation below the grid point's score keeps the grid point


def _valley(sigma: float):
    """A concave log-evidence in the search's coordinates with a tilted valley, peaked at (1.1, 0.8)."""
    def evidence(shape):
        a, b = np.arcsinh(shape.loading * sigma) - 1.1, np.log(shape.unloading * sigma) - 0.8
        return -100.0 * (a**2 + 3.0 * b**2 + 2.0 * a * b)
    return evidence


def _coordinates(shape, sigma):
    return np.arcsinh(shape.loading * sigma), np.log(shape.unloading * sigma)


@pytest.mark.parametrize("rounded_revisits", [True, False])
def test_a_shape_search_passes_over_a_shape_reached_back_up_to_the_rounding_when_asked(rounded_revisits):
    # the shapes are written with 3 significant digits: moving back and forth along the valley reaches shapes
    # tried before under another name; with rounded_revisits False no two scored shapes lie that close
    sigma, evidence = 1.0, _valley(1.0)
    entry_effect = hysteresis_effect(1, BoucWen.from_branches(0.2, 1.0))
    entry = EffectScore(entry_effect, evidence(entry_effect.shape))
    scored = [entry_effect]

    def score(effect, near):
        scored.append(effect)
        return EffectScore(effect, evidence(effect.shape))

    search_shape(entry, score, sigma, budget=30, rounded_revisits=rounded_revisits)
    assert len({e.term.name for e in scored}) == len(scored)  # never the same name twice, either way
    finest = np.array([SHAPE_RESOLUTION * step for step in SHAPE_STEPS])
    points = np.array([_coordinates(e.shape, sigma) for e in scored])
    close = [(i, j) for i in range(len(points)) for j in range(i)
             if np.all(np.abs(points[i] - points[j]) < finest / 4)]
    assert (len(close) > 0) == rounded_revisits


@pytest.mark.parametrize("min_gain", [0.0, 5.0, 1e9])
def test_a_shape_search_moves_only_for_the_least_gain_it_is_given(min_gain):
    sigma, evidence = 1.0, _valley(1.0)
    entry_effect = hysteresis_effect(1, BoucWen.from_branches(0.2, 1.0))
    entry = EffectScore(entry_effect, evidence(entry_effect.shape))
    starts = []

    def score(effect, near):
        starts.append(near.log_evidence)
        return EffectScore(effect, evidence(effect.shape))

    found = search_shape(entry, score, sigma, budget=30, min_gain=min_gain)
    moves = np.diff(list(dict.fromkeys(starts)) + [found.log_evidence])  # the best so far, each time it changed
    moves = moves[moves != 0]
    assert np.all(moves > min_gain)
    if min_gain > 1e6:
        assert found is entry  # no neighbour gains that much: the grid point stands
    else:
        assert found.log_evidence > entry.log_evidence + 50  # the valley's floor is found either way


@pytest.mark.parametrize("domain", ["time", "frequency"])
def test_only_a_frequency_route_search_asks_a_least_gain_and_passes_over_rounded_revisits(monkeypatch, domain):
    # there a trial is refined from its neighbour's model, whose score carries that start; on the time route
    # every trial is a full identification and the search is as it was
    asked = {}

    def fake_search(entry, near, sigma, budget, confirm=None, **kwargs):
        asked.update(kwargs)
        return entry

    monkeypatch.setattr(scoring, "search_shape", fake_search)
    monkeypatch.setattr(scoring, "displacement_spread", lambda signals, effect: 1.0)
    entry = EffectScore(hysteresis_effect(1, BoucWen.from_branches(0.2, 1.0)), 1000.0)
    nsi = NSIOptions(domain=domain, order=2, block_rows=20)
    linear = CandidateModel(name="linear", terms=())
    refine_shape(None, linear, entry, nsi, correlations=object(), base_log_evidence=600.0)
    frequency = domain == "frequency"
    assert asked["min_gain"] == (pytest.approx(SHAPE_MIN_GAIN * 400.0) if frequency else 0.0)
    assert asked["rounded_revisits"] is not frequency
    refine_shape(None, linear, entry, nsi, correlations=object())  # no base: no least gain
    assert asked["min_gain"] == 0.0


def test_noise_replicates_reidentify_a_boucwen_candidate(case):
    result = identify(case.signals, case.truth, case.nsi)
    _, coefficients, _, _, failures = noise_replicates(result, case.signals, case.nsi, n_replicates=6, seed=1)
    assert not failures and coefficients.shape == (6, 1)
    spread = coefficients[:, 0].std(ddof=1)
    assert 0 < spread < 0.05 * result.coefficients[0].value  # sensor noise moves λ by a few per cent at most


def test_the_loop_adds_the_hysteresis_first_and_halves_the_validation_error(case, other):
    loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1, effects=(HYSTERESIS, "x^3", "v|v|")),
                          nsi=case.nsi, evidence=EvidenceOptions(seed=0))
    assert [s.effect.base for s in loop.added] == [HYSTERESIS] and loop.added[0].effect.location == (1,)
    assert loop.final.coefficients[-1].value == pytest.approx(300.0, rel=0.1)
    before = loop.start.reconstruct(other.signals, closed_loop=True).nrmse
    after = loop.final.reconstruct(other.signals, closed_loop=True).nrmse
    assert after <= before / 2


@pytest.mark.slow
@pytest.mark.parametrize("name", ["hysteresis", "control-hysteresis", "control-two-dof"])
def test_the_full_loop_on_the_hysteresis_case_and_its_controls(name):
    case = undeclared_case(name, seed=0, noise_percent=2.0)
    loop = close_the_loop(case.signals, case.declared, LoopOptions(), nsi=case.nsi, evidence=EvidenceOptions(seed=0))
    if case.is_negative_control:
        assert loop.added == ()
        return
    assert loop.added[0].effect.base == HYSTERESIS and loop.added[0].effect.location == (1,)
    other = undeclared_case(name, seed=1000, noise_percent=2.0)
    before = loop.start.reconstruct(other.signals, closed_loop=True).nrmse
    assert loop.final.reconstruct(other.signals, closed_loop=True).nrmse <= before / 2


def test_the_frequency_route_and_harmonic_balance_hold_a_boucwen_term():
    # the Bouc-Wen benchmark's system (2 kg, 10 N s/m, 5e4 N/m, α = 5e4 N/m, β γ = 800, β δ = -1100 1/m)
    term = Term("boucwen(x1, beta=800, gamma=-1100)", 1)
    period, fs, oversample = 1024, 750.0, 8

    def record(seed, n_periods):
        force = multisine(period, fs, (5.0, 150.0), rms=50.0, rng=seed, n_periods=n_periods, oversample=oversample)
        response = simulate_hysteretic_response([[2.0]], [[10.0]], [[5e4]], [1], force.fine, fs * oversample,
                                                oversample, [term], [5e4])
        keep = slice(period, None)  # the first period is the transient
        rng = np.random.default_rng(seed + 7)
        noisy = response.displacement[keep] + 1e-6 * rng.standard_normal(response.displacement[keep].shape)
        return Signals(force=force.samples[keep], displacement=noisy, fs=fs, input_dofs=(1,), output_dofs=(1,),
                       period=period)

    estimation, validation = record(0, 5), record(1, 3)
    nsi = NSIOptions(domain="frequency", order=2, block_rows=20)
    model = identify(estimation, CandidateModel.from_terms("Bouc-Wen", [(term.expr.text, 1)]), nsi)
    assert model.coefficients[0].value == pytest.approx(5e4, rel=0.05) and model.coefficients[0].imag_ratio < 0.1
    linear = identify(estimation, CandidateModel(name="linear", terms=()), nsi)
    hysteretic_error = model.reconstruct(validation, closed_loop=True).nrmse  # harmonic balance, periodic z
    assert hysteretic_error < 0.1  # measured 0.072 (linear 0.244, cubic 0.172)
    assert hysteretic_error < linear.reconstruct(validation, closed_loop=True).nrmse / 3


def test_a_frequency_route_shape_search_beats_its_grid_point_and_approaches_the_truth(monkeypatch):
    # the Bouc-Wen benchmark's system again; trials identified from the best shape's model so far
    truth = BoucWen(beta=800.0, gamma=-1100.0)
    term = Term("boucwen(x1, beta=800, gamma=-1100)", 1)
    period, fs, oversample = 1024, 750.0, 8
    force = multisine(period, fs, (5.0, 150.0), rms=50.0, rng=0, n_periods=5, oversample=oversample)
    response = simulate_hysteretic_response([[2.0]], [[10.0]], [[5e4]], [1], force.fine, fs * oversample,
                                            oversample, [term], [5e4])
    noisy = response.displacement[period:] + 1e-6 * np.random.default_rng(7).standard_normal((4 * period, 1))
    signals = Signals(force=force.samples[period:], displacement=noisy, fs=fs, input_dofs=(1,), output_dofs=(1,),
                      period=period)
    nsi = NSIOptions(domain="frequency", order=2, block_rows=20)
    evidence = EvidenceOptions(residual=LoopOptions().residual, compare=())
    linear = CandidateModel(name="linear", terms=())
    start = hysteresis_effect(1, BoucWen.from_branches(truth.loading, 1.5 * truth.unloading))
    grid = score_effects(signals, linear, [start], nsi, evidence)[0]
    starts = []

    def spy(*args, start=None, **kwargs):
        starts.append(start)
        return identify(*args, start=start, **kwargs)

    monkeypatch.setattr(scoring, "identify", spy)
    best = refine_shape(signals, linear, grid, nsi, evidence)
    assert best.log_evidence > grid.log_evidence + 10
    assert starts[-1] is None and all(s is not None for s in starts[:-1]) and len(starts) > 4
    assert abs(np.log(best.effect.shape.unloading / truth.unloading)) < np.log(1.5) / 2
    full = identify(signals, linear.with_term(best.effect.term), nsi)  # the entry kept is the full identification
    assert best.result.coefficients[0].value == pytest.approx(full.coefficients[0].value, rel=1e-9)
    assert best.result.coefficients[0].value == pytest.approx(5e4, rel=0.05)
