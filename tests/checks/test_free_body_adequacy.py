"""Adequacy of a free body: its force residual against the force noise, not the drift.

The records are a carriage without spring, ``M q'' + Fv q' + Fc sign(q') = tau``, held by a PD
position loop running at 10x the output rate (semi-implicit Euler, as in tests/_helpers/carriage.py); the
applied force carries a smooth disturbance (below the filter's band edge, so it is force the model
must explain) and the *recorded* force a white sensor noise of known std ``SIGMA_F`` that the
carriage never feels. Reference for the noise level: ``SIGMA_F`` times the noise gain of the
force view's filter, measured here by filtering a long white sequence (Monte Carlo, not the
formula the package uses). Without friction the linear model is the true one and must be
adequate; with Coulomb friction the linear model must not be. (The true Coulomb model is not used
as the adequate one: the force view compares the filtered force with ``Fc sign(v)`` of the filtered
velocity, which differ at each velocity reversal, 3.9 N rms on this record with the true
parameters.)
"""

from __future__ import annotations

import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import signal as sps

from bayesnsi.checks.adequacy import adequacy_findings, model_checks
from bayesnsi.exceptions import SpuriousPoleWarning
from bayesnsi.findings import messages
from bayesnsi.nsi import force_noise_std, identify
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals

MASS, FV, FC = 95.0, 200.0, 20.0  # the EMPS axis in round numbers
FS = 200.0
SIGMA_F = 1.0  # N, white noise of the force sensor


def _record(fc: float, seed: int = 1, duration: float = 60.0, sub: int = 10):
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    h = 1.0 / (FS * sub)
    t = np.arange(n * sub) * h
    ref = sum(0.05 * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) for f in rng.uniform(0.1, 1.0, 5))
    smooth = sps.sosfiltfilt(sps.butter(4, 3.0, fs=FS, output="sos"), rng.normal(0.0, 1.0, n))
    disturbance = np.interp(t, np.arange(n) / FS, 5.0 * smooth / smooth.std())
    kp, kv = 4000.0, 600.0
    q = v = tau = 0.0
    qs, taus = np.empty(n), np.empty(n)
    for k in range(n * sub):
        # the controller runs at the fine rate: the recorded force is the force at the sample instant
        tau = kp * (ref[k] - q) - kv * v + disturbance[k]
        if k % sub == 0:
            qs[k // sub], taus[k // sub] = q, tau
        v += h * (tau - FV * v - fc * np.sign(v)) / MASS
        q += h * v
    measured = taus + rng.normal(0.0, SIGMA_F, n)
    return Signals(
        force=(measured - measured.mean())[:, None], displacement=(qs - qs.mean())[:, None], fs=FS,
        input_dofs=(1,), output_dofs=(1,),
    )


@pytest.fixture(scope="module")
def carriage():
    """Checks of the linear model on the record without friction and on the one with friction."""
    checks = {}
    for name, fc in (("no friction", 0.0), ("friction", FC)):
        signals = _record(fc)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
            result = identify(signals, None, NSIOptions(block_rows=20, order=2))
        checks[name] = model_checks([SimpleNamespace(name="linear", result=result)], signals)["linear"]
    return signals, checks


def test_force_noise_level_is_the_sensor_noise_through_the_filter(carriage):
    signals = _record(FC, duration=20.0)
    sos = sps.butter(4, FS / 20, fs=FS, output="sos")
    gain = sps.sosfiltfilt(sos, np.random.default_rng(9).normal(size=400_000))[1000:-1000].std()
    assert force_noise_std(signals) == pytest.approx(SIGMA_F * gain, rel=0.1)


def test_free_body_is_judged_on_its_force_residual(carriage):
    signals, checks = carriage
    true, wrong = checks["no friction"], checks["friction"]
    assert true.quantity == wrong.quantity == "force"
    assert wrong.noise_std[0] == pytest.approx(force_noise_std(signals))
    # the true structure leaves the sensor noise, the linear model the missing friction (judged on
    # the displacement the ratio was the drift of the rigid-body mode over the encoder noise)
    assert true.adequate and 0.8 < true.noise_ratio < 1.3
    assert not wrong.adequate and wrong.noise_ratio > 10.0
    assert not any("no candidate is adequate" in m for m in messages(adequacy_findings({"linear": true}, "linear")))
    assert true.to_dict()["quantity"] == "force"


def test_no_adequate_free_body_says_force(carriage):
    _, checks = carriage
    (message,) = [m for m in messages(adequacy_findings({"linear": checks["friction"]}, "linear")) if "adequate" in m]
    assert "force residual against the force noise" in message


def test_free_body_validating_worse_is_reported_without_tolerance():
    from bayesnsi.checks.adequacy import ModelCheck

    def check(name, nrmse, quantity):
        return ModelCheck(
            name=name, order=2, residual_rms=(2.0,), noise_std=(1.0,), noise_ratio=2.0, adequate=False,
            quality_index=0.01, quality_ok=True, validation_nrmse=nrmse, quantity=quantity,
        )

    # the EMPS figures (workflows/README.md): the selected Coulomb + v|v| predicts the pulses' force 5 % worse
    force = {"Coulomb + v|v|": check("Coulomb + v|v|", 0.0647, "force"), "Coulomb": check("Coulomb", 0.0616, "force")}
    (message,) = [m for m in messages(adequacy_findings(force, "Coulomb + v|v|")) if "validates worse" in m]
    assert "'Coulomb'" in message and "force-prediction" in message and "+5 %" in message
    assert not [m for m in messages(adequacy_findings(force, "Coulomb")) if "validates worse" in m]
    # a closed-loop simulation keeps the 10 % tolerance of the adequacy check
    moved = {n: check(n, c.validation_nrmse, "displacement") for n, c in force.items()}
    assert not [m for m in messages(adequacy_findings(moved, "Coulomb + v|v|")) if "validates worse" in m]


def test_parallel_filtering_of_the_nonlinear_columns():
    # the true carriage's force from its filtered motion: sign(v) of the filtered velocity jumps where
    # the filtered force ramps unless the column is filtered as the force was (3.9 N -> 1.2 N here;
    # what remains is the friction at the velocity reversals, where sign(v) of any estimate errs)
    from bayesnsi.models import Term
    from bayesnsi.nsi.inverse import edge_samples, filtered_kinematics, inverse_force

    signals = _record(FC)
    x, v, a, f, cutoff = filtered_kinematics(signals)
    keep = slice(edge_samples(FS, cutoff), -edge_samples(FS, cutoff))

    def rms(**filtering):
        r = (f - inverse_force(MASS, FV, 0.0, [Term("sign(v1)", 1)], [FC], x, v, a, **filtering))[keep]
        return float(np.sqrt(np.mean((r - r.mean()) ** 2)))

    assert rms(fs=FS, cutoff_hz=cutoff) < 0.4 * rms()


EMPS = Path(__file__).resolve().parents[3] / "shared" / "data" / "emps" / "DATA_EMPS.mat"


@pytest.mark.skipif(not EMPS.exists(), reason="EMPS data not present")
def test_parallel_filtering_reproduces_the_published_emps_inverse_model():
    # least squares on [a, v, filtered sign(v), 1] of the EMPS estimation file gives the published
    # IDIM-LS values (data README: 95.1089 kg, 203.5034 N s/m, 20.3935 N, -3.1648 N); the
    # unfiltered sign column gives Fc 20.25 N, Fv 204.9 N s/m
    import scipy.io

    from bayesnsi.nsi.inverse import edge_samples, filtered_kinematics, parallel_filter

    data = scipy.io.loadmat(EMPS)
    fs = 1.0 / float(np.median(np.diff(data["t"][:, 0])))
    force = float(data["gtau"][0, 0]) * data["vir"][:, 0]
    signals = Signals(force=force[:, None], displacement=data["qm"][:, :1], fs=fs, input_dofs=(1,), output_dofs=(1,))
    x, v, a, f, cutoff = filtered_kinematics(signals)
    keep = slice(edge_samples(fs, cutoff), -edge_samples(fs, cutoff))
    columns = np.column_stack([a, v, parallel_filter(np.sign(v), fs, cutoff), np.ones_like(v)])[keep]
    mass, damping, coulomb, offset = np.linalg.lstsq(columns, f[keep], rcond=None)[0]
    assert mass == pytest.approx(95.1089, rel=1e-3) and damping == pytest.approx(203.5034, rel=1e-3)
    assert coulomb == pytest.approx(20.3935, rel=2e-3) and offset == pytest.approx(-3.1648, rel=5e-3)
