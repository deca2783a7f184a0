"""Data-only localisation of a nonlinearity on periodic data and the loop's periodic screen."""

from __future__ import annotations

import numpy as np
import pytest

from bayesnsi.exceptions import BayesNSIError
from bayesnsi.loop.localise import location_distortion, screen_effects_periodic
from bayesnsi.models import CandidateModel, Term, effect_dictionary
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, multisine, simulate_response

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 4, 4
# a three-DOF chain, force at DOF 1, a cubic spring between DOFs 2 and 3 (k3 = 2e6 N/m³)
MCK = chain_system([1.0, 1.2, 0.9], [800.0, 900.0, 700.0], [2.0, 2.0, 2.0])
JOINT = Term("(x2-x3)**3", (2, 3))


def _record(k3: float, seed: int = 4) -> Signals:
    rng = np.random.default_rng(seed)
    force = multisine(P, FS, (1.0, 20.0), 10.0, rng, n_periods=N_PERIODS + TRANSIENT, kind="random-odd")
    terms, coefs = ([JOINT], [k3]) if k3 else ([], [])
    response = simulate_response(*MCK, [1], force.fine, FS * force.oversample, force.oversample, terms, coefs)
    signals = Signals(force=response.force, displacement=add_output_noise(response.displacement, 1.0, rng),
                      fs=FS, input_dofs=(1,), output_dofs=(1, 2, 3), period=P)
    return signals.segment(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)


@pytest.fixture(scope="module")
def joint_record() -> Signals:
    return _record(2e6)


def test_the_relative_motion_across_the_joint_is_the_most_distorted(joint_record):
    levels = location_distortion(joint_record, [(1,), (2,), (3,), (1, 2), (2, 3), (4,)])
    odd = {loc: level[0] for loc, level in levels.items()}
    assert np.isnan(odd[(4,)])  # not measured
    others = [v for loc, v in odd.items() if loc not in ((2, 3), (4,))]
    assert odd[(2, 3)] > 2.0 * max(others)  # the joint pair leads every other location
    assert all(level[1] < 2.0 for loc, level in levels.items() if loc != (4,))  # an odd nonlinearity: even lines empty


def test_a_linear_record_shows_no_location_above_the_noise():
    linear = _record(0.0)
    spectra = location_distortion(linear, [(2, 3)])[(2, 3)]
    joint = location_distortion(_record(2e6), [(2, 3)])[(2, 3)]
    # the same pair without the spring: only noise at the empty lines, which is no distortion level at all
    assert np.isnan(spectra[0]) and joint[0] > 0


def test_the_periodic_screen_puts_the_joint_effects_first_and_even_ones_last(joint_record):
    effects = effect_dictionary((1, 2, 3), ["x^2", "x^3", "v|v|", "sign(v)"])
    ranked = screen_effects_periodic(joint_record, CandidateModel(name="linear", terms=()), effects)
    locations = [tuple(e.location) for e, _, _ in ranked]
    names = [e.term.name for e, _, _ in ranked]
    scores = [score for _, score, _ in ranked[:3]]
    assert len(set(scores)) == 3  # the effects at one location differ in score (no tie)
    assert locations[:3] == [(2, 3)] * 3 and "(x2-x3)**2@2-3" not in names[:3]  # odd types at the joint first
    assert names.index("(x2-x3)**2@2-3") > names.index("x1**3@1")  # even effects after every odd one
    aperiodic = Signals(force=joint_record.force, displacement=joint_record.displacement, fs=FS, input_dofs=(1,),
                        output_dofs=(1, 2, 3))
    with pytest.raises(BayesNSIError, match="periodic"):
        screen_effects_periodic(aperiodic, CandidateModel(name="linear", terms=()), effects)
