"""Frequency route on the fitted lines (docs/method.md §11): the open-loop residual the
evidence scores, and the quality index weighted by where the data inform λ(ω)."""

from __future__ import annotations

import types

import numpy as np
import pytest

from bayesnsi.models import CandidateModel, Term
from bayesnsi.nsi import affine_reconstruction, identify
from bayesnsi.nsi._frequency import _coefficients
from bayesnsi.nsi.physics import band_coefficients, coefficient_spectrum
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, multisine, simulate_response

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 6, 4
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
CUBIC = [Term("x1**3", 1)]


def _records(seed: int = 0) -> tuple[Signals, np.ndarray]:
    """Steady-state periods of the two-DOF chain with k3 = 1e5 at DOF 1, 2 % output noise; and the noise."""
    rng = np.random.default_rng(seed)
    force = multisine(P, FS, (0.5, 20.0), 5.0, rng, n_periods=N_PERIODS + TRANSIENT)
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, CUBIC, [1e5])
    noisy = add_output_noise(response.displacement, 2.0, rng)
    keep = slice(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)
    signals = Signals(force=response.force[keep], displacement=noisy[keep], fs=FS, input_dofs=(2,),
                      output_dofs=(1, 2), period=P)
    return signals, (noisy - response.displacement)[keep]


@pytest.fixture(scope="module")
def cubic():
    signals, noise = _records()
    result = identify(signals, CandidateModel(name="cubic", terms=tuple(CUBIC)),
                      NSIOptions(domain="frequency", order=4))
    return signals, noise, result


def _on_lines(x: np.ndarray, band) -> np.ndarray:
    """Each period of ``x`` with only the DFT lines inside ``band`` kept (independent of the package)."""
    spec = np.fft.rfft(x.reshape(-1, P, x.shape[1]), axis=1)
    freqs = np.fft.rfftfreq(P, 1.0 / FS)
    spec[:, ~((freqs >= band[0]) & (freqs <= band[1]) & (freqs > 0))] = 0.0
    return np.fft.irfft(spec, P, axis=1).reshape(x.shape)


def test_open_loop_residual_of_a_frequency_route_model_is_the_noise_on_its_lines(cubic):
    signals, noise, result = cubic
    band = result.settings["fit_band_hz"]
    affine = affine_reconstruction(result, signals)
    np.testing.assert_allclose(affine.measured, _on_lines(np.asarray(signals.displacement), band), atol=1e-12)
    residual = affine.measured - affine.predict(affine.estimate)
    noise_rms = np.sqrt(np.mean(_on_lines(noise, band) ** 2))
    ratio = np.sqrt(np.mean(residual**2)) / noise_rms
    assert 0.8 < ratio < 1.2, ratio  # the model at its estimate leaves the noise on the lines, no more
    without = np.sqrt(np.mean((affine.measured - affine.predict(np.zeros(1))) ** 2)) / noise_rms
    assert without > 5.0, without  # the cubic spring's contribution stands far above the noise


def _model_with_a_local_defect(freq_defect: float):
    """One-DOF oscillator (k = 400, c = 0.5, m = 1); the term's column is λ H(ω) plus a lightly damped
    resonance at ``freq_defect`` seen only by the term input: λ(ω) = λ + defect(ω) / H(ω) is complex
    near ``freq_defect`` and real (= λ) far from it."""
    lam, wd = 1e4, 2 * np.pi * freq_defect
    Ac = np.zeros((4, 4))
    Ac[:2, :2] = [[0.0, 1.0], [-400.0, -0.5]]
    Ac[2:, 2:] = [[0.0, 1.0], [-(wd**2), -0.4 * wd]]
    Bc = np.array([[0.0, 0.0], [1.0, lam], [0.0, 0.0], [0.0, 3e3]])
    C = np.array([[1.0, 0.0, 1.0, 0.0]])
    return Ac, Bc, C, np.zeros((1, 2)), lam


def test_quality_index_counts_the_lines_where_the_term_carries_power():
    Ac, Bc, C, D, lam = _model_with_a_local_defect(8.0)
    freqs = np.linspace(1.0, 10.0, 181)
    signals = types.SimpleNamespace(input_dofs=(1,), output_dofs=(1,))
    band = (1.0, 10.0)
    term = [Term("x1**3", 1)]

    def index(power):
        inputs = np.column_stack([np.ones(len(freqs)), np.sqrt(power)]).astype(complex)
        data = types.SimpleNamespace(freqs_hz=freqs, inputs=inputs, output_std=np.full((len(freqs), 1), 1e-3))
        return _coefficients(Ac, Bc, C, D, signals, term, band, data)[0]

    away = index(np.where(np.abs(freqs - 8.0) > 1.0, 1.0, 1e-6))  # no basis power near the defect
    near = index(np.where(np.abs(freqs - 8.0) <= 1.0, 1.0, 1e-6))  # power only near it
    grid = np.linspace(*band, 512)  # the plain band mean of |Im|/|Re| on a uniform grid (docs/method.md §4)
    frf = np.stack([C @ np.linalg.solve(2j * np.pi * f * np.eye(4) - Ac, Bc) + D for f in grid])
    plain = band_coefficients(coefficient_spectrum(frf, (1,), (1,), term), term, band)[0]
    assert away.imag_ratio < 0.01 and near.imag_ratio > 0.3, (away, near)
    assert plain.imag_ratio > 5 * away.imag_ratio, (plain, away)  # the defect's lines veto the plain index
    assert away.value == near.value == pytest.approx(plain.value, rel=1e-9)  # the value: plain band mean of Re λ
