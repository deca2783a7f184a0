"""``diagnose --start``: results.json keeps the ranking's selection beside the start.

The payload's ``selected`` is the ranking's, not the ``--start`` candidate: an EMPS run from a linear
start must not say "selected: linear" while the ranking gives another model P = 1.
"""

from __future__ import annotations

import json

from bayesnsi.cli import main

TRUTH = """

[[candidates]]
name = "truth"
terms = [{ expr = "v1*abs(v1)", at = 1 }]

[evidence]
likelihood = "white"
n_steps = 300
n_burn = 100
"""


def test_diagnose_from_a_start_keeps_the_selected_model(tmp_path):
    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    config = csv.with_suffix(".toml")
    config.write_text(config.read_text() + TRUTH)  # the declared (linear) model and the true one
    out = tmp_path / "out"
    args = ["diagnose", str(config), "--out", str(out), "--quiet", "--no-figures", "--max-steps", "1",
            "--start", "declared"]
    assert main(args) == 0
    results = json.loads((out / "results.json").read_text())
    column = f"p_{results['likelihood']}"
    best = max(results["ranking"], key=lambda row: row[column])["candidate"]
    assert best == "truth"  # the simulated case holds v|v|: the ranking must give it the probability
    assert results["selected"] == best and results["start"] == "declared"


def test_a_start_that_failed_to_identify_says_why(tmp_path, capsys):
    # a start candidate that failed (unstable at that order) is not "not an identified candidate": the
    # message says it failed, why, and what to change
    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    config = csv.with_suffix(".toml")
    config.write_text(config.read_text() + TRUTH
                      + '\n[[candidates]]\nname = "constant"\nterms = [{ expr = "x1 - x1 + 1e-300*x1", at = 1 }]\n')
    capsys.readouterr()
    args = ["diagnose", str(config), "--out", str(tmp_path / "out"), "--quiet", "--no-figures", "--start", "constant"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "'constant' could not be identified" in err and "identifiable" in err and "block_rows or order" in err


def test_the_default_start_is_the_plausible_model_when_the_selected_one_fails_a_check(tmp_path, monkeypatch, capsys):
    # the evidence selects a sign() with a negative coefficient (negative dissipation): the loop does not
    # start from a model that is not physical but from Selection.plausible.
    import bayesnsi.selection as selection_module

    monkeypatch.setattr(selection_module.Selection, "plausible", property(lambda self: "declared"))
    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    config = csv.with_suffix(".toml")
    config.write_text(config.read_text() + TRUTH)
    out = tmp_path / "out"
    capsys.readouterr()
    assert main(["diagnose", str(config), "--out", str(out), "--quiet", "--no-figures", "--max-steps", "1"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["selected"] == "truth" and results["start"] == "declared" and results["plausible"] == "declared"
    # diagnose says it as select does (even with --quiet)
    err = capsys.readouterr().err
    assert "the selected model fails a physical check" in err and "passes every check: declared" in err


def test_diagnose_prints_the_final_coefficients_with_their_intervals(tmp_path, capsys):
    # after "closing the loop" diagnose prints the final model, not only the files it wrote
    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--out", str(csv), "--quiet"]) == 0
    config = csv.with_suffix(".toml")
    config.write_text(config.read_text() + TRUTH)
    capsys.readouterr()
    out = tmp_path / "out"
    args = ["diagnose", str(config), "--out", str(out), "--no-figures", "--max-steps", "1", "--start", "truth"]
    assert main(args) == 0
    printed = capsys.readouterr()
    final = json.loads((out / "results.json").read_text())["final_coefficients"]
    text = printed.out + printed.err
    assert "closing the loop" in text and "Closing the loop from truth" in text
    from bayesnsi.report.text import format_interval

    for record in final:
        assert f"{record['term']} = {record['estimate']:.4g}, 95 % interval {format_interval(record['ci95'])}" in text


def test_the_answer_quotes_the_final_model_values_and_its_grid():
    # the answer quoted a step's λ = 0.458 while the final model, re-identified on the 4x grid, held 0.367
    from types import SimpleNamespace

    from bayesnsi.models import Term
    from bayesnsi.report.loop import added_sentence

    coefficients = (SimpleNamespace(term=Term("x4**3", 4), value=5.07e6), SimpleNamespace(term=Term("sign(v7)", 7),
                                                                                         value=0.3961))
    step = SimpleNamespace(effect=SimpleNamespace(name="sign(v)", location=(7,)), log_bayes_factor=40.0)

    def diagnosis(upsample):
        loop = SimpleNamespace(final=SimpleNamespace(coefficients=coefficients),
                               final_nsi=SimpleNamespace(upsample=upsample), nsi=SimpleNamespace(upsample=1))
        return SimpleNamespace(loop=loop, added=(step,), start="linear")

    expected = "Final model: x4**3@4 = 5.07e+06, sign(v7)@7 = 0.3961 (re-identified on a 4x finer grid)."
    assert added_sentence(diagnosis(4)).endswith(expected)
    assert added_sentence(diagnosis(1)).endswith("sign(v7)@7 = 0.3961.")
