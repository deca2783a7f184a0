"""The simulated ground vibration test: structure, records, data-only diagnosis."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from bayesnsi.exceptions import InputDataError
from bayesnsi.nsi import best_linear_approximation, periodic_integration
from bayesnsi.signals import Signals
from bayesnsi.simulate import GVT_BAND_HZ, GVT_JOINT, GVT_SENSORS, GVT_SHAKER, gvt_records, gvt_structure


def test_structure_has_many_modes_in_band_and_a_suspension_mode_below():
    M, C, K, terms, coefs = gvt_structure()
    freqs = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)) / (2 * np.pi)
    in_band = (freqs >= GVT_BAND_HZ[0]) & (freqs <= GVT_BAND_HZ[1])
    assert in_band.sum() >= 8 and in_band.sum() > len(GVT_SENSORS)  # more modes than sensors
    assert 0 < freqs[0] < 0.5 * GVT_BAND_HZ[0]  # the suspension (rigid-body) mode below the band
    assert set(GVT_JOINT) <= set(GVT_SENSORS) and GVT_SHAKER in GVT_SENSORS
    assert all(term.expr.dofs == GVT_JOINT for term in terms) and np.all(coefs > 0)
    # modal damping 10 % (suspension) and 1.5 %: Φᵀ C Φ = diag(2 ζ ω) (independent check of the damping matrix)
    w2, phi = scipy.linalg.eigh(K, M)
    modal = phi.T @ C @ phi
    assert np.allclose(np.diag(modal), 2 * np.r_[0.10, [0.015] * 11] * np.sqrt(w2), rtol=1e-8)


@pytest.fixture(scope="module")
def records():
    return gvt_records(levels=(0.1, 8.0), n_realisations=2, n_periods=2, transient=2, period=1024, seed=3)


def _signals(record) -> Signals:
    velocity, displacement = periodic_integration(record.acceleration, record.fs, record.period, (1.0, 20.0))
    return Signals(force=record.force, displacement=displacement, velocity=velocity, fs=record.fs,
                   input_dofs=(GVT_SHAKER,), output_dofs=GVT_SENSORS, period=record.period)


def test_records_are_periodic_steady_states_with_noisy_accelerometers(records):
    assert len(records) == 4 and [r.level for r in records] == [0.1, 0.1, 8.0, 8.0]
    for record in records:
        p = record.period
        assert record.force.shape == (2 * p, 1) and record.acceleration.shape == (2 * p, 3)
        assert np.allclose(record.force[:p], record.force[p:])  # the same force every period
        drift = np.max(np.abs(record.displacement[:p] - record.displacement[p:])) / np.ptp(record.displacement)
        assert drift < 2e-3  # steady state after the two transient periods
        noise = np.std(record.acceleration[:p] - record.acceleration[p:], axis=0) / np.sqrt(2)
        assert np.allclose(noise / np.std(record.acceleration, axis=0), 0.015, rtol=0.15)
    assert not np.allclose(records[0].force, records[1].force)  # new phases per realisation
    assert np.array_equal(records[0].lines, records[3].lines)  # the same random-odd lines


def _relative(record) -> Signals:
    """The relative motion of each sensor pair (2-7, 2-8, 7-8) as the outputs."""
    signals = _signals(record)
    x = signals.displacement
    pairs = np.c_[x[:, 0] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 2]]
    return Signals(force=signals.force, displacement=pairs, fs=signals.fs, input_dofs=(GVT_SHAKER,),
                   output_dofs=(1, 2, 3), period=signals.period)


def test_distortion_rises_with_level_and_points_at_the_joint(records):
    low = best_linear_approximation([_signals(r) for r in records[:2]])
    high = best_linear_approximation([_signals(r) for r in records[2:]])
    assert np.all(high.unexcited_ratio()["odd"] > low.unexcited_ratio()["odd"])
    assert np.all(high.unexcited_ratio()["even"] < 2.0)  # the joint is odd (friction, cubic)
    # data-only localisation (method notes: relative motion of the joint's two sensors): the pair
    # 7-8 shows the most power at the unexcited odd lines, at both levels (seeds 3-6: 3.9-7.9 against
    # 1.3-2.2 at 0.1 N, 24-137 against 7-48 at 8 N)
    for level in (records[:2], records[2:]):
        odd = best_linear_approximation([_relative(r) for r in level]).unexcited_ratio()["odd"]
        assert np.argmax(odd) == 2 and odd[2] > 1.3 * max(odd[:2])


def test_gvt_records_refuse_bad_levels():
    with pytest.raises(InputDataError, match="levels"):
        gvt_records(levels=(0.0,))
