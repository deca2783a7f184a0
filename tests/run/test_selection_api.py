"""The library-level selection: select() -> Selection, and its results.json record.

Reference: the paper's two-DOF case (SPEC 8.1), where the true model ("model 1", the cubic
stiffness at DOF 1) is selected; the numbers compared here are those of the lower-level calls
(identify, candidate_evidence, compare_evidence) made by hand, which select must reproduce.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from bayesnsi import EvidenceOptions, NSIOptions, select, simulate_case
from bayesnsi.evidence import candidate_evidence, compare_evidence
from bayesnsi.exceptions import ArgumentTypeError, NotIdentifiableError
from bayesnsi.io import selection_payload
from bayesnsi.nsi import identify

NSI = NSIOptions(block_rows=40, order=4)
FAST = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=(), seed=3)


@pytest.fixture(scope="module")
def case():
    return simulate_case("two-dof", seed=0, duration=10.0)


@pytest.fixture(scope="module")
def selection(case):
    segments = [("second half", case.signals.segment(case.signals.n_samples // 2, case.signals.n_samples))]
    return select(case.signals, case.candidates, NSI, FAST, validation=segments)


def test_selection_reproduces_the_lower_level_calls(case, selection):
    assert [o.name for o in selection.outcomes] == [c.name for c in case.candidates]
    seeds = np.random.SeedSequence(FAST.seed).spawn(len(case.candidates))
    by_hand = {}
    for candidate, seed, outcome in zip(case.candidates, seeds, selection.outcomes):
        result = identify(case.signals, candidate, NSI)
        evidence = candidate_evidence(result, case.signals, FAST, seed, candidate, warn=False)
        by_hand[candidate.name] = list(evidence.values())
        assert outcome.status == "ok"
        assert outcome.evidences["white"].log_evidence == evidence["white"].log_evidence
        assert [c.value for c in outcome.result.coefficients] == [c.value for c in result.coefficients]
    rng = np.random.default_rng(np.random.SeedSequence(FAST.seed).spawn(len(case.candidates) + 1)[-1])
    table = compare_evidence(by_hand, priors=[c.prior for c in case.candidates], rng=rng)
    assert np.array_equal(table["p_white"].to_numpy(), selection.table["p_white"].to_numpy())
    assert selection.selected == table["p_white"].idxmax() == "model 1"  # the true model (SPEC 8.1)
    assert selection.selected_gaussian == table["p_plain"].idxmax()
    assert set(selection.results) == set(selection.evidences) == {c.name for c in case.candidates}
    assert [e.name for e in selection.validation["model 1"]] == ["second half"]
    assert selection.validation["model 1"][0].nrmse < 0.05
    # adequacy (Ljung-Box on the innovations): the true model leaves a white residual, the others not
    assert selection.adequacy["model 1"].adequate
    assert not selection.adequacy["model 2"].adequate and not selection.adequacy["model 3"].adequate


def test_evidence_failure_keeps_the_identification(case, monkeypatch):
    import bayesnsi.evidence as evidence_module  # the run layer imports candidate_evidence where it is used

    original = evidence_module.candidate_evidence

    def fail_for_model_2(result, signals, options, seed_sequence, candidate=None, **keywords):
        if result.candidate.name == "model 2":
            raise NotIdentifiableError("simulated evidence failure")
        return original(result, signals, options, seed_sequence, candidate, **keywords)

    monkeypatch.setattr(evidence_module, "candidate_evidence", fail_for_model_2)
    selection = select(case.signals, case.candidates, NSI, FAST)
    failed = selection.outcome("model 2")
    assert failed.status == "evidence_failed" and failed.failed_stage == "evidence"
    assert failed.result is not None and failed.evidences is None and "simulated" in failed.error
    assert selection.selected == "model 1" and "model 2" in selection.results


def test_selection_payload_is_json_with_evidence_and_validation(case, selection, tmp_path):
    config = type("Config", (), {"path": Path("two_dof.toml"), "raw": {}, "seed": 3, "nsi": NSI})()
    payload = json.loads(json.dumps(selection_payload(selection, "select", config)))
    assert payload["selected"] == "model 1" and payload["likelihood"] == "white"
    records = {r["name"]: r for r in payload["candidates"]}
    assert records["model 1"]["posterior"] == pytest.approx(float(selection.table.loc["model 1", "p_white"]))
    assert all(c["ci95"] is not None for c in records["model 1"]["coefficients"])
    assert payload["validation"][0]["name"] == "second half"
    assert records["model 1"]["adequacy"]["adequate"] and not records["model 2"]["adequacy"]["adequate"]
    assert payload["settings"]["evidence"] == FAST.to_dict()


def test_options_of_the_wrong_type_are_refused(case):
    with pytest.raises(ArgumentTypeError, match="nsi must be a NSIOptions, got dict"):
        select(case.signals, case.candidates, {"block_rows": 40}, FAST)
    with pytest.raises(ArgumentTypeError, match="execution must be a ExecutionOptions"):
        select(case.signals, case.candidates, NSI, FAST, execution={"jobs": 2})
