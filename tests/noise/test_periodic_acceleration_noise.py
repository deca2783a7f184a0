"""The noise of a periodic record of integrated accelerations (an F-16-style GVT file), and its messages.

The displacement noise lies in the integration band only, where high-order differences see almost
nothing: replicates drawn at that level add ~1e-3 of the real noise and the intervals come out ~1000x
too narrow (k3 in [1.9890e7, 1.9967e7], holding neither the true 2e7 nor a width the data support).
On whole periods the replicate noise is drawn from the period-to-period scatter.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from bayesnsi.models import Term
from bayesnsi.noise import white_noise_std
from bayesnsi.nsi import identify, periodic_integration
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import chain_system, multisine, simulate_response
from bayesnsi.uncertainty.replicates import noise_replicates

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 8, 4
BAND = (1.0, 20.0)
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
CUBIC = [Term("x1**3", 1)]


def _integrated_record(seed: int = 0):
    """Steady-state periods of a cubic 2-DOF chain, accelerometer noise integrated line by line.

    Returns the Signals and the displacement and velocity noise alone (the same integration applied
    to the added acceleration noise: integration is linear), the independent reference.
    """
    rng = np.random.default_rng(seed)
    force = multisine(P, FS, BAND, 5.0, rng, n_periods=N_PERIODS + TRANSIENT)
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, CUBIC, [1e5])
    keep = slice(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)
    acc = response.acceleration[keep]
    noise = 0.02 * acc.std(axis=0) * rng.standard_normal(acc.shape)
    v, x = periodic_integration(acc + noise, FS, P, BAND)
    v_noise, x_noise = periodic_integration(noise, FS, P, BAND)
    signals = Signals(force=response.force[keep], displacement=x, velocity=v, fs=FS, input_dofs=(2,),
                      output_dofs=(1, 2), period=P)
    return signals, x_noise, v_noise


def test_replicate_noise_level_of_integrated_periodic_accelerations_is_the_period_scatter():
    signals, x_noise, _ = _integrated_record(0)
    result = identify(signals, CUBIC, NSIOptions(domain="frequency", order=4))
    noise_std, coefs, *_ = noise_replicates(result, signals, NSIOptions(domain="frequency", order=4), n_replicates=2)
    truth = x_noise.std(axis=0)
    # the differences see the band-limited noise as almost nothing: far below the truth
    assert np.all(white_noise_std(signals.displacement) < 0.05 * truth)
    # the period scatter estimates it (8 periods; the 1/ω² weight leaves few effective lines: ~5 % error)
    assert np.allclose(noise_std, truth, rtol=0.1)
    assert coefs.shape == (2, 1) and np.all(np.isfinite(coefs))


def test_period_noise_draws_keep_the_scatter_spectrum_and_channel_link():
    from bayesnsi.noise import period_noise

    signals, _, _ = _integrated_record(1)
    y = np.column_stack([signals.displacement, signals.velocity])
    scatter = period_noise(y, P)
    assert period_noise(y, None) is None and period_noise(y[: P + 10], P) is None  # not two whole periods
    rng = np.random.default_rng(3)
    draws = np.stack([scatter.draw(len(y) - 250, rng) for _ in range(100)])  # a trailing part period too
    assert draws.shape == (100, len(y) - 250, 4)
    # variance per channel: the scatter's (100 draws x 7.75 periods, a few % sampling error)
    assert np.allclose(draws.std(axis=(0, 1)), scatter.std, rtol=0.1)
    # the spectrum of a drawn period is the scatter's (line by line, averaged over the draws),
    # out-of-band leakage of one period included: E|E*(k)|² = Σ_j |D_j(k)|² / (n - 1)
    expected = np.sum(np.abs(np.fft.rfft(scatter.deviations, axis=1)) ** 2, axis=0) / (N_PERIODS - 1)
    drawn = np.mean(np.abs(np.fft.rfft(draws[:, :P], axis=1)) ** 2, axis=0)
    strong = expected > 1e-3 * expected.max(axis=0)
    ratio = drawn[strong] / expected[strong]
    assert abs(np.mean(ratio) - 1) < 0.05 and np.median(np.abs(ratio - 1)) < 0.2
    # the channels drawn together: the covariance between displacement and velocity noise is kept
    dev = scatter.deviations.reshape(-1, 4)
    cov_data = dev.T @ dev / (len(dev) * (N_PERIODS - 1) / N_PERIODS)
    flat = draws.reshape(-1, 4)
    cov_draw = flat.T @ flat / len(flat)
    scale = np.sqrt(np.outer(np.diag(cov_data), np.diag(cov_data)))
    assert np.all(np.abs(cov_draw - cov_data) < 0.1 * scale)


# --- periods that do not repeat: a transient or another realisation inside the window -------------

def _concatenated_realisations(n_periods: int = 8, noise: float = 0.5):
    """Two realisations (new phases, same lines) from rest, concatenated as in one GVT file."""
    rng = np.random.default_rng(7)
    forces = [multisine(P, FS, BAND, 5.0, rng, n_periods=n_periods) for _ in range(2)]
    response = simulate_response(*MCK, [2], np.stack([f.fine for f in forces]), FS * 8, 8, CUBIC, [1e5])
    x = response.displacement
    x = x + noise / 100 * x.std(axis=(0, 1)) * rng.standard_normal(x.shape)
    return np.concatenate(list(response.force)), np.concatenate(list(x))


def test_period_problems_name_the_transient_and_the_next_realisation():
    from bayesnsi.nsi.steady import period_problems

    force, x = _concatenated_realisations()
    steady = slice(3 * P, 8 * P)  # periods 4-8 of realisation 1 (slowest mode e^{-0.28 t}): nothing to say
    assert period_problems(force[steady], x[steady], P) == []
    transient = period_problems(force[: 8 * P], x[: 8 * P], P, offset=100)
    assert "period 1 of 8 (samples [100, 1100))" in transient[0] and "transient" in transient[0]
    assert all("period 1 " in t or "period 2 " in t for t in transient)  # 6 % of it left after 10 s
    crossing = period_problems(force[4 * P : 9 * P], x[4 * P : 9 * P], P)  # runs into realisation 2
    assert len(crossing) == 1 and "force does not repeat every 1000 samples" in crossing[0]
    wrong_period = period_problems(force[steady], x[steady], 700)
    assert len(wrong_period) == 1 and "force does not repeat" in wrong_period[0]
    assert period_problems(force[P : 3 * P], x[P : 3 * P], P) == []  # two periods: cannot tell
    assert period_problems(force, x, None) == []


def test_loading_a_window_with_a_transient_warns_in_one_plain_line(tmp_path):
    import warnings

    from bayesnsi.cli import main
    from bayesnsi.exceptions import PeriodicityWarning
    from bayesnsi.io import load_config, load_signals

    force, x = _concatenated_realisations()
    np.savetxt(tmp_path / "gvt.csv", np.column_stack([force[:, 0], x]), delimiter=",", header="Force,x1,x2",
               comments="")
    (tmp_path / "gvt.toml").write_text(
        f'[data]\nfile = "gvt.csv"\nfs = {FS}\nperiod = {P}\nestimation = [0, {8 * P}]\n'
        'inputs = { Force = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
        '[nsi]\ndomain = "frequency"\norder = 4\n[[candidates]]\nname = "linear"\nterms = []\n'
    )
    config = load_config(tmp_path / "gvt.toml")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_signals(config)
    assert caught and {w.category for w in caught} == {PeriodicityWarning}
    assert "samples [0, 8000): period 1 of 8" in str(caught[0].message)
    # as a user runs it: a fresh process (in this one the suite records the warnings, so none is shown)
    command = ["identify", str(tmp_path / "gvt.toml"), "--out", str(tmp_path / "out"), "--quiet", "--no-figures"]
    run = subprocess.run([sys.executable, "-m", "bayesnsi", *command], capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    assert "warning: " in run.stderr and "period 1 of 8" in run.stderr and "PeriodicityWarning" not in run.stderr
    # and a caller that collects the warnings still gets them (plain_warnings changes their format only)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["identify", str(tmp_path / "gvt.toml"), "--out", str(tmp_path / "out2"), "--quiet",
                     "--no-figures"]) == 0
    assert any(w.category is PeriodicityWarning for w in caught)


# --- diagnose: "nothing added" while an effect that passes was never examined (n_tries) ---------

def _loop(examined=("(v7-v8)*abs(v7-v8)", "(x7-x8)*abs(x7-x8)", "tanh((v7-v8)/0.0613)")):
    """A loop from 'linear' (8 N, realisation 1): three effects examined and rejected, the joint's cubic ranked
    4th by evidence, passing the quality index, never examined (``n_tries = 3``)."""
    import math
    from types import SimpleNamespace

    from bayesnsi.loop import EffectScore, LoopResult
    from bayesnsi.models import Effect, Term
    from bayesnsi.options import LoopOptions

    def score(expr, base, bf, ratio):
        effect = Effect(base, Term(expr, (7, 8)), eps=float(expr.split("/")[1][:-1]) if base == "tanh(v/eps)" else None)
        return EffectScore(effect, math.nan if bf is None else 1000.0 + bf, log_bayes_factor=math.nan if bf is None
                           else bf, imag_ratio=math.nan if ratio is None else ratio)

    search = (
        score("(v7-v8)*abs(v7-v8)", "v|v|", 44768.1, 1.199),
        score("(x7-x8)*abs(x7-x8)", "x|x|", 44100.6, 0.287),
        score("tanh((v7-v8)/0.0613)", "tanh(v/eps)", 38972.7, 1.384),
        score("(x7-x8)**3", "x^3", 35964.2, 0.200),
        score("tanh((v7-v8)/0.0306)", "tanh(v/eps)", 30736.4, 1.152),  # fails the quality index
        score("sign(v7-v8)", "sign(v)", None, None),  # screened out
    )
    steps = tuple(SimpleNamespace(term=row.term, accepted=False, reason="quality index", imag_ratio=row.imag_ratio)
                  for row in search if row.term.expr.text in examined)
    return LoopResult(start=None, final=None, steps=steps, scores=(search,),
                      options=LoopOptions(threshold=4.6, max_imag_ratio=0.3, n_tries=3))


def test_nothing_added_names_the_unexamined_effect_that_passes():
    from bayesnsi.report.loop import unexamined_note

    note = unexamined_note(_loop())
    assert "(x7-x8)**3@7-8 (log Bayes factor 3.6e+04, |Im|/|Re| 0.2)" in note
    assert "tanh((v7-v8)/0.0306)" not in note and "sign(v7-v8)" not in note
    assert "n_tries = 3" in note and "--n-tries 6" in note
    everything = _loop(examined=("(v7-v8)*abs(v7-v8)", "(x7-x8)*abs(x7-x8)", "tanh((v7-v8)/0.0613)", "(x7-x8)**3"))
    assert unexamined_note(everything) == ""  # examined: nothing left unexamined to name


# --- a periodic test loaded without its period: say so -----------------------------------------

def test_repeating_period_finds_the_multisine_period_and_nothing_in_a_sweep_or_noise():
    from bayesnsi.nsi.steady import repeating_period

    rng = np.random.default_rng(5)
    force = multisine(P, FS, BAND, 5.0, rng, n_periods=4).samples[:, 0]
    assert repeating_period(force) == P
    assert repeating_period(force + 0.3 * force.std() * rng.standard_normal(force.shape)) == P  # noisy force
    assert repeating_period(force[: P + P // 2]) is None  # not two periods
    t = np.arange(4 * P) / FS
    sweep = np.sin(2 * np.pi * (1.0 * t + 0.5 * (19.0 / t[-1]) * t**2))  # linear sweep 1 -> 20 Hz
    assert repeating_period(sweep) is None
    assert repeating_period(rng.standard_normal(4 * P)) is None


def test_a_periodic_record_without_period_gets_a_note_naming_the_period(tmp_path, capsys):
    from bayesnsi.cli import main

    force, x = _concatenated_realisations()
    np.savetxt(tmp_path / "gvt.csv", np.column_stack([force[:, 0], x]), delimiter=",", header="Force,x1,x2",
               comments="")
    (tmp_path / "gvt.toml").write_text(
        f'[data]\nfile = "gvt.csv"\nfs = {FS}\nestimation = [{3 * P}, {8 * P}]\n'
        'inputs = { Force = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
        '[nsi]\norder = 4\n[[candidates]]\nname = "linear"\nterms = []\n'
    )
    assert main(["identify", str(tmp_path / "gvt.toml"), "--out", str(tmp_path / "out"), "--quiet",
                 "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert f"note: the force repeats every {P} samples" in err and f"[data] period = {P}" in err


def test_predictor_noise_of_integrated_periodic_accelerations_is_the_period_scatter():
    """The errors-in-variables predictor (default evidence residual) reads the period scatter, not 5e-18 m."""
    from bayesnsi.noise import measured_noise_std

    signals, x_noise, v_noise = _integrated_record(0)
    disp, vel = measured_noise_std(signals)
    assert np.allclose(disp, x_noise.std(axis=0), rtol=0.1)  # same reference as the replicates' test
    assert vel is not None and np.allclose(vel, v_noise.std(axis=0), rtol=0.1)
