"""Frequency-domain NSI on periodic data (SPEC 11): accuracy, result object, errors."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import ConfigError, InputDataError, OrderError
from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, multisine, simulate_response
from tests._helpers.multisine_chain import CUBIC, FS, K3, MCK, N_PERIODS, TRANSIENT, P
from tests._helpers.multisine_chain import periodic_record as _record


def _exact_frequencies() -> np.ndarray:
    """Undamped-free natural frequencies |s|/2π from eig of the linear state matrix (independent)."""
    M, C, K = MCK
    Ac = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    s = np.linalg.eigvals(Ac)
    return np.sort(np.abs(s[s.imag > 0]) / (2 * np.pi))


@pytest.fixture(scope="module")
def record() -> Signals:
    return _record()


def test_frequency_route_recovers_k3_and_the_frequencies_on_a_noisy_multisine(record):
    result = identify(record, CUBIC, NSIOptions(domain="frequency", order=4))
    assert result.settings["domain"] == "frequency" and result.settings["n_periods"] == N_PERIODS
    k3 = result.coefficient_values[0]
    assert abs(k3 / K3 - 1) < 0.005  # within 0.5 %
    freqs = np.array([mode.frequency_hz for mode in result.modes])
    assert np.all(np.abs(freqs / _exact_frequencies() - 1) < 2e-4)  # within 0.02 %
    assert result.coefficients[0].imag_ratio < 0.02


def test_frequency_route_is_exact_on_noise_free_steady_state():
    result = identify(_record(seed=1, noise=0.0), CUBIC, NSIOptions(domain="frequency", order=4))
    assert abs(result.coefficient_values[0] / K3 - 1) < 1e-4
    freqs = np.array([mode.frequency_hz for mode in result.modes])
    assert np.all(np.abs(freqs / _exact_frequencies() - 1) < 1e-5)  # RK4 error ~ 2e-6


def test_frequency_result_works_like_the_time_result(record):
    result = identify(record, CUBIC, NSIOptions(domain="frequency", order=4))
    lam = result.coefficient_spectrum(np.linspace(1.0, 9.0, 50))
    assert lam.shape == (50, 1) and np.allclose(lam.real, K3, rtol=0.03)
    assert result.frf([2.0, 5.0]).shape == (2, 2, 2)
    rec = result.reconstruct(record)
    assert np.all(rec.nrmse < 0.05)  # open loop on the estimation record: close to the 2 % noise
    linear = identify(record, None, NSIOptions(domain="frequency", order=4))
    assert linear.coefficients == () and len(linear.modes) == 2


def test_frequency_route_refuses_what_it_cannot_use(record):
    with pytest.raises(ConfigError, match="domain"):
        NSIOptions(domain="laplace")
    aperiodic = Signals(force=record.force, displacement=record.displacement, fs=FS, input_dofs=(2,),
                        output_dofs=(1, 2))
    with pytest.raises(InputDataError, match="period"):
        identify(aperiodic, CUBIC, NSIOptions(domain="frequency"))
    capped = identify(record, CUBIC, NSIOptions(domain="frequency", block_rows=200, order=4))
    assert capped.settings["block_rows"] == capped.settings["n_lines"] // 4  # m + q + l = 4
    with pytest.raises(OrderError, match="impossible"):
        identify(record, CUBIC, NSIOptions(domain="frequency", band_hz=(0.5, 1.0), order=40))
    with pytest.raises(InputDataError, match="excited line"):
        identify(record, CUBIC, NSIOptions(domain="frequency", band_hz=(30.0, 40.0)))
    one_period = record.segment(0, P)
    with pytest.raises(InputDataError, match="two periods"):
        identify(one_period, CUBIC, NSIOptions(domain="frequency"))


def test_time_route_stays_the_default(record):
    assert NSIOptions().domain == "time"
    result = identify(record, CUBIC, NSIOptions(order=4))
    assert "domain" not in result.settings or result.settings["domain"] == "time"


def test_config_data_period_and_nsi_domain_load_a_periodic_record(tmp_path, record):
    from bayesnsi.exceptions import ConfigError as _ConfigError
    from bayesnsi.io import load_config, load_signals

    rows = ["f2,x1,x2"] + [f"{f:.17g},{a:.17g},{b:.17g}" for f, (a, b) in zip(record.force[:, 0], record.displacement)]
    (tmp_path / "data.csv").write_text("\n".join(rows) + "\n")
    text = (
        '[data]\nfile = "data.csv"\nfs = 100.0\nperiod = 1000\nestimation = [1000, 10000]\n'
        "inputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n"
        '[nsi]\ndomain = "frequency"\norder = 4\n'
        '[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n'
    )
    (tmp_path / "experiment.toml").write_text(text)
    config = load_config(tmp_path / "experiment.toml")
    signals = load_signals(config)
    assert config.nsi.domain == "frequency" and signals.period == P and signals.n_samples == 9 * P
    result = identify(signals, config.candidates[0], config.nsi)
    assert abs(result.coefficient_values[0] / K3 - 1) < 0.01 and result.settings["n_periods"] == 9
    (tmp_path / "bad.toml").write_text(text.replace("period = 1000", "period = 1000\ndecimate = 3"))
    with pytest.raises(_ConfigError, match="period"):
        load_config(tmp_path / "bad.toml")


def test_unstable_poles_are_reflected_with_a_named_warning_not_a_failure(record):
    from bayesnsi.exceptions import SpuriousPoleWarning

    # an over-parametrised linear model of the nonlinear data: the subspace step gives an unstable pair
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = identify(record, None, NSIOptions(domain="frequency", order=8))
    messages = [str(w.message) for w in caught if issubclass(w.category, SpuriousPoleWarning)]
    assert any(re.search(r"unstable pole\(s\) at [0-9.]+ Hz .* reflected", m) for m in messages), messages
    assert result.model.is_stable and len(result.settings["reflected_poles_hz"]) == 1
    assert np.all(np.real(result.model.poles) < 0)


def test_line_misfit_says_how_much_of_the_residual_is_noise(record):
    from bayesnsi.io.schema import _identification

    true = identify(record, CUBIC, NSIOptions(domain="frequency", order=4))
    linear = identify(record, None, NSIOptions(domain="frequency", order=4))
    assert 0.8 < true.settings["line_misfit"] < 1.3  # the true model leaves the noise (weighted rms ≈ 1)
    assert linear.settings["line_misfit"] > 10.0
    periodic = _identification(true)["periodic"]
    assert periodic["domain"] == "frequency" and periodic["n_periods"] == N_PERIODS and periodic["line_misfit"] > 0


def test_accelerations_as_measured_periodic_config(tmp_path):
    """Accelerometers only: [data] integrate with a period divides by (jω)² on the lines (no drift)."""
    from bayesnsi.io import load_config, load_signals

    rng = np.random.default_rng(3)
    force = multisine(P, FS, (0.5, 20.0), 5.0, rng, n_periods=N_PERIODS + TRANSIENT)
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, CUBIC, [K3])
    acc = add_output_noise(response.acceleration, 2.0, rng)[TRANSIENT * P :]
    f = response.force[TRANSIENT * P :, 0]
    rows = ["f2,a1,a2"] + [f"{a:.17g},{b:.17g},{c:.17g}" for a, (b, c) in zip(f, acc)]
    (tmp_path / "data.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "experiment.toml").write_text(
        '[data]\nfile = "data.csv"\nfs = 100.0\nperiod = 1000\ninputs = { f2 = 2 }\n'
        "accelerations = { a1 = 1, a2 = 2 }\nintegrate = { band_hz = [0.4, 30.0] }\n"
        '[nsi]\ndomain = "frequency"\norder = 4\n'
        '[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n'
    )
    config = load_config(tmp_path / "experiment.toml")
    signals = load_signals(config)
    assert signals.period == P and signals.velocity is not None
    result = identify(signals, config.candidates[0], config.nsi)
    assert abs(result.coefficient_values[0] / K3 - 1) < 0.005  # measured -0.30 %
    freqs = np.array([mode.frequency_hz for mode in result.modes])
    assert np.all(np.abs(freqs / _exact_frequencies() - 1) < 2e-4)  # measured 0.012 %, 0.013 %


def test_random_odd_record_reports_power_at_unexcited_lines():
    cubic = identify(_record(seed=2, rms=10.0, kind="random-odd"), CUBIC, NSIOptions(domain="frequency", order=4))
    ratio = cubic.settings["unexcited_ratio"]
    assert ratio["odd"][0] > 5.0  # odd nonlinearity at DOF 1: power at the unexcited odd lines
    assert ratio["even"][0] < 2.0  # nothing even
    assert abs(cubic.coefficient_values[0] / K3 - 1) < 0.01  # the excited (odd) lines suffice
    linear_data = _record(seed=2, rms=10.0, k3=0.0, kind="random-odd")
    ratio = identify(linear_data, None, NSIOptions(domain="frequency", order=4)).settings["unexcited_ratio"]
    assert max(ratio["odd"] + ratio["even"]) < 2.0
    full = identify(_record(seed=2), CUBIC, NSIOptions(domain="frequency", order=4))
    assert full.settings["unexcited_ratio"] is None  # a full multisine leaves no line out


def test_the_loop_closes_on_the_frequency_route(record):
    """diagnose works unchanged: from the linear model it adds the cubic spring at DOF 1 and stops."""
    from bayesnsi.loop import close_the_loop
    from bayesnsi.models import CandidateModel
    from bayesnsi.options import EvidenceOptions, LoopOptions

    loop = close_the_loop(record, CandidateModel(name="linear", terms=()), LoopOptions(max_steps=2),
                          nsi=NSIOptions(domain="frequency", order=4), evidence=EvidenceOptions(n_steps=200, n_burn=50))
    assert [t.name for t in loop.final.terms] == [CUBIC[0].name]
    assert loop.final.settings["domain"] == "frequency"
    assert abs(loop.final.coefficient_values[0] / K3 - 1) < 0.01


def test_a_validation_window_shorter_than_a_period_loads_without_it(tmp_path, record):
    from bayesnsi.io import load_config, load_signals, load_validation

    rows = ["f2,x1,x2"] + [f"{f:.17g},{a:.17g},{b:.17g}" for f, (a, b) in zip(record.force[:, 0], record.displacement)]
    (tmp_path / "data.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "experiment.toml").write_text(
        '[data]\nfile = "data.csv"\nfs = 100.0\nperiod = 1000\nestimation = [0, 8000]\n'
        "inputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n"
        '[[candidates]]\nname = "linear"\nterms = []\n'
        '[[validation]]\nname = "short"\nstart = 8000\nstop = 8500\n'
    )
    config = load_config(tmp_path / "experiment.toml")
    assert load_signals(config).period == P
    (segment,) = load_validation(config)
    assert segment[1].period is None and segment[1].n_samples == 500
