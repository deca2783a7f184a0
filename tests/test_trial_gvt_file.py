"""Trial "new user with a GVT file" (F-16 style): what it found broken, pinned.

Noise replicates of a periodic record of integrated accelerations: the displacement noise lies in
the integration band only, where high-order differences see almost nothing, so the replicates
added ~1e-3 of the real noise and the default intervals came out ~1000x too narrow (trial: k3
interval [1.9890e7, 1.9967e7] held neither the true 2e7 nor a width the data support). On whole
periods the replicate noise is now drawn from the period-to-period scatter.
"""

from __future__ import annotations

import numpy as np

from bayesnsi.evidence.perturbation import noise_replicates
from bayesnsi.models import Term
from bayesnsi.nsi import identify, periodic_integration, white_noise_std
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import chain_system, multisine, simulate_response

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 8, 4
BAND = (1.0, 20.0)
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
CUBIC = [Term("x1**3", 1)]


def _integrated_record(seed: int = 0):
    """Steady-state periods of a cubic 2-DOF chain, accelerometer noise integrated line by line.

    Returns the Signals and the displacement noise alone (the same integration applied to the
    added acceleration noise: integration is linear), the independent reference.
    """
    rng = np.random.default_rng(seed)
    force = multisine(P, FS, BAND, 5.0, rng, n_periods=N_PERIODS + TRANSIENT)
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, CUBIC, [1e5])
    keep = slice(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)
    acc = response.acceleration[keep]
    noise = 0.02 * acc.std(axis=0) * rng.standard_normal(acc.shape)
    v, x = periodic_integration(acc + noise, FS, P, BAND)
    _, x_noise = periodic_integration(noise, FS, P, BAND)
    signals = Signals(force=response.force[keep], displacement=x, velocity=v, fs=FS, input_dofs=(2,),
                      output_dofs=(1, 2), period=P)
    return signals, x_noise


def test_replicate_noise_level_of_integrated_periodic_accelerations_is_the_period_scatter():
    signals, x_noise = _integrated_record(0)
    result = identify(signals, CUBIC, NSIOptions(domain="frequency", order=4))
    noise_std, coefs, *_ = noise_replicates(result, signals, NSIOptions(domain="frequency", order=4), n_replicates=2)
    truth = x_noise.std(axis=0)
    # the differences see the band-limited noise as almost nothing (the bug): far below the truth
    assert np.all(white_noise_std(signals.displacement) < 0.05 * truth)
    # the period scatter estimates it (8 periods; the 1/ω² weight leaves few effective lines: ~5 % error)
    assert np.allclose(noise_std, truth, rtol=0.1)
    assert coefs.shape == (2, 1) and np.all(np.isfinite(coefs))


def test_period_noise_draws_keep_the_scatter_spectrum_and_channel_link():
    from bayesnsi.evidence._period_noise import period_noise

    signals, _ = _integrated_record(1)
    y = np.column_stack([signals.displacement, signals.velocity])
    scatter = period_noise(y, P)
    assert period_noise(y, None) is None and period_noise(y[: P + 10], P) is None  # not two whole periods
    rng = np.random.default_rng(3)
    draws = np.stack([scatter.draw(len(y) - 250, rng) for _ in range(100)])  # a trailing part period too
    assert draws.shape == (100, len(y) - 250, 4)
    # variance per channel: the scatter's (100 draws x 7.75 periods, a few % sampling error)
    assert np.allclose(draws.std(axis=(0, 1)), scatter.std, rtol=0.1)
    # the spectrum of a drawn period is the scatter's (line by line, averaged over the draws),
    # out-of-band leakage of one period included: E|E*(k)|² = Σ_j |D_j(k)|² / (n - 1)
    expected = np.sum(np.abs(np.fft.rfft(scatter.deviations, axis=1)) ** 2, axis=0) / (N_PERIODS - 1)
    drawn = np.mean(np.abs(np.fft.rfft(draws[:, :P], axis=1)) ** 2, axis=0)
    strong = expected > 1e-3 * expected.max(axis=0)
    ratio = drawn[strong] / expected[strong]
    assert abs(np.mean(ratio) - 1) < 0.05 and np.median(np.abs(ratio - 1)) < 0.2
    # the channels drawn together: the covariance between displacement and velocity noise is kept
    dev = scatter.deviations.reshape(-1, 4)
    cov_data = dev.T @ dev / (len(dev) * (N_PERIODS - 1) / N_PERIODS)
    flat = draws.reshape(-1, 4)
    cov_draw = flat.T @ flat / len(flat)
    scale = np.sqrt(np.outer(np.diag(cov_data), np.diag(cov_data)))
    assert np.all(np.abs(cov_draw - cov_data) < 0.1 * scale)
