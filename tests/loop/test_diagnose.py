"""Closing the loop (SPEC 7) on simulated data with undeclared effects, and negative controls.

Data: :mod:`bayesnsi.simulate.undeclared` (the two- and three-DOF chains of SPEC 8 with effects
that the declared candidate lacks; truth known from the simulation). Criteria (docs/accuracy.md): the
right type and location found first, its coefficient within 10 %, NRMSE after at most a third of
NRMSE before or at the noise floor (the NRMSE of the true model identified by NSI on the same
data), and nothing added to a negative control. The full statistics over seeds and noise levels
are in ``benchmarks/diagnose_suite.py``; here one seed per effect type.
"""


import numpy as np
import pytest

from bayesnsi import CandidateModel
from bayesnsi.exceptions import ConfigError
from bayesnsi.loop import close_the_loop, refine_gap, score_effects
from bayesnsi.models import default_gaps, effect_dictionary
from bayesnsi.models.dictionary import Effect, clearance_effect
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions, ExecutionOptions, LoopOptions
from bayesnsi.simulate.undeclared import (
    UNDECLARED_CASES,
    effect_sizes,
    undeclared_case,
    undeclared_cases,
)

FLOOR_FACTOR = 1.1  # "at the noise floor": at most 1.1 x the NRMSE of the true model


def run_loop(case, jobs=1, **options):
    return close_the_loop(
        case.signals, case.declared, LoopOptions(**options), nsi=case.nsi,
        evidence=EvidenceOptions(seed=case.seed), execution=ExecutionOptions(jobs=jobs),
    )


def truth_nrmse(case):
    return identify(case.signals, case.truth, case.nsi).reconstruct(case.signals).nrmse


def final_coefficient(loop, effect):
    """Coefficient, in the final model, of the added term matching ``effect`` (type and location)."""
    step = next(s for s in loop.added if effect.matches(s.effect.base, s.term))
    index = loop.final.terms.index(step.term)
    return loop.final.coefficients[index].value, step


def assert_found(case, loop):
    """Every missing effect added (type and location), nothing else, coefficients within 10 %."""
    assert len(loop.added) == len(case.missing), [s.term.name for s in loop.added]
    assert any(e.matches(loop.added[0].effect.base, loop.added[0].term) for e in case.missing)
    for effect in case.missing:
        value, step = final_coefficient(loop, effect)
        assert value == pytest.approx(effect.coefficient, rel=0.10), effect.describe()
        assert step.log_bayes_factor > np.log(100.0)


def assert_nrmse_criterion(case, loop):
    before = loop.start.reconstruct(case.signals).nrmse
    after = loop.final.reconstruct(case.signals).nrmse
    assert after <= before / 3 or after <= FLOOR_FACTOR * truth_nrmse(case), (before, after, truth_nrmse(case))


# --------------------------------------------------------------------------------------------
# the cases themselves


def test_undeclared_cases_declare_part_of_the_truth():
    for name in UNDECLARED_CASES:
        case = undeclared_case(name, seed=0, noise_percent=1.0, duration=5.0)
        assert case.truth.terms[: case.declared.n_terms] == case.declared.terms
        assert case.reference.true_terms == case.truth.terms
        assert case.is_negative_control == name.startswith("control")
        sizes = effect_sizes(case)
        assert all(0.03 < r < 0.6 for r in sizes.values()), (name, sizes)  # physically significant, not dominant


def test_undeclared_cases_are_seeded():
    a, b = undeclared_cases("clearance", [3, 4], 2.0, duration=5.0)
    again = undeclared_case("clearance", seed=4, noise_percent=2.0, duration=5.0)
    np.testing.assert_allclose(b.signals.displacement, again.signals.displacement)
    assert not np.allclose(a.signals.displacement, b.signals.displacement)
    assert b.missing[0].gap == 0.015


def test_clearance_effects_carry_their_gap():
    effect = clearance_effect((1, 2), 0.0123456)
    assert effect.gap == pytest.approx(0.0123456)
    assert effect.base == "clearance" and effect.term.at == (1, 2) and effect.location == (1, 2)
    effects = effect_dictionary([1, 2], types=("x^3",), gaps={(2,): [0.01, 0.02]})
    assert [e.name for e in effects] == ["x^3", "x^3", "clearance g=0.01", "clearance g=0.02", "x^3"]


# --------------------------------------------------------------------------------------------
# closing the loop


@pytest.fixture(scope="module")
def coulomb():
    case = undeclared_case("coulomb-dof2", seed=0, noise_percent=2.0)
    return case, run_loop(case, max_steps=2)


def test_undeclared_coulomb_friction_at_other_dof_is_found(coulomb):
    case, loop = coulomb
    assert_found(case, loop)
    first = loop.added[0]
    assert first.term.name == "sign(v2)@2"
    assert first.ci95[0] < first.coefficient < first.ci95[1]


def test_final_model_with_friction_is_reidentified_upsampled(coulomb):
    # sign(v2) switches between the 100 Hz samples: the final model is identified again with
    # upsample = 4 (block rows x 4); reference: the simulated Coulomb coefficient (1.0 N).
    # Measured (benchmarks/diagnose_suite.py, coulomb-dof2, 1 % noise, 5 seeds): within 3.1 %
    # after the refinement, up to 12 % at the data rate.
    case, loop = coulomb
    assert loop.final_nsi.upsample == 4
    assert loop.final_nsi.block_rows == 4 * case.nsi.block_rows
    assert loop.final.upsample == 4
    value, _ = final_coefficient(loop, case.missing[0])
    assert value == pytest.approx(case.missing[0].coefficient, rel=0.05)


def test_coulomb_nrmse_after_is_a_third_or_at_noise_floor(coulomb):
    # measured (seed 0, 2 %): 0.092 -> 0.033, the true model's NRMSE on the same data is 0.033:
    # sign(v2) at 100 Hz leaves model error above the 2 % noise, for the truth as well
    assert_nrmse_criterion(*coulomb)


def test_accepted_step_reports_closed_loop_errors_and_residual_force(coulomb):
    # SPEC 7.5: error before and after in open and closed loop, residual force at the location
    case, loop = coulomb
    step = loop.added[0]
    assert step.closed_loop_nrmse_after < step.closed_loop_nrmse_before
    truth = identify(case.signals, case.truth, case.nsi).reconstruct(case.signals, closed_loop=True).nrmse
    assert step.closed_loop_nrmse_after <= FLOOR_FACTOR * truth  # the true model simulated alike
    rf = step.residual_force
    assert rf.location == (2,)
    assert len(rf.before) == len(rf.after) == case.signals.n_samples
    # the model with sign(v2) leaves a residual force several times smaller at DOF 2 ...
    assert np.std(rf.after) < 0.5 * np.std(rf.before)
    # ... and the data's force there (effect + residual) follows the effect: a step against v2
    v = rf.velocity
    assert np.median(rf.component_plus_residual[v > 0.1]) > 0.5 * step.coefficient
    assert np.median(rf.component_plus_residual[v < -0.1]) < -0.5 * step.coefficient
    rejected = [s for s in loop.steps if not s.accepted]
    assert all(s.residual_force is None and np.isnan(s.closed_loop_nrmse_after) for s in rejected)


def test_accepted_steps_posterior_interval_holds_its_estimate(coulomb):
    # the posterior given the linear part is centred on its own mean, outside its narrow interval from the
    # NSI estimate (once 1.92647e8 against [1.92726e8, 1.92768e8]): the step reports it moved onto λ
    _, loop = coulomb
    for step in loop.added:
        low, high = step.ci95
        assert low < step.coefficient < high
        assert high - low < 0.2 * abs(step.coefficient)  # the posterior's own width, not the final intervals'


def test_simulate_command_writes_an_undeclared_case_with_what_is_missing(tmp_path):
    from bayesnsi.cli import main
    from bayesnsi.io import load_config

    csv = tmp_path / "coulomb.csv"
    assert main(["simulate", "coulomb-dof2", "--seed", "1", "--out", str(csv), "--quiet"]) == 0
    config = load_config(csv.with_suffix(".toml"))
    assert [c.name for c in config.candidates] == ["declared"]
    assert [t.name for t in config.candidates[0].terms] == ["v1*abs(v1)@1"]
    assert config.raw["meta"]["missing"] == [{"type": "sign(v)", "expr": "sign(v2)", "at": [2], "coefficient": 1.0}]


def test_clearance_gap_is_refined_off_the_grid():
    case = undeclared_case("clearance", seed=1, noise_percent=1.0)
    loop = run_loop(case, max_steps=2)
    assert_found(case, loop)
    assert loop.added[0].effect.gap == pytest.approx(case.missing[0].gap, rel=0.05)
    assert_nrmse_criterion(case, loop)


def test_refine_gap_moves_towards_the_true_gap():
    case = undeclared_case("clearance", seed=2, noise_percent=1.0, duration=15.0)
    options = EvidenceOptions(compare=())
    coarse = [clearance_effect(2, g) for g in (0.008, 0.024)]
    scored = score_effects(case.signals, case.declared, coarse, case.nsi, options)
    best = refine_gap(case.signals, case.declared, scored[0], coarse, case.nsi, options)
    assert best.log_evidence > scored[0].log_evidence
    assert abs(best.effect.gap - 0.015) < abs(scored[0].effect.gap - 0.015)
    assert best.effect.gap == pytest.approx(0.015, rel=0.05)


def test_negative_control_adds_nothing():
    case = undeclared_case("control-two-dof", seed=3, noise_percent=2.0)
    loop = run_loop(case, max_steps=2)
    assert loop.added == ()
    assert loop.final.candidate == case.declared


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cubic-pair", "quadratic-damping"])
def test_undeclared_single_effect_is_found(name):
    case = undeclared_case(name, seed=0, noise_percent=2.0)
    loop = run_loop(case)
    assert_found(case, loop)
    assert_nrmse_criterion(case, loop)


@pytest.mark.slow
def test_two_missing_effects_are_both_found():
    case = undeclared_case("two-missing", seed=0, noise_percent=1.0)
    loop = run_loop(case)
    assert_found(case, loop)
    assert_nrmse_criterion(case, loop)


@pytest.mark.slow
def test_negative_control_three_dof_adds_nothing():
    case = undeclared_case("control-three-dof", seed=0, noise_percent=5.0)
    loop = run_loop(case)
    assert loop.added == ()


def test_loop_from_a_candidate_object_keeps_declared_terms(coulomb):
    case, loop = coulomb
    assert isinstance(loop.final.candidate, CandidateModel)
    assert loop.final.terms[: case.declared.n_terms] == case.declared.terms


def test_loop_is_identical_with_two_workers():
    # the effects of a step scored in two local worker processes (joblib) give the same loop
    case = undeclared_case("quadratic-damping", seed=0, noise_percent=1.0)
    serial = run_loop(case, max_steps=1)
    parallel = run_loop(case, max_steps=1, jobs=2)
    rows = [[(r.effect.name, r.term.name, r.log_evidence) for r in loop.scores[0]] for loop in (serial, parallel)]
    assert rows[0] == rows[1]
    assert [s.term.name for s in serial.added] == [s.term.name for s in parallel.added] == ["v1*abs(v1)@1"]
    assert serial.added[0].ci95 == parallel.added[0].ci95


@pytest.mark.parametrize("name", ["quadratic-damping", "coulomb-dof2", "clearance", "cubic-pair"])
def test_screen_ranks_the_missing_effect_among_the_best_three(name):
    # truth: the effect left out of the declared candidate by the simulation
    from bayesnsi.loop.screen import screen_effects

    case = undeclared_case(name, seed=0, noise_percent=2.0)
    start = identify(case.signals, case.declared, case.nsi)
    std = {d: case.signals.displacement[:, c].std() for c, d in enumerate(case.signals.output_dofs)}
    effects = effect_dictionary(case.signals.output_dofs, gaps={(d,): default_gaps(s) for d, s in std.items()})
    ranked = screen_effects(
        case.signals, case.declared, effects, max_frequency_hz=1.6 * max(m.frequency_hz for m in start.modes)
    )
    assert len(ranked) == len(effects) - case.declared.n_terms
    # close_the_loop re-identifies the best 6; on cubic-pair, x|x| across the pair ranks above x³
    best = [effect for effect, _ in ranked[:3]]
    assert any(case.missing[0].matches(e.base, e.term) for e in best), [e.term.name for e in best]
    assert all(score > 0 for _, score in ranked[:3])


def test_screen_refuses_a_record_too_short_for_its_groups():
    from bayesnsi.exceptions import BayesNSIError
    from bayesnsi.loop.screen import screen_effects

    case = undeclared_case("quadratic-damping", seed=0, noise_percent=2.0)
    short = case.signals.segment(0, 30)
    with pytest.raises(BayesNSIError, match="too few to screen"):
        screen_effects(short, case.declared, effect_dictionary(short.output_dofs), max_frequency_hz=5.0)


def test_screened_loop_adds_what_the_full_loop_adds():
    # the screen only chooses which effects are re-identified: same decision, same numbers
    case = undeclared_case("quadratic-damping", seed=1, noise_percent=2.0)
    screened = run_loop(case, max_steps=1)
    full = run_loop(case, max_steps=1, screen=None)
    assert [s.term.name for s in screened.added] == [s.term.name for s in full.added] == ["v1*abs(v1)@1"]
    assert screened.added[0].log_bayes_factor == pytest.approx(full.added[0].log_bayes_factor, rel=1e-9)
    assert screened.final.coefficient_values == pytest.approx(full.final.coefficient_values, rel=1e-9)
    scored = [row.log_evidence for row in screened.scores[0]]
    # the rest were screened out: 6 without memory re-identified, and one Bouc-Wen grid point per location
    assert sum(np.isfinite(scored)) <= 6 + 3 and np.isnan(scored[-1])
    assert len(scored) == len(full.scores[0])


@pytest.mark.parametrize("screen", [0, -2, 2.5, True])
def test_loop_refuses_a_screen_that_is_not_a_positive_count(screen):
    with pytest.raises(ConfigError, match=r"\[diagnose\] screen: expected an integer in \[1, 100000\]"):
        LoopOptions(screen=screen)


def test_look_alike_taken_first_is_exchanged_once_its_partner_is_in():
    # two-missing, seed 8, 1 % noise: a clearance at DOF 1 fits the first misfit best while the
    # Coulomb friction at DOF 2 is missing; with the friction in, x1³ (the simulated effect) beats
    # it by 1105 nat (Laplace) and replaces it. Reference: the simulation's missing effects. (With
    # Bouc-Wen elements in the dictionary a grid shape at DOF 2 takes one of the n_tries and the loop
    # reaches the same pair by the look-ahead instead: the exchange is tested without them.)
    from bayesnsi.models.dictionary import CLEARANCE, DEFAULT_EFFECT_TYPES, SMOOTH_FRICTION

    case = undeclared_cases("two-missing", [8], 1.0)[0]
    loop = run_loop(case, effects=(*DEFAULT_EFFECT_TYPES, CLEARANCE, SMOOTH_FRICTION))
    assert [s.term.name for s in loop.added] == ["x1**3@1", "sign(v2)@2"]
    assert loop.added[0].reason.startswith("accepted in exchange for")
    assert loop.added[0].residual_force is not None
    exchanged = [s for s in loop.steps if s.reason.startswith("exchanged for x1**3@1")]
    assert len(exchanged) == 1 and exchanged[0].effect.base == "clearance"
    assert_found(case, loop)


# --------------------------------------------------------------------------------------------
# the loop's API: typed effects, options, the record-half guard, results.json


def test_halves_too_short_for_the_block_rows_use_fewer_and_the_effect_can_be_added():
    # 1000 samples (the README's 10 s tour) identify v1|v1| with 60 block rows, but each half,
    # 500 samples, is too short for them (k = 1 force + 1 term + 2 outputs: 2*60*5 - 1 = 599 > 500).
    # Before: both halves NaN, the effect rejected, so the loop could never add anything. Now the
    # halves use the most block rows 500 samples allow, (500 + 1) // (2 * 5) = 50, and say so.
    from bayesnsi.loop.guards import TOO_SHORT

    case = undeclared_case("quadratic-damping", seed=0, noise_percent=1.0)
    short = case.signals.segment(0, 1000)
    loop = close_the_loop(short, case.declared, LoopOptions(max_steps=1, effects=("v|v|", "v^3")), nsi=case.nsi)
    first = loop.steps[0]
    assert first.term.name == "v1*abs(v1)@1" and first.log_bayes_factor > np.log(100.0)
    assert first.accepted, first.reason
    assert first.half_block_rows == 50
    assert first.half_note.startswith(TOO_SHORT) and "identified with 50" in first.half_note
    assert np.all(np.isfinite(first.half_coefficients))
    assert {row.effect.base for row in loop.scores[0]} == {"v|v|", "v^3"}


def test_halves_too_short_even_for_two_block_rows_are_reported_as_such():
    from bayesnsi.loop.guards import half_block_rows, half_coefficients

    assert half_block_rows(500, 60, 4) == 50 and half_block_rows(5000, 60, 4) == 60
    case = undeclared_case("quadratic-damping", seed=0, noise_percent=1.0, duration=5.0)
    tiny = case.signals.segment(0, 18)  # halves of 9 samples: 2 block rows need 2*2*5 - 1 = 19
    halves, too_short, rows = half_coefficients(tiny, case.truth, case.nsi)
    assert too_short and rows < 2 and all(np.isnan(halves))


def test_loop_options_choose_the_effect_types_of_the_dictionary():
    from bayesnsi.loop import loop_effects

    case = undeclared_case("clearance", seed=0, noise_percent=1.0, duration=5.0)
    # 2 DOFs and the pair 1-2: 8 types x 3 locations + 3 gaps x 3 locations + 2 tanh widths x 3 locations
    # + 9 Bouc-Wen shapes x 3 locations (|v| among the types: every location of the vibrating chain reverses in
    # both record halves)
    assert len(loop_effects(case.signals)) == len(loop_effects(case.signals, LoopOptions().effects)) == 66
    chosen = loop_effects(case.signals, LoopOptions(effects=["clearance", "x^3"]).effects)
    assert [e.name.split(" ")[0] for e in chosen] == ["x^3", "clearance", "clearance", "clearance"] * 3
    assert {e.location for e in chosen if e.gap is not None} == {(1,), (2,), (1, 2)}  # a clearance between sensors
    with pytest.raises(ConfigError, match=r"\[diagnose\] effects: expected a non-empty list"):
        LoopOptions(effects=[])
    with pytest.raises(ConfigError, match=r"\[diagnose\] effects: unknown type\(s\) \['x\^4'\]"):
        loop_effects(case.signals, LoopOptions(effects=["x^3", "x^4"]).effects)
    with pytest.raises(ConfigError, match="unknown effect type"):
        effect_dictionary([1], types=("x^4",))
    with pytest.raises(ConfigError, match="effect type 'x\\^4' unknown"):
        Effect("x^4", case.declared.terms[0])


def test_loop_refuses_options_that_are_not_typed():
    case = undeclared_case("quadratic-damping", seed=0, noise_percent=2.0, duration=5.0)
    with pytest.raises(ConfigError, match="options must be a LoopOptions"):
        close_the_loop(case.signals, case.declared, {"max_steps": 1})
    with pytest.raises(ConfigError, match="nsi must be a NSIOptions"):
        close_the_loop(case.signals, case.declared, nsi={"block_rows": 60})


def test_diagnose_command_writes_effects_and_their_scores(tmp_path):
    import json

    from bayesnsi.cli import main

    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    out = tmp_path / "out"
    args = ["diagnose", str(csv.with_suffix(".toml")), "--out", str(out), "--quiet", "--no-figures", "--max-steps", "1"]
    assert main(args) == 0
    results = json.loads((out / "results.json").read_text())
    added = results["loop"][0]
    assert added["effect"] == {"type": "v|v|", "at": [1], "gap": None} and added["effect_type"] == "v|v|"
    first = results["loop_scores"][0]  # the first search: every effect, best first
    assert first[0]["term"] == "v1*abs(v1)@1" and first[0]["type"] == "v|v|"
    scored = [row["log_evidence_laplace"] for row in first if isinstance(row["log_evidence_laplace"], float)]
    # the screen's best 6 without memory, and the best Bouc-Wen grid point of each of the 3 locations
    assert len(scored) == 6 + 3 and scored == sorted(scored, reverse=True)
    assert len(first) == results["settings"]["loop"]["n_effects"]  # the declared model is linear: every effect


def test_posterior_intervals_are_moved_onto_the_nsi_estimates():
    from types import SimpleNamespace

    from bayesnsi.loop.guards import about_estimates

    rng = np.random.default_rng(0)
    draws = rng.normal([2.0, -1.0], [0.01, 0.02], size=(8, 500, 2))  # (chain, draw, q): centred away from NSI
    hdi = np.quantile(draws.reshape(-1, 2), [0.025, 0.975], axis=0).T
    evidence = SimpleNamespace(posterior=SimpleNamespace(coefficients=draws), ci95=hdi)
    moved = about_estimates(evidence, np.array([2.5 + 0.3j, -0.9]))  # real parts count
    np.testing.assert_allclose(moved[:, 1] - moved[:, 0], hdi[:, 1] - hdi[:, 0])  # the posterior's widths
    np.testing.assert_allclose(moved.mean(axis=1), [2.5, -0.9], atol=2e-3)  # about the estimates
