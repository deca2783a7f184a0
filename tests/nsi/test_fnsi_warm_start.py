"""Frequency route: a term added to a model never worsens the fit on the lines; unexcited band lines are fitted."""

from __future__ import annotations

import numpy as np
import pytest

from bayesnsi.models import CandidateModel, Term
from bayesnsi.nsi import identify
from bayesnsi.options import NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, multisine, simulate_response

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 4, 4
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])  # the frequency-route tests' chain, k3 = 1e5 at DOF 1
OPTIONS = NSIOptions(domain="frequency", order=4, band_hz=(0.5, 20.0))


@pytest.fixture(scope="module")
def record() -> Signals:
    rng = np.random.default_rng(5)
    force = multisine(P, FS, (0.5, 20.0), 10.0, rng, n_periods=N_PERIODS + TRANSIENT, kind="random-odd")
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample,
                                 [Term("x1**3", 1)], [1e5])
    signals = Signals(force=response.force, displacement=add_output_noise(response.displacement, 2.0, rng),
                      fs=FS, input_dofs=(2,), output_dofs=(1, 2), period=P)
    return signals.segment(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)


def _fit(record, *terms):
    return identify(record, CandidateModel(name="c", terms=tuple(Term(e, at) for e, at in terms)), OPTIONS)


def test_adding_any_term_never_raises_the_weighted_misfit_on_the_band_lines(record):
    linear = _fit(record)
    assert linear.settings["n_band_lines"] > linear.settings["n_lines"]  # the empty lines are fitted too
    assert linear.settings["band_misfit"] > 5.0  # the linear model leaves the distortion (measured 24)
    for expr, at in [("v2**3", 2), ("x2*abs(x2)", 2), ("sign(v1)", 1), ("(x1-x2)**3", (1, 2)), ("x1**3", 1)]:
        assert _fit(record, (expr, at)).settings["band_misfit"] <= linear.settings["band_misfit"] * (1 + 1e-9), expr
    true = _fit(record, ("x1**3", 1))
    assert true.settings["band_misfit"] < 1.5  # the true model explains the empty lines down to the noise
    assert abs(true.coefficient_values[0] / 1e5 - 1) < 0.03  # measured 1.5 % (4 periods, 2 % noise)
    two = _fit(record, ("x1**3", 1), ("v2**3", 2))
    assert two.settings["band_misfit"] <= true.settings["band_misfit"] * (1 + 1e-9)


def test_the_result_does_not_depend_on_what_was_identified_before(record):
    from bayesnsi.nsi import _frequency

    first = _fit(record, ("x1**3", 1), ("v2**3", 2)).coefficient_values
    _frequency._WARM.clear()
    again = _fit(record, ("x1**3", 1), ("v2**3", 2)).coefficient_values
    # equal up to the refinement's tolerance (measured 5e-5 relative on k3 for some hash seeds: the
    # spurious v2**3 leaves a flat direction in which the Levenberg-Marquardt end point wanders)
    assert np.allclose(first[0], again[0], rtol=1e-3)
