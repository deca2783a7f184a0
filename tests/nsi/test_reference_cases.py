"""Paper reference cases (SPEC 8): NSI against the simulators' exact values.

Exact references: modal parameters of the simulators' M, C, K (eig of the state matrix) and
the true coefficients used in the simulation. Tolerances are the acceptance criteria of docs/accuracy.md.
"""

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import BayesNSIError, SpuriousPoleWarning
from bayesnsi.nsi import identify
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.simulate import simulate_case, simulate_cases
from tests._helpers.cases import twin_case

N_SEEDS = 20


def _identify(signals, candidate, options=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)
        return identify(signals, candidate, options)


def _modal_errors(result, case):
    """Relative errors of identified modes against the nearest exact mode."""
    exact_f, exact_z = case.exact_frequencies_hz, case.exact_damping_ratios
    f = np.array([m.frequency_hz for m in result.modes])
    z = np.array([m.damping_ratio for m in result.modes])
    nearest = np.array([np.argmin(np.abs(exact_f - fi)) for fi in f])
    return f, f / exact_f[nearest] - 1, z / exact_z[nearest] - 1, nearest


@pytest.fixture(scope="module")
def two_dof_10s():
    cases = simulate_cases("two-dof", range(N_SEEDS))
    results = [[_identify(c.signals, cand, NSIOptions(block_rows=60, order=4)) for cand in c.candidates] for c in cases]
    return cases, results


@pytest.fixture(scope="module")
def two_dof_100s():
    cases = simulate_cases("two-dof", range(N_SEEDS), duration=100.0)
    options = NSIOptions(block_rows=60, order=4)
    results = [[_identify(c.signals, cand, options) for cand in c.candidates[:2]] for c in cases]
    return cases, results


def test_two_dof_paper_settings(two_dof_10s):
    """10 s, 2 % noise, 20 seeds: f_n within 0.5 % every seed; α mean error ≤ 2 %, sd ≤ 4 %."""
    cases, results = two_dof_10s
    alpha_errors = []
    for case, (true_model, *_) in zip(cases, results):
        _, f_err, _, nearest = _modal_errors(true_model, case)
        assert sorted(nearest) == [0, 1]
        assert np.max(np.abs(f_err)) < 0.005
        alpha_errors.append(true_model.coefficient_values[0] / case.true_coefficients[0] - 1)
    alpha_errors = np.array(alpha_errors)
    assert abs(alpha_errors.mean()) < 0.02
    assert alpha_errors.std() < 0.04


def test_two_dof_long_records(two_dof_100s):
    """100 s records: α within 2 % and damping ratios within 5 % on every seed."""
    cases, results = two_dof_100s
    for case, (true_model, _) in zip(cases, results):
        _, f_err, z_err, _ = _modal_errors(true_model, case)
        assert abs(true_model.coefficient_values[0] / 20.0 - 1) < 0.02
        assert np.max(np.abs(z_err)) < 0.05


def test_two_dof_wrong_candidates_fit_worse(two_dof_10s, two_dof_100s):
    """Paper Tables 3-4: Coulomb-only model misfits; the superset's Coulomb term is negligible."""
    cases, results = two_dof_100s
    for case, (true_model, coulomb) in zip(cases, results):
        nrmse_true = true_model.reconstruct(case.signals).nrmse
        assert coulomb.reconstruct(case.signals).nrmse > 1.5 * nrmse_true
        _, _, z_err, _ = _modal_errors(coulomb, case)
        assert np.max(np.abs(z_err)) > 0.5  # damping of the wrong model is far off (paper: 272-633 %)
    cases, results = two_dof_10s
    force_rms = 10.0
    for _, _, superset in results:
        coulomb_term = superset.coefficients[1]
        # the sign(v1) force it claims is < 1 % of the excitation (paper: 0.17 N, ranked out)
        assert abs(coulomb_term.value) < 0.01 * force_rms


@pytest.fixture(scope="module")
def beam():
    case = simulate_case("beam", seed=0)
    options = NSIOptions(block_rows=60, order=32, band_hz=(1.0, 30.0), bd_method="output-error")
    results = {}
    for cand in case.candidates:
        try:
            results[cand.name] = _identify(case.signals, cand, options)
        except BayesNSIError as err:
            results[cand.name] = err
    return case, results


def test_beam_frequencies(beam):
    """Identified modes between 1 and 80 Hz within 0.1 % of the exact ones (0.509 Hz mode reported apart)."""
    case, results = beam
    true_model = results["model 3"]
    f, f_err, _, nearest = _modal_errors(true_model, case)
    in_band = (f > 1.0) & (f < 80.0)
    assert len(set(nearest[in_band])) >= 14  # of the 15 exact modes above 1 Hz
    assert np.max(np.abs(f_err[in_band])) < 0.001


def test_beam_wrong_candidates_clearly_worse(beam):
    """Tables 6-7: x|x| alone and x³ alone give unstable or much worse models."""
    case, results = beam
    nrmse_true = results["model 3"].reconstruct(case.signals).nrmse
    for name in ("model 1", "model 2"):
        res = results[name]
        if isinstance(res, BayesNSIError):
            continue  # unstable underlying model: rejected with its reason
        try:
            assert res.reconstruct(case.signals).nrmse > 3 * nrmse_true
        except BayesNSIError:
            pass


def test_beam_evidence_selects_the_true_model(beam):
    """On the beam, candidate {x13², x13³} (model 3) gets posterior > 0.95
    under the marginal evidence (AR(1), emcee + bridge sampling); models 1 and 2 are either
    rejected as unstable (their reason kept) or scored."""
    from bayesnsi.evidence import candidate_evidence, compare_evidence

    case, results = beam
    options = EvidenceOptions(compare=())
    evidences = {}
    for (name, res), seed in zip(results.items(), np.random.SeedSequence(0).spawn(len(results))):
        if isinstance(res, BayesNSIError):
            assert str(res)  # a failed candidate carries its reason
            evidences[name] = None
            continue
        evidences[name] = list(candidate_evidence(res, case.signals, options, seed).values())
    table = compare_evidence(evidences)
    assert table.loc["model 3", "p_ar1"] > 0.95, table


BEAM_SETTINGS = NSIOptions(
    block_rows=40,
    order=32,
    band_hz=(1.0, 30.0),
    bd_method="prediction-error",
    refine_poles=(1.5, 85.0),
    c_method="prediction-error",
)


SPEC_FREQUENCY = 0.003  # SPEC §8.2: natural frequencies within 0.3 %, k2 and k3 within about 1 %
BEAM_DAMPING = 0.05  # damping of every identified 1-80 Hz mode within 5 %


def _assert_beam_criterion(result, case):
    """One identification: at least 14 of the 15 in-band modes (the 10.55 Hz mode, half of a close pair, is
    missed), each within SPEC §8.2's 0.3 % in frequency and 5 % in damping, k2, k3 within 1 %. A single
    record's frequency errors scatter: the 10.1 Hz mode beside its unresolved partner reads +0.065 % with sd
    0.018 % over seeds 0-7, so the tighter 0.1 % is a property of the method checked on the mean over seeds
    (test_beam_mean_modal_errors_over_seeds)."""
    f, f_err, z_err, nearest = _modal_errors(result, case)
    in_band = (f > 1.0) & (f < 80.0)
    assert len(set(nearest[in_band])) >= 14
    assert np.max(np.abs(f_err[in_band])) < SPEC_FREQUENCY
    assert np.max(np.abs(z_err[in_band])) < BEAM_DAMPING
    np.testing.assert_allclose(result.coefficient_values, case.true_coefficients, rtol=0.01)


def test_beam_damping_and_coefficients(beam):
    """One identification (seed 0): frequencies within 0.3 %, damping within 5 %, k2 and k3 within 1 %, with
    poles refined by output error (refine_poles), C re-fitted to them and B, D by prediction error
    (c_method, bd_method "prediction-error"). benchmarks/beam_bias.py, seeds 0-7: k within 0.45 %,
    damping within 2.7-5.4 %, frequencies within 0.048-0.102 % (docs/measurements.md, c_method)."""
    case, _ = beam
    _assert_beam_criterion(_identify(case.signals, case.candidate("model 3"), BEAM_SETTINGS), case)


@pytest.mark.slow
def test_beam_mean_modal_errors_over_seeds():
    """The method over seeds 0-7 (benchmarks/beam_bias.py): each in-band mode's mean error within 0.1 % in
    frequency and 5 % in damping (measured worst: 0.065 % and 2.7 %), k2 and k3 within 1 % on every seed
    (measured at most 0.45 %)."""
    errors = []
    for seed in range(8):
        case = simulate_case("beam", seed=seed)
        result = _identify(case.signals, case.candidate("model 3"), BEAM_SETTINGS)
        np.testing.assert_allclose(result.coefficient_values, case.true_coefficients, rtol=0.01)
        f, f_err, z_err, nearest = _modal_errors(result, case)
        in_band = (f > 1.0) & (f < 80.0)
        errors += [(int(k), fe, ze) for k, fe, ze in zip(nearest[in_band], f_err[in_band], z_err[in_band])]
    for mode in {k for k, _, _ in errors}:
        f_mean = np.mean([fe for k, fe, _ in errors if k == mode])
        z_mean = np.mean([ze for k, _, ze in errors if k == mode])
        assert abs(f_mean) < 0.001 and abs(z_mean) < BEAM_DAMPING, (mode, f_mean, z_mean)


def _beam_prediction_error(case, block_rows=40):
    options = NSIOptions(block_rows=block_rows, order=32, band_hz=(1.0, 30.0), bd_method="prediction-error")
    return _identify(case.signals, case.candidate("model 3"), options)


def test_beam_coefficients_prediction_error(beam):
    """k2, k3 within 1 % (SPEC §8.2) with the errors-in-variables B/D step (seed 0)."""
    case, _ = beam
    result = _beam_prediction_error(case)
    np.testing.assert_allclose(result.coefficient_values, case.true_coefficients, rtol=0.01)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_beam_coefficients_prediction_error_seeds(seed):
    """k2, k3 within 1 % on further seeds (benchmarks/beam_bias.py: output-error is off by up to 5.6 %)."""
    case = simulate_case("beam", seed=seed)
    result = _beam_prediction_error(case)
    np.testing.assert_allclose(result.coefficient_values, case.true_coefficients, rtol=0.01)




def test_beam_damping_refined_poles(beam):
    """identify(refine_poles=...) (output error on band-passed data): damping of every identified
    1-80 Hz mode within 5 %, frequencies within SPEC §8.2's 0.3 % (seed 0; seeds 0-4 in benchmarks/beam_bias.py:
    at most 3.1-5.4 %, against 8.8-17.9 % from the subspace A, which is why the subspace A alone misses the
    5 % criterion). The 10.55 Hz mode is still missed. k2, k3 need c_method="prediction-error" with it
    (test_beam_damping_and_coefficients)."""
    case, _ = beam
    options = NSIOptions(
        block_rows=40, order=32, band_hz=(1.0, 30.0), bd_method="output-error", refine_poles=(1.5, 85.0)
    )
    result = _identify(case.signals, case.candidate("model 3"), options)
    f, f_err, z_err, nearest = _modal_errors(result, case)
    in_band = (f > 1.0) & (f < 80.0)
    assert len(set(nearest[in_band])) >= 14
    assert np.max(np.abs(f_err[in_band])) < SPEC_FREQUENCY
    assert np.max(np.abs(z_err[in_band])) < BEAM_DAMPING


@pytest.mark.parametrize("seed", [0, 1])
def test_negative_stiffness_twin_model_2(seed):
    """Table 8 model 2: k1 (static FRF), k2, k3, α1, α2 within 3 %."""
    case = twin_case(seed)
    result = _identify(case.signals, case.candidate("model 2"), NSIOptions(block_rows=40, order=2, band_hz=(5.0, 20.0)))
    k1 = 1.0 / result.underlying_frf([0.0])[0, 0, 0].real
    assert k1 == pytest.approx(case.K[0, 0], rel=0.03)
    np.testing.assert_allclose(result.coefficient_values, case.true_coefficients, rtol=0.03)


def test_negative_stiffness_twin_upsampled_identification():
    """identify(upsample=4) resolves the sign() friction between samples: every coefficient of
    Table 8 model 2 within 1 % (against the simulator's exact values; the default sampled
    identification gives α1 -2.1 %, benchmarks/upsample.py), reconstructed at the data's samples."""
    case = twin_case(0)
    model_2 = case.candidate("model 2")
    sampled = _identify(case.signals, model_2, NSIOptions(block_rows=40, order=2, band_hz=(5.0, 20.0)))
    fine = _identify(case.signals, model_2, NSIOptions(block_rows=80, order=2, band_hz=(5.0, 20.0), upsample=4))
    np.testing.assert_allclose(fine.coefficient_values, case.true_coefficients, rtol=0.01)
    assert abs(fine.coefficient_values[2] / case.true_coefficients[2] - 1) < 0.5 * abs(
        sampled.coefficient_values[2] / case.true_coefficients[2] - 1
    )
    rec = fine.reconstruct(case.signals)
    assert rec.predicted.shape == case.signals.displacement.shape
    assert rec.nrmse < sampled.reconstruct(case.signals).nrmse
    assert fine.settings["upsample"] == 4 and fine.settings["fs"] == case.signals.fs
