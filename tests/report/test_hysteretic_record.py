"""What select and diagnose say on a Bouc-Wen-like hysteretic record (nonlinearbenchmark.org's layout).

The benchmark drives its system with a full random-phase multisine (every line of 5-150 Hz), ships
input and output as separate headerless single-column files, and its hysteresis has internal
state that no static n(y, ydot) represents: no candidate is adequate. Each test checks a message of
that case (the simulated system: ``benchmarks/bouc_wen.py``).
"""

from __future__ import annotations

import matplotlib
import numpy as np

matplotlib.use("Agg")

from bayesnsi.findings import messages
from bayesnsi.report.document import Report
from bayesnsi.report.periodic import HEADING, periodic_section
from bayesnsi.signals import Signals

FS, P = 200.0, 512


def _full_multisine_record(seed: int = 0) -> Signals:
    """A one-DOF linear oscillator (2 kg, 1e5 N/m, 10 N s/m) driven by a full random-phase multisine.

    Every DFT line of 5-60 Hz is excited, so no line inside the band is left empty. The response is
    computed independently of bayesnsi: the exact periodic steady state, line by line, from
    H(jw) = 1 / (k - m w^2 + j c w).
    """
    rng = np.random.default_rng(seed)
    k = np.arange(P // 2 + 1)
    freqs = k * FS / P
    excited = (freqs >= 5.0) & (freqs <= 60.0)
    spectrum = np.where(excited, np.exp(2j * np.pi * rng.random(k.size)), 0.0)
    w = 2 * np.pi * freqs
    h = 1.0 / (1e5 - 2.0 * w**2 + 10j * w)
    force = np.fft.irfft(spectrum, P)
    force *= 10.0 / force.std()
    disp = np.fft.irfft(np.fft.rfft(force) * h, P)
    n_periods = 4
    x = np.tile(disp, n_periods)
    x = x + 0.02 * x.std() * rng.standard_normal(x.size)
    return Signals(force=np.tile(force, n_periods)[:, None], displacement=x[:, None], fs=FS,
                   input_dofs=(1,), output_dofs=(1,), period=P)


def test_distortion_level_of_a_full_multisine_is_stated_as_not_measurable_not_nan():
    # Before: "the response at the lines the force leaves empty is up to nan times its noise level".
    report = Report("t")
    assert periodic_section(report, _full_multisine_record())
    blocks = next(b for _, name, b in report.sections if name == HEADING)
    text = next(b for b in blocks if isinstance(b, str) and b.startswith("Distortion level"))
    assert "nan" not in text.lower()
    assert "not measurable" in text and "excites every line" in text


def test_distortion_level_names_the_kind_of_unexcited_lines_it_measured():
    from bayesnsi.report.periodic import distortion_text

    text = distortion_text({"odd": np.array([np.nan]), "even": np.array([1.04])}, 4, 1, 100)
    assert "nan" not in text.lower() and "1.04 times its noise level at the unexcited even lines" in text


def _fake_outcome(name: str, terms_values, residual_ratio: float):
    """A candidate outcome with the fields model_checks reads: no identification needed."""
    from types import SimpleNamespace

    from bayesnsi.models import Term

    coefficients = [SimpleNamespace(term=Term(expr, 1), value=value, imag_ratio=0.05) for expr, value in terms_values]
    residual = np.full((400, 1), 0.02 * residual_ratio) * np.where(np.arange(400) % 2, 1.0, -1.0)[:, None]
    result = SimpleNamespace(order=2, coefficients=coefficients, virtual_stiffness=None, physical_parameters=(),
                             lowest_frequency_hz=0.0, reconstruct=lambda signals: SimpleNamespace(residual=residual))
    return SimpleNamespace(name=name, result=result, intervals=None)


def _periodic_noise_record(noise: float = 0.02) -> Signals:
    """Four identical periods plus white noise of std ``noise``: the period-to-period noise is ``noise``."""
    rng = np.random.default_rng(3)
    x = np.tile(np.sin(np.linspace(0.0, 2 * np.pi, 100, endpoint=False)), 4)[:, None]
    return Signals(force=x.copy(), displacement=x + noise * rng.standard_normal((400, 1)), fs=100.0,
                   input_dofs=(1,), output_dofs=(1,), period=100)


def test_selected_model_feeding_energy_in_is_warned():
    # A selected 'cubic + Coulomb' held sign(v1)@1 = -5.83 N (time route) and the frequency
    # route's Coulomb -14.4 N: a friction with a negative coefficient does positive work on every
    # motion, which the loop refuses ("negative dissipation") but select reported silently.
    from bayesnsi.checks.adequacy import adequacy_findings, model_checks

    outcomes = [
        _fake_outcome("cubic + Coulomb", [("x1**3", 7.6e9), ("sign(v1)", -5.83)], 6.5),
        _fake_outcome("quadratic damping", [("v1*abs(v1)", 266.0)], 8.2),
        _fake_outcome("stiffening only", [("x1*abs(x1)", -3.0e6)], 7.0),  # not a velocity term: no warning
    ]
    checks = model_checks(outcomes, _periodic_noise_record())
    assert checks["cubic + Coulomb"].energy_input == (("sign(v1)@1", -5.83),)
    assert checks["quadratic damping"].energy_input == () and checks["stiffening only"].energy_input == ()
    assert checks["cubic + Coulomb"].to_dict()["negative_dissipation"] == [{"term": "sign(v1)@1", "coefficient": -5.83}]
    warned = adequacy_findings(checks, "cubic + Coulomb")
    assert any(f.kind == "adequacy.negative_dissipation" and "sign(v1)@1 = -5.83" in f.message for f in warned)
    assert not any("negative dissipation" in f.message for f in adequacy_findings(checks, "quadratic damping"))


def test_intervals_of_an_inadequate_selected_model_are_qualified():
    # The time and frequency routes gave x1**3 = 7.37e9 [7.35e9, 7.47e9] and 4.43e9 [4.02e9, 4.80e9]
    # on the same record: intervals that hold the sensor noise only cannot hold a model-form error of 40 %.
    from bayesnsi.checks.adequacy import adequacy_findings, model_checks

    record = _periodic_noise_record()
    none_fit = model_checks([_fake_outcome("a", [("x1**3", 1.0)], 6.0), _fake_outcome("b", [], 8.0)], record)
    nothing = [f.message for f in adequacy_findings(none_fit, "a") if f.kind == "adequacy.none_adequate"]
    assert len(nothing) == 1 and "intervals carry the sensor noise only" in nothing[0]  # none to widen here
    one_fits = model_checks([_fake_outcome("a", [("x1**3", 1.0)], 6.0), _fake_outcome("b", [], 1.0)], record)
    assert one_fits["b"].adequate and not one_fits["a"].adequate
    said = messages(adequacy_findings(one_fits, "a"))
    assert any("'a' is not adequate" in w and "sensor noise only" in w for w in said), said
    assert messages(adequacy_findings(one_fits, "b")) == ()


def _fake_diagnosis(steps, checks, scores=(), added=(), validation=((), ())):
    """A Diagnosis with the fields the report's loop sentences read: no loop needed."""
    from types import SimpleNamespace

    from bayesnsi.options import LoopOptions

    loop = SimpleNamespace(steps=tuple(steps), scores=tuple(scores), options=LoopOptions(), friction=None,
                           unexamined=lambda: (), start=SimpleNamespace(reconstruct=None),
                           final=SimpleNamespace(coefficients=()), final_nsi=SimpleNamespace(upsample=1))
    final = SimpleNamespace(check=None, intervals=None, result=SimpleNamespace(coefficients=()),
                            validation_before=validation[0], validation=validation[1])
    selection = SimpleNamespace(checks=checks, signals=None)
    return SimpleNamespace(loop=loop, added=tuple(added), start="linear", final=final, selection=selection)


def test_diagnose_answer_says_why_nothing_was_added_and_that_the_model_left_is_inadequate():
    # Time route from 'linear': six effects rejected, all by the quality index (|Im|/|Re| 0.94-23.2),
    # and the answer said only "nothing added", while the linear model's residual was 8.50x the noise.
    from types import SimpleNamespace

    from bayesnsi.report.loop import nothing_added_note

    steps = [SimpleNamespace(reason=f"quality index |Im|/|Re| = {r:.2f} >= 0.3", imag_ratio=r) for r in (0.99, 23.24)]
    inadequate = {"linear": SimpleNamespace(adequate=False, noise_ratio=8.4994),
                  "cubic": SimpleNamespace(adequate=False, noise_ratio=7.2)}
    note = nothing_added_note(_fake_diagnosis(steps, inadequate))
    assert "failed the quality index (|Im|/|Re| 0.99-23)" in note and "memory (hysteresis" in note
    # measured: --max-imag-ratio 1.0 adds x1**3, validation NRMSE 0.257 -> 0.187
    assert "raise [diagnose] max_imag_ratio above 0.99 (--max-imag-ratio)" in note
    assert "linear, is not adequate: its residual is 8.50x the noise it passes on" in note
    # a re-identified effect not examined that passes the quality index: a dictionary term may do after all
    scored = [[SimpleNamespace(imag_ratio=0.22)]]
    assert "memory" not in nothing_added_note(_fake_diagnosis(steps, inadequate, scored))
    mixed = steps + [SimpleNamespace(reason="log Bayes factor 1.2 < 5", imag_ratio=0.02)]
    adequate = {"linear": SimpleNamespace(adequate=True, noise_ratio=1.05)}
    assert nothing_added_note(_fake_diagnosis(mixed, adequate)) == ""  # a control with nothing missing


def test_headerless_single_column_file_says_how_to_join_input_and_output(tmp_path):
    # The benchmark ships uval_multisine.csv / yval_multisine.csv: one headerless column each. Before, the
    # message said only "found only numbers; add a header line", not how to give one file input and output.
    from bayesnsi.exceptions import InputDataError
    from bayesnsi.io import read_csv_columns

    path = tmp_path / "uval_multisine.csv"
    path.write_text("-3.1685884343e+00\n5.1152134151e+00\n4.3372220951e+00\n")
    try:
        read_csv_columns(path, ["u"])
    except InputDataError as err:
        message = str(err)
    else:
        raise AssertionError("a headerless file was read")
    assert "only numbers (1 column(s), no header)" in message
    assert "separate headerless files" in message and '[data] files = { u = "u.csv", y = "y.csv" }' in message
    assert "\n" not in message and "3.1685884343" not in message  # one line, never quotes the file


def test_diagnose_prints_what_it_added_and_the_validation_error_before_and_after():
    # `bayesnsi diagnose` prints the outcome: what was added and the validation error before and after
    from types import SimpleNamespace

    from bayesnsi.models import Term
    from bayesnsi.report.terminal import diagnosis_lines

    before = (SimpleNamespace(name="second realisation", nrmse=0.25712, quantity="displacement"),)
    after = (SimpleNamespace(name="second realisation", nrmse=0.18685, quantity="displacement"),)
    inadequate = {"linear": SimpleNamespace(adequate=False, noise_ratio=8.5)}
    step = SimpleNamespace(accepted=True, term=Term("x1**3", 1), reason="", imag_ratio=0.1, log_bayes_factor=12.0,
                           effect=SimpleNamespace(name="x^3", location=(1,)))
    lines = diagnosis_lines(_fake_diagnosis([step], inadequate, added=[step], validation=(before, after)))
    assert lines[0].startswith("Closing the loop from linear: added x^3 at DOF 1 (log Bayes factor 12.0)")
    assert "  validation second realisation: closed-loop NRMSE 0.2571 -> 0.1868" in lines
    rejected = SimpleNamespace(accepted=False, term=Term("x1**3", 1), imag_ratio=0.99,
                               reason="quality index |Im|/|Re| = 0.99 >= 0.3")
    lines = diagnosis_lines(_fake_diagnosis([rejected], inadequate, validation=(before, before)))
    assert lines[0].startswith("Closing the loop from linear: nothing added.")
    assert "memory (hysteresis" in lines[0] and "8.50x the noise it passes on" in lines[0]


def test_no_harmonic_balance_of_a_sign_friction_model_names_the_switching_term():
    # frequency route: 'Coulomb' (sign(v1), -14.4 N) has no periodic steady state while 'smoothed friction'
    # (tanh(v1/0.01), -14.9 N) settles: the message names the discontinuity, not "unstable in feedback".
    import pytest

    from bayesnsi.exceptions import UnstableModelError
    from bayesnsi.nsi._harmonic import _solve

    with pytest.raises(UnstableModelError, match=r"sign\(v1\)@1 switch with the velocity.*tanh\(v/eps\)"):
        _solve(lambda X: X + 1.0, np.ones((4, 1), dtype=complex), "Coulomb", ("sign(v1)@1",))
    with pytest.raises(UnstableModelError, match="residual .* of the response\\): the model is unstable in feedback$"):
        _solve(lambda X: X + 1.0, np.ones((4, 1), dtype=complex), "cubic")


def test_report_answer_qualifies_the_probability_when_no_candidate_is_adequate(tmp_path, capsys):
    # every candidate leaves 6-8x the sensor noise: the answer must not lead with "Selected: ..., posterior
    # probability > 0.9999" alone but say that the probabilities rank wrong models.
    import json

    from bayesnsi.cli import main

    assert main(["simulate", "two-dof", "--seed", "3", "--out", str(tmp_path / "two_dof.csv"), "--quiet"]) == 0
    config = tmp_path / "wrong.toml"
    config.write_text(
        '[data]\nfile = "two_dof.csv"\nfs = 100.0\ninputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
        '[nsi]\nblock_rows = 60\norder = 4\n'
        '[evidence]\nn_steps = 200\nn_burn = 50\nlikelihood = "white"\ncompare = []\ninterval = "posterior"\n'
        '[[candidates]]\nname = "linear"\nterms = []\n'
        '[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n'
    )
    capsys.readouterr()
    assert main(["select", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert not any(c["model_check"]["adequate"] for c in results["candidates"])  # the truth is v1|v1|
    html = (tmp_path / "out" / "report.html").read_text()
    assert ("no candidate explains the data down to the noise, so the probability says which is least wrong, not "
            "that it is right") in html and "class='lead-bad'" in html


def test_a_selected_model_whose_validation_failed_is_not_said_to_be_inf_percent_worse():
    # frequency route, residual = "reconstruction": the selected 'cubic + Coulomb' has no periodic steady state on
    # the validation record; the warning says it could not be validated, not "NRMSE inf (+inf %)".
    from bayesnsi.checks.adequacy import ModelCheck, adequacy_findings

    def check(name, nrmse):
        return ModelCheck(name=name, order=2, residual_rms=(6.0,), noise_std=(1.0,), noise_ratio=6.0, adequate=False,
                          quality_index=0.1, quality_ok=True, validation_nrmse=nrmse)

    said = messages(adequacy_findings({"cubic + Coulomb": check("cubic + Coulomb", float("inf")),
                              "cubic": check("cubic", 0.1836)}, "cubic + Coulomb"))
    failed = [w for w in said if "could not be validated" in w]
    assert len(failed) == 1 and "closed-loop simulation failed" in failed[0]
    assert "'cubic' validates with closed-loop NRMSE 0.184" in failed[0]
    assert not any("inf" in w for w in said)


def test_a_look_ahead_row_of_the_loop_table_names_the_rejected_term_it_was_tried_with():
    # time route from 'linear': x1**3 rejected at step 1, the "step 2" rows (clearance, x|x|) show NRMSE before
    # 0.215 - the x1**3 model's - and must say that they were tried with it.
    from types import SimpleNamespace

    from bayesnsi.models import Term
    from bayesnsi.report.loop import tried_with

    cubic, xabs = Term("x1**3", 1), Term("x1*abs(x1)", 1)
    first = SimpleNamespace(accepted=False, term=cubic, candidate=SimpleNamespace(terms=(cubic,)))
    pair = SimpleNamespace(accepted=False, term=xabs, candidate=SimpleNamespace(terms=(cubic, xabs)))
    loop = SimpleNamespace(start=SimpleNamespace(terms=()), steps=[first, pair])
    assert tried_with(first, loop) == "" and tried_with(pair, loop) == " (tried with x1**3@1)"
    added = SimpleNamespace(accepted=True, term=cubic, candidate=SimpleNamespace(terms=(cubic,)))
    assert tried_with(pair, SimpleNamespace(start=loop.start, steps=[added, pair])) == ""  # on the current model
