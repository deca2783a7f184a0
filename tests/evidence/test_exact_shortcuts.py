"""Shortcuts that must give what the long way gives (benchmarks/evidence_channels.py).

References are computed here the long way: the free response and the least-squares initial state by
powers of A (no modal form, no cut where |λ|^k underflows); emcee's own integrated autocorrelation
time; the AR(1) innovation sum of squares by the general contraction over the lag windows; the
measured noise levels of a fresh copy of the record.
"""

import dataclasses

import numpy as np
import pytest

from bayesnsi.evidence._collapsed_run import _integrated_time
from bayesnsi.evidence._target import Target
from bayesnsi.evidence.likelihood import sufficient_statistics
from bayesnsi.noise import measured_noise_std
from bayesnsi.nsi.reconstruct import initial_state
from bayesnsi.nsi.statespace import StateSpaceModel, decay_lengths
from bayesnsi.signals import Signals
from tests._helpers.affine import make_affine, make_priors


def _damped_model(rng) -> StateSpaceModel:
    """Modes that die out within tens of samples beside one that lasts the record (a Kalman predictor's mix)."""
    poles = [0.3 * np.exp(0.9j), 0.6 * np.exp(2.1j), 0.9995 * np.exp(0.05j)]
    blocks = [np.array([[p.real, -p.imag], [p.imag, p.real]]) for p in poles] + [np.array([[-0.4]])]
    A = np.zeros((7, 7))
    for k, block in enumerate(blocks):
        A[2 * k : 2 * k + len(block), 2 * k : 2 * k + len(block)] = block
    T = rng.standard_normal((7, 7)) + 3 * np.eye(7)  # not in modal coordinates
    return StateSpaceModel(T @ A @ np.linalg.inv(T), rng.standard_normal((7, 1)), rng.standard_normal((2, 7)) @
                           np.linalg.inv(T), np.zeros((2, 1)), 0.01)


def _powers_response(model: StateSpaceModel, x0, n: int) -> np.ndarray:
    out, x = np.empty((n, model.C.shape[0])), np.array(x0, dtype=float)
    for k in range(n):
        out[k] = model.C @ x
        x = model.A @ x
    return out


def test_decay_lengths_cut_where_the_powers_fall_below_rounding():
    lengths = decay_lengths([0.5, 0.5j, 0.999, 1.0, 1.2, 0.0, 0.9999], 50000)
    assert lengths[0] == lengths[1] == 61  # 0.5^60 = 2^-60
    assert 0.999 ** (lengths[2] - 1) < 2.0**-60 < 0.999 ** (lengths[2] - 2)
    assert list(lengths[3:5]) == [50000, 50000]  # no decay: the whole record
    assert lengths[5] == 1
    assert lengths[6] == 50000  # decays after the record ends


@pytest.mark.parametrize("seed", [0, 1])
def test_free_response_and_initial_state_equal_the_powers_of_a(seed):
    rng = np.random.default_rng(seed)
    model = _damped_model(rng)
    n = 3000  # the slow mode lasts 8e4 samples, the fast ones 40 to 120
    x0 = rng.standard_normal(7)
    expected = _powers_response(model, x0, n)
    # the modal form's rounding grows along the slow mode (1e-11 of the peak at 3000 samples, as before the cut)
    np.testing.assert_allclose(model.initial_response(x0, n), expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    outputs = expected + 0.01 * rng.standard_normal(expected.shape)
    free = np.stack([_powers_response(model, e, n).ravel() for e in np.eye(7)], axis=1)  # row block k: C A^k
    dense = np.linalg.lstsq(free, outputs.ravel(), rcond=None)[0]
    fitted = initial_state(model, None, outputs, forced=np.zeros_like(outputs))
    np.testing.assert_allclose(fitted, dense, rtol=1e-8, atol=1e-10)


def test_integrated_time_is_emcees():
    from emcee.autocorr import integrated_time

    rng = np.random.default_rng(3)
    walkers, draws = 8, 2000
    chains = np.empty((walkers, draws, 2))
    chains[:, 0] = rng.standard_normal((walkers, 2))
    for t in range(1, draws):  # AR(1) chains with correlations 0.9 and 0.3
        chains[:, t] = np.array([0.9, 0.3]) * chains[:, t - 1] + rng.standard_normal((walkers, 2))
    tau, reliable = _integrated_time(chains)
    expected = integrated_time(np.swapaxes(chains, 0, 1), quiet=True)  # emcee: (draw, walker, param)
    np.testing.assert_allclose(tau, expected, rtol=1e-10)
    assert reliable and 12 < tau[0] < 26 and 1.5 < tau[1] < 2.3  # (1 + ρ)/(1 - ρ) = 19 and 1.86


def test_ar1_innovation_sum_of_squares_equals_the_general_contraction():
    rng = np.random.default_rng(4)
    affine = make_affine(600, 3, 2, rng, rho=0.6)
    target = Target.build(sufficient_statistics(affine, ar_order=1), make_priors(affine), "ar1")
    lam = affine.estimate + 0.01 * rng.standard_normal((5, 2))
    theta = np.concatenate([lam, np.log(rng.uniform(0.3, 0.7, (5, 3))), rng.uniform(-0.9, 0.9, (5, 3))], axis=1)
    lam, u, rho = target.split(theta)
    forms = target.forms(lam)
    taps = np.concatenate([np.ones(rho.shape[:-1] + (1,)), -rho], axis=-1)
    ss = np.einsum("...ji,...jik,...jk->...j", taps, forms, taps)
    expected = np.sum(-0.5 * target.n_eff * (np.log(2 * np.pi) + 2 * u) - 0.5 * ss * np.exp(-2 * u)
                      + 0.5 * np.log1p(-rho[..., 0] ** 2), axis=-1)
    np.testing.assert_allclose(target.log_likelihood(theta), expected, rtol=1e-12)


def test_noise_levels_are_measured_once_per_record_and_read_only():
    rng = np.random.default_rng(5)
    n = 4000
    t = np.arange(n) / 100.0
    x = np.column_stack([np.sin(2 * np.pi * 1.3 * t), np.cos(2 * np.pi * 2.1 * t)])
    v = np.column_stack([2 * np.pi * 1.3 * np.cos(2 * np.pi * 1.3 * t), -2 * np.pi * 2.1 * np.sin(2 * np.pi * 2.1 * t)])
    signals = Signals(force=rng.standard_normal((n, 1)), displacement=x + 1e-3 * rng.standard_normal(x.shape),
                      velocity=v + 1e-2 * rng.standard_normal(x.shape), fs=100.0, input_dofs=(1,), output_dofs=(1, 2))
    first = measured_noise_std(signals)
    assert measured_noise_std(signals) is first  # kept with the record
    fresh = measured_noise_std(dataclasses.replace(signals))  # a copy measures afresh: the same values
    assert fresh is not first
    for kept, again in zip(first, fresh, strict=True):
        np.testing.assert_array_equal(kept, again)
        with pytest.raises(ValueError, match="read-only"):
            kept[0] = 0.0
    np.testing.assert_allclose(first[0], 1e-3, rtol=0.2)
    np.testing.assert_allclose(first[1], 1e-2, rtol=0.2)
