"""A failure of the intervals is not a failure of the candidate: the evidence is kept (nothing is lost)."""

import bayesnsi.uncertainty
from bayesnsi.exceptions import BlockRowsError
from bayesnsi.options import EvidenceOptions
from bayesnsi.run import run_candidates
from bayesnsi.simulate import simulate_case

FAST = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=())


def test_failed_intervals_keep_the_evidence(monkeypatch):
    case = simulate_case("two-dof", seed=0)

    def too_short(*args, **kwargs):
        raise BlockRowsError("record windows too short for the block rows")

    monkeypatch.setattr(bayesnsi.uncertainty, "candidate_intervals", too_short)
    (outcome,) = run_candidates(case.signals, case.candidates[:1], case.recommended, FAST)
    assert outcome.error is None and outcome.failed_stage is None
    assert outcome.evidences is not None and "white" in outcome.evidences
    assert outcome.intervals is None
    assert any("intervals not computed" in f.message and "evidence is kept" in f.message for f in outcome.findings)


def test_a_bug_in_the_intervals_still_fails_the_candidate(monkeypatch):
    case = simulate_case("two-dof", seed=0)

    def bug(*args, **kwargs):
        raise KeyError("bug")

    monkeypatch.setattr(bayesnsi.uncertainty, "candidate_intervals", bug)
    (outcome,) = run_candidates(case.signals, case.candidates[:1], case.recommended, FAST)
    assert outcome.failed_stage == "internal"
    assert outcome.evidences is None
