"""Model adequacy beside the evidence: residual vs noise, quality index, validation, orders.

References: the simulated two-DOF case (SPEC 8.1) whose true model is 20 v1|v1| at DOF 1 and
whose output noise is 2 % of each channel's std: the true model's open-loop residual is at the
noise level (measured ratio 1.0-1.1), a Coulomb-only or linear model's is not (1.5-2.4).
"""

import json
import math
import warnings

import numpy as np
import pytest

from bayesnsi.checks.adequacy import ModelCheck, adequacy_findings
from bayesnsi.exceptions import AdequacyWarning
from bayesnsi.findings import messages
from bayesnsi.models import CandidateModel
from bayesnsi.options import EvidenceOptions
from bayesnsi.selection import select
from bayesnsi.simulate import simulate_case

FAST = EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=(), interval="posterior")


def _check(name, ratio=1.0, quality=0.01, order=4, nrmse=None):
    return ModelCheck(
        name=name, order=order, residual_rms=(ratio,), noise_std=(1.0,), noise_ratio=ratio, adequate=ratio <= 1.3,
        quality_index=quality, quality_ok=quality is None or quality <= 0.3, validation_nrmse=nrmse,
    )


def test_nothing_to_say_about_a_good_selection():
    checks = {"a": _check("a", nrmse=0.10), "b": _check("b", ratio=2.0, nrmse=0.105)}
    assert messages(adequacy_findings(checks, "a")) == ()


def test_each_warning_is_raised_by_its_own_failure():
    quality = messages(adequacy_findings({"a": _check("a", quality=0.8)}, "a"))
    assert len(quality) == 1 and "quality index" in quality[0]
    worse = messages(adequacy_findings({"a": _check("a", nrmse=0.2), "b": _check("b", nrmse=0.1)}, "a"))
    assert len(worse) == 1 and "validates worse than 'b'" in worse[0]
    within = {"a": _check("a", nrmse=0.105), "b": _check("b", nrmse=0.1)}
    assert messages(adequacy_findings(within, "a")) == ()  # within 10 %
    nothing = messages(adequacy_findings({"a": _check("a", ratio=1.6), "b": _check("b", ratio=2.5)}, "a"))
    assert len(nothing) == 1 and "no candidate is adequate" in nothing[0] and "'a': 1.60x" in nothing[0]
    orders = messages(adequacy_findings({"a": _check("a", order=10), "b": _check("b", order=12)}, "a"))
    assert len(orders) == 1 and "different orders" in orders[0] and "a: 10, b: 12" in orders[0]


@pytest.fixture(scope="module")
def two_dof():
    case = simulate_case("two-dof", seed=0)
    held_out = simulate_case("two-dof", seed=101)
    return case, held_out


def test_true_model_is_adequate_and_predicts_best(two_dof):
    case, held_out = two_dof
    with warnings.catch_warnings():
        warnings.simplefilter("error", AdequacyWarning)  # nothing to warn about
        selection = select(case.signals, case.candidates[:2], case.recommended, FAST,
                           validation=[("seed 101", held_out.signals)])
    assert selection.selected == "model 1" and selection.findings == ()
    true, coulomb = selection.checks["model 1"], selection.checks["model 2"]
    assert true.adequate and 0.8 < true.noise_ratio < 1.3
    assert not coulomb.adequate
    assert true.quality_ok and true.order == coulomb.order == 4
    assert true.validation_nrmse < coulomb.validation_nrmse
    assert true.validation_log_predictive > coulomb.validation_log_predictive
    assert math.isfinite(true.validation_log_predictive)


def test_no_candidate_fits_is_reported_inadequate(two_dof):
    """Linear and Coulomb-only candidates for quadratic damping: neither reaches the noise level."""
    case, _ = two_dof
    candidates = [CandidateModel.from_terms("linear", []), case.candidates[1]]
    with pytest.warns(AdequacyWarning) as raised:  # also: Coulomb's sign(v1) < 0 feeds energy in
        selection = select(case.signals, candidates, case.recommended, FAST)
    assert any("no candidate is adequate" in str(w.message) for w in raised)
    assert not any(c.adequate for c in selection.checks.values())
    assert any("no candidate is adequate" in f.message for f in selection.findings)


def test_results_json_lists_the_warnings(two_dof, tmp_path):
    from types import SimpleNamespace

    from bayesnsi.io import selection_payload

    case, _ = two_dof
    candidates = [CandidateModel.from_terms("linear", []), case.candidates[1]]
    with pytest.warns(AdequacyWarning):
        selection = select(case.signals, candidates, case.recommended, FAST)
    config = SimpleNamespace(path=tmp_path / "c.toml", raw={}, seed=0, nsi=case.recommended)
    payload = selection_payload(selection, "select", config)
    assert payload["findings"] == [f.to_dict() for f in selection.findings] and payload["findings"]
    assert payload["candidates"][0]["model_check"]["adequate"] is False


def test_command_line_prints_the_warnings(tmp_path, capsys):
    """``bayesnsi select --quiet`` on candidates that cannot fit: the warning on stderr and in results.json."""
    from bayesnsi.cli import main

    assert main(["simulate", "two-dof", "--seed", "3", "--out", str(tmp_path / "two_dof.csv"), "--quiet"]) == 0
    config = tmp_path / "wrong.toml"
    config.write_text(
        '[data]\nfile = "two_dof.csv"\nfs = 100.0\ninputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
        '[nsi]\nblock_rows = 60\norder = 4\n'
        '[evidence]\nn_steps = 200\nn_burn = 50\nlikelihood = "white"\ncompare = []\ninterval = "posterior"\n'
        '[[candidates]]\nname = "linear"\nterms = []\n'
        '[[candidates]]\nname = "coulomb"\nterms = [{ expr = "sign(v1)", at = 1 }]\n'
    )
    capsys.readouterr()
    assert main(["select", str(config), "--out", str(tmp_path / "out"), "--quiet", "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "warning: no candidate is adequate" in err
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert any(f["kind"] == "adequacy.none_adequate" and "no candidate is adequate" in f["message"]
               for f in results["findings"])


def test_periodic_records_take_the_noise_from_the_period_to_period_scatter():
    """Coloured noise on a periodic response: the scatter between periods is the noise (reference: the
    noise added, computed directly); high-order differences see only its part near Nyquist."""
    from scipy.signal import butter, lfilter

    from bayesnsi.noise import noise_model, white_noise_std
    from bayesnsi.signals import Signals

    rng = np.random.default_rng(5)
    period, n_periods = 512, 8
    t = np.arange(period * n_periods)
    clean = np.sin(2 * np.pi * 3 * t / period) + 0.3 * np.sin(2 * np.pi * 17 * t / period)
    noise = lfilter(*butter(4, 0.2), 0.05 * rng.standard_normal((len(t), 2)), axis=0)  # band-limited noise
    x = clean[:, None] + noise
    force = np.tile(rng.standard_normal(period), n_periods)[:, None]
    periodic = Signals(force=force, displacement=x, fs=100.0, input_dofs=(1,), output_dofs=(1, 2), period=period)
    np.testing.assert_allclose(noise_model(periodic).std(), noise.std(axis=0), rtol=0.05)
    assert noise_model(periodic).source == "period scatter"
    assert np.all(white_noise_std(x) < 0.5 * noise.std(axis=0))
    plain = Signals(force=force, displacement=x, fs=100.0, input_dofs=(1,), output_dofs=(1, 2))
    np.testing.assert_array_equal(noise_model(plain).std(), white_noise_std(x))
    assert noise_model(plain).source == "differences"


def test_gvt_with_no_fitting_candidate_is_reported_inadequate():
    """Simulated GVT at 0.1 N rms (joint nearly idle): with the linear model or the right joint in the set
    some candidate leaves a residual near the period-to-period noise (measured 1.09x and 1.22x); with
    only a wrong-location and a wrong-type element none does (2.4x, 67x) and the selection says so.
    Reference: the noise is the scatter between the record's periods (independent of any model)."""
    from bayesnsi.checks.adequacy import model_checks
    from bayesnsi.nsi import periodic_integration
    from bayesnsi.options import NSIOptions
    from bayesnsi.run import run_candidates
    from bayesnsi.signals import Signals
    from bayesnsi.simulate import GVT_BAND_HZ, GVT_SENSORS, GVT_SHAKER, gvt_records

    (record,) = gvt_records(levels=(0.1,), n_realisations=1, seed=0)
    velocity, displacement = periodic_integration(record.acceleration, record.fs, record.period, (1.0, 20.0))
    signals = Signals(force=record.force, displacement=displacement, velocity=velocity, fs=record.fs,
                      input_dofs=(GVT_SHAKER,), output_dofs=GVT_SENSORS, period=record.period)
    candidates = [
        CandidateModel.from_terms("joint 7-8", [("tanh((v7-v8)/0.002)", (7, 8)), ("(x7-x8)**3", (7, 8))]),
        CandidateModel.from_terms("joint 2-7", [("tanh((v2-v7)/0.002)", (2, 7)), ("(x2-x7)**3", (2, 7))]),
        CandidateModel.from_terms("damping 7-8", [("(v7-v8)*abs(v7-v8)", (7, 8)), ("(x7-x8)**2", (7, 8))]),
        CandidateModel.from_terms("linear", []),
    ]
    nsi = NSIOptions(order=20, block_rows=20, zero_feedthrough=False, domain="frequency", band_hz=GVT_BAND_HZ)
    outcomes = run_candidates(signals, candidates, nsi, None)
    checks = model_checks(outcomes, signals)
    assert checks["linear"].adequate and not checks["damping 7-8"].adequate and not checks["joint 2-7"].adequate
    assert not any("no candidate is adequate" in w for w in messages(adequacy_findings(checks, "linear")))
    wrong = {name: checks[name] for name in ("joint 2-7", "damping 7-8")}
    warned = messages(adequacy_findings(wrong, "joint 2-7"))
    assert any("no candidate is adequate" in w for w in warned)
