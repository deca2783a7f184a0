"""Command line, in-process: simulate -> identify/select, results.json (SPEC 9), report, errors."""

import json

import pytest

from bayesnsi.cli import main

SPEC9_CANDIDATE_FIELDS = {
    "name", "terms", "coefficients", "modes", "nrmse", "log_likelihood_gaussian", "posterior_gaussian",
    "log_evidence", "log_evidence_se", "posterior", "rhat_max", "ess_min",
}


@pytest.fixture(scope="module")
def two_dof_config(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli")
    assert main(["simulate", "two-dof", "--seed", "3", "--out", str(folder / "two_dof.csv"), "--quiet"]) == 0
    return folder / "two_dof.toml"


def test_select_writes_spec9_results_and_report(two_dof_config, tmp_path):
    out = tmp_path / "sel"
    assert main(["select", str(two_dof_config), "--out", str(out), "--quiet"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["selected"] == "model 1"
    assert {"selected", "candidates", "settings", "versions"} <= set(results)
    for cand in results["candidates"]:
        assert SPEC9_CANDIDATE_FIELDS <= set(cand), SPEC9_CANDIDATE_FIELDS - set(cand)
        for coef in cand["coefficients"]:
            assert {"expr", "at", "value", "imag_ratio", "ci95"} <= set(coef)
            assert coef["ci95"][0] <= coef["value"] <= coef["ci95"][1] or cand["name"] != "model 1"
        for mode in cand["modes"]:
            assert {"frequency_hz", "damping_ratio"} <= set(mode)  # intervals may follow
    probabilities = [c["posterior"] for c in results["candidates"]]
    assert sum(probabilities) == pytest.approx(1.0)
    assert results["candidates"][0]["posterior"] > 0.95
    assert results["versions"]["numpy"]
    html = (out / "report.html").read_text()
    # the answer first (selected model, how sure, against which candidates), the versions last
    headings = [h.split(">", 1)[1].split("<", 1)[0] for h in html.split("<h2")[1:]]
    assert headings[0] == "Answer" and headings[-1] == "Versions", headings
    assert [h.split(" (")[0] for h in headings[:4]] == ["Answer", "Evidence and adequacy of every candidate",
                                                        "Intervals of coefficients and modes", "Identified models"]
    answer = html.split("<h2")[1]
    assert "Selected: model 1, posterior probability" in answer and "log Bayes factor" in answer
    assert all(c["name"] in answer for c in results["candidates"])  # against every other candidate
    # readable headers: no raw field names of the ranking table or the arviz summary
    for raw in ("p_ar1", "log_evidence_", "p_plain", "hdi95_lb", "ess_bulk", "nrmse_before"):
        assert raw not in html, raw
    # every table: answer, ranking, adequacy, model check, modes, coefficients, NRMSE, one arviz summary per
    # candidate, the intervals of coefficients and of modes
    n_cand = len(results["candidates"])
    assert html.count("<table") == 7 + n_cand + 2
    assert "residual / noise, worst channel" in html  # the model check table
    assert html.count("class='scroll'") == html.count("<table")  # wide tables scroll, the page does not widen
    assert "Ljung-Box" in html and all(c["adequacy"]["p_value"] for c in results["candidates"])
    # Bayes factors, band ratios, one FRF figure, λ(ω) of every candidate in one figure, the first candidate's
    # singular values beside its stabilisation diagram, the overlays of two channels side by side, the posterior of
    # each candidate
    assert html.count("<img") == 1 + 1 + 1 + 1 + 1 + 1 + n_cand
    assert "over the noise it passes on, per frequency band" in html
    check = results["candidates"][0]["model_check"]  # the truth: near 1 in every band (measured 1.10)
    assert check["band_ratio"] < 1.5 and len(check["band_ratios"]) == len(check["band_edges_hz"]) - 1
    assert "units from the data file: force in N, displacement in m" in html  # simulate writes a units row
    assert html.index("numpy") > html.index("Coefficient posteriors") and "data:image/png;base64," in html
    # the posterior draws of every candidate, as netCDF that arviz reads
    from bayesnsi.io.posterior import read_posterior

    assert set(results["posterior_files"]) == {c["name"] for c in results["candidates"]}
    tree = read_posterior(out / results["posterior_files"]["model 1"])
    lo, hi = results["candidates"][0]["coefficients"][0]["ci95_given_linear_part"]
    assert lo < float(tree["posterior"]["coefficient"].mean()) < hi


def test_identify_and_existing_output(two_dof_config, tmp_path, capsys):
    out = tmp_path / "id"
    assert main(["identify", str(two_dof_config), "--out", str(out), "--quiet", "--no-figures"]) == 0
    first = (out / "results.json").read_bytes()
    # a second run without --force refuses and keeps the earlier results
    assert main(["identify", str(two_dof_config), "--out", str(out), "--quiet"]) == 2
    assert "--force" in capsys.readouterr().err
    assert (out / "results.json").read_bytes() == first


def test_failed_candidate_is_reported_and_others_complete(two_dof_config, tmp_path):
    text = two_dof_config.read_text()
    text += '\n[[candidates]]\nname = "constant"\nterms = [{ expr = "x1 - x1 + 1e-300*x1", at = 1 }]\n'
    config = tmp_path / "cfg.toml"
    config.write_text(text.replace('file = "two_dof.csv"', f'file = "{two_dof_config.with_suffix(".csv")}"'))
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out), "--quiet", "--no-figures"]) == 0
    records = {c["name"]: c for c in json.loads((out / "results.json").read_text())["candidates"]}
    assert records["constant"]["status"] == "failed" and "identifiable" in records["constant"]["error"]
    assert records["model 1"]["status"] == "ok"


def test_every_candidate_failing_exits_2_and_keeps_the_errors(two_dof_config, tmp_path, capsys):
    # not exit 0 with "selected: None" when every candidate failed
    text = two_dof_config.read_text().split("[[candidates]]")[0]
    text += '\n[[candidates]]\nname = "constant"\nterms = [{ expr = "x1 - x1 + 1e-300*x1", at = 1 }]\n'
    config = tmp_path / "cfg.toml"
    config.write_text(text.replace('file = "two_dof.csv"', f'file = "{two_dof_config.with_suffix(".csv")}"'))
    out = tmp_path / "out"
    capsys.readouterr()
    assert main(["select", str(config), "--out", str(out), "--quiet", "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no candidate could be identified" in err and "Traceback" not in err
    records = json.loads((out / "results.json").read_text())["candidates"]
    assert records[0]["status"] == "failed" and "identifiable" in records[0]["error"]


@pytest.mark.parametrize(
    "edit, message",
    [
        (("block_rows = 60", "block_rows = 600"), "too few"),
        (('expr = "v1*abs(v1)"', 'expr = "__import__(1)"'), "unknown name"),
        (("[nsi]", "[nsi]\nbogus = 1"), "bogus"),
    ],
)
def test_bad_input_exits_2_with_one_line(two_dof_config, tmp_path, capsys, edit, message):
    config = tmp_path / "bad.toml"
    text = two_dof_config.read_text().replace(*edit)
    config.write_text(text.replace('file = "two_dof.csv"', f'file = "{two_dof_config.with_suffix(".csv")}"'))
    code = main(["select", str(config), "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2  # "too few": every candidate fails; results.json keeps each error
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    for command in ("simulate", "identify", "select", "demo"):
        assert command in out


def test_select_is_reproducible_and_independent_of_jobs(two_dof_config, tmp_path):
    """Same config and seed: identical numbers on rerun and with --jobs 1 vs --jobs 2."""
    numbers = []
    for run, jobs in enumerate(["1", "1", "2"]):
        out = tmp_path / f"run{run}"
        assert main(["select", str(two_dof_config), "--out", str(out), "--quiet", "--no-figures", "--jobs", jobs]) == 0
        results = json.loads((out / "results.json").read_text())
        numbers.append(
            [
                (c["name"], c["log_evidence"], c["posterior"], [k["value"] for k in c["coefficients"]], c["nrmse"])
                for c in results["candidates"]
            ]
        )
        assert results["settings"]["seed"] == 3 and results["versions"]["bayesnsi"]
    assert numbers[0] == numbers[1] == numbers[2]
