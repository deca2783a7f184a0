"""``diagnose --start`` (issue 14): results.json keeps the ranking's selection beside the start.

Before the fix the payload's ``selected`` was overwritten with the ``--start`` candidate, so that the
EMPS run from a linear start said "selected: linear" while the ranking gave another model P = 1.
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
