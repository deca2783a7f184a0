"""The free-body evidence: the inverse-model force likelihood, offset profiled; one-line failures.

A free body (rigid-body pole, identified with a virtual spring) is scored by default on the force
it predicts from the measured motion, with the inverse model's linear part ``[a, v, x, 1]`` -
mass, viscous damping, stiffness and the constant force offset - profiled out
(:func:`bayesnsi.evidence.candidate_affine`, docs/method.md §11). Reference record: a carriage
with Coulomb friction and an offset in a PD position loop, integrated independently here (fine-step
semi-implicit Euler, as tests/_helpers/carriage.py). On the measured EMPS axis (skipped without the
data) the same likelihood ranks direction-dependent viscous friction above the symmetric curvature
v|v| (benchmarks/emps_ranking.py: the six velocity plateaus give Fv 155 forwards, 229 N s/m
backwards).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi.evidence import candidate_evidence
from bayesnsi.exceptions import SpuriousPoleWarning
from bayesnsi.nsi import identify, is_free_body
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.signals import Signals

FS = 200.0
FAST = EvidenceOptions(n_steps=300, n_burn=100, likelihood="ar1", compare=())
EMPS = Path(__file__).resolve().parents[3] / "shared" / "data" / "emps" / "DATA_EMPS.mat"


def _carriage(seed=1, duration=60.0, sub=10, mass=95.0, fv=200.0, fc=20.0, offset=-3.0):
    rng = np.random.default_rng(seed)
    n, h = int(duration * FS), 1.0 / (FS * sub)
    t = np.arange(n * sub) * h
    ref = sum(0.05 * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in rng.uniform(0.1, 1.0, 5))
    disturbance = rng.normal(0.0, 5.0, n)
    q = v = tau = 0.0
    qs, taus = np.empty(n), np.empty(n)
    for k in range(n * sub):
        if k % sub == 0:
            tau = 4000.0 * (ref[k] - q) - 600.0 * v + disturbance[k // sub]
            qs[k // sub], taus[k // sub] = q, tau
        v += h * (tau - fv * v - fc * np.sign(v) - offset) / mass
        q += h * v
    qs = qs + rng.normal(0.0, 1e-6, n)
    return Signals(force=(taus - taus.mean())[:, None], displacement=(qs - qs.mean())[:, None], fs=FS,
                   input_dofs=(1,), output_dofs=(1,))


def _log_z(signals, terms, nsi):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        result = identify(signals, terms, nsi)
        assert is_free_body(result)
        evidence = candidate_evidence(result, signals, FAST, np.random.SeedSequence(0), warn=False)
    return evidence["ar1"].log_evidence


@pytest.fixture(scope="module")
def carriage_scores():
    signals = _carriage()
    nsi = NSIOptions(block_rows=20, order=2, upsample=2)
    candidates = {
        "Coulomb": [("sign(v1)", 1)],
        "Coulomb + offset": [("sign(v1)", 1), ("1", 1)],
        "Coulomb + v|v|": [("sign(v1)", 1), ("v1*abs(v1)", 1)],
    }
    return {name: _log_z(signals, terms, nsi) for name, terms in candidates.items()}


def test_offset_is_part_of_the_profiled_inverse_model(carriage_scores):
    """The offset column is constant: profiled with the linear part it adds nothing and costs nothing."""
    assert carriage_scores["Coulomb + offset"] == pytest.approx(carriage_scores["Coulomb"], abs=0.05)


def test_true_coulomb_carriage_is_not_bent_into_v_abs_v(carriage_scores):
    """Control: where the friction law is Coulomb + viscous, v|v| loses (its prior costs, its fit gains nothing)."""
    assert carriage_scores["Coulomb"] > carriage_scores["Coulomb + v|v|"]


def test_failed_candidate_says_why_on_one_line():
    from bayesnsi.report.terminal import outcome_line

    message = "UnstableModelError: |eig| = 1.0001\ntry another order or number of block rows"
    failed = SimpleNamespace(name="c", cached=False, seconds=1.0, result=None, error=message, evidences=None)
    text = outcome_line(failed, "ar1")
    assert "\n" not in text and "|eig| = 1.0001 try another order" in text
    identified = SimpleNamespace(name="c", cached=True, seconds=0.0, error=message, evidences=None,
                                 result=SimpleNamespace(order=2), nrmse=0.1)
    text = outcome_line(identified, "ar1")
    assert "\n" not in text and text.startswith("c: order 2, NRMSE 0.1000, evidence failed - UnstableModelError")


@pytest.mark.skipif(not EMPS.exists(), reason="EMPS data (../shared/data/emps) not present")
def test_emps_direction_dependent_damping_beats_the_symmetric_curvature():
    """Measured EMPS: Coulomb + v+ (Fv by direction) > Coulomb + v|v| > Coulomb = Coulomb + offset (log Z, AR(1))."""
    from bayesnsi.io import load_config, load_signals

    config = load_config(Path(__file__).resolve().parents[2] / "workflows" / "emps" / "emps.toml")
    signals = load_signals(config)
    scores = {
        name: _log_z(signals, terms, config.nsi)
        for name, terms in {
            "Coulomb": [("sign(v1)", 1)],
            "Coulomb + v|v|": [("sign(v1)", 1), ("v1*abs(v1)", 1)],
            "Coulomb + v+": [("sign(v1)", 1), ("v1*(1+sign(v1))/2", 1)],
        }.items()
    }
    assert scores["Coulomb + v+"] > scores["Coulomb + v|v|"] + 100  # 185 nat measured
    assert scores["Coulomb + v|v|"] > scores["Coulomb"] + 20  # 62 nat measured


def test_free_body_is_scored_on_the_profiled_force_residual_whatever_the_residual_option():
    """The documented default: every residual option gives the IDIM force residual with [a, v, x, 1] profiled."""
    from bayesnsi.evidence import candidate_affine
    from bayesnsi.nsi import force_affine

    signals = _carriage(seed=2, duration=30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        result = identify(signals, [("sign(v1)", 1)], NSIOptions(block_rows=20, order=2, upsample=2))
    profiled = force_affine(result, signals, profile=True)
    for residual in ("innovations", "reconstruction", "force"):
        affine = candidate_affine(result, signals, residual)
        np.testing.assert_array_equal(affine.measured, profiled.measured)
        np.testing.assert_array_equal(affine.signatures, profiled.signatures)
    # profiled: the measured force holds nothing along the inverse model's linear part, the offset included
    assert abs(float(np.mean(profiled.measured))) < 1e-9 * float(np.std(profiled.measured))


def test_noise_intervals_accept_a_model_without_modes():
    """A free body has no oscillatory mode: the replicates' moments of zero parameters are empty, not an error
    (every EMPS candidate failed with 'cannot reshape array of size 0 into shape (0)')."""
    from bayesnsi.uncertainty.replicates import replicate_moments

    sd, bias, count = replicate_moments(np.zeros(0), np.zeros((16, 0)))
    assert sd.shape == bias.shape == count.shape == (0,)
    sd, bias, count = replicate_moments([1.0], [[0.9], [1.1], [np.nan]])
    assert count.tolist() == [2] and sd[0] == pytest.approx(np.std([0.9, 1.1], ddof=1))
    assert bias[0] == pytest.approx(0.0)
