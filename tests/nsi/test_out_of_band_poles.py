"""Time route: an unstable pole outside [nsi] band_hz is mirrored with a warning, not a failure."""

from __future__ import annotations

import numpy as np
import pytest

from bayesnsi.exceptions import SpuriousPoleWarning, UnstableModelError
from bayesnsi.nsi import identify
from bayesnsi.nsi._stabilise import reflect_out_of_band
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, simulate_response

FS = 100.0
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])  # the two-DOF chain of the frequency-route tests


def _exact_hz() -> np.ndarray:
    """Damped natural frequencies |s|/2π from the eigenvalues of the linear state matrix (independent)."""
    M, C, K = MCK
    Ac = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    s = np.linalg.eigvals(Ac)
    return np.sort(np.abs(s[s.imag > 0]) / (2 * np.pi))


def _band_limited(white: np.ndarray, fs: float, band_hz) -> np.ndarray:
    """White noise with every DFT line outside ``band_hz`` set to zero (unit std)."""
    spectrum = np.fft.rfft(white, axis=0)
    lines = np.fft.rfftfreq(len(white), 1 / fs)
    spectrum[(lines < band_hz[0]) | (lines > band_hz[1])] = 0
    out = np.fft.irfft(spectrum, len(white), axis=0)
    return out / out.std()


@pytest.fixture(scope="module")
def drifting() -> Signals:
    """A force band-limited to 2-20 Hz; the outputs carry a growing 0.2 Hz drift (e^{0.08 t}) below the band."""
    rng = np.random.default_rng(0)
    n = 6000
    force = _band_limited(rng.standard_normal((2 * n, 1)), 2 * FS, (2.0, 20.0)) * 5
    response = simulate_response(*MCK, [2], force, 2 * FS, 2, [], [])
    t = np.arange(n)[:, None] / FS
    drift = 2e-4 * np.exp(0.08 * t) * np.sin(2 * np.pi * 0.2 * t + np.array([[0.0, 0.5]]))
    return Signals(force=response.force, displacement=add_output_noise(response.displacement, 1.0, rng) + drift,
                   fs=FS, input_dofs=(2,), output_dofs=(1, 2))


def test_a_growing_pole_below_the_band_is_mirrored_with_a_warning_naming_it(drifting):
    message = r"outside the band \(2.0, 20.0\) Hz, where the force has no power, at 0.2 Hz \(\|z\| = 1.00"
    with pytest.warns(SpuriousPoleWarning, match=message):
        result = identify(drifting, None, NSIOptions(order=6, block_rows=10, band_hz=(2.0, 20.0)))
    assert result.settings["reflected_poles_hz"] == [pytest.approx(0.2, abs=0.01)]
    assert np.max(np.abs(result.model.poles_discrete)) < 1.0
    in_band = np.array([m.frequency_hz for m in result.modes if 2.0 <= m.frequency_hz <= 20.0])
    assert np.all(np.abs(in_band / _exact_hz() - 1) < 0.02)  # the physical modes are kept (measured 0.3 %, 1.6 %)


def test_without_a_band_the_unstable_model_still_fails(drifting):
    with pytest.raises(UnstableModelError, match="unstable"):
        identify(drifting, None, NSIOptions(order=6, block_rows=10))


def test_reflection_keeps_frequencies_and_refuses_an_unstable_pole_inside_the_band():
    dt = 0.01
    z = np.array([1.002 * np.exp(2j * np.pi * 0.1 * dt), 0.99 * np.exp(2j * np.pi * 5.0 * dt)])
    A = np.zeros((4, 4))
    for k, p in enumerate(z):  # real 2x2 blocks with eigenvalues p, conj(p)
        A[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = [[p.real, p.imag], [-p.imag, p.real]]
    stable, mirrored = reflect_out_of_band(A, dt, (1.0, 10.0))
    poles = np.linalg.eigvals(stable)
    assert np.max(np.abs(poles)) < 1.0 and len(mirrored) == 1
    assert np.sort(np.abs(poles)) == pytest.approx([0.99, 0.99, 1 / 1.002, 1 / 1.002])  # mirrored: 1/|z|
    assert np.allclose(sorted(np.abs(np.angle(poles))), sorted(np.abs(np.angle(np.r_[z, z.conj()]))))  # same angles
    assert reflect_out_of_band(A, dt, (0.05, 10.0)) is None  # the growing pole is inside this band
    assert reflect_out_of_band(A, dt, None) is None
    white = np.random.default_rng(1).standard_normal((20_000, 1))
    assert reflect_out_of_band(A, dt, (1.0, 10.0), white) is None  # a white force informs 0.1 Hz: a failure
    limited = _band_limited(white, 1 / dt, (1.0, 10.0))
    assert reflect_out_of_band(A, dt, (1.0, 10.0), limited) is not None  # nothing at 0.1 Hz: mirrored


def test_a_growing_pole_where_a_broadband_force_has_power_still_fails(drifting):
    """The beam's case (white force up to Nyquist, a real unstable pole of a wrong candidate at 0 Hz): the
    force informs that frequency, so the pole is the data's verdict on the candidate, not a blind spot."""
    rng = np.random.default_rng(2)
    force = rng.standard_normal((len(drifting.force), 1)) * np.std(drifting.force)
    broadband = Signals(force=force, displacement=drifting.displacement, fs=FS, input_dofs=(2,), output_dofs=(1, 2))
    with pytest.raises(UnstableModelError, match="at a frequency the force excites"):
        identify(broadband, None, NSIOptions(order=6, block_rows=10, band_hz=(2.0, 20.0)))
