"""The whiteness test ``select`` reports is computed with each candidate's evidence, on the residual the
evidence scored, and equals the test run afresh on the identified model (residual_whiteness)."""

import numpy as np
import pytest

from bayesnsi import simulate_case
from bayesnsi.checks.validation import residual_whiteness
from bayesnsi.options import EvidenceOptions
from bayesnsi.run import run_candidates

FAST = dict(n_steps=200, n_burn=50, likelihood="white", compare=())


@pytest.mark.parametrize("residual", ["innovations", "reconstruction"])
def test_outcome_whiteness_equals_a_fresh_test(residual):
    case = simulate_case("two-dof", seed=0, duration=20.0)
    outcomes = run_candidates(case.signals, case.candidates[:2], case.recommended,
                              EvidenceOptions(residual=residual, **FAST))
    for outcome in outcomes:
        fresh = residual_whiteness(outcome.result, case.signals, residual)
        assert outcome.whiteness is not None and outcome.whiteness.residual == residual
        np.testing.assert_allclose(outcome.whiteness.statistic, fresh.statistic, rtol=1e-12)
        np.testing.assert_allclose(outcome.whiteness.p_value, fresh.p_value, rtol=1e-9, atol=1e-300)
    # and it still tells the true model (white innovations) from the wrong one
    if residual == "innovations":
        assert outcomes[0].whiteness.adequate and not outcomes[1].whiteness.adequate


def test_no_whiteness_without_evidence():
    case = simulate_case("two-dof", seed=0, duration=10.0)
    (outcome,) = run_candidates(case.signals, case.candidates[:1], case.recommended, None)
    assert outcome.whiteness is None
