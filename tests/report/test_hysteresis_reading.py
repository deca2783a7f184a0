"""The physical reading of a Bouc-Wen term in the diagnose report and the terminal (docs/method.md §12).

The record is the suite's hysteresis case (:func:`bayesnsi.simulate.undeclared_case`, RK4 of the augmented
state): a ground spring λ z at DOF 1 with λ = 300 N/m, β = 150, γ = -50 1/m, so z levels off on loading at
1/(β + γ) = 0.01 m. The model identified with the true term must read that yield and dissipate energy.
"""

from __future__ import annotations

import re

import pytest

from bayesnsi.io.units import ChannelUnits
from bayesnsi.nsi import identify
from bayesnsi.report.loop import hysteresis_sentences
from bayesnsi.simulate import undeclared_case


def test_a_boucwen_term_is_read_as_stiffness_yield_and_energy_per_cycle():
    case = undeclared_case("hysteresis", seed=0, noise_percent=1.0, duration=20.0)
    result = identify(case.signals, case.truth, case.nsi)
    (sentence,) = hysteresis_sentences(result, case.signals, ChannelUnits(force="N", displacement="m"))
    stiffness = float(re.search(r"hysteretic stiffness ([-0-9.e+]+) N/m", sentence).group(1))
    assert stiffness == pytest.approx(300.0, rel=0.05)
    assert "yield displacement 0.01 m" in sentence
    energy = float(re.search(r"dissipates ([-0-9.e+]+) N·m per cycle", sentence).group(1))
    assert energy > 0  # the loop runs the dissipative way round


def test_a_model_without_memory_has_no_hysteresis_reading():
    case = undeclared_case("hysteresis", seed=0, noise_percent=1.0, duration=20.0)
    assert hysteresis_sentences(identify(case.signals, case.declared, case.nsi), case.signals) == []
