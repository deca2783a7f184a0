"""Velocity sensors alone (a laser vibrometer): integrated once on load, their noise kept.

A two-shaker chain measured by a vibrometer (velocities only) must load without mapping velocities
as accelerations, which would integrate them twice without a word: ``[data] velocities`` with
``integrate`` and no ``outputs`` integrates them once
(:func:`bayesnsi.preprocess.integrate_velocity`), keeps the white velocity noise with the recipe
(:class:`bayesnsi.noise.integrated.AccelerationNoise`, ``measured = "velocity"``) for the noise
replicates and the adequacy check, and reports errors in velocity.
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi.checks.adequacy import model_checks
from bayesnsi.exceptions import ConfigError, InputDataError
from bayesnsi.io import load_config, load_signals
from bayesnsi.io.units import data_units
from bayesnsi.models import CandidateModel, Term
from bayesnsi.noise import AccelerationNoise, acceleration_noise_of, noise_model
from bayesnsi.nsi import identify, periodic_integration
from bayesnsi.options import NSIOptions
from bayesnsi.preprocess import band_filter, integrate_velocity
from bayesnsi.simulate import band_limited_gaussian, chain_system, simulate_response

FS, BAND = 100.0, (1.0, 45.0)
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
TRUE = CandidateModel("x1 cubic", (Term("x1**3", 1),))
WRONG = CandidateModel("x2 cubic", (Term("x2**3", 2),))
NSI = NSIOptions(order=4)


@pytest.mark.parametrize("method, rtol", [("frequency", 1e-3), ("time", 0.02)])
def test_integrate_velocity_of_an_in_band_sine_is_its_integral(method, rtol):
    # analytic: v = cos(ωt) -> x = sin(ωt)/ω; the frequency method is exact in the band away from the
    # record's ends, the trapezoid rule has gain (ωΔt/2)/tan(ωΔt/2) and the high-pass -0.8 % at 2 f_lo
    fs, f0, n = 200.0, 7.0, 8000
    t = np.arange(n) / fs
    omega = 2 * np.pi * f0
    velocity, displacement = integrate_velocity(np.cos(omega * t), fs, (1.0, 60.0), method)
    inner = slice(800, n - 800)
    assert np.allclose(displacement[inner], np.sin(omega * t[inner]) / omega, atol=rtol / omega)
    assert np.allclose(velocity[inner], np.cos(omega * t[inner]), atol=rtol)
    with pytest.raises(InputDataError, match="band"):
        integrate_velocity(np.cos(omega * t), fs, (0.0, 60.0))


def test_periodic_integration_of_a_velocity_is_exact_on_its_lines():
    fs, period = 100.0, 400
    t = np.arange(3 * period) / fs
    lines = np.array([3, 11, 40])  # DFT lines of one period
    omega = 2 * np.pi * lines * fs / period
    v = np.cos(np.outer(t, omega)).sum(axis=1)
    velocity, displacement = periodic_integration(v, fs, period, (0.5, 20.0), measured="velocity")
    assert np.allclose(displacement, (np.sin(np.outer(t, omega)) / omega).sum(axis=1), atol=1e-10)
    assert np.allclose(velocity, v, atol=1e-10)
    with pytest.raises(InputDataError, match="measured"):
        periodic_integration(v, fs, period, (0.5, 20.0), measured="jerk")


def _record(tmp_path, seed=0, noise=0.02, data_lines=None):
    """60 s of the cubic chain under a 1-30 Hz random force, two velocity sensors with 2 % noise, as a file."""
    rng = np.random.default_rng(seed)
    n = 6000
    force = band_limited_gaussian(n, FS, 5.0, rng, oversample=8, band_hz=(1.0, 30.0))
    response = simulate_response(*MCK, [2], force.fine, FS * 8, 8, [Term("x1**3", 1)], [1e5])
    std = noise * response.velocity.std(axis=0)
    vel = response.velocity + std * rng.standard_normal(response.velocity.shape)
    rows = "\n".join(",".join(f"{v:.10e}" for v in row)
                     for row in np.column_stack([np.arange(n) / FS, response.force[:, 0], vel]))
    (tmp_path / "record.csv").write_text("t,f,v1,v2\ns,N,m/s,m/s\n" + rows + "\n")
    data = data_lines or (
        "velocities = { v1 = 1, v2 = 2 }\n"
        f"integrate = {{ band_hz = [{BAND[0]}, {BAND[1]}] }}\n"
    )
    (tmp_path / "config.toml").write_text(
        '[data]\nfile = "record.csv"\ntime_column = "t"\ninputs = { f = 2 }\n' + data
        + '[[candidates]]\nname = "x1 cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n'
    )
    return load_signals(load_config(tmp_path / "config.toml")), std, response


def test_velocities_alone_are_integrated_once_with_their_noise_kept(tmp_path):
    signals, std, response = _record(tmp_path)
    config = load_config(tmp_path / "config.toml")
    assert config.data.integrated == "velocity" and config.data.outputs == {"x1": 1, "x2": 2}
    assert signals.measured == "velocity" and signals.velocity is not None
    noise = acceleration_noise_of(signals)
    assert isinstance(noise, AccelerationNoise) and noise.measured == "velocity" and noise.source == "estimated"
    # the white velocity noise, estimated before integration (the part the force does not explain)
    assert np.allclose(noise.acceleration_std, std, rtol=0.06)
    # the loaded displacement is the band-passed true one, up to the velocity noise integrated by the
    # same recipe (its std from the recipe, Monte-Carlo): independent check against the simulation
    edge = noise.trim
    truth = band_filter(response.displacement, FS, BAND)[edge : len(response.displacement) - edge]
    truth = truth - truth.mean(axis=0)
    error = (signals.displacement - signals.displacement.mean(axis=0)) - truth
    ratio = error.std(axis=0) / noise.std(len(signals.displacement))[0]
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio
    assert data_units(config).displacement == "m" and data_units(config).velocity == "m/s"
    from bayesnsi.report.choices import measured_text  # the report's data section says how x was obtained

    assert "integrated once from the measured velocities on load, frequency method, band [1, 45] Hz" in (
        measured_text(config))


def test_adequacy_on_integrated_velocities_divides_by_their_integrated_noise(tmp_path):
    signals, _, _ = _record(tmp_path)
    outcomes = [SimpleNamespace(name=m.name, result=identify(signals, m, NSI), intervals=None) for m in (TRUE, WRONG)]
    checks = model_checks(outcomes, signals)
    assert 0.5 < checks[TRUE.name].noise_ratio < 2.0
    assert checks[WRONG.name].noise_ratio > 1.3 * checks[TRUE.name].noise_ratio
    assert checks[TRUE.name].to_dict()["noise_source"] == "velocity sensors (estimated)"
    # the noise the ratio divides by is the recipe's, not the differences' of the integrated displacement
    without = noise_model(replace(signals, acceleration_noise=None)).std(interior=True)
    assert np.all(noise_model(signals).std(interior=True) > 2 * without)


def test_config_messages_for_velocity_sensors(tmp_path):
    velocities_only = "velocities = { v1 = 1, v2 = 2 }\n"
    with pytest.raises(ConfigError, match=r"integrate = \{ band_hz"):
        _record(tmp_path, data_lines=velocities_only)
    with pytest.raises(ConfigError, match="remove outputs"):
        _record(tmp_path, data_lines=velocities_only + 'outputs = { v1 = 1 }\nintegrate = { band_hz = [1, 45] }\n')
    with pytest.raises(ConfigError, match="velocities"):
        _record(tmp_path, data_lines='outputs = { v1 = 1 }\nintegrate = { band_hz = [1, 45] }\n')


def test_modes_below_the_integration_band_are_set_aside():
    # a swept beam integrated from 8 Hz: order 6 gives 30 and 120 Hz and a "mode" at 1.6 Hz (ζ = 0.99),
    # which must not be listed as physical nor set the default averaging band below the data
    from bayesnsi.nsi.identify import informed_modes
    from bayesnsi.nsi.physics import Mode
    from bayesnsi.signals import Signals

    fs = 2000.0
    noise = AccelerationNoise(acceleration_std=(0.01,), fs=fs, band_hz=(8.0, 450.0))  # taper 0.5: nothing below 4 Hz
    rng = np.random.default_rng(0)
    signals = Signals(force=rng.standard_normal((512, 1)), displacement=rng.standard_normal((512, 1)), fs=fs,
                      input_dofs=(1,), output_dofs=(1,), measured="acceleration", acceleration_noise=noise)
    low, first, second = Mode(1.62, 0.99, -10 + 1.4j), Mode(30.0, 0.01, -1.9 + 188j), Mode(120.0, 0.015, -11 + 754j)
    assert informed_modes([low, first, second], signals) == ([first, second], [low])
    assert informed_modes([low], signals) == ([low], [])  # nothing would remain: all kept
    plain = replace(signals, measured="displacement", acceleration_noise=None)
    assert informed_modes([low, first], plain) == ([low, first], [])


def test_heavily_damped_mode_at_the_integration_corner_is_set_aside():
    # an accelerometer chain integrated from 1 Hz at order 10: a 1.33-1.41 Hz "mode" with ζ 0.42-0.45 (the
    # integrated noise, largest at the band's lower edge) must not be reported as f1 of every candidate
    from bayesnsi.nsi.identify import informed_modes
    from bayesnsi.nsi.physics import Mode
    from bayesnsi.signals import Signals

    fs = 1000.0
    noise = AccelerationNoise(acceleration_std=(0.01,), fs=fs, band_hz=(1.0, 200.0))
    rng = np.random.default_rng(1)
    signals = Signals(force=rng.standard_normal((512, 1)), displacement=rng.standard_normal((512, 1)), fs=fs,
                      input_dofs=(1,), output_dofs=(1,), measured="acceleration", acceleration_noise=noise)
    artefact = Mode(1.37, 0.43, -3.7 + 7.8j)  # half-power band from 0.78 Hz, below the 1 Hz corner
    near_corner = Mode(1.05, 0.02, -0.13 + 6.6j)  # lightly damped just above the corner: a mode the data show
    damped_above = Mode(10.3, 0.3, -19 + 62j)  # heavily damped but well inside the band (7.2 Hz)
    assert informed_modes([artefact, near_corner, damped_above], signals) == ([near_corner, damped_above], [artefact])
