"""Innovations (one-step-ahead predictor) form of the affine reconstruction, SPEC 6 and 10."""

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import SpuriousPoleWarning
from bayesnsi.nsi import affine_reconstruction, identify, predictor_reconstruction
from bayesnsi.simulate import simulate_case


def _identify(signals, candidate, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)
        return identify(signals, candidate, **kw)


@pytest.fixture(scope="module")
def two_dof():
    case = simulate_case("two-dof", seed=3, duration=30.0)
    return case, _identify(case.signals, case.candidate("model 1"), block_rows=60, order=4)


def test_innovations_are_white_at_the_measurement_noise_level(two_dof):
    """Independent reference: the simulator's own noise (noisy minus clean displacements)."""
    case, result = two_dof
    affine = predictor_reconstruction(result, case.signals)
    innovations = affine.measured - affine.predict(affine.estimate)
    noise_std = (case.signals.displacement - case.clean.displacement).std(axis=0)
    np.testing.assert_allclose(innovations[100:].std(axis=0), noise_std, rtol=0.15)
    open_loop = affine_reconstruction(result, case.signals)
    residual = open_loop.measured - open_loop.predict(open_loop.estimate)
    assert np.all(innovations.std(axis=0) < residual.std(axis=0))  # the predictor also uses the measured past
    for channel in range(2):
        assert abs(np.corrcoef(innovations[1:, channel], innovations[:-1, channel])[0, 1]) < 0.2


def test_innovations_are_affine_in_the_coefficients(two_dof):
    """Superposition: ŷ(λ) - ŷ(0) scales with λ (a fixed predictor gain)."""
    case, result = two_dof
    affine = predictor_reconstruction(result, case.signals)
    lam = affine.estimate
    np.testing.assert_allclose(
        affine.predict(2 * lam) - affine.predict(0 * lam), 2 * (affine.predict(lam) - affine.predict(0 * lam)), atol=1e-12
    )
    assert affine.signatures.shape == case.signals.displacement.shape + (1,)


def test_without_nonlinear_inputs_the_predictor_is_the_open_loop_reconstruction(two_dof):
    """No term carries measurement noise into the state (Q = 0): K = 0, innovations = open-loop residual."""
    case, _ = two_dof
    linear = _identify(case.signals, None, block_rows=60, order=4)
    predictor = predictor_reconstruction(linear, case.signals)
    open_loop = affine_reconstruction(linear, case.signals)
    scale = np.abs(open_loop.measured).max()
    np.testing.assert_allclose(predictor.predict([]), open_loop.predict([]), atol=1e-6 * scale)


def test_upsampled_result_predicts_at_the_data_samples():
    case = simulate_case("negative-stiffness", seed=1, duration=20.0)
    result = _identify(case.signals, case.candidate("model 2"), block_rows=40, order=2, band_hz=(5.0, 20.0), upsample=2)
    affine = predictor_reconstruction(result, case.signals)
    assert affine.measured.shape == case.signals.displacement.shape
    innovations = affine.measured - affine.predict(affine.estimate)
    noise_std = (case.signals.displacement - case.clean.displacement).std()
    assert innovations[50:].std() == pytest.approx(noise_std, rel=0.25)
