"""The report shows the honest intervals: coefficients and modes with the intervals of
:func:`bayesnsi.uncertainty.candidate_intervals`, the posterior-only interval beside them, labelled.

Reference values: the outcome's own ``intervals`` and its evidence's ``ci95`` (the report only
words them), formatted as the report does (4 significant digits).
"""

import numpy as np
import pytest

from bayesnsi.options import EvidenceOptions
from bayesnsi.report.document import Report
from bayesnsi.report.intervals import (
    coefficient_intervals_frame,
    coefficient_sentence,
    interval_sections,
    mode_intervals_frame,
)
from bayesnsi.run import run_candidates
from bayesnsi.simulate import simulate_case

FAST = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=())


@pytest.fixture(scope="module")
def outcome():
    case = simulate_case("two-dof", seed=0)
    (found,) = run_candidates(case.signals, case.candidates[:1], case.recommended, FAST)
    assert found.intervals is not None and found.intervals.method == "noise"  # the default
    return found


def _pair(ci):
    """The report's text of an interval, checked against the values it words (to 5 % of the width)."""
    from bayesnsi.report.intervals import format_interval

    text = format_interval(ci)
    lo, hi = (float(v) for v in text.strip("[]").split(", "))
    assert abs(lo - ci[0]) <= 0.05 * abs(ci[1] - ci[0]) + 1e-12 and abs(hi - ci[1]) <= 0.05 * abs(ci[1] - ci[0]) + 1e-12
    return text


def test_report_contains_the_honest_interval_values(outcome):
    report = Report("t")
    interval_sections(report, [outcome], "white")
    report.section("Answer", 0).append(coefficient_sentence(outcome.name, outcome.intervals))
    html = report.to_html()
    honest = outcome.intervals.coefficients[0]
    posterior = outcome.evidences["white"].ci95[0]
    assert _pair(honest.ci95) in html and _pair(honest.ci50) in html
    assert _pair(posterior) in html and "given the linear part" in html
    assert "linear part" in html and "copies of the record" in html and "errors-in-variables bias" in html
    # the honest interval is the wider one (it adds the linear part's scatter to the posterior)
    assert honest.ci95[1] - honest.ci95[0] > posterior[1] - posterior[0]
    for f, z in zip(outcome.intervals.frequencies, outcome.intervals.damping_ratios):
        assert _pair(f.ci95) in html and _pair([100 * v for v in z.ci95]) in html


def test_interval_frames(outcome):
    coefficients = coefficient_intervals_frame([outcome], "white")
    assert coefficients.loc[(outcome.name, outcome.intervals.coefficients[0].name), "sd"] == pytest.approx(
        outcome.intervals.coefficients[0].sd)
    modes = mode_intervals_frame([outcome])
    assert len(modes) == 2
    assert np.allclose(modes["frequency [Hz]"], [m.frequency_hz for m in outcome.result.modes])
    assert coefficient_intervals_frame([], "white") is None and mode_intervals_frame([]) is None


def test_select_report_shows_the_intervals_of_results_json(tmp_path, capsys):
    """``bayesnsi select``: report.html carries results.json's honest ci95 of α and of the modes."""
    import json

    from bayesnsi.cli import main

    assert main(["simulate", "two-dof", "--seed", "3", "--out", str(tmp_path / "two_dof.csv"), "--quiet"]) == 0
    config = tmp_path / "true.toml"
    config.write_text(
        '[data]\nfile = "two_dof.csv"\nfs = 100.0\ninputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
        '[nsi]\nblock_rows = 60\norder = 4\n'
        '[evidence]\nn_steps = 200\nn_burn = 50\nlikelihood = "white"\ncompare = []\n'
        '[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n'
    )
    assert main(["select", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    capsys.readouterr()
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    (record,) = results["candidates"]
    html = (tmp_path / "out" / "report.html").read_text()
    coefficient = record["coefficients"][0]
    assert coefficient["interval"] == "noise"  # the default
    assert _pair(coefficient["ci95"]) in html and _pair(coefficient["ci95_given_linear_part"]) in html
    assert _pair(record["modes"][0]["frequency_ci95"]) in html


def test_report_says_when_a_term_is_discontinuous(outcome):
    """A candidate with sign() gets the note on its bias estimate; the smooth two-DOF candidate does not."""
    from dataclasses import replace
    from types import SimpleNamespace

    from bayesnsi.models.terms import Term
    from bayesnsi.report.intervals import interval_text
    from bayesnsi.uncertainty.replicates import discontinuity_findings

    terms = (Term("v1*abs(v1)", 1), Term("sign(v2)", 2))
    noted = replace(outcome.intervals, findings=discontinuity_findings(SimpleNamespace(terms=terms)))
    coulomb = SimpleNamespace(name="coulomb", intervals=noted, result=SimpleNamespace(terms=terms))
    assert "discontinuous" not in interval_text([outcome])
    text = interval_text([outcome, coulomb])
    assert "coulomb: sign(v2)@2 is discontinuous" in text and outcome.name + ":" not in text
