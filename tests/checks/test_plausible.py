"""``Selection.plausible``: the most probable candidate whose model passes every physical check.

On a swept beam at a nearly linear level (accelerometers) the evidence can select a sign() of a noisy
velocity with P > 0.9999 over linear (4.6e4 nat) although its coefficient is negative (it feeds energy
in) and it fails the quality index. The answer, the command line and results.json then also name the
most probable candidate that passes the checks.
"""

from __future__ import annotations

from types import SimpleNamespace

import pandas as pd

from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.selection import Selection


def _check(quality_ok=True, energy_input=(), unsupported=()):
    return SimpleNamespace(quality_ok=quality_ok, energy_input=energy_input, unsupported=unsupported,
                           adequate=True, noise_ratio=1.0)


def _selection(checks):
    names = list(checks)
    outcomes = tuple(SimpleNamespace(name=n, status="ok", evidences={"ar1": object()}, result=object(), error=None)
                     for n in names)
    # far behind the first, every probability is 0: the log evidence ranks them (a swept beam: the true cubic
    # 4.7e5 nat above linear, both P = 0: the cubic must be named)
    log_evidence = {"Coulomb": 3693791.8, "cubic": 3501481.3, "linear": 3028984.9}
    table = pd.DataFrame({"prior": [0.2] * len(names), "log_evidence_ar1": [log_evidence[n] for n in names],
                          "p_ar1": [1.0 if n == "Coulomb" else 0.0 for n in names]},
                         index=pd.Index(names, name="candidate"))
    return Selection(outcomes, table, NSIOptions(), EvidenceOptions(likelihood="ar1"), checks=checks)


def test_the_most_probable_sound_candidate_is_named_beside_the_selected_one():
    failing = _check(quality_ok=False, energy_input=(("sign(v3)@3", -8.9e-5),),
                     unsupported=(("sign(v3)@3", -2e-4, 6e-5),))
    selection = _selection({"Coulomb": failing, "linear": _check(),
                            "cubic": _check(unsupported=(("x3**3@3", -1.0, 2.0),))})
    # a term whose interval holds zero is not a failed check: the cubic is the most probable sound model
    assert selection.selected == "Coulomb" and selection.plausible == "cubic"
    unsound = _selection({"Coulomb": failing, "cubic": _check(quality_ok=False), "linear": _check()})
    assert unsound.plausible == "linear"
    sound = _selection({"Coulomb": _check(), "cubic": _check(), "linear": _check()})
    assert sound.plausible == sound.selected == "Coulomb"
    assert _selection({"Coulomb": failing}).plausible is None


def test_the_answer_says_the_selected_model_fails_and_names_the_plausible_one():
    from bayesnsi.report.choices import plausible_text

    failing = _check(quality_ok=False, energy_input=(("sign(v3)@3", -8.9e-5),))
    selection = _selection({"Coulomb": failing, "cubic": _check(quality_ok=False), "linear": _check()})
    decision = pd.DataFrame({"log_bayes_factor": [float("nan"), 120.0, 64765.3]}, index=["Coulomb", "cubic", "linear"])
    text = plausible_text(selection, "Coulomb", decision)
    assert "But Coulomb fails a physical check" in text and "most probable is linear (6.48e+04 nat behind)" in text
    assert plausible_text(selection, "linear", decision) == ""  # diagnose --start linear: not the evidence's choice
    sound = _selection({"Coulomb": _check(), "cubic": _check(), "linear": _check()})
    assert plausible_text(sound, "Coulomb", decision) == ""


def test_an_inadequate_plausible_model_is_named_as_such():
    # a 10-DOF chain, 1e6 samples: when the true model fails the quality index, "linear" (76.6x the noise it
    # passes on) may be the plausible model, and its fit must be named with it
    from bayesnsi.report.choices import inadequacy_note, plausible_text

    linear = SimpleNamespace(quality_ok=True, energy_input=(), unsupported=(), adequate=False, noise_ratio=76.6)
    selection = _selection({"Coulomb": _check(quality_ok=False), "linear": linear})
    decision = pd.DataFrame({"log_bayes_factor": [float("nan"), 9.2e6]}, index=["Coulomb", "linear"])
    text = plausible_text(selection, "Coulomb", decision)
    assert selection.plausible == "linear"
    assert text.endswith("most probable is linear (9.2e+06 nat behind), but its residual is 76.6x the noise it "
                         "passes on (not adequate either).")
    assert inadequacy_note(_check()) == "" and inadequacy_note(None) == ""
