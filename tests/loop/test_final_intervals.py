"""The loop's final model carries the honest intervals of ``select``.

Reference: the simulated quadratic-damping case (true coefficient in the config's [meta]); the
loop from the declared (linear) model adds v|v| at DOF 1. The final coefficient's interval
must include the linear part's uncertainty (wider than the posterior given the linear part),
and results.json / the report must carry the values of :attr:`bayesnsi.Diagnosis.final`.
"""

from __future__ import annotations

import json
import tomllib

import pytest

from bayesnsi.cli import main

FAST = '[evidence]\nn_steps = 200\nn_burn = 50\nlikelihood = "white"\ncompare = []\n\n'


def _pair(ci):
    """The report's text of an interval, checked against the values it words (to 5 % of the width)."""
    from bayesnsi.report.intervals import format_interval

    text = format_interval(ci)
    lo, hi = (float(v) for v in text.strip("[]").split(", "))
    assert abs(lo - ci[0]) <= 0.05 * abs(ci[1] - ci[0]) + 1e-12 and abs(hi - ci[1]) <= 0.05 * abs(ci[1] - ci[0]) + 1e-12
    return text


@pytest.fixture(scope="module")
def loop_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("loop")
    csv = tmp / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    config = csv.with_suffix(".toml")
    config.write_text(config.read_text().replace("[meta]", FAST + "[meta]"))
    out = tmp / "out"
    assert main(["diagnose", str(config), "--out", str(out), "--quiet", "--max-steps", "1", "--no-figures"]) == 0
    return tomllib.loads(config.read_text()), json.loads((out / "results.json").read_text()), out


def test_results_json_final_coefficients_carry_honest_intervals(loop_run):
    _, results, _ = loop_run
    assert results["loop"], "the loop should add v|v| on this case"
    (coefficient,) = results["final_coefficients"]
    assert coefficient["interval"] == "noise"  # the default
    lo, hi = coefficient["ci95"]
    plo, phi = coefficient["ci95_given_linear_part"]
    assert lo < coefficient["estimate"] < hi and hi - lo > phi - plo  # linear-part uncertainty widens it
    clo, chi = coefficient["ci50"]
    assert lo < clo < chi < hi
    record = results["final_intervals"]
    assert record["method"] == "noise" and record["n_segments"] >= 2
    assert record["coefficients"][0]["ci95"] == coefficient["ci95"]
    assert len(record["frequencies"]) >= 1 and "ci95" in record["damping_ratios"][0]


def test_final_interval_covers_the_true_coefficient(loop_run):
    config, results, _ = loop_run
    true = config["meta"]["true_coefficients"][-1]
    lo, hi = results["final_coefficients"][0]["ci95"]
    assert lo < true < hi, (lo, true, hi)


@pytest.fixture(scope="module")
def diagnosis():
    """The same loop through the library: select on the declared model, then diagnose from it."""
    import warnings

    from bayesnsi import EvidenceOptions, LoopOptions, diagnose, select
    from bayesnsi.exceptions import AdequacyWarning
    from bayesnsi.simulate import undeclared_case

    case = undeclared_case("quadratic-damping", seed=0)
    evidence = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdequacyWarning)  # the declared model lacks v|v|: select says so
        selection = select(case.signals, [case.declared], case.nsi, evidence)
        return diagnose(selection, LoopOptions(max_steps=1))


def test_final_model_adequacy_is_reported_beside_the_starting_models(diagnosis):
    # the declared linear model lacks v|v| (its residual is well above the noise it passes on); the final model
    # holds the truth: near 1, and the answer says both
    from bayesnsi.report.document import Report
    from bayesnsi.report.loop import added_sentence, diagnosis_sections

    after = diagnosis.final.check
    before = diagnosis.selection.checks[diagnosis.start]
    assert after.adequate and 0.7 < after.noise_ratio < 1.3 < before.noise_ratio
    assert after.band_ratio < 2.0 and len(after.passed_on_std) == len(after.noise_std)
    report = Report("t", figures=False)
    diagnosis_sections(report, diagnosis, None)
    html = report.to_html()
    assert added_sentence(diagnosis) in html
    assert (f"Adequate: its open-loop residual is {after.noise_ratio:.2f}x the noise it passes on "
            f"({diagnosis.start}: {before.noise_ratio:.2f}x).") in html
    assert "class='lead'" in html  # green: the final model is adequate


def test_loop_report_table_shows_the_final_intervals(diagnosis):
    """The loop section's table of final coefficients words the final model's intervals."""
    from bayesnsi.report.document import Report
    from bayesnsi.report.intervals import final_coefficients_frame

    report = Report("t")
    report.section("loop", 10).append(final_coefficients_frame(diagnosis.final))
    html = report.to_html()
    interval = diagnosis.final.intervals.coefficients[0]
    given = diagnosis.final.evidence.ci95[0]
    assert _pair(interval.ci95) in html and _pair(given) in html
    assert _pair(interval.ci50) in html and "noise replicates + posterior" in html


def test_final_intervals_replicate_with_the_final_models_upsampled_settings(monkeypatch):
    """The noise replicates re-identify with ``LoopResult.final_nsi`` (upsample 4, block rows x 4), the settings
    the reported final coefficients were identified with, not the loop's data-rate ones."""
    from types import SimpleNamespace

    import bayesnsi.evidence
    import bayesnsi.uncertainty
    from bayesnsi.diagnosis import _final_model
    from bayesnsi.options import EvidenceOptions, NSIOptions

    seen = {}

    def fake_evidence(result, signals, options, seeds, warn=True):
        return {options.likelihood: "evidence"}

    def fake_intervals(result, signals, evidence, options, nsi):
        seen["nsi"] = nsi
        return "intervals"

    monkeypatch.setattr(bayesnsi.evidence, "candidate_evidence", fake_evidence)
    monkeypatch.setattr(bayesnsi.uncertainty, "candidate_intervals", fake_intervals)
    monkeypatch.setattr(bayesnsi.uncertainty, "widen_final", lambda result, intervals, signals, **kw: (intervals, None))
    data_rate = NSIOptions(block_rows=60, order=4)
    fine = data_rate.replace(upsample=4, block_rows=240)
    loop = SimpleNamespace(final="final", start="start", added=("step",), nsi=data_rate, final_nsi=fine)
    selection = SimpleNamespace(segments=(), evidence=EvidenceOptions(), signals="signals")
    final = _final_model(loop, selection, "start")
    assert final.evidence == "evidence" and final.intervals == "intervals"
    assert seen["nsi"].upsample == 4 and seen["nsi"].block_rows == 240


def test_loop_report_notes_a_final_model_with_a_sign_term():
    """The loop report tells when the final model's noise intervals carry a discontinuous term."""
    from types import SimpleNamespace

    from bayesnsi.findings import Finding
    from bayesnsi.report.loop import _interval_how

    note = Finding("interval.discontinuous", "sign(v2)@2 is discontinuous at velocity reversals", "", "note")
    noise = SimpleNamespace(intervals=SimpleNamespace(method="noise", findings=(note,)))
    assert "sign(v2)@2 is discontinuous" in _interval_how(noise)
    assert _interval_how(SimpleNamespace(intervals=SimpleNamespace(method="segments", findings=()))) == ""
    assert _interval_how(SimpleNamespace(intervals=None)) == ""


def test_an_inadequate_final_model_gets_select_s_widened_intervals():
    """With velocity sensors ``select`` widened a model's intervals 43.7x for its model error while the loop's
    final intervals of the same model were not widened; the final model now gets the same widening
    (:func:`bayesnsi.uncertainty.widening.widen_final`). Reference: the quadratic-damping case, whose linear
    model misses v|v| (residual several times the noise) and whose loop adds it."""
    import warnings

    import numpy as np

    from bayesnsi.evidence import candidate_evidence
    from bayesnsi.exceptions import BayesNSIWarning
    from bayesnsi.loop import close_the_loop
    from bayesnsi.options import EvidenceOptions, LoopOptions
    from bayesnsi.simulate import undeclared_case
    from bayesnsi.uncertainty import candidate_intervals
    from bayesnsi.uncertainty.widening import widen_final

    case = undeclared_case("quadratic-damping", seed=0)
    evidence = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BayesNSIWarning)  # the loop's own (spurious poles of candidate effects)
        loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1), nsi=case.nsi)
        assert [t.name for t in loop.final.terms] == ["v1*abs(v1)@1"]

        def intervals(model):
            found = candidate_evidence(model, case.signals, evidence, np.random.SeedSequence(0), warn=False)["white"]
            return candidate_intervals(model, case.signals, found, evidence, loop.final_nsi)

        kept, check = widen_final(loop.final, intervals(loop.final), case.signals)
        linear, linear_check = widen_final(loop.start, intervals(loop.start), case.signals)
    assert check.adequate and not linear_check.adequate
    assert kept.widening == 1.0  # the true model is adequate: its intervals carry the sensor noise only
    assert linear.widening > 1.3
    assert any(f.message.startswith(f"widened {linear.widening:.2f}x") for f in linear.findings)
