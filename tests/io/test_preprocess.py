"""Sensor conversions (bayesnsi.preprocess) and the accelerations-only path of the config.

Measured numbers (seed 0, recorded when the tests were written):

- Sum of five sinusoids 1.23-23.5 Hz, fs = 200 Hz, 60 s, band (0.5, 40) Hz, the first and last
  10 s (= 5/f_lo) excluded: frequency method max |x error| = 0.38 % of std(x), velocity 0.05 %;
  time method 0.79 % / 2.2 % (the trapezoid gain error at 23 Hz).
- Two-DOF case, 100 s, accelerations with 2 % noise, integrate band (1, 40) Hz, frequency
  method, forces filtered with the same band, identify(model 1, i = 60, n = 4): natural
  frequencies -0.07 % / -0.23 %, α = 19.47 (-2.6 %). Time method: -0.01 % / -0.06 %, α = 19.53
  (-2.3 %). Without filtering the forces the identification fails (modes off by 67-82 %).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sp_signal

from bayesnsi.exceptions import ConfigError, InputDataError
from bayesnsi.io import dump_config, load_config, load_signals, load_validation, write_signals_csv
from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.preprocess import (
    band_filter,
    band_window,
    decimate,
    detrend,
    integrate_acceleration,
    select_segment,
    upsample,
)
from bayesnsi.signals import Signals
from bayesnsi.simulate import simulate_case

# ---------------------------------------------------------------------------------------------
# integration of an analytic acceleration

FS = 200.0
FREQS = np.array([1.2345, 2.71828, 5.1234, 11.111, 23.456])  # not periodic in the record
AMPS = np.array([1.0, 0.5, 0.3, 0.1, 0.02])


def _sinusoids(duration=60.0, fs=FS, freqs=FREQS, amps=AMPS, seed=1):
    t = np.arange(int(duration * fs)) / fs
    phase = np.random.default_rng(seed).uniform(0, 2 * np.pi, len(freqs))
    w = 2 * np.pi * np.asarray(freqs)
    arg = np.outer(t, w) + phase
    x = (amps * np.sin(arg)).sum(axis=1)
    v = (amps * w * np.cos(arg)).sum(axis=1)
    a = -(amps * w**2 * np.sin(arg)).sum(axis=1)
    return a, v, x


@pytest.mark.parametrize("method, x_tol, v_tol", [("frequency", 0.01, 0.002), ("time", 0.015, 0.03)])
def test_integration_recovers_sinusoids_in_band(method, x_tol, v_tol):
    a, v, x = _sinusoids()
    velocity, displacement = integrate_acceleration(a, FS, (0.5, 40.0), method=method)
    inner = slice(int(10 * FS), len(a) - int(10 * FS))  # 5 / f_lo from each end
    assert np.max(np.abs(displacement[inner] - x[inner])) < x_tol * x.std()
    assert np.max(np.abs(velocity[inner] - v[inner])) < v_tol * v.std()
    assert displacement.shape == a.shape


def test_multichannel_matches_single_channels():
    a, _, _ = _sinusoids(duration=20.0)
    stacked = np.column_stack([a, 2 * a[::-1]])
    v, x = integrate_acceleration(stacked, FS, (0.5, 40.0))
    v0, x0 = integrate_acceleration(stacked[:, 1], FS, (0.5, 40.0))
    assert v.shape == x.shape == stacked.shape
    np.testing.assert_allclose(x[:, 1], x0, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(v[:, 1], v0, rtol=1e-12, atol=1e-15)


def test_content_below_f_lo_is_lost():
    a, _, x = _sinusoids(duration=60.0, freqs=[0.2], amps=[1.0])
    _, displacement = integrate_acceleration(a, FS, (0.5, 40.0))
    inner = slice(int(10 * FS), len(a) - int(10 * FS))
    assert np.max(np.abs(displacement[inner])) < 0.01 * np.max(np.abs(x))


def test_band_window_is_zero_phase_raised_cosine():
    f = np.array([0.0, 0.25, 0.375, 0.5, 10.0, 40.0, 50.0, 60.0, 100.0])
    w = band_window(f, (0.5, 40.0), fs=200.0, taper=0.5)
    np.testing.assert_allclose(w, [0, 0, 0.5, 1, 1, 1, 0.5, 0, 0], atol=1e-12)
    assert band_window([30.0, 99.0], (0.5, 200.0), fs=200.0)[1] == 1.0  # f_hi >= fs/2: no low-pass


def test_band_filter_keeps_in_band_and_matches_integration_gain():
    a, _, _ = _sinusoids(duration=40.0)
    filtered = band_filter(a, FS, (0.5, 40.0))
    inner = slice(int(10 * FS), len(a) - int(10 * FS))
    assert np.max(np.abs(filtered[inner] - a[inner])) < 0.002 * a.std()
    # the same weighting as the integration: integrating the filtered signal changes nothing
    _, x1 = integrate_acceleration(a, FS, (0.5, 40.0))
    _, x2 = integrate_acceleration(filtered, FS, (0.5, 40.0))
    assert np.max(np.abs(x2[inner] - x1[inner])) < 0.005 * x1.std()
    # time method: the documented Butterworth gain (1 + (f_lo/f)^8)^-2 at f = 2 f_lo, zero phase
    tone = np.sin(2 * np.pi * 1.0 * np.arange(len(a)) / FS)
    gain = (1 + 0.5**8) ** -2
    np.testing.assert_allclose(band_filter(tone, FS, (0.5, 100.0), method="time")[inner], gain * tone[inner], atol=2e-3)
    _, x_time = integrate_acceleration(-(2 * np.pi) ** 2 * tone, FS, (0.5, 100.0), method="time")
    trapezoid = (np.pi / FS) / np.tan(np.pi / FS)  # gain of the trapezoid rule at 1 Hz, per integration
    np.testing.assert_allclose(x_time[inner], gain * trapezoid**2 * tone[inner], atol=2e-3)


def test_inputs_are_never_modified():
    a, _, _ = _sinusoids(duration=10.0)
    frozen = np.column_stack([a, -a])
    frozen.setflags(write=False)
    copy = frozen.copy()
    for method in ("frequency", "time"):
        integrate_acceleration(frozen, FS, (0.5, 40.0), method=method)
        band_filter(frozen, FS, (0.5, 40.0), method=method)
    detrend(frozen, 2)
    decimate(frozen, 2)
    select_segment(frozen, 5, 50)
    np.testing.assert_array_equal(frozen, copy)


def test_integration_errors():
    a, _, _ = _sinusoids(duration=5.0)
    with pytest.raises(InputDataError, match="f_lo > 0"):
        integrate_acceleration(a, FS, (0.0, 40.0))
    with pytest.raises(InputDataError, match="band_hz must"):
        integrate_acceleration(a, FS, (5.0, 1.0))
    with pytest.raises(InputDataError, match="below the Nyquist"):
        integrate_acceleration(a, FS, (150.0, 300.0))
    with pytest.raises(InputDataError, match="unknown integration method"):
        integrate_acceleration(a, FS, (0.5, 40.0), method="simpson")
    with pytest.raises(InputDataError, match="NaN/Inf"):
        integrate_acceleration(np.r_[a, np.nan], FS, (0.5, 40.0))
    with pytest.raises(InputDataError, match="taper"):
        integrate_acceleration(a, FS, (0.5, 40.0), taper=1.0)
    with pytest.raises(InputDataError, match="fs must be"):
        integrate_acceleration(a, 0.0, (0.5, 40.0))


# ---------------------------------------------------------------------------------------------
# detrend, decimate, select_segment


def _signals(n=4000, fs=FS):
    a, v, x = _sinusoids(duration=n / fs, fs=fs)
    t = np.arange(n) / fs
    return Signals(
        force=np.column_stack([a]), displacement=np.column_stack([x, 2 * x + 0.1 * t]),
        velocity=np.column_stack([v, 2 * v + 0.1]), fs=fs, input_dofs=(2,), output_dofs=(1, 2),
        input_names=("f2",), output_names=("x1", "x2"),
    )


def test_detrend_removes_polynomials():
    t = np.linspace(0, 10, 1001)
    wave = np.sin(2 * np.pi * 3.1 * t)
    trend = 3.0 - 2.0 * t + 0.5 * t**2
    removed = detrend(np.column_stack([wave + trend, trend]), order=2)
    np.testing.assert_allclose(removed[:, 1], 0.0, atol=1e-10)
    np.testing.assert_allclose(removed[:, 0], detrend(wave, 2), atol=1e-10)  # linear in the data
    signals = _signals()
    flat = detrend(signals, order=1)
    assert isinstance(flat, Signals) and flat is not signals
    np.testing.assert_allclose(flat.displacement.mean(axis=0), 0.0, atol=1e-12)
    assert signals.displacement[:, 1].mean() > 0.5  # the original is untouched
    assert detrend(wave, 0).shape == wave.shape


def test_decimate_signals_is_antialiased_and_zero_phase():
    signals = _signals()
    half = decimate(signals, 4)
    assert half.fs == FS / 4 and half.n_samples == 1000
    assert (half.input_names, half.output_dofs) == (signals.input_names, signals.output_dofs)
    # scipy's zero-phase FIR decimation, channel by channel
    expected = sp_signal.decimate(signals.displacement, 4, ftype="fir", zero_phase=True, axis=0)
    np.testing.assert_allclose(half.displacement, expected, rtol=1e-12, atol=1e-15)
    # in band (components up to 11 Hz < 0.8 x 25 Hz): sample j is the input sample 4j, no delay
    inner = slice(20, -20)
    low = _sinusoids(duration=20.0, freqs=FREQS[:4], amps=AMPS[:4])[2]
    np.testing.assert_allclose(decimate(low, 4)[inner], low[::4][inner], atol=0.004 * np.abs(low).max())
    # a tone above the new Nyquist frequency (60 Hz > 1.17 x 25 Hz) is removed, not aliased
    tone = np.sin(2 * np.pi * 60.0 * np.arange(4000) / FS)
    assert np.max(np.abs(decimate(tone, 4)[inner])) < 0.01
    assert decimate(signals, 1).displacement is not signals.displacement
    with pytest.raises(InputDataError, match="factor must be an integer"):
        decimate(signals, 2.5)


def test_select_segment():
    signals = _signals()
    part = select_segment(signals, 100, 300)
    np.testing.assert_array_equal(part.displacement, signals.displacement[100:300])
    by_time = select_segment(signals, 0.5, 1.5, unit="s")
    np.testing.assert_array_equal(by_time.force, signals.force[100:300])
    array = select_segment(np.arange(10.0), 2.0 / FS, 5.0 / FS, unit="s", fs=FS)
    np.testing.assert_array_equal(array, [2.0, 3.0, 4.0])
    with pytest.raises(InputDataError, match="outside the record"):
        select_segment(signals, 100, 5000)
    with pytest.raises(InputDataError, match="needs fs"):
        select_segment(np.arange(10.0), 0.0, 1.0, unit="s")


# ---------------------------------------------------------------------------------------------
# accelerations only: config -> integrate on load -> identify (the accelerations-only path)


CANDIDATES = [{"name": "model 1", "terms": [{"expr": "v1*abs(v1)", "at": 1}]}]


@pytest.fixture(scope="module")
def acceleration_case(tmp_path_factory):
    case = simulate_case("two-dof", seed=0, duration=100.0)
    acc = case.response.acceleration
    noisy = acc + 0.02 * acc.std(axis=0) * np.random.default_rng(0).standard_normal(acc.shape)
    folder = tmp_path_factory.mktemp("accelerations")
    write_signals_csv(
        folder / "acc.csv", columns={"f2": case.clean.force[:, 0], "a1": noisy[:, 0], "a2": noisy[:, 1]},
        fs=case.clean.fs, float_format="%.17g",
    )
    return case, noisy, folder


def _acc_config(folder, name="acc.toml", integrate=None, **data):
    section = {
        "file": "acc.csv", "fs": 100.0, "inputs": {"f2": 2}, "accelerations": {"a1": 1, "a2": 2},
        "integrate": integrate if integrate is not None else {"band_hz": [1.0, 40.0]}, **data,
    }
    path = folder / name
    path.write_text(dump_config({"data": section, "candidates": CANDIDATES}))
    return load_config(path)


@pytest.mark.parametrize("method", ["frequency", "time"])
def test_accelerations_only_identify_two_dof(acceleration_case, method):
    case, noisy, folder = acceleration_case
    config = _acc_config(folder, f"{method}.toml",  # every sample kept, as integrate_acceleration gives them
                         integrate={"band_hz": [1.0, 40.0], "method": method, "trim_edges": False})
    assert dict(config.data.outputs) == {"x1": 1, "x2": 2} and config.data.velocities is None
    signals = load_signals(config)
    assert signals.velocity is not None and signals.output_names == ("x1", "x2")

    # the same as the API route
    v, x = integrate_acceleration(noisy, 100.0, (1.0, 40.0), method=method)
    np.testing.assert_allclose(signals.displacement, x, rtol=1e-12, atol=1e-12 * np.abs(x).max())
    np.testing.assert_allclose(signals.force, band_filter(case.clean.force, 100.0, (1.0, 40.0), method=method),
                               rtol=1e-12, atol=1e-12 * np.abs(case.clean.force).max())

    result = identify(signals, case.candidates[0], NSIOptions(block_rows=60, order=4))
    freqs = np.array([m.frequency_hz for m in result.modes])
    np.testing.assert_allclose(freqs, case.exact_frequencies_hz, rtol=0.01)
    assert result.coefficient_values[0] == pytest.approx(20.0, rel=0.10)


def test_integrated_windows_and_decimation_count_file_samples(acceleration_case):
    case, noisy, folder = acceleration_case
    raw = {
        "data": {
            "file": "acc.csv", "fs": 100.0, "inputs": {"f2": 2}, "accelerations": {"a1": 1, "a2": 2},
            "integrate": {"band_hz": [1.0, 20.0], "trim_edges": False}, "decimate": 2, "estimation": [1000, 9000],
        },
        "candidates": CANDIDATES,
        "validation": [{"name": "tail", "start": 9000, "stop": 10000}],
    }
    path = folder / "dec.toml"
    path.write_text(dump_config(raw))
    config = load_config(path)
    estimation = load_signals(config)
    assert estimation.fs == 50.0 and estimation.n_samples == 4000
    # each window is cut first, then integrated, then decimated
    v, x = integrate_acceleration(noisy[1000:9000], 100.0, (1.0, 20.0))
    np.testing.assert_allclose(estimation.displacement, decimate(x, 2), rtol=1e-12, atol=1e-12 * np.abs(x).max())
    [(name, tail)] = load_validation(config)
    assert name == "tail" and tail.n_samples == 500 and tail.fs == 50.0


def test_decimate_measured_displacements(tmp_path):
    case = simulate_case("two-dof", seed=0)
    write_signals_csv(tmp_path / "d.csv", case.signals, float_format="%.17g")
    raw = {
        "data": {"file": "d.csv", "inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}, "decimate": 2},
        "candidates": CANDIDATES,
    }
    (tmp_path / "d.toml").write_text(dump_config(raw))
    loaded = load_signals(load_config(tmp_path / "d.toml"))
    reference = decimate(case.signals, 2)
    assert loaded.fs == pytest.approx(50.0, rel=1e-9) and loaded.velocity is None
    np.testing.assert_allclose(loaded.displacement, reference.displacement, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d.update(outputs={"x1": 1}), "with integrate, displacements and velocities are derived"),
        (lambda d: d.pop("accelerations"), "from accelerations or from velocities .* but neither is given"),
        (lambda d: d.update(integrate={"band_hz": [0.0, 10.0]}), r"0 < f_lo < f_hi"),
        (lambda d: d.update(integrate={"band_hz": [60.0, 70.0]}), "Nyquist"),
        (lambda d: d.update(integrate={"band_hz": [1.0, 10.0], "methd": "time"}), "did you mean 'method'"),
        (lambda d: d.update(integrate={"band_hz": [1.0, 10.0], "method": "simpson"}), "'frequency', 'time'"),
        (lambda d: d.update(integrate={"band_hz": [1.0, 10.0], "taper": 1.5}), r"\[0, 1\)"),
        (lambda d: d.update(integrate={}), "band_hz"),
        (lambda d: d.pop("integrate"), "derive displacements from the accelerations with integrate"),
        (lambda d: d.update(decimate=0), "decimate: expected an integer >= 1"),
    ],
)
def test_integrate_config_errors(tmp_path, change, message):
    section = {
        "file": "acc.csv", "fs": 100.0, "inputs": {"f2": 2}, "accelerations": {"a1": 1, "a2": 2},
        "integrate": {"band_hz": [1.0, 40.0]},
    }
    change(section)
    path = tmp_path / "bad.toml"
    path.write_text(dump_config({"data": section, "candidates": CANDIDATES}))
    with pytest.raises(ConfigError, match=message):
        load_config(path, check_files=False)


def test_nsi_band_is_checked_against_the_decimated_nyquist(tmp_path):
    section = {"file": "d.csv", "fs": 100.0, "inputs": {"f2": 2}, "outputs": {"x1": 1}, "decimate": 4}
    path = tmp_path / "nyq.toml"
    path.write_text(dump_config({"data": section, "nsi": {"band_hz": [1.0, 20.0]}, "candidates": CANDIDATES}))
    with pytest.raises(ConfigError, match="below the Nyquist frequency 12.5 Hz"):
        load_config(path, check_files=False)


def test_upsample_is_exact_for_band_limited_signals_and_keeps_samples():
    """Independent reference: the analytic sinusoids evaluated on the finer grid."""
    fs, n = 100.0, 1000
    t = np.arange(n) / fs
    x = np.c_[np.sin(2 * np.pi * 3 * t), 0.3 * np.cos(2 * np.pi * 11 * t + 0.4)]
    fine = upsample(x, 4)
    tf = np.arange(4 * n) / (4 * fs)
    exact = np.c_[np.sin(2 * np.pi * 3 * tf), 0.3 * np.cos(2 * np.pi * 11 * tf + 0.4)]
    np.testing.assert_allclose(fine[::4], x, atol=1e-12)
    interior = slice(200, -200)  # the mirrored extension is not periodic in slope at the ends
    np.testing.assert_allclose(fine[interior], exact[interior], atol=1e-4)
    signals = Signals(x[:, :1], x[:, 1:], fs, [1], [1], velocity=x[:, 1:] * 2)
    up = upsample(signals, 3)
    assert up.fs == 3 * fs and up.n_samples == 3 * n
    np.testing.assert_allclose(up.displacement[::3], signals.displacement, atol=1e-12)
    with pytest.raises(InputDataError):
        upsample(x, 0)
