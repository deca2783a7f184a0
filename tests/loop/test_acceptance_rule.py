"""The loop's one acceptance rule, its direction-dependent friction effects and their physical reading."""

from types import SimpleNamespace

import numpy as np
import pytest

from bayesnsi import Signals
from bayesnsi.loop import Check, FrictionReading, close_the_loop, friction_reading, loop_effects
from bayesnsi.loop.guards import _decision
from bayesnsi.models import Term
from bayesnsi.models.dictionary import MIN_REVERSALS, velocity_reversals
from bayesnsi.options import LoopOptions
from bayesnsi.simulate import undeclared_case


def test_velocity_reversals_count_direction_changes_beyond_the_dead_band():
    t = np.linspace(0.0, 5.0, 5001)
    assert velocity_reversals(np.sin(2 * np.pi * t + 0.3)) == 10  # 5 periods: two reversals each
    rest = np.r_[np.ones(100), 1e-4 * np.random.default_rng(0).standard_normal(1000), -np.ones(100)]
    assert velocity_reversals(rest) == 1  # noise about a standstill inside the dead band does not count


def _signals(displacement, fs=100.0, force=None):
    x = np.asarray(displacement, dtype=float)[:, None]
    f = np.random.default_rng(1).standard_normal(x.shape) if force is None else np.asarray(force)[:, None]
    return Signals(force=f, displacement=x, fs=fs, input_dofs=(1,), output_dofs=(1,))


def test_direction_dependent_friction_is_offered_only_where_both_halves_reverse():
    t = np.arange(4000) / 100.0
    oscillating = _signals(np.sin(2 * np.pi * 0.5 * t))
    assert "|v|" in {e.base for e in loop_effects(oscillating)}
    # reverses often in the first half, then moves one way only: the second half holds one direction
    one_way = np.where(t < 20.0, np.sin(2 * np.pi * 0.5 * t), 0.3 * (t - 20.0))
    signals = _signals(one_way)
    v = signals.velocities()
    assert velocity_reversals(v[2000:]) < MIN_REVERSALS <= velocity_reversals(v[:2000])
    assert "|v|" not in {e.base for e in loop_effects(signals)}


def test_friction_reading_recovers_forward_and_backward_viscous_friction():
    """A carriage simulated with a known friction law (the reference): forwards 150, backwards 230 N s/m."""
    fs, mass, coulomb, offset = 1000.0, 95.0, 20.0, -3.0
    t = np.arange(40_000) / fs
    x = 0.05 * np.sin(2 * np.pi * 0.2 * t) + 0.02 * np.sin(2 * np.pi * 0.7 * t + 1.0)
    v = np.gradient(x, 1 / fs)
    a = np.gradient(v, 1 / fs)
    law = np.where(v > 0, 150.0 * v, 230.0 * v) + coulomb * np.sign(v) + offset
    noise = 0.5 * np.random.default_rng(2).standard_normal(len(t))
    signals = _signals(x, fs, mass * a + law + noise)
    model = SimpleNamespace(physical_parameters=(object(),), terms=(Term("sign(v1)", 1), Term("abs(v1)", 1)),
                            candidate=SimpleNamespace(name="Coulomb + |v|"))
    reading = friction_reading(model, signals)
    assert isinstance(reading, FrictionReading) and reading.other == ()
    truth = {"mass": mass, "viscous_forward": 150.0, "viscous_backward": 230.0, "coulomb": coulomb, "offset": offset}
    for name, value in truth.items():
        low, high = reading.intervals[name]
        assert low < value < high, (name, reading.intervals[name])
        assert high - low < 0.05 * abs(value) + 0.2  # informative intervals, not merely wide ones
    # v·[v > 0] beside v is the same model: the same reading
    plus = SimpleNamespace(**{**vars(model), "terms": (Term("sign(v1)", 1), Term("v1*(1+sign(v1))/2", 1))})
    again = friction_reading(plus, signals)
    assert again.viscous_forward == pytest.approx(reading.viscous_forward, rel=1e-6)
    assert again.viscous_backward == pytest.approx(reading.viscous_backward, rel=1e-6)
    # the white noise it was simulated with, through the force view's low-pass at fs/20: 0.5 sqrt(50 / 500)
    assert reading.force_error(signals) == pytest.approx(0.5 * np.sqrt(0.1), rel=0.1)


def test_quality_only_is_marked_and_accepted_only_with_the_flag():
    passed = [Check("log Bayes factor", 250.0, 4.6, True, "bf"), Check("record halves", 1.1, 1.4, True, "halves")]
    quality = Check("quality index", 1.07, 0.3, False, "quality index |Im|/|Re| = 1.07 >= 0.3")
    checks = (passed[0], quality, passed[1])
    assert _decision(checks, False) == (quality.text, True)
    reason, flag = _decision(checks, True)
    assert flag and reason.startswith("accepted: only the quality index objects (quality index |Im|/|Re| = 1.07")
    unstable = Check("record halves", 2.0, 1.4, False, "unstable")
    assert _decision((passed[0], quality, unstable), True) == (quality.text, False)  # two failed: rejected
    assert _decision((passed[0], quality), True) == (quality.text, False)  # halves not computed: not marked


def test_every_rejection_names_a_check_the_effect_itself_failed():
    case = undeclared_case("quadratic-damping", seed=0)
    loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=2), nsi=case.nsi)
    assert [s.term.name for s in loop.added] == ["v1*abs(v1)@1"]
    rejected = [s for s in loop.steps if not s.accepted]
    assert rejected
    for step in rejected:
        failed = step.failed_checks
        if failed:  # its reason is the first check it failed, with its value and limit
            assert step.reason == failed[0].text
            assert f"{failed[0].limit:g}"[:3] in step.reason or failed[0].name == "record halves"
        else:  # only a look-ahead pair declined for its first effect's index
            assert step.reason.startswith("not added: checked only beside")
    assert all(c.passed for c in loop.added[0].checks)
    assert loop.unexplained() == ()
    assert loop.friction is None  # v|v| is no piecewise-linear friction law (and the chain has two DOFs)
