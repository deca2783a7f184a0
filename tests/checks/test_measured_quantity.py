"""Errors in the measured quantity (SPEC §9 last bullet)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi._measured import to_measured
from bayesnsi.checks.validation import VALIDATION_INIT_SAMPLES, measured_errors, validate
from bayesnsi.exceptions import AdequacyWarning
from bayesnsi.models import Term
from bayesnsi.nsi import identify
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, multisine, simulate_response

FS, P, K3, TRANSIENT = 100.0, 1000, 1e5, 4
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])  # the two-DOF chain of the frequency-route tests
CUBIC = [Term("x1**3", 1)]
BAND = (0.4, 30.0)


def _band_limited(a: np.ndarray) -> np.ndarray:
    """The raw acceleration column restricted to the integration band (full complex FFT, DC dropped)."""
    spectrum = np.fft.fft(a, axis=0)
    f = np.abs(np.fft.fftfreq(len(a), 1 / FS))
    keep = (f >= BAND[0]) & (f <= BAND[1]) & (f > 0)
    return np.real(np.fft.ifft(spectrum * keep[:, None], axis=0))


@pytest.fixture(scope="module")
def accel_case(tmp_path_factory):
    """Accelerometers only, 10 periods: 8 for estimation, 2 held out; 2 % acceleration noise."""
    from bayesnsi.io import load_config, load_signals, load_validation

    tmp = tmp_path_factory.mktemp("acc")
    rng = np.random.default_rng(5)
    force = multisine(P, FS, (0.5, 20.0), 5.0, rng, n_periods=10 + TRANSIENT)
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, CUBIC, [K3])
    acc = add_output_noise(response.acceleration, 2.0, rng)[TRANSIENT * P :]
    f = response.force[TRANSIENT * P :, 0]
    rows = ["f2,a1,a2"] + [f"{a:.17g},{b:.17g},{c:.17g}" for a, (b, c) in zip(f, acc)]
    (tmp / "data.csv").write_text("\n".join(rows) + "\n")
    (tmp / "experiment.toml").write_text(
        '[data]\nfile = "data.csv"\nfs = 100.0\nperiod = 1000\nestimation = [0, 8000]\ninputs = { f2 = 2 }\n'
        f"accelerations = {{ a1 = 1, a2 = 2 }}\nintegrate = {{ band_hz = [{BAND[0]}, {BAND[1]}] }}\n"
        '[nsi]\ndomain = "frequency"\norder = 4\n'
        '[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n'
        '[[validation]]\nname = "held out"\nstart = 8000\nstop = 10000\n'
    )
    config = load_config(tmp / "experiment.toml")
    signals = load_signals(config)
    result = identify(signals, config.candidates[0], config.nsi)
    return signals, load_validation(config), result, acc


def test_loaded_accelerations_say_so(accel_case):
    signals, validation, _, _ = accel_case
    assert signals.measured == "acceleration" and validation[0][1].measured == "acceleration"
    assert signals.segment(0, 2000).measured == "acceleration"


def test_validation_error_is_in_accelerations_and_matches_an_independent_computation(accel_case):
    _, validation, result, acc = accel_case
    (name, held), = validation
    err = validate(result, validation)[0]
    assert err.quantity == "acceleration" and err.to_dict()["quantity"] == "acceleration"
    # independent: the raw CSV accelerations (band-limited) against the model's displacement times -ω²
    measured = _band_limited(acc[8000:10000])
    pred = result.reconstruct(held, closed_loop=True, n_init=VALIDATION_INIT_SAMPLES).predicted
    spectrum = np.fft.fft(pred, axis=0)
    omega = 2 * np.pi * np.fft.fftfreq(len(pred), 1 / FS)
    omega[len(pred) // 2] = 0.0  # Nyquist line dropped, as the package does
    model = np.real(np.fft.ifft(-(omega**2)[:, None] * spectrum, axis=0))
    e = (measured - model)[VALIDATION_INIT_SAMPLES:]
    y = measured[VALIDATION_INIT_SAMPLES:]
    rmse_c = np.sqrt(np.mean(e**2, axis=0))
    nrmse_c = rmse_c / np.sqrt(np.mean(y**2, axis=0))
    np.testing.assert_allclose(err.rmse_per_channel, rmse_c, rtol=1e-6)
    np.testing.assert_allclose(err.nrmse_per_channel, nrmse_c, rtol=1e-6)
    assert err.rmse == pytest.approx(np.sqrt(np.mean(rmse_c**2)), rel=1e-6)
    assert err.nrmse == pytest.approx(np.sqrt(np.mean(nrmse_c**2)), rel=1e-6)
    # the true model leaves about the 2 % sensor noise (its in-band share): measured 0.0165
    assert 0.005 < err.nrmse < 0.04
    assert len(err.displacement_rmse_per_channel) == 2 and "nrmse_per_channel" in err.to_dict()


def test_open_and_closed_loop_errors_in_accelerations(accel_case):
    signals, _, result, _ = accel_case
    open_loop = measured_errors(result, signals)
    closed = measured_errors(result, signals, closed_loop=True)
    assert open_loop.quantity == closed.quantity == "acceleration"
    assert len(open_loop.nrmse_per_channel) == 2 and 0.005 < open_loop.nrmse < 0.04
    assert closed.nrmse < 0.06
    assert set(open_loop.to_dict()) == {"quantity", "rmse", "nrmse", "rmse_per_channel", "nrmse_per_channel"}


def test_displacement_records_keep_the_displacement_error():
    rng = np.random.default_rng(0)
    t = np.arange(4000) / FS
    x = np.column_stack([np.sin(2 * np.pi * 1.3 * t), np.cos(2 * np.pi * 0.7 * t)])
    s = Signals(force=rng.standard_normal((4000, 1)), displacement=x, fs=FS, input_dofs=(1,), output_dofs=(1, 2))
    assert s.measured == "displacement"
    np.testing.assert_array_equal(to_measured(x, FS, "displacement"), x)


@pytest.mark.parametrize("period", [None, 1000])
def test_differentiation_of_a_sine(period):
    """Periodic: exact on a line; time record: the fourth-order stencil twice (gain error ~ 2(ωΔt)⁴/30)."""
    t = np.arange(4000) / FS
    w = 2 * np.pi * 2.0
    a = to_measured(np.sin(w * t)[:, None], FS, "acceleration", period)[:, 0]
    inner = slice(10, -10)
    tol = 1e-9 if period else 2 * (w / FS) ** 4 / 30 + 1e-9
    np.testing.assert_allclose(a[inner], -(w**2) * np.sin(w * t)[inner], atol=tol * w**2)
    v = to_measured(np.sin(w * t)[:, None], FS, "velocity", period)[:, 0]
    np.testing.assert_allclose(v[inner], w * np.cos(w * t)[inner], atol=tol * w)


def test_measured_must_be_a_known_quantity():
    from bayesnsi.exceptions import InputDataError

    with pytest.raises(InputDataError, match="measured must be one of"):
        Signals(force=np.ones((10, 1)) * np.arange(10)[:, None], displacement=np.arange(10.0), fs=1.0,
                input_dofs=(1,), output_dofs=(1,), measured="jerk")


def test_results_json_says_the_quantity_of_open_loop_and_validation_errors(accel_case):
    """select -> selection_payload: candidates carry open_loop and validation errors in accelerations."""
    from bayesnsi.io import selection_payload
    from bayesnsi.options import EvidenceOptions
    from bayesnsi.selection import select

    signals, validation, result, _ = accel_case
    fast = EvidenceOptions(n_steps=100, n_burn=20, likelihood="white", compare=(), interval="posterior")
    with warnings.catch_warnings():
        # the adequacy check's noise level (white part of the displacement) is near zero on
        # displacements integrated line by line: the residual/noise ratio is not this test's point
        warnings.simplefilter("ignore", AdequacyWarning)
        selection = select(signals, [result.candidate], result_options(result), fast, validation=validation)

    class _Config:  # the two fields selection_payload reads besides the settings
        path, raw, seed, nsi = "experiment.toml", {}, 0, result_options(result)

    payload = selection_payload(selection, "select", _Config())
    (record,) = payload["candidates"]
    expected = measured_errors(selection.results[result.candidate.name], signals)
    assert record["open_loop"]["quantity"] == "acceleration"
    assert record["open_loop"]["nrmse"] == pytest.approx(expected.nrmse, rel=1e-9)
    # the candidate's own nrmse is in the measured quantity too (not in the integrated displacement)
    assert record["nrmse"] == pytest.approx(expected.nrmse, rel=1e-9)
    assert record["nrmse"] != pytest.approx(selection.results[result.candidate.name].reconstruct(signals).nrmse)
    assert len(record["open_loop"]["nrmse_per_channel"]) == 2
    (segment,) = record["validation"]
    assert segment["quantity"] == "acceleration" and len(segment["nrmse_per_channel"]) == 2


def result_options(result):
    from bayesnsi.options import NSIOptions

    return NSIOptions(domain="frequency", order=4)


def test_loop_step_errors_are_in_the_measured_quantity(accel_case):
    """A loop step's open- and closed-loop NRMSE on acceleration data: in accelerations, labelled so."""
    from bayesnsi.loop.guards import _closed_loop_nrmse
    from bayesnsi.loop.state import measured_nrmse

    signals, _, result, _ = accel_case
    rec = result.reconstruct(signals)
    assert measured_nrmse(rec, signals) == pytest.approx(measured_errors(result, signals).nrmse, rel=1e-12)
    assert measured_nrmse(rec, signals) != pytest.approx(rec.nrmse)
    closed = result.reconstruct(signals, closed_loop=True)
    assert _closed_loop_nrmse(result, signals) == pytest.approx(measured_nrmse(closed, signals), rel=1e-12)
    on_displacement = Signals(force=signals.force, displacement=signals.displacement, fs=signals.fs,
                              input_dofs=signals.input_dofs, output_dofs=signals.output_dofs, period=signals.period)
    assert measured_nrmse(rec, on_displacement) == rec.nrmse
