"""The evidence's stated errors hold: the exact reference, and rms(error / stated error) over seeds.

The exact reference is the quadrature over at most three coefficients of the collapsed integrand
(:func:`bayesnsi.evidence.quadrature_log_evidence`); it is checked here against the closed form
(quadrature over the noise parameters, itself checked against brute force in tests/evidence/test_evidence.py)
wherever both exist. Against it, each sampled path's error divided by its stated Monte-Carlo error
must have an rms of at most 1.3 over seeds of the two-DOF paper case (models 1 and 2, white and AR(1)
residuals; docs/measurements.md has the longer study, ``benchmarks/evidence_errors.py``).
"""


import numpy as np
import pytest

from bayesnsi.evidence import (
    candidate_affine,
    candidate_priors,
    closed_form_log_evidence,
    evidence_from_statistics,
    quadrature_log_evidence,
    sufficient_statistics,
)
from bayesnsi.exceptions import InputDataError
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions
from bayesnsi.simulate.reference import case_setup, run_setup
from tests._helpers.affine import make_affine, make_priors
from tests._helpers.cases import base_seed

QUICK_JOINT = {"n_walkers": 32, "n_steps": 600, "n_burn": 100}  # emcee over all parameters, short runs
RMS_Z = 1.3  # rms of error / stated error over the seeds


@pytest.mark.parametrize(
    ("likelihood", "n_channels", "q", "rho"),
    [("white", 1, 1, 0.0), ("white", 2, 2, 0.0), ("white", 3, 3, 0.0), ("white", 4, 1, 0.0), ("ar1", 1, 3, 0.9),
     ("ar1", 2, 2, 0.5)],
)
def test_quadrature_over_the_coefficients_equals_the_closed_form(likelihood, n_channels, q, rho):
    rng = np.random.default_rng(base_seed() + 401 + 10 * n_channels + q)
    affine = make_affine(1000, n_channels, q, rng, rho=rho, smooth=True)
    priors = make_priors(affine)
    stats = sufficient_statistics(affine, ar_order=1)
    exact = quadrature_log_evidence(stats, priors, likelihood)
    assert exact.error < 1e-8
    assert exact.log_evidence == pytest.approx(closed_form_log_evidence(stats, priors, likelihood), abs=1e-6)


def test_quadrature_runs_at_sixteen_channels_and_refuses_what_it_cannot_do():
    rng = np.random.default_rng(base_seed() + 402)
    affine = make_affine(2000, 16, 3, rng, rho=0.6, smooth=True)
    priors = make_priors(affine)
    stats = sufficient_statistics(affine, ar_order=2)
    for likelihood in ("white", "ar1"):
        exact = quadrature_log_evidence(stats, priors, likelihood)
        assert np.isfinite(exact.log_evidence) and exact.error < 1e-8
        with pytest.raises(InputDataError, match="quadrature"):
            closed_form_log_evidence(stats, priors, likelihood)  # 16 or 32 noise parameters: no closed form
        # the default estimate reports it beside itself, and agrees within its stated error
        result = evidence_from_statistics(stats, priors, likelihood, rng=base_seed() + 7, warn=False)
        assert result.quadrature is not None and result.quadrature.log_evidence == exact.log_evidence
        assert abs(result.log_evidence - exact.log_evidence) <= 4 * result.log_evidence_se
        assert result.laplace_error == pytest.approx(abs(result.laplace_log_evidence - exact.log_evidence))
        assert result.to_dict()["laplace_is_approximation"] is True
    with pytest.raises(InputDataError, match="do not integrate out"):
        quadrature_log_evidence(stats, priors, "ar2")
    four = make_affine(500, 1, 4, rng)
    with pytest.raises(InputDataError, match="at most 3"):
        quadrature_log_evidence(sufficient_statistics(four), make_priors(four))


def _two_dof_statistics(n_seeds: int, duration: float):
    """Statistics and default priors of models 1 and 2 of the two-DOF paper case, per seed."""
    cases = run_setup(case_setup("two-dof", duration=duration), [base_seed() + s for s in range(n_seeds)], 1.0)
    out = []
    for case in cases:
        for index in (0, 1):
            candidate = case.candidates[index]
            result = identify(case.signals, candidate, case.recommended)
            affine = candidate_affine(result, case.signals, "innovations")
            out.append((sufficient_statistics(affine, ar_order=1),
                        candidate_priors(result, case.signals, affine, EvidenceOptions(), candidate)))
    return out


def test_stated_errors_hold_over_seeds_on_the_two_dof_case():
    """10 seeds x models 1 and 2 x white and AR(1): rms z <= 1.3 for the default and the joint path."""
    z = {"collapsed": [], "joint": []}
    root = np.random.SeedSequence(base_seed() + 403)
    for stats, priors in _two_dof_statistics(10, 30.0):
        for likelihood in ("white", "ar1"):
            exact = quadrature_log_evidence(stats, priors, likelihood).log_evidence
            default_seed, joint_seed = root.spawn(2)
            default = evidence_from_statistics(stats, priors, likelihood, rng=np.random.default_rng(default_seed),
                                               warn=False, closed_form=False)
            joint = evidence_from_statistics(stats, priors, likelihood, rng=np.random.default_rng(joint_seed),
                                             warn=False, closed_form=False, collapse=False, **QUICK_JOINT)
            assert joint.sampler.parameters == "all parameters" and joint.sampler.n_steps == 600
            for path, result in (("collapsed", default), ("joint", joint)):
                z[path].append((result.log_evidence - exact) / result.log_evidence_se)
    for path, values in z.items():
        values = np.asarray(values)
        assert values.size == 40
        assert np.sqrt(np.mean(values**2)) <= RMS_Z, (path, np.round(values, 2))
