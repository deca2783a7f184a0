"""Model selection on NSI results: Occam behaviour of the marginal evidence (SPEC 6).

The nested pair {v1|v1|} ⊂ {v1|v1|, x1³} on two-DOF data, where x1³ is truly absent.
The plain ranking (paper Eq. 4) compares maximised likelihoods and has no Occam factor; the
marginal evidence integrates the extra coefficient over its stated prior.
"""

import warnings

import numpy as np

from bayesnsi.evidence import candidate_evidence, compare_evidence
from bayesnsi.exceptions import ConvergenceWarning
from bayesnsi.models import Term
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.simulate import simulate_cases
from tests._helpers.cases import twin_case


def test_evidence_prefers_smaller_nested_model():
    cases = simulate_cases("two-dof", range(10))
    options = EvidenceOptions(compare=())
    evidence_small, plain_big = 0, 0
    for case in cases:
        small = case.candidates[0]
        big = small.with_term(Term("x1**3", 1), name="with x1^3")
        seeds = np.random.SeedSequence(case.seed).spawn(2)
        evidences = {}
        for cand, seed in zip((small, big), seeds):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)  # r_hat just over 1.01 on a seed: not tested here
                res = identify(case.signals, cand, NSIOptions(block_rows=60, order=4))
                evidences[cand.name] = list(candidate_evidence(res, case.signals, options, seed).values())
        table = compare_evidence(evidences)
        evidence_small += table.loc[small.name, "p_ar1"] > 0.5
        plain_big += table.loc[big.name, "p_plain"] > 0.5
    # measured: the evidence (innovations residual, AR(1)) picks the smaller model on 10 of 10
    # seeds (8 of 10 with the open-loop residual); the plain ranking picks the superset on 4 of 10
    assert evidence_small >= 9
    assert plain_big >= 2


def test_negative_stiffness_twin_true_model_ranked_first():
    """On the negative-stiffness twin (SPEC 8.3, seed 0, recommended settings:
    upsample 4) the marginal evidence (AR(1), innovations of the errors-in-variables predictor,
    emcee + bridge sampling) ranks the true Table 8 model 2 first, above the superset model 4
    whose extra α3·sign(ż) is truly absent. Measured (Laplace, seeds 0-4): model 4 below model 2
    by 7.5, 8.1, 4.0, 7.1, 12.6 nat; with the velocity noise from high-order differences it was
    8-10 nat above."""
    case = twin_case(0)
    options = EvidenceOptions(compare=())
    evidences = {}
    for cand, seed in zip(case.candidates, np.random.SeedSequence(0).spawn(len(case.candidates))):
        res = identify(case.signals, cand, case.recommended)
        evidences[cand.name] = list(candidate_evidence(res, case.signals, options, seed).values())
    log_z = {name: ev[0].log_evidence for name, ev in evidences.items()}
    assert max(log_z, key=log_z.get) == "model 2", log_z
    assert log_z["model 2"] - log_z["model 4"] > np.log(20.0)
    table = compare_evidence(evidences)
    assert table.loc["model 2", "p_ar1"] > 0.95
