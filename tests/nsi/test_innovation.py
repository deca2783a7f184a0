"""The innovation (Kalman predictor) form of an identified model: NSIResult.innovation_form / kalman_gain.

A linear two-DOF chain (the undeclared cases' M, C, K), driven at DOF 2 by a measured white force
and an unmeasured white force (process noise), outputs with 2 % white measurement noise. The
reference is independent of the package: the true discretised system (scipy.signal.cont2discrete)
and its Kalman predictor from scipy.linalg.solve_discrete_are.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg, signal

from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals

FS, N, FORCE_STD, DISTURBANCE_STD = 100.0, 10_000, 10.0, 3.0


def _system():
    M, C = np.diag([1.0, 1.5]), np.array([[2.0, -1.0], [-1.0, 1.0]])
    K = np.array([[1800.0, -1000.0], [-1000.0, 1000.0]])
    Mi = np.linalg.inv(M)
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ K, -Mi @ C]])
    b = np.vstack([np.zeros((2, 1)), Mi[:, [1]]])
    c = np.hstack([np.eye(2), np.zeros((2, 2))])
    A, B, C_, _, _ = signal.cont2discrete((a, b, c, np.zeros((2, 1))), 1 / FS)
    return A, B, C_


@pytest.fixture(scope="module")
def case():
    A, B, C = _system()
    rng = np.random.default_rng(0)
    force, disturbance = rng.normal(0, FORCE_STD, N), rng.normal(0, DISTURBANCE_STD, N)
    x, clean = np.zeros(4), np.empty((N, 2))
    for k in range(N):
        clean[k] = C @ x
        x = A @ x + B[:, 0] * (force[k] + disturbance[k])
    noise_std = 0.02 * clean.std(axis=0)
    y = clean + rng.normal(size=clean.shape) * noise_std
    signals = Signals(force=force[:, None], displacement=y, fs=FS, input_dofs=(2,), output_dofs=(1, 2))
    result = identify(signals, None, NSIOptions(block_rows=30, order=4))
    # the true system's steady-state predictor (independent reference)
    P = linalg.solve_discrete_are(A.T, C.T, DISTURBANCE_STD**2 * B @ B.T, np.diag(noise_std**2))
    true_std = np.sqrt(np.diag(C @ P @ C.T + np.diag(noise_std**2)))
    return signals, result, noise_std, true_std


def _max_autocorrelation(e, lags=10):
    e = e - e.mean(axis=0)
    return max(
        abs(float(e[lag:, c] @ e[:-lag, c] / (e[:, c] @ e[:, c])))
        for lag in range(1, lags + 1)
        for c in range(e.shape[1])
    )


def test_innovations_of_the_identified_model_are_white_with_the_predicted_covariance(case):
    signals, result, noise_std, true_std = case
    u, y = result.extended_input(signals), signals.displacement
    # without the unmeasured force the gain is ~0 and the residual (output error) is far from white
    output_error = result.innovation_form(signals, noise_std=noise_std)
    assert np.abs(output_error.gain).max() < 1e-6
    assert _max_autocorrelation(output_error.innovations(u, y)[200:]) > 0.5
    form = result.innovation_form(signals, noise_std=noise_std, force_noise_std=[DISTURBANCE_STD])
    eps = form.innovations(u, y)[200:]  # the predictor's start-up transient dropped
    assert _max_autocorrelation(eps) < 0.06  # 2/sqrt(N) = 0.02: white to within a model error
    predicted = np.sqrt(np.diag(form.innovation_covariance))
    np.testing.assert_allclose(eps.std(axis=0), predicted, rtol=0.1)
    np.testing.assert_allclose(predicted, true_std, rtol=0.1)  # the true system's Kalman predictor


def test_kalman_gain_solves_the_riccati_equation_of_its_covariances(case):
    signals, result, noise_std, _ = case
    form = result.innovation_form(signals, noise_std=noise_std, force_noise_std=[DISTURBANCE_STD])
    A, C = result.model.A, result.model.C
    Q, R, S = form.process_covariance, form.measurement_covariance, form.cross_covariance
    P = linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)
    K = (A @ P @ C.T + S) @ np.linalg.inv(C @ P @ C.T + R)
    np.testing.assert_allclose(form.gain, K, rtol=1e-5, atol=1e-8 * np.abs(K).max())
    np.testing.assert_allclose(result.kalman_gain(signals, noise_std, [DISTURBANCE_STD]), form.gain)
    assert np.all(np.abs(np.linalg.eigvals(form.predictor.A)) < 1)  # a stabilising gain


def test_innovation_form_refuses_noise_stds_of_the_wrong_shape(case):
    from bayesnsi.exceptions import InputDataError

    signals, result, _, _ = case
    with pytest.raises(InputDataError, match="noise_std needs 2 values"):
        result.innovation_form(signals, noise_std=[1.0])
