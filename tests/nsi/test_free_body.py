"""Free bodies: a rigid-body pole identifies, physical parameters, force prediction.

The reference record is built by an independent fine-step integration (tests/_helpers/carriage.py) (semi-implicit Euler
at 10× the output rate) of a carriage without spring, ``M q'' + Fv q' + Fc sign(q') + offset =
tau``, held by a PD position loop as the measured EMPS axis is; the true parameters are the
reference values.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from bayesnsi.exceptions import SpuriousPoleWarning, UnstableModelError
from bayesnsi.nsi import identify
from bayesnsi.nsi.free_body import free_frf, stabilise
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from tests._helpers.carriage import FC, FS, FV, MASS
from tests._helpers.carriage import free_body_record as _free_body_record


@pytest.fixture(scope="module")
def carriage() -> Signals:
    q, tau = _free_body_record()
    # means removed: the constant offset force then leaves no trace in the identification
    return Signals(
        force=(tau - tau.mean())[:, None],
        displacement=(q - q.mean())[:, None],
        fs=FS,
        input_dofs=(1,),
        output_dofs=(1,),
    )


def _identify(signals, terms, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SpuriousPoleWarning)  # the rigid-body pole of the free body
        return identify(signals, terms, NSIOptions(block_rows=20, order=2, **options))


def test_linear_free_body_identifies_with_rigid_body_pole(carriage):
    result = _identify(carriage, None)
    assert result.virtual_stiffness > 0
    # one rigid-body pole, |s| below the record's resolution 2π/T
    assert len(result.rigid_body_poles) == 1
    assert abs(result.rigid_body_poles[0]) < 2 * np.pi / 60.0
    # the free model keeps a pole at z ≈ 1
    assert np.min(np.abs(result.free_model.poles_discrete - 1.0)) < 1e-3
    (phys,) = result.physical_parameters
    assert phys.mass == pytest.approx(MASS, rel=0.05)
    assert abs(phys.stiffness) < 0.05 * result.virtual_stiffness


def test_without_the_stabilising_spring_the_free_body_fails(carriage):
    with pytest.raises(UnstableModelError):
        _identify(carriage, None, virtual_stiffness=0.0)


def test_coulomb_free_body_recovers_mass_damping_friction(carriage):
    result = _identify(carriage, [("sign(v1)", 1)])
    (phys,) = result.physical_parameters
    # tolerances: the targets on the measured EMPS axis (M 2 %, Fv and Fc 5 %)
    assert phys.mass == pytest.approx(MASS, rel=0.02)
    assert phys.damping == pytest.approx(FV, rel=0.05)
    assert result.coefficient_values[0] == pytest.approx(FC, rel=0.05)
    assert abs(phys.stiffness) < 5.0  # N/m: no spring
    assert result.modes == ()  # no oscillatory mode: the body is free
    assert result.reconstruct(carriage).nrmse < 0.05


def test_free_frf_is_the_frf_of_the_free_model(carriage):
    result = _identify(carriage, [("sign(v1)", 1)])
    freqs = np.linspace(*result.band_hz, 7)
    direct = result.free_model.frf(freqs)
    assert np.allclose(result.frf(freqs), direct, rtol=1e-8)
    # H(ω) ≈ 1/(-Mω² + jωFv) of the true carriage within a few per cent in the band (the force is
    # held between samples here, so the phase drifts above the band)
    omega = 2 * np.pi * freqs
    true = 1.0 / (-MASS * omega**2 + 1j * omega * FV)
    assert np.allclose(direct[:, 0, 0], true, rtol=0.05)
    k = result.virtual_stiffness
    assert np.allclose(free_frf(result.model.frf(freqs), k, (1,), (1,)), direct, rtol=1e-8)
    assert np.allclose(stabilise(carriage, k).force[:, 0], carriage.force[:, 0] + k * carriage.displacement[:, 0])


def test_force_prediction_matches_that_of_the_true_parameters(carriage):
    from bayesnsi.models import Term
    from bayesnsi.nsi import force_prediction, short_horizon_nrmse
    from bayesnsi.nsi.inverse import filtered_kinematics, inverse_force

    coulomb = _identify(carriage, [("sign(v1)", 1)])
    linear = _identify(carriage, None)
    error = force_prediction(coulomb, carriage, cutoff_hz=10.0)
    before = force_prediction(linear, carriage, cutoff_hz=10.0)
    assert error.quantity == "force"
    # reference: the inverse model with the true parameters, same filter, offset fitted to the
    # mean-removed force (the identification removed the mean, the offset with it)
    x, v, a, f, _ = filtered_kinematics(carriage, 10.0)
    true = inverse_force(MASS, FV, 0.0, [Term("sign(v1)", 1)], [FC], x, v, a)
    keep = slice(20, -20)
    true_rmse = np.sqrt(np.mean(((f - true) - np.mean((f - true)[keep]))[keep] ** 2))
    assert error.rmse < 1.1 * true_rmse + 0.5
    assert before.rmse > 1.5 * error.rmse
    assert short_horizon_nrmse(coulomb, carriage, 200) < short_horizon_nrmse(linear, carriage, 200)
