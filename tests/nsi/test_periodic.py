"""Periodic data (SPEC 11): multisines, period-averaged spectra, best linear approximation."""

from __future__ import annotations

import numpy as np
import pytest

from bayesnsi.exceptions import InputDataError
from bayesnsi.models import Term
from bayesnsi.nsi import best_linear_approximation, period_dft, period_spectra
from bayesnsi.signals import Signals
from bayesnsi.simulate import (
    add_output_noise,
    chain_system,
    multisine,
    multisine_lines,
    simulate_response,
    underlying_frf,
)

FS, P = 100.0, 512
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])  # the two-DOF chain of the frequency-route tests


def _realisations(k3: float, n_real: int = 6, n_periods: int = 4, seed: int = 0, rms: float = 20.0):
    """Random-odd multisine realisations (same lines, new phases), one transient period first."""
    rng = np.random.default_rng(seed)
    lines = multisine_lines(P, FS, (1.0, 20.0), "random-odd", rng)
    forces = [multisine(P, FS, (1.0, 20.0), rms, rng, n_periods=n_periods + 1, lines=lines) for _ in range(n_real)]
    terms, coefs = ([Term("x1**3", 1)], [k3]) if k3 else ([], [])
    response = simulate_response(*MCK, [2], np.stack([f.fine for f in forces]), FS * 8, 8, terms, coefs)
    return lines, [
        Signals(force=response.force[b], displacement=add_output_noise(response.displacement[b], 2.0, rng),
                fs=FS, input_dofs=(2,), output_dofs=(1, 2))
        for b in range(n_real)
    ]


def test_period_dft_of_a_sine_is_half_its_amplitude_on_its_line():
    t = np.arange(3 * 64)
    x = 2.5 * np.cos(2 * np.pi * 5 * t / 64 + 0.3)
    spec = period_dft(x, 64, drop=1)
    assert spec.shape == (2, 33, 1)
    assert np.allclose(spec[:, 5, 0], 1.25 * np.exp(0.3j))
    assert np.allclose(np.delete(spec[0, :, 0], 5), 0.0, atol=1e-12)


def test_random_odd_multisine_excites_odd_lines_less_one_per_group():
    lines = multisine_lines(1000, 100.0, (1.0, 20.0), "random-odd", rng=3)
    odd = multisine_lines(1000, 100.0, (1.0, 20.0), "odd")
    assert np.all(lines % 2 == 1) and set(lines) < set(odd)
    assert len(odd) - len(lines) == len(odd) // 4
    exc = multisine(1000, 100.0, (1.0, 20.0), 3.0, rng=1, n_periods=3, lines=lines)
    assert np.allclose(exc.samples[:1000], exc.samples[2000:]) and np.isclose(np.sqrt(np.mean(exc.samples**2)), 3.0)
    assert np.allclose(exc.fine[::8], exc.samples)
    power = np.abs(np.fft.rfft(exc.samples[:1000, 0])) ** 2
    assert set(np.flatnonzero(power > 1e-6 * power.max())) == set(lines)


def test_period_spectra_noise_variance_and_excited_lines():
    rng = np.random.default_rng(4)
    lines = multisine_lines(P, FS, (2.0, 30.0), "odd")
    force = multisine(P, FS, (2.0, 30.0), 1.0, rng, n_periods=8, lines=lines).samples
    sigma = 0.1
    noise = sigma * rng.standard_normal((len(force), 2))
    signals = Signals(force=force, displacement=noise + force, fs=FS, input_dofs=(1,), output_dofs=(1, 2), period=P)
    spectra = period_spectra(signals, drop=1)
    assert spectra.n_periods == 7
    assert np.array_equal(spectra.lines(), lines)
    assert np.array_equal(spectra.lines((10.0, 20.0)), lines[(lines * FS / P >= 10) & (lines * FS / P <= 20)])
    # white noise: variance of one period's DFT line is σ²/P, of the mean over 7 periods σ²/(7P)
    expected = sigma**2 / (P * 7)
    assert np.mean(spectra.response_var[1:-1]) == pytest.approx(expected, rel=0.05)
    cross = spectra.response_cov[1:-1, 0, 1]
    assert abs(np.mean(cross)) < 0.05 * expected  # independent channels


def test_bla_of_a_linear_system_has_distortion_at_the_noise_level():
    lines, records = _realisations(0.0)
    bla = best_linear_approximation(records, period=P, drop=1)
    assert bla.n_realisations == 6 and bla.n_periods == 4
    assert np.allclose(bla.freqs_hz, lines * FS / P)
    assert np.all(bla.distortion_ratio() < 1.5)
    assert np.all(bla.unexcited_ratio()["odd"] < 2.0) and np.all(bla.unexcited_ratio()["even"] < 2.0)
    # G_BLA against the exact receptance (independent: [K - ω²M + jωC]⁻¹), within 4 noise std
    exact = underlying_frf(*MCK, bla.freqs_hz, (1, 2), (2,))[:, :, 0]
    z = np.abs(bla.frf - exact) / np.sqrt(bla.noise_var)
    assert np.median(z) < 1.5 and np.max(z) < 4.5  # |z|² of a complex Gaussian is Exp(1)


def test_bla_of_a_cubic_spring_shows_distortion_above_the_noise():
    _, records = _realisations(1e5)
    bla = best_linear_approximation(records, period=P, drop=1)
    ratio = bla.distortion_ratio()
    assert ratio[0] > 4.0  # the DOF of the cubic spring
    assert bla.unexcited_ratio()["odd"][0] > 5.0  # odd nonlinearity: power at unexcited odd lines
    assert np.all(bla.distortion_var >= 0)


def test_periodic_input_errors():
    signals = Signals(force=np.arange(10.0), displacement=np.sin(np.arange(10.0)), fs=1.0, input_dofs=(1,),
                      output_dofs=(1,))
    with pytest.raises(InputDataError, match="no period"):
        period_spectra(signals)
    with pytest.raises(InputDataError, match="leaves none"):
        period_spectra(signals, period=4, drop=2)
    with pytest.raises(InputDataError, match="at least two periods"):
        best_linear_approximation([signals], period=5, drop=1)
    with pytest.raises(InputDataError, match="period must be"):
        period_dft(np.ones(8), 1.5)


def test_periodic_integration_recovers_the_displacement_of_a_steady_state_response():
    from bayesnsi.nsi import periodic_integration

    rng = np.random.default_rng(5)
    force = multisine(P, FS, (1.0, 20.0), 5.0, rng, n_periods=10)
    response = simulate_response(*MCK, [2], force.fine, FS * 8, 8)  # linear: response band-limited to 1-20 Hz
    acc, x, v = (arr[8 * P :] for arr in (response.acceleration, response.displacement, response.velocity))
    vel, disp = periodic_integration(acc, FS, P, (0.5, 30.0))
    x = x - x.mean(axis=0)
    v = v - v.mean(axis=0)
    # the start transient decays as e^{-0.28 t}: 1e-5 of it is left after eight 5.12 s periods
    assert np.max(np.abs(disp - x)) < 1e-4 * np.max(np.abs(x))
    assert np.max(np.abs(vel - v)) < 1e-4 * np.max(np.abs(v))
    with pytest.raises(InputDataError, match="whole periods"):
        periodic_integration(acc[:-1], FS, P, (0.5, 30.0))
