"""Closing the loop (SPEC 7) on simulated data with an undeclared effect, and a negative control.

Data: the paper's two-DOF chain (declared: 20·v1|v1| at DOF 1) simulated with an extra effect
that no candidate declares; truth known from the simulation.
"""

import numpy as np
import pytest

from bayesnsi import CandidateModel, Signals, Term
from bayesnsi.diagnose import close_the_loop
from bayesnsi.models import effect_dictionary
from bayesnsi.simulate import add_output_noise, band_limited_gaussian, chain_system, simulate_response

NSI = dict(block_rows=60, order=4)
DECLARED = CandidateModel.from_terms("declared", [("v1*abs(v1)", 1)])
EFFECTS = effect_dictionary([1, 2], types=("x^3", "sign(v)", "v|v|", "x|x|"))


def two_dof_with(extra_terms, extra_coefficients, seed, duration=20.0, noise=2.0, fs=100.0, oversample=8):
    M, C, K = chain_system([1.0, 1.5], [800.0, 1000.0], [1.0, 1.0])
    terms = [Term("v1*abs(v1)", 1)] + [Term(*t) for t in extra_terms]
    rng = np.random.default_rng(seed)
    excitation = band_limited_gaussian(int(duration * fs), fs, 10.0, rng, oversample=oversample)
    response = simulate_response(
        M, C, K, [2], excitation.fine, fs * oversample, oversample, terms, [20.0] + list(extra_coefficients)
    )
    x = add_output_noise(response.displacement, noise, rng)
    v = add_output_noise(response.velocity, noise, rng)
    return Signals(excitation.samples, x, fs, [2], [1, 2], velocity=v)


@pytest.fixture(scope="module")
def coulomb_loop():
    signals = two_dof_with([("sign(v2)", 2)], [1.0], seed=0)
    return close_the_loop(signals, DECLARED, nsi_options=NSI, effects=EFFECTS, max_steps=2, seed=0)


def test_undeclared_coulomb_friction_at_other_dof_is_found(coulomb_loop):
    first = coulomb_loop.added[0]
    assert first.term.name == "sign(v2)@2"
    assert first.coefficient == pytest.approx(1.0, rel=0.10)
    assert first.ci95[0] < first.coefficient < first.ci95[1]
    assert len(coulomb_loop.added) == 1  # nothing spurious after it
    # measured: NRMSE 0.094 -> 0.036 (2.6x lower; noise floor ≈ 0.02)
    assert first.nrmse_after < 0.45 * first.nrmse_before


@pytest.mark.xfail(strict=True, reason="open (issue 4): sign(v2) at 100 Hz leaves model error, NRMSE 0.036 vs floor 0.02")
def test_coulomb_nrmse_after_is_a_third_or_at_noise_floor(coulomb_loop):
    first = coulomb_loop.added[0]
    assert first.nrmse_after <= first.nrmse_before / 3 or first.nrmse_after < 0.025


def test_negative_control_adds_nothing():
    signals = two_dof_with([], [], seed=3)
    loop = close_the_loop(signals, DECLARED, nsi_options=NSI, effects=EFFECTS, max_steps=2, seed=3)
    assert loop.added == ()
    assert loop.final.candidate == DECLARED
