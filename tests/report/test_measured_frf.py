"""The data's own FRF (multiple-input H1) drawn beside the identified models over the excited band.

A mode the models lack (300 Hz, order "auto") is hidden when the FRF and stabilisation figures stop at
1.3x the highest identified mode; the data's own FRF over the excited band shows it.
References: the exact receptance [K - ω²M + jωC]⁻¹ of the simulated structure.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

from bayesnsi.curves import measured_frf
from bayesnsi.exceptions import InputDataError
from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.plots import plot_frf
from bayesnsi.signals import Signals
from bayesnsi.simulate import band_limited_gaussian, chain_system, simulate_response, underlying_frf

MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])


def _random_record(n=60000, fs=100.0, seed=0):
    rng = np.random.default_rng(seed)
    force = band_limited_gaussian(n, fs, 5.0, rng, oversample=8, band_hz=(0.5, 30.0))
    response = simulate_response(*MCK, [2], force.fine, fs * 8, 8, [], [])
    noisy = response.displacement + 1e-6 * rng.standard_normal(response.displacement.shape)
    return Signals(force=response.force, displacement=noisy, fs=fs, input_dofs=(2,), output_dofs=(1, 2))


def test_h1_of_a_random_test_is_the_receptance_over_the_excited_band():
    signals = _random_record()
    measured = measured_frf(signals)
    assert 28.0 < measured.excited_hz <= 30.5  # 99 % of a 0.5-30 Hz force's power
    exact = underlying_frf(*MCK, measured.freqs_hz, (1, 2), (2,))
    band = (measured.freqs_hz > 1.0) & (measured.freqs_hz < 25.0)
    error = np.abs(measured.frf[band] - exact[band]) / np.abs(exact[band])
    assert np.median(error) < 0.01 and np.quantile(error, 0.9) < 0.05
    assert np.median(measured.coherence[band]) > 0.9


def test_h1_of_a_periodic_test_is_exact_on_the_excited_lines_only():
    # a steady-state multisine built line by line from the receptance: over whole periods Y = H F exactly
    fs, period, periods = 100.0, 1000, 4
    freqs = np.fft.rfftfreq(period, 1 / fs)
    lines = np.arange(3, 300, 2)  # odd lines only: the even ones carry no force
    rng = np.random.default_rng(1)
    F = np.zeros(len(freqs), dtype=complex)
    F[lines] = np.exp(2j * np.pi * rng.random(len(lines)))
    H = underlying_frf(*MCK, freqs, (1, 2), (2,))
    f = np.fft.irfft(F, period)
    y = np.fft.irfft(H[:, :, 0] * F[:, None], period, axis=0)
    signals = Signals(force=np.tile(f, periods)[:, None], displacement=np.tile(y, (periods, 1)), fs=fs,
                      input_dofs=(2,), output_dofs=(1, 2), period=period)
    measured = measured_frf(signals)
    assert np.allclose(measured.freqs_hz, freqs[lines][freqs[lines] <= measured.excited_hz])
    assert np.allclose(measured.frf, H[np.isin(freqs, measured.freqs_hz)], rtol=1e-8)
    with pytest.raises(InputDataError, match="64 samples"):
        measured_frf(Signals(force=f[:40, None], displacement=y[:40], fs=fs, input_dofs=(2,), output_dofs=(1, 2)))


def test_the_frf_figure_draws_the_data_beside_the_models():
    signals = _random_record(n=20000)
    result = identify(signals, None, NSIOptions(block_rows=20, order=4))
    measured = measured_frf(signals)
    fig = plot_frf([result], np.geomspace(0.1, measured.excited_hz, 400), measured=measured, log_frequency=True)
    try:
        labels = [line.get_label() for line in fig.axes[0].get_lines()]
        assert any(label.startswith("measured (H1") for label in labels) and fig.axes[-1].get_xscale() == "log"
    finally:
        plt.close(fig)
