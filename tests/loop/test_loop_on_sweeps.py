"""The loop's record-half check on swept-sine tests (docs/method.md §7, the "stable coefficient" guard).

On a beam swept 10-400 Hz (accelerometers) the half check would reject the true cubic spring as
"unstable across record halves: 5.4e7 vs -1.2e10" - the second half of a sweep never drives the first
mode, so the halves are two different experiments and their coefficients need not agree. The check
is skipped when the halves' forces excite different bands (:func:`bayesnsi.loop.guards.half_overlap`).
Reference: the two-DOF chain with a cubic spring k3 = 5e5 at DOF 1 (the simulated truth), swept 1-30 Hz.
"""

from __future__ import annotations

import numpy as np
import pytest

from bayesnsi.loop import close_the_loop
from bayesnsi.loop.guards import MIN_HALF_OVERLAP, half_overlap
from bayesnsi.models import CandidateModel, Term
from bayesnsi.options import LoopOptions, NSIOptions
from bayesnsi.signals import Signals
from bayesnsi.simulate import band_limited_gaussian, chain_system, simulate_response

FS, DURATION, K3 = 100.0, 120.0, 5e5
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])


def _record(force_fine, seed=0):
    response = simulate_response(*MCK, [2], force_fine, FS * 8, 8, [Term("x1**3", 1)], [K3])
    rng = np.random.default_rng(seed)
    x = response.displacement + 0.01 * response.displacement.std(axis=0) * rng.standard_normal(
        response.displacement.shape)
    return Signals(force=response.force, displacement=x, fs=FS, input_dofs=(2,), output_dofs=(1, 2))


def _sweep():
    t = np.arange(int(FS * DURATION) * 8) / (FS * 8)
    phase = 2 * np.pi * (1.0 * t + (30.0 - 1.0) / (2 * DURATION) * t**2)  # linear sweep 1 -> 30 Hz
    return _record(5.0 * np.sin(phase)[:, None])


def test_half_overlap_tells_a_sweep_from_a_stationary_test():
    rng = np.random.default_rng(1)
    random = _record(band_limited_gaussian(int(FS * 60), FS, 5.0, rng, oversample=8, band_hz=(1.0, 30.0)).fine)
    assert half_overlap(random) > 0.8 > MIN_HALF_OVERLAP > 0.05 > half_overlap(_sweep())


def test_the_loop_adds_the_cubic_spring_of_a_swept_test():
    signals = _sweep()
    loop = close_the_loop(signals, CandidateModel("linear", ()), LoopOptions(max_steps=1),
                          nsi=NSIOptions(block_rows=40, order=4))
    assert [t.name for t in loop.final.terms] == ["x1**3@1"]
    step = next(s for s in loop.steps if s.accepted)
    assert step.coefficient == pytest.approx(K3, rel=0.05)
    assert "record halves not compared" in step.half_note and step.half_block_rows is None
