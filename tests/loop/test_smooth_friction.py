"""The tanh(v/eps) friction effect of the loop's dictionary and the negative-dissipation guard."""

import numpy as np
import pytest

from bayesnsi.checks.dissipation import dissipative_shape, injects_energy
from bayesnsi.exceptions import ConfigError
from bayesnsi.loop import loop_effects
from bayesnsi.loop.guards import NEGATIVE_DISSIPATION
from bayesnsi.models import (
    SMOOTH_FRICTION,
    Effect,
    Term,
    default_widths,
    parse_expression,
    smooth_friction_effect,
)
from bayesnsi.simulate import undeclared_case


def test_smooth_friction_effect_writes_its_width_as_a_number_the_parser_reads():
    effect = smooth_friction_effect((7, 8), 0.0045512)
    assert effect.eps == 0.00455 and effect.name == "tanh(v/eps) eps=0.00455"
    assert effect.term.name == "tanh((v7-v8)/0.00455)@7-8"
    parsed = parse_expression(effect.term.expr.canonical)  # what results.json holds parses back to the same
    v = np.zeros((8, 3))
    v[6] = [0.01, -0.002, 0.0]
    assert np.allclose(parsed.evaluate(np.zeros((8, 3)), v), np.tanh(v[6] / 0.00455))
    assert not effect.term.expr.switches_with_velocity  # smooth: no upsampled refinement needed
    with pytest.raises(ConfigError, match="positive number"):
        smooth_friction_effect(1, 0.0)
    with pytest.raises(ConfigError, match="a width is given with, and only with"):
        Effect(SMOOTH_FRICTION, Term("tanh(v1/0.1)", 1))


def test_loop_dictionary_sets_the_widths_from_the_velocity_spread():
    case = undeclared_case("clearance", seed=0, noise_percent=1.0, duration=5.0)
    v = case.signals.velocities()
    smooth = [e for e in loop_effects(case.signals) if e.base == SMOOTH_FRICTION]
    assert [e.location for e in smooth] == [(1,), (1,), (2,), (2,), (1, 2), (1, 2)]
    stds = (v[:, 0].std(), v[:, 1].std(), (v[:, 0] - v[:, 1]).std())
    expected = [w for s in stds for w in default_widths(s)]
    assert np.allclose([e.eps for e in smooth], expected, rtol=5e-3)  # 3 significant digits
    assert np.allclose(default_widths(0.02), [0.005, 0.01])
    only = loop_effects(case.signals, [SMOOTH_FRICTION])
    assert len(only) == 6 and all(e.eps is not None for e in only)


@pytest.mark.parametrize(
    ("expr", "at", "shape"),
    [
        ("v1*abs(v1)", 1, True), ("v1**3", 1, True), ("sign(v1)", 1, True), ("tanh(v1/0.002)", 1, True),
        ("(v7-v8)*abs(v7-v8)", (7, 8), True), ("tanh((v7-v8)/0.00455)", (7, 8), True),
        ("(v8-v7)**3", (7, 8), False),  # acts against the element's direction: power -n·(v7-v8) <= 0
        ("x1**3", 1, False), ("x1**2*sign(v1)", 1, False), ("(1+sign(v1))/2", 1, False),
        ("v1*(1+sign(v1))/2", 1, False), ("v2*abs(v2)", 1, False), ("v1**2", 1, False),
    ],
)
def test_dissipative_shape_is_odd_pure_velocity_with_nonnegative_power(expr, at, shape):
    term = Term(expr, at)
    assert dissipative_shape(term) is shape
    # the power of the force -λ l n on the motion: -λ n(v)·(l·v); λ < 0 feeds energy in for these shapes
    assert injects_energy(term, -1.0) is shape and not injects_energy(term, 1.0)
    assert not injects_energy(term, float("nan"))


def test_negative_quadratic_damping_is_never_accepted():
    """On the quadratic-damping case (true λ = +20) the added v1|v1| has λ > 0; no λ < 0 passes."""
    from bayesnsi.loop import close_the_loop
    from bayesnsi.options import LoopOptions

    case = undeclared_case("quadratic-damping", seed=0)
    loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1, n_tries=1), nsi=case.nsi)
    added = [s for s in loop.steps if s.accepted]
    assert [s.term.name for s in added] == ["v1*abs(v1)@1"] and added[0].coefficient > 0
    assert not any(injects_energy(s.term, s.coefficient) for s in added)


def test_an_effect_rejected_for_negative_dissipation_does_not_use_up_a_try(monkeypatch):
    """With n_tries = 1, the best effect relabelled as feeding energy in: the next one is still checked."""
    from dataclasses import replace

    from bayesnsi.loop import Check, close_the_loop, guards, search
    from bayesnsi.options import LoopOptions

    calls = []

    def first_feeds_energy(context, entry, *args, **kwargs):
        verdict = guards.check_effect(context, entry, *args, **kwargs)
        calls.append(entry.term.name)
        if len(calls) == 1:
            reason = f"{NEGATIVE_DISSIPATION}: (test)"
            failed = Check("dissipation", -1.0, 0.0, False, reason)
            step = replace(verdict.step, accepted=False, reason=reason, checks=(*verdict.step.checks, failed))
            return replace(verdict, step=step)
        return verdict

    monkeypatch.setattr(search, "check_effect", first_feeds_energy)
    case = undeclared_case("quadratic-damping", seed=0)
    loop = close_the_loop(case.signals, case.declared, LoopOptions(max_steps=1, n_tries=1), nsi=case.nsi)
    assert len(calls) == 2 and calls[0] == "v1*abs(v1)@1"  # the relabelled best did not count as the try
    assert loop.steps[-1].term.name == calls[0] and loop.steps[-1].reason.startswith(NEGATIVE_DISSIPATION)


def test_width_search_climbs_the_evidence_in_log_width_from_the_grid():
    from bayesnsi.loop.results import EffectScore
    from bayesnsi.loop.widths import WIDTH_RESOLUTION, search_width

    peak = 0.0031  # a concave log-evidence in log2(eps), the grid width 0.00455 on its slope
    calls = []

    def score(effect):
        calls.append(effect.eps)
        return EffectScore(effect, -100.0 * (np.log2(effect.eps / peak)) ** 2)

    start = smooth_friction_effect((7, 8), 0.00455)
    found = search_width(score(start), score, grid=(0.002, 0.0091))
    assert found.effect.location == (7, 8) and found.term.name.startswith("tanh((v7-v8)/")
    assert abs(np.log2(found.effect.eps / peak)) <= WIDTH_RESOLUTION  # within the search's resolution
    assert len(calls) - 1 <= 12  # the budget
    flat = search_width(EffectScore(start, 5.0), lambda effect: EffectScore(effect, 5.0),  # nothing beats it
                        grid=(0.002, 0.0091))
    assert flat.effect.eps == 0.00455
    sharper = EffectScore(start, -np.log(start.eps))  # the evidence rises as the width falls
    sharp = search_width(sharper, lambda effect: EffectScore(effect, -np.log(effect.eps)), grid=(0.00455, 0.0091))
    assert sharp.effect.eps == 0.00455  # the smallest grid width bounds it: sharper is sign(v)'s place
    other = EffectScore(Effect("x^3", Term("x1**3", 1)), 1.0)
    assert search_width(other, score) is other
