"""Estimation over several realisations of a periodic test at once (``[data] realisations``, ``Signals.realisations``).

Reference values: the simulation's true coefficients (``K3`` below, the cubic spring of the chain
that :func:`bayesnsi.simulate.simulate_response` integrates) and the noise actually added.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import BayesNSIError, ConfigError, InputDataError, PeriodicityWarning
from bayesnsi.models import Term
from bayesnsi.noise import period_scatter_std
from bayesnsi.nsi import best_linear_approximation, identify, predictor_reconstruction, reconstruct
from bayesnsi.nsi.steady import period_problems
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals, join_realisations
from bayesnsi.simulate import chain_system, multisine, multisine_lines, simulate_response
from bayesnsi.uncertainty.intervals import segment_estimates
from bayesnsi.uncertainty.replicates import noise_replicates

FS, P, KEEP, TRANSIENT, R = 100.0, 500, 3, 3, 4
BAND = (1.0, 20.0)
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])
K3 = 2e5
CUBIC = [Term("x1**3", 1)]
FREQ = NSIOptions(domain="frequency", order=4, block_rows=10)


def _realisations(seed: int, noise: float = 0.05, n: int = R, level: float = 20.0, kind: str = "random-odd"):
    """``n`` realisations (new phases, the same random-odd lines) of the cubic chain, steady periods only,
    with ``noise`` x the channel std of white displacement noise; and the noise-free displacements."""
    rng = np.random.default_rng(seed)
    lines = multisine_lines(P, FS, BAND, kind, rng)
    out, clean = [], []
    for _ in range(n):
        force = multisine(P, FS, BAND, level, rng, n_periods=KEEP + TRANSIENT, lines=lines)
        resp = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, CUBIC, [K3])
        keep = slice(TRANSIENT * P, (KEEP + TRANSIENT) * P)
        x = resp.displacement[keep]
        noisy = x + noise * x.std(axis=0) * rng.standard_normal(x.shape)
        out.append(Signals(force=resp.force[keep], displacement=noisy, fs=FS, input_dofs=(2,), output_dofs=(1, 2),
                           period=P))
        clean.append(x)
    return out, clean


def test_joined_realisations_estimate_closer_to_the_truth_than_single_ones():
    single_errors, joint_errors = [], []
    for seed in range(3):
        records, _ = _realisations(seed)
        singles = [identify(s, CUBIC, FREQ) for s in records]
        joint = identify(join_realisations(records), CUBIC, FREQ)
        errors = [abs(r.coefficient_values[0] / K3 - 1) for r in singles]
        error = abs(joint.coefficient_values[0] / K3 - 1)
        assert error < np.mean(errors), (seed, error, errors)
        single_errors.append(np.mean(errors))
        joint_errors.append(error)
        assert joint.settings["n_realisations"] == R and joint.settings["n_periods"] == KEEP
        # the noise of each realisation from its own periods: the true model fits the stacked lines as each alone
        assert joint.settings["line_misfit"] < 1.5 * max(r.settings["line_misfit"] for r in singles)
    # 4 x 3 periods against 3: the scatter falls, the errors-in-variables bias (negative) stays
    # (measured: mean error 0.017 against 0.029 over the seeds)
    assert np.mean(joint_errors) < 0.75 * np.mean(single_errors), (joint_errors, single_errors)
    # the same samples read as one realisation mix phases: the force "scatters" between periods as much as
    # it is strong, (almost) no line counts as excited and the record cannot be used at all
    mixed = Signals(force=joint_force(records), displacement=np.concatenate([s.displacement for s in records]),
                    fs=FS, input_dofs=(2,), output_dofs=(1, 2), period=P)
    with pytest.raises(BayesNSIError, match="excited line|block rows"):
        identify(mixed, CUBIC, FREQ)


def joint_force(records):
    return np.concatenate([s.force for s in records])


def test_noise_and_reconstruction_per_realisation():
    records, clean = _realisations(1, n=2, level=3.0, kind="full")  # harmonic balance settles at this level
    joined = join_realisations(records)
    noise = np.concatenate([s.displacement for s in records]) - np.concatenate(clean)
    # the period scatter pools the realisations, each about its own mean (the truth: the added noise's std)
    assert np.allclose(period_scatter_std(joined.displacement, P, 2), noise.std(axis=0), rtol=0.1)
    # read as one realisation the phase change between realisations counts as noise
    assert np.all(period_scatter_std(joined.displacement, P) > 3 * noise.std(axis=0))
    result = identify(joined, CUBIC, FREQ)
    # closed loop by harmonic balance, each realisation from its own force: against the noise-free response
    predicted = reconstruct(result, joined, closed_loop=True).predicted
    truth = np.concatenate(clean)
    nrmse = np.sqrt(np.mean((predicted - truth) ** 2, axis=0) / np.mean(truth**2, axis=0))
    assert np.all(nrmse < 0.05), nrmse
    separately = [reconstruct(result, one, closed_loop=True).predicted for one in records]
    assert np.allclose(predicted, np.concatenate(separately))
    # open loop and innovations: each realisation from its own initial state (no state across the boundary)
    for build in (lambda sig: reconstruct(result, sig).predicted,
                  lambda sig: predictor_reconstruction(result, sig, noise.std(axis=0)).baseline):
        assert np.allclose(build(joined), np.concatenate([build(one) for one in records]))
    # noise replicates: each realisation's noise drawn from its own period scatter, at the true level
    noise_std, coefs, *_ = noise_replicates(result, joined, FREQ, n_replicates=2)
    assert np.allclose(noise_std, noise.std(axis=0), rtol=0.1) and np.all(np.isfinite(coefs))
    # the segments interval re-identifies each realisation (their scatter: noise and stochastic distortion)
    samples, seg_coefs, *_ = segment_estimates(result, joined, FREQ)
    same = FREQ.replace(order=result.order, band_hz=tuple(result.band_hz))  # what the re-identification keeps
    singles = [identify(one, CUBIC, same).coefficient_values for one in records]
    assert samples == 3 * P and np.allclose(seg_coefs, singles)
    # the best linear approximation takes the realisations of the joined record: distortion from 2 of them
    bla = best_linear_approximation([joined])
    assert bla.n_realisations == 2 and bla.n_periods == KEEP


def test_periodicity_checked_inside_each_realisation_not_at_their_boundary():
    records, _ = _realisations(2, noise=0.01, n=2)
    joined = join_realisations(records)
    # read as one record: the second realisation's force does not repeat the first's
    assert period_problems(joined.force, joined.displacement, P)
    assert period_problems(joined.force, joined.displacement, P, realisations=2) == []
    # a transient inside realisation 2 is still named
    disturbed = np.array(joined.displacement)
    disturbed[3 * P : 4 * P] += 5 * disturbed.std(axis=0)
    problems = period_problems(joined.force, disturbed, P, realisations=2)
    assert len(problems) == 1 and problems[0].startswith("realisation 2: period 1 of 3")


def test_bad_realisation_input_is_refused_with_what_to_do():
    records, _ = _realisations(3, n=2)
    f = joint_force(records)
    x = np.concatenate([s.displacement for s in records])
    kw = dict(fs=FS, input_dofs=(2,), output_dofs=(1, 2))
    with pytest.raises(InputDataError, match="needs the period"):
        Signals(force=f, displacement=x, realisations=2, **kw)
    with pytest.raises(InputDataError, match="does not split into 4 equal realisations"):
        Signals(force=f, displacement=x, period=P, realisations=4, **kw)
    with pytest.raises(InputDataError, match="at least two steady periods"):
        Signals(force=f[: 2 * P], displacement=x[: 2 * P], period=P, realisations=2, **kw)
    with pytest.raises(InputDataError, match="differs from realisation 1 in n_samples"):
        join_realisations([records[0], records[1].segment(0, 2 * P)])
    with pytest.raises(InputDataError, match="at least two steady periods"):
        join_realisations(records, drop=2)
    joined = join_realisations(records, drop=1)
    assert joined.realisations == 2 and joined.n_samples == 4 * P
    # the time route: one Hankel block would span two realisations
    with pytest.raises(InputDataError, match='domain = "frequency"'):
        identify(joined, CUBIC, NSIOptions(order=4, block_rows=10))
    # segments: whole realisations keep their count, one inside a realisation is one, a cut across is not periodic
    assert joined.segment(0, 2 * P).realisations == 1 and joined.segment(0, 2 * P).period == P
    assert joined.segment(P, 3 * P).period is None
    assert [s.n_samples for s in joined.realisation_records()] == [2 * P, 2 * P]


def _write(path, records):
    rows = np.column_stack([joint_force(records), np.concatenate([s.displacement for s in records])])
    np.savetxt(path, rows, delimiter=",", header="f,x1,x2", comments="")


def _config(tmp_path, records, validation: str = "", **data):
    from bayesnsi.io import load_config

    _write(tmp_path / "gvt.csv", records)
    domain = data.pop("nsi_domain", "frequency")
    extra = "\n".join(f"{k} = {v}" for k, v in data.items())
    (tmp_path / "c.toml").write_text(
        f'[data]\nfile = "gvt.csv"\nfs = {FS}\ninputs = {{ f = 2 }}\noutputs = {{ x1 = 1, x2 = 2 }}\n{extra}\n'
        f'[nsi]\ndomain = "{domain}"\norder = 4\nblock_rows = 10\n'
        '[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = [1] }]\n' + validation
    )
    return load_config(tmp_path / "c.toml")


def test_config_declares_realisations_and_transient_periods(tmp_path):
    from bayesnsi.io import load_signals, load_validation

    records, _ = _realisations(4, n=2)  # 3 periods each: the first dropped as a transient
    config = _config(tmp_path, records, period=P, realisations=2, transient_periods=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PeriodicityWarning)  # no warning at the declared boundary
        signals = load_signals(config)
    expected = join_realisations(records, drop=1)
    assert signals.realisations == 2 and signals.period == P
    assert np.allclose(signals.displacement, expected.displacement)
    # read as one realisation the boundary is named
    with pytest.warns(PeriodicityWarning, match="does not repeat"):
        load_signals(_config(tmp_path, records, period=P))
    with pytest.raises(ConfigError, match="needs the period"):
        _config(tmp_path, records, realisations=2)
    with pytest.raises(ConfigError, match='add domain = "frequency"'):
        _config(tmp_path, records, period=P, realisations=2, nsi_domain="time")
    with pytest.raises(ConfigError, match="does not split into realisations = 4 equal parts"):
        load_signals(_config(tmp_path, records, period=P, realisations=4))
    with pytest.raises(ConfigError, match="1 after transient_periods = 2"):
        load_signals(_config(tmp_path, records, period=P, realisations=2, transient_periods=2))
    # a validation record of realisations, declared the same way
    others, _ = _realisations(5, n=2)
    _write(tmp_path / "val.csv", others)
    segment = '[[validation]]\nname = "other"\nfile = "val.csv"\nrealisations = 2\ntransient_periods = 1\n'
    config = _config(tmp_path, records, segment, period=P, realisations=2, transient_periods=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PeriodicityWarning)
        (name, held_out), = load_validation(config)
    assert held_out.realisations == 2 and np.allclose(held_out.force, join_realisations(others, drop=1).force)
    with pytest.raises(ConfigError, match="needs the period"):
        _config(tmp_path, records, segment)
