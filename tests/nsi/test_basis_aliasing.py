"""The frequency route's basis spectra keep the harmonics of a sharp switch above Nyquist off the band."""

import numpy as np
import pytest
from scipy.integrate import quad

from bayesnsi.models import Term
from bayesnsi.nsi import _aft

PERIOD, LINE, AMPLITUDE, WIDTH = 16, 3, 1.0, 0.05  # v = AMPLITUDE cos(2π LINE t / PERIOD), tanh(v / WIDTH)


def _spectra(factor):
    x_spec = np.zeros((PERIOD // 2 + 1, 1), dtype=complex)
    omega = 2 * np.pi * LINE  # fs = PERIOD Hz: one period per second
    x_spec[LINE] = AMPLITUDE / (2j * omega)  # x = A sin(ωt)/ω, v = A cos(ωt): each rfft / period line holds half
    v_spec = 1j * 2 * np.pi * np.arange(PERIOD // 2 + 1)[:, None] * x_spec
    force = np.zeros_like(x_spec)
    force[1] = 1.0
    return _aft.basis_spectra([Term("tanh(v1/0.05)", (1,))], x_spec, v_spec, force, float(PERIOD), (1,), (1,), PERIOD,
                              oversampling=factor)[:, 0]


def _harmonic(n):
    """Half the cosine coefficient of -tanh(A cos θ / ε) at harmonic n (its rfft / period line), by quadrature."""
    return quad(lambda t: -np.tanh(AMPLITUDE * np.cos(t) / WIDTH) * np.cos(n * t), 0, np.pi, limit=400)[0] / np.pi


def test_the_band_lines_are_the_fourier_coefficients_of_the_continuous_switch():
    # at 16 samples per period the 3rd harmonic (line 9) folds onto line 7, the 5th (line 15) onto line 1,
    # where the continuous force has nothing
    fine = _spectra(_aft.OVERSAMPLING)
    expected = np.zeros(PERIOD // 2 + 1)
    expected[LINE] = _harmonic(1)
    assert np.abs(fine - expected).max() < 0.01 * abs(expected[LINE])
    coarse = _spectra(1)  # evaluated at the data's samples: the folded harmonics are there
    assert abs(coarse[7]) > 0.2 * abs(expected[LINE])
    folded = [n for n in range(3, 400, 2) if (LINE * n) % PERIOD in (7, PERIOD - 7)]  # 3, 13, 19, 29, ...
    assert coarse[7].real == pytest.approx(sum(_harmonic(n) for n in folded), rel=0.01)
