"""The information-weighted band mean of λ(ω) and the loader's check of the integration band's lower edge.

Reference values: the one-sided density of white noise, 2σ²/fs, and of a sine, A²/2 in total; the
weighted mean written out by hand; the integrated noise's slopes 1/ω⁴ and 1/ω².
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import IntegrationWarning
from bayesnsi.io import load_config, load_signals
from bayesnsi.models import Term
from bayesnsi.noise.lowband import EDGE_SNR_MIN, noise_edge_messages
from bayesnsi.nsi._line_information import averaged_periodogram, line_information, output_noise_psd
from bayesnsi.nsi.physics import band_coefficients

FS = 100.0


def test_averaged_periodogram_of_white_noise_and_of_a_sine():
    rng = np.random.default_rng(0)
    n = 200_000
    noise = 2.0 * rng.standard_normal((n, 1))
    freqs = np.linspace(5.0, 45.0, 81)
    density = averaged_periodogram(noise, FS, freqs)[:, 0]
    assert density.mean() == pytest.approx(2 * 2.0**2 / FS, rel=0.03)
    t = np.arange(n) / FS
    sine = 3.0 * np.sin(2 * np.pi * 12.5 * t)[:, None]
    fine = np.linspace(10.0, 15.0, 5001)
    total = np.sum(averaged_periodogram(sine, FS, fine)[:, 0]) * (fine[1] - fine[0])
    assert total == pytest.approx(3.0**2 / 2, rel=0.03)  # its power, A²/2


def test_output_noise_psd_follows_the_integrated_sensor():
    from bayesnsi.noise import AccelerationNoise

    freqs = np.array([4.0, 8.0])
    white = output_noise_psd(freqs, [0.1, 0.2])
    assert np.allclose(white, [[0.01, 0.04], [0.01, 0.04]])
    acc = AccelerationNoise(acceleration_std=(1.0, 2.0), fs=FS, band_hz=(1.0, 45.0))
    psd = output_noise_psd(freqs, [0.1, 0.2], acc)
    assert np.allclose(psd[0] / psd[1], 16.0) and psd[0, 1] / psd[0, 0] == pytest.approx(4.0)
    vel = AccelerationNoise(acceleration_std=(1.0, 2.0), fs=FS, band_hz=(1.0, 45.0), measured="velocity")
    assert np.allclose(output_noise_psd(freqs, [0.1, 0.2], vel)[0] / output_noise_psd(freqs, [0.1, 0.2], vel)[1], 4)


def test_line_information_is_the_terms_power_at_the_outputs_over_their_noise():
    frf = np.array([[[1.0], [2.0j]], [[0.5], [0.0]]])  # (2 lines, 2 outputs, 1 term)
    w = line_information(frf, np.array([[2.0], [4.0]]), np.array([[1.0, 4.0], [1.0, 0.0]]))
    assert np.allclose(w[:, 0], [2.0 * (1.0 / 1.0 + 4.0 / 4.0), 4.0 * 0.25])  # a zero noise density counts nothing


def test_weighted_band_mean_keeps_the_plain_quality_index():
    terms = (Term("x1**3", 1),)
    spectrum = np.array([1.0 + 0.1j, 2.0 - 0.2j, 3.0 + 0.3j, 4.0 + 0.0j])[:, None]
    plain = band_coefficients(spectrum, terms, (1.0, 4.0))[0]
    weighted = band_coefficients(spectrum, terms, (1.0, 4.0), np.array([[0.0], [1.0], [1.0], [2.0]]))[0]
    assert plain.value == pytest.approx(2.5)
    assert weighted.value == pytest.approx((2.0 + 3.0 + 2 * 4.0) / 4)
    assert weighted.imag_ratio == plain.imag_ratio == pytest.approx(0.15 / 2.5)
    nothing = band_coefficients(spectrum, terms, (1.0, 4.0), np.zeros((4, 1)))[0]
    assert nothing.value == plain.value  # no weight anywhere: the plain mean


def _motion_above(f_start: float, n: int, rng) -> np.ndarray:
    """Unit-rms random motion with no power below ``f_start`` (built line by line)."""
    freqs = np.fft.rfftfreq(n, 1 / FS)
    spectrum = np.where((freqs >= f_start) & (freqs <= 40.0), np.exp(2j * np.pi * rng.random(len(freqs))), 0.0)
    x = np.fft.irfft(spectrum, n)
    return x / x.std()


def test_noise_edge_message_names_where_the_motion_clears_the_noise():
    rng = np.random.default_rng(1)
    n = 60_000
    acc = np.column_stack([_motion_above(5.0, n, rng), _motion_above(5.0, n, rng)])
    std = np.array([0.05, 0.05])
    acc = acc + std * rng.standard_normal(acc.shape)
    (message,) = noise_edge_messages(acc, std, FS, (2.0, 45.0), ["a1", "a2"])
    assert "'a1', 'a2'" in message
    # the median over [f0, 1.5 f0] clears once most of the window lies above 5 Hz: f0 = 4 Hz
    advised = float(message.rsplit("band_hz[0] to about ", 1)[1].split()[0])
    assert 3.8 <= advised <= 5.0
    assert f"{EDGE_SNR_MIN:g}x" in message
    assert noise_edge_messages(acc, std, FS, (6.0, 45.0), ["a1", "a2"]) == []
    assert noise_edge_messages(acc[:, :1], [0.5], FS, (2.0, 45.0), ["a1"], "velocity")[0].startswith("velocity 'a1'")


def test_loader_warns_when_the_integration_band_starts_in_the_noise(tmp_path):
    rng = np.random.default_rng(2)
    n = 30_000
    motion = _motion_above(6.0, n, rng)
    force = 2.0 * motion + 0.01 * rng.standard_normal(n)  # a mass line above 6 Hz: nothing below the band
    acc = motion + 0.05 * rng.standard_normal(n)
    np.savetxt(tmp_path / "r.csv", np.column_stack([np.arange(n) / FS, force, acc]), delimiter=",",
               header="t,f,a1", comments="")
    text = ('[data]\nfile = "r.csv"\ntime_column = "t"\ninputs = { f = 1 }\naccelerations = { a1 = 1 }\n'
            "integrate = { band_hz = [BAND, 45.0], noise_std = 0.05 }\n"
            '[[candidates]]\nname = "c"\nterms = [{ expr = "x1**3", at = 1 }]\n')
    (tmp_path / "c.toml").write_text(text.replace("BAND", "2.0"))
    with pytest.warns(IntegrationWarning, match=r"acceleration 'a1': over 2-3 Hz.*heavily damped mode near 2 Hz"):
        load_signals(load_config(tmp_path / "c.toml"))
    (tmp_path / "c.toml").write_text(text.replace("BAND", "7.0"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", IntegrationWarning)
        load_signals(load_config(tmp_path / "c.toml"))


def test_the_datas_warnings_reach_the_report_and_results_json(tmp_path):
    # the loader's warnings were printed on the command line only; a report read later showed the consequences
    # (a residual far above the noise near a missing mode) without their cause
    import json

    from bayesnsi.cli import main

    rng = np.random.default_rng(4)
    n = 20_000
    motion = _motion_above(6.0, n, rng)
    force = 2.0 * motion + 0.01 * rng.standard_normal(n)
    acc = motion + 0.05 * rng.standard_normal(n)
    np.savetxt(tmp_path / "r.csv", np.column_stack([np.arange(n) / FS, force, acc]), delimiter=",",
               header="t,f,a1", comments="")
    (tmp_path / "c.toml").write_text(
        '[data]\nfile = "r.csv"\ntime_column = "t"\ninputs = { f = 1 }\naccelerations = { a1 = 1 }\n'
        "integrate = { band_hz = [2.0, 45.0], noise_std = 0.05 }\n[nsi]\norder = 2\nblock_rows = 10\n"
        '[[candidates]]\nname = "linear"\nterms = []\n'
    )
    with pytest.warns(IntegrationWarning, match="lower edge"), warnings.catch_warnings():
        warnings.simplefilter("ignore", category=UserWarning)  # the identification's own (e.g. spurious poles)
        warnings.simplefilter("always", category=IntegrationWarning)
        assert main(["identify", str(tmp_path / "c.toml"), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    (message,) = json.loads((tmp_path / "out" / "results.json").read_text())["data_findings"]
    assert "integration band's lower edge" in message["message"] and message["kind"] == "warning.IntegrationWarning"
    html = (tmp_path / "out" / "report.html").read_text()
    assert "Loading the data:" in html and "lower edge" in html
    assert "Loading the data gave 1 warning(s)" in html  # the Answer points at them
