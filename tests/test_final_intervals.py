"""The loop's final model carries the honest intervals of ``select`` (issue 15).

Reference: the simulated quadratic-damping case (true coefficient in the config's [meta]); the
loop from the declared (linear) model adds v|v| at DOF 1. The final coefficient's interval
must include the linear part's uncertainty (wider than the posterior given the linear part),
and results.json / the report must carry the values of :func:`bayesnsi.loop.final_intervals`.
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
    plo, phi = coefficient["ci95_posterior"]
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


def test_final_model_adequacy_is_reported_beside_the_starting_models(loop_run):
    # the declared linear model lacks v|v| (its residual is well above the noise it passes on); the final model
    # holds the truth: near 1, and the answer says both (the sentence the report's answer appends)
    from bayesnsi.report.loop import _adequacy_after

    _, results, _ = loop_run
    after = results["final_model_check"]
    before = next(c for c in results["candidates"] if c["name"] == results["start"])["model_check"]
    assert after["adequate"] and 0.7 < after["noise_ratio"] < 1.3 < before["noise_ratio"]
    assert after["band_ratio"] < 2.0 and len(after["passed_on_std"]) == len(after["noise_std"])
    sentence = _adequacy_after(results, results["start"])
    assert sentence == (f" Its open-loop residual is {after['noise_ratio']:.2f}x the noise it passes on "
                        f"({results['start']}: {before['noise_ratio']:.2f}x).")


def test_loop_report_table_shows_the_final_intervals(loop_run):
    """The loop section's table of final coefficients (report.html) words results.json's values."""
    from bayesnsi.report.document import Report
    from bayesnsi.report.intervals import final_coefficients_frame

    _, results, _ = loop_run
    report = Report("t")
    report.section("loop", 10).append(final_coefficients_frame(results["final_coefficients"]))
    html = report.to_html()
    coefficient = results["final_coefficients"][0]
    assert _pair(coefficient["ci95"]) in html and _pair(coefficient["ci95_posterior"]) in html
    assert _pair(coefficient["ci50"]) in html and "noise replicates + posterior" in html


def test_final_intervals_replicate_with_the_final_models_upsampled_settings(monkeypatch):
    """The noise replicates re-identify with ``settings["final_nsi"]`` (upsample 4, block rows x 4),
    the settings the reported final coefficients were identified with, not the loop's data-rate ones."""
    from types import SimpleNamespace

    from bayesnsi.loop import final as final_module
    from bayesnsi.options import NSIOptions

    seen = {}

    def fake_evidence(result, signals, options, seeds, warn=True):
        return {options.likelihood: "evidence"}

    def fake_intervals(result, signals, evidence, options, nsi):
        seen["nsi"] = nsi
        return "intervals"

    monkeypatch.setattr(final_module, "candidate_evidence", fake_evidence)
    monkeypatch.setattr(final_module, "candidate_intervals", fake_intervals)
    data_rate = NSIOptions(block_rows=60, order=4)
    fine = data_rate.replace(upsample=4, block_rows=240)
    loop = SimpleNamespace(final="final", settings={"nsi": data_rate.to_dict(), "final_nsi": fine.to_dict(),
                                                    "evidence": {}})
    assert final_module.final_intervals(loop, "signals") == ("evidence", "intervals")
    assert seen["nsi"].upsample == 4 and seen["nsi"].block_rows == 240


def test_loop_report_notes_a_final_model_with_a_sign_term():
    """The loop report tells when the final model's noise intervals carry a discontinuous term."""
    from types import SimpleNamespace

    from bayesnsi.models.terms import Term
    from bayesnsi.report.loop import _discontinuity

    coulomb = SimpleNamespace(final=SimpleNamespace(terms=(Term("v1*abs(v1)", 1), Term("sign(v2)", 2))))
    smooth = SimpleNamespace(final=SimpleNamespace(terms=(Term("v1*abs(v1)", 1),)))
    noise = {"final_intervals": {"method": "noise"}}
    assert "sign(v2)@2 is discontinuous" in _discontinuity(noise, coulomb)
    assert _discontinuity({"final_intervals": {"method": "segments"}}, coulomb) == ""
    assert _discontinuity(noise, smooth) == "" and _discontinuity({}, coulomb) == ""


def test_an_inadequate_final_model_gets_select_s_widened_intervals():
    """Trial with velocity sensors: ``select`` widened the model's intervals 43.7x for its model error, the
    loop's final intervals of the same model were not widened (44x narrower); ``bayesnsi diagnose`` now
    widens them with :func:`bayesnsi.uncertainty.widening.widen_final`. Reference: the quadratic-damping
    case, whose linear model misses v|v| (residual several times the noise) and whose loop adds it."""
    import warnings
    from types import SimpleNamespace

    from bayesnsi.loop import close_the_loop, final_intervals
    from bayesnsi.options import EvidenceOptions, LoopOptions
    from bayesnsi.simulate import undeclared_case
    from bayesnsi.uncertainty.widening import widen_final

    case = undeclared_case("quadratic-damping", seed=0)
    evidence = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1), nsi=case.nsi)
        assert [t.name for t in loop.final.terms] == ["v1*abs(v1)@1"]
        _, kept = final_intervals(loop, case.signals, evidence)
        kept, check = widen_final(loop.final, kept, case.signals)
        _, linear = final_intervals(SimpleNamespace(final=loop.start, settings=loop.settings), case.signals, evidence)
        linear, linear_check = widen_final(loop.start, linear, case.signals)
    assert check.adequate and not linear_check.adequate
    assert kept.widening == 1.0  # the true model is adequate: its intervals carry the sensor noise only
    assert linear.widening > 1.3 and any(note.startswith(f"widened {linear.widening:.2f}x") for note in linear.notes)
