"""Per-effect screen and evidence scores of each loop search, and the loop's
``--lookahead/--no-lookahead`` and ``--effects`` flags of ``bayesnsi diagnose``.

Data: the two-DOF chain of :func:`bayesnsi.simulate.undeclared_case` with quadratic damping at DOF 1
missing from the declared (linear) model. Reference for the screen ranks: an independent call of
:func:`bayesnsi.loop.screen.screen_effects` on the same data, band and dictionary.
"""

from __future__ import annotations

import json
import math

import pytest

from bayesnsi import LoopOptions
from bayesnsi.cli import main
from bayesnsi.exceptions import ConfigError
from bayesnsi.loop import close_the_loop, loop_effects
from bayesnsi.loop.screen import PLACES_PER_LOCATION, best_locations_first, screen_effects, second_widths_last
from bayesnsi.loop.search import SCREEN_BAND
from bayesnsi.models.dictionary import clearance_effect, effect_dictionary, smooth_friction_effect
from bayesnsi.simulate import undeclared_case

TRUE_TERM = "v1*abs(v1)@1"


@pytest.fixture(scope="module")
def loop_case():
    case = undeclared_case("quadratic-damping", seed=0, noise_percent=2.0)
    return case, close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1), nsi=case.nsi)


def test_each_step_lists_the_screened_effects_with_screen_rank_and_evidence(loop_case):
    case, loop = loop_case
    step = loop.added[0]
    assert step.term.name == TRUE_TERM and step.search == 0
    records = loop.search_records(step.search)
    assert len(records) == loop.n_effects  # a linear start: the whole dictionary
    # the screen ranks are a permutation of 1..n; the screen's own ranking, computed independently
    top_hz = max(m.frequency_hz for m in loop.start.modes)
    ranked = screen_effects(case.signals, case.declared, loop_effects(case.signals),
                            max_frequency_hz=SCREEN_BAND * top_hz, velocity_method=case.nsi.velocity_method)
    reference = {e.term.name: k for k, (e, _) in enumerate(ranked, start=1)}
    assert sorted(r["screen_rank"] for r in records) == list(range(1, len(records) + 1))
    assert {r["term"]: r["screen_rank"] for r in records} == reference
    assert all(r["screen_view"] == "frequency" for r in records)
    true = next(r for r in records if r["term"] == TRUE_TERM)
    assert 1 <= true["screen_rank"] <= loop.options.screen
    assert true["status"] == "accepted" and true["reason"] == "accepted"
    # the evidence scores of the step itself, as the guards saw them
    assert true["log_bayes_factor"] == pytest.approx(step.log_bayes_factor, rel=1e-12)
    assert true["imag_ratio"] == pytest.approx(step.imag_ratio, rel=1e-12)
    assert true["nrmse"] == pytest.approx(step.nrmse_after, rel=1e-12)
    screen = loop.options.screen
    out = [r for r in records if r["status"] == "screened out"]
    # the screen's places go to the effects without memory at the best ceil(screen / 3) locations (ordered by
    # their best effect), one friction width per location before any second one; the best Bouc-Wen grid
    # point of each location besides
    static = sorted((r for r in records if r["type"] != "boucwen"), key=lambda r: r["screen_rank"])
    best_locations = list(dict.fromkeys(tuple(r["at"]) for r in static))[: -(-screen // PLACES_PER_LOCATION)]
    widths: dict = {}
    for r in static:
        if r["type"] == "tanh(v/eps)":
            widths.setdefault(tuple(r["at"]), r["term"])
    places = sorted(static, key=lambda r: (tuple(r["at"]) not in best_locations,  # stable: screen order within
                                           widths.get(tuple(r["at"]), r["term"]) != r["term"]
                                           and r["type"] == "tanh(v/eps)"))
    assert [r["status"] == "screened out" for r in places] == [False] * screen + [True] * (len(places) - screen)
    for at in {tuple(r["at"]) for r in records if r["type"] == "boucwen"}:
        best = min((r for r in records if r["type"] == "boucwen" and tuple(r["at"]) == at),
                   key=lambda r: r["screen_rank"])
        assert best["status"] != "screened out"
    assert all(math.isnan(r["log_evidence_laplace"]) and "not re-identified" in r["reason"] for r in out)
    kept = [r for r in records if r["status"] != "screened out"]
    # (a Bouc-Wen shape that dissipates more than the data allow fails: its underlying linear model is unstable)
    assert all(math.isfinite(r["log_bayes_factor"]) and math.isfinite(r["imag_ratio"]) for r in kept
               if r["type"] != "boucwen" or r["status"] != "failed")
    assert [r["log_evidence_laplace"] for r in kept] == sorted((r["log_evidence_laplace"] for r in kept), reverse=True)
    assert all(r["reason"] for r in records)


def test_diagnose_flags_set_lookahead_and_effects_and_results_list_the_screen(tmp_path):
    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    out = tmp_path / "out"
    args = ["diagnose", str(csv.with_suffix(".toml")), "--out", str(out), "--quiet", "--no-figures",
            "--max-steps", "1", "--no-lookahead", "--effects", "v|v|", "x^3", "sign(v)", "--screen", "2"]
    assert main(args) == 0
    results = json.loads((out / "results.json").read_text())
    loop = results["settings"]["loop"]
    assert loop["lookahead"] is False and loop["effects"] == ["v|v|", "x^3", "sign(v)"]
    step = results["loop"][0]
    screened = step["screened"]
    assert {r["type"] for r in screened} == {"v|v|", "x^3", "sign(v)"}  # only the types asked for
    assert len(screened) == loop["n_effects"] == 9  # 3 types x (DOF 1, DOF 2, element 1-2)
    true = next(r for r in screened if r["term"] == TRUE_TERM)
    assert true["screen_rank"] in (1, 2) and true["status"] == "accepted" and true["log_bayes_factor"] > 0
    assert sum(r["status"] == "screened out" for r in screened) == 7
    assert results["loop_scores"][step["search"]] == screened


def test_diagnose_flags_refuse_an_unknown_effect_before_any_work(tmp_path, capsys):
    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    args = ["diagnose", str(csv.with_suffix(".toml")), "--out", str(tmp_path / "o"), "--quiet", "--no-figures",
            "--effects", "v^5"]
    assert main(args) == 2
    assert "unknown type(s) ['v^5']" in capsys.readouterr().err
    assert not (tmp_path / "o" / "results.json").exists() and not (tmp_path / "o" / "cache").exists()
    with pytest.raises(ConfigError, match="unknown type"):  # the same check in the Python API
        loop_effects(undeclared_case("quadratic-damping", seed=0, duration=5.0).signals, ["v^5"])


def test_a_second_friction_width_at_a_location_waits_for_every_other_effect_but_a_second_gap_does_not():
    cubic, coulomb = effect_dictionary([1, 2], ["x^3", "sign(v)"], pairs=[])[:2]
    wide, narrow, other = (smooth_friction_effect(at, eps) for at, eps in ((1, 0.1), (1, 0.05), (2, 0.1)))
    gap, second_gap = clearance_effect(1, 0.02), clearance_effect(1, 0.01)
    ordered = [wide, narrow, gap, second_gap, other, cubic, smooth_friction_effect(1, 0.2), coulomb]
    assert second_widths_last(ordered) == [wide, gap, second_gap, other, cubic, coulomb, narrow, ordered[6]]


def test_the_places_go_to_the_types_of_the_best_locations_before_one_type_elsewhere():
    # screen order: a clearance at the pair 1-2 first, then one at the pairs 2-3 and 1-3, then the
    # cubic at 1-2; with 3 places (one location) the cubic comes before the other pairs' clearances
    by_name = {e.term.name: e for e in effect_dictionary([1, 2, 3], ["x^3"], pairs=[(1, 2), (2, 3), (1, 3)])}
    cubic12 = by_name["(x1-x2)**3@1-2"]
    gap12, gap23, gap13 = (clearance_effect(at, 0.01) for at in ((1, 2), (2, 3), (1, 3)))
    ordered = [gap12, gap23, gap13, cubic12, by_name["x1**3@1"]]
    assert best_locations_first(ordered, 3) == [gap12, cubic12, gap23, gap13, by_name["x1**3@1"]]
    # six places: two locations, in the order of their best effect
    assert best_locations_first(ordered, 6) == [gap12, gap23, cubic12, gap13, by_name["x1**3@1"]]
