"""Innovations (one-step-ahead predictor) form of the affine reconstruction, SPEC 6 and 10."""

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import SpuriousPoleWarning
from bayesnsi.nsi import affine_reconstruction, identify, predictor_reconstruction
from bayesnsi.options import NSIOptions
from bayesnsi.simulate import simulate_case
from tests._helpers.cases import twin_case


def _identify(signals, candidate, options=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)
        return identify(signals, candidate, options)


@pytest.fixture(scope="module")
def two_dof():
    case = simulate_case("two-dof", seed=3, duration=30.0)
    return case, _identify(case.signals, case.candidate("model 1"), NSIOptions(block_rows=60, order=4))


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
    zero = affine.predict(0 * lam)
    np.testing.assert_allclose(affine.predict(2 * lam) - zero, 2 * (affine.predict(lam) - zero), atol=1e-12)
    assert affine.signatures.shape == case.signals.displacement.shape + (1,)


def test_without_nonlinear_inputs_the_predictor_is_the_open_loop_reconstruction(two_dof):
    """No term carries measurement noise into the state (Q = 0): K = 0, innovations = open-loop residual."""
    case, _ = two_dof
    linear = _identify(case.signals, None, NSIOptions(block_rows=60, order=4))
    predictor = predictor_reconstruction(linear, case.signals)
    open_loop = affine_reconstruction(linear, case.signals)
    scale = np.abs(open_loop.measured).max()
    np.testing.assert_allclose(predictor.predict([]), open_loop.predict([]), atol=1e-6 * scale)


def test_upsampled_result_predicts_at_the_data_samples():
    case = simulate_case("negative-stiffness", seed=1, duration=20.0)
    options = NSIOptions(block_rows=40, order=2, band_hz=(5.0, 20.0), upsample=2)
    result = _identify(case.signals, case.candidate("model 2"), options)
    affine = predictor_reconstruction(result, case.signals)
    assert affine.measured.shape == case.signals.displacement.shape
    innovations = affine.measured - affine.predict(affine.estimate)
    noise_std = (case.signals.displacement - case.clean.displacement).std()
    assert innovations[50:].std() == pytest.approx(noise_std, rel=0.25)


def test_measured_noise_std_from_channel_consistency():
    """Independent reference: the simulator's own noise. On the negative-stiffness twin the velocity
    has broadband content (base excitation, friction): high-order differences overestimate its
    noise 10×, the displacement-velocity consistency fit does not."""
    from bayesnsi.noise import measured_noise_std, white_noise_std

    case = twin_case(0)
    true_disp = (case.signals.displacement - case.clean.displacement).std(axis=0)
    true_vel = (case.signals.velocity - case.clean.velocity).std(axis=0)
    disp, vel = measured_noise_std(case.signals)
    np.testing.assert_allclose(disp, true_disp, rtol=0.05)
    np.testing.assert_allclose(vel, true_vel, rtol=0.10)
    assert white_noise_std(case.signals.velocity)[0] > 5 * true_vel[0]  # what the consistency fit replaces


def test_twin_innovations_are_white():
    """With the channel noise from the consistency fit, the errors-in-variables predictor of the
    true twin model (Table 8 model 2, upsample 4) leaves white innovations (measured: lag 1-5
    autocorrelation within ±0.03; with the difference-based velocity noise it was -0.08 at lags 1-3)."""
    case = twin_case(0)
    result = _identify(case.signals, case.candidate("model 2"), case.recommended)
    affine = predictor_reconstruction(result, case.signals)
    e = (affine.measured - affine.predict(affine.estimate))[100:, 0]
    e = e - e.mean()
    acf = np.array([np.dot(e[k:], e[:-k]) / np.dot(e, e) for k in range(1, 6)])
    assert np.all(np.abs(acf) < 0.05), acf


def test_prediction_error_on_an_upsampled_record_with_friction():
    # An upsampled record's noise is band-limited to the data's Nyquist frequency, so the
    # displacement-velocity consistency fit meets empty spectral bins: it must fall back to the
    # difference estimate instead of failing (it raised LinAlgError, with LAPACK messages).
    # Reference: the simulated coefficients of the undeclared-effect case (quadratic damping 20,
    # Coulomb 1 N at DOF 2).
    from bayesnsi.noise import measured_noise_std
    from bayesnsi.preprocess import upsample
    from bayesnsi.simulate.undeclared import undeclared_case

    case = undeclared_case("coulomb-dof2", seed=0, noise_percent=2.0)
    disp, vel = measured_noise_std(upsample(case.signals, 2))
    assert np.all(np.isfinite(disp)) and np.all(disp > 0) and np.all(np.isfinite(vel))
    options = NSIOptions(block_rows=120, order=4, upsample=2, bd_method="prediction-error")
    result = _identify(case.signals, case.truth, options)
    np.testing.assert_allclose(result.coefficient_values, [20.0, 1.0], rtol=0.1)
