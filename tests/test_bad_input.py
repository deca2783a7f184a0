"""Catalogue of bad inputs: each gets its own error class and a message that says what to do."""

from bayesnsi.options import EvidenceOptions, NSIOptions
import re
import warnings

import numpy as np
import pytest

from bayesnsi import CandidateModel, Signals, identify
from bayesnsi.exceptions import (
    BlockRowsError,
    ExpressionError,
    InputDataError,
    NotIdentifiableError,
    OrderError,
    ShapeError,
    UnstableModelError,
)
from bayesnsi.models import parse_expression
from bayesnsi.nsi import StateSpaceModel

RNG = np.random.default_rng(0)
F, X = RNG.standard_normal((400, 1)), RNG.standard_normal((400, 2))


@pytest.mark.parametrize(
    "make, error, message",
    [
        (lambda: Signals(F, np.where(np.arange(800).reshape(400, 2) == 7, np.nan, X), 100, [1], [1, 2]), InputDataError, "NaN/Inf"),
        (lambda: Signals(F, np.c_[X[:, 0], np.inf * X[:, 1]], 100, [1], [1, 2]), InputDataError, "NaN/Inf"),
        (lambda: Signals(F, np.c_[X[:, 0], np.ones(400)], 100, [1], [1, 2]), InputDataError, "constant"),
        (lambda: Signals(F, X[:300], 100, [1], [1, 2]), ShapeError, "same length"),
        (lambda: Signals(F, X, 100, [1], [1, 1]), InputDataError, "repeated"),
        (lambda: Signals(F, X, 100, [1], [0, 1]), InputDataError, "numbered from 1"),
        (lambda: Signals(F, X, 100, [1], [1]), ShapeError, "2 channels"),
        (lambda: Signals(F, X, -1.0, [1], [1, 2]), InputDataError, "sampling frequency"),
        (lambda: Signals(F, X[:, :, None] * np.ones(2), 100, [1], [1, 2]), ShapeError, "n_samples, n_channels"),
    ],
)
def test_bad_signals(make, error, message):
    with pytest.raises(error, match=message):
        make()


@pytest.mark.parametrize("text", ["__import__('os')", "x1.__class__", "lambda: 0", "x1**99999", "open('f')", "[x1]"])
def test_bad_expressions(text):
    with pytest.raises(ExpressionError):
        parse_expression(text)


def _signals():
    return Signals(F, X, 100.0, [1], [1, 2])


def test_identification_errors():
    with pytest.raises(BlockRowsError, match="too few.*use fewer block rows"):
        identify(_signals(), None, NSIOptions(block_rows=100))
    with pytest.raises(OrderError, match="lower the order or raise block_rows"):
        identify(_signals(), None, NSIOptions(block_rows=5, order=11))
    with pytest.raises(NotIdentifiableError, match="not measured"):
        identify(_signals(), [("x3**3", 1)], NSIOptions(block_rows=5, order=2))
    with pytest.raises(NotIdentifiableError, match="cannot be identified"):
        identify(Signals(F, X, 100.0, [1], [1, 2]), [("x1**3", 3)], NSIOptions(block_rows=5, order=2))
    with pytest.raises(NotIdentifiableError, match="constant"):
        identify(_signals(), [("x1 - x1", 1)], NSIOptions(block_rows=5, order=2))
    with pytest.raises(InputDataError, match="Signals object"):
        identify(np.zeros((10, 2)), None)
    with pytest.raises(InputDataError, match="route"):
        identify(_signals(), None, NSIOptions(block_rows=5, route="qr"))


def test_unstable_identified_model_is_refused():
    # outputs that grow without bound: no stable underlying linear model explains them
    t = np.arange(400)[:, None]
    growing = np.exp(0.02 * t) * np.c_[np.sin(0.3 * t), np.cos(0.21 * t)] + 1e-3 * X
    with pytest.raises(UnstableModelError, match="unstable"):
        identify(Signals(F, growing, 100.0, [1], [1, 2]), None, NSIOptions(block_rows=5, order=2))


def test_unstable_simulation_is_reported():
    model = StateSpaceModel(np.array([[1.5]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), 0.01)
    with pytest.raises(UnstableModelError, match="unstable"):
        model.simulate(np.ones((2000, 1)))


def test_empty_candidate_name_and_duplicate_terms():
    from bayesnsi.exceptions import ConfigError

    with pytest.raises(ConfigError, match="non-empty name"):
        CandidateModel(name="", terms=())
    with pytest.raises(ConfigError, match="repeats"):
        CandidateModel.from_terms("m", [("x1", 1), ("x1", 1)])


# ---------------------------------------------------------------------------------------------
# the rest of the catalogue (issue 6): files and configs, candidate lists, physics, MCMC, CLI


def _experiment(folder, edit=None, csv_columns=None):
    """A small valid experiment (CSV + config) in ``folder``, optionally edited; returns the config path."""
    from bayesnsi.io import dump_config

    n = 300
    rng = np.random.default_rng(1)
    columns = csv_columns or {"f2": rng.normal(size=n), "x1": rng.normal(size=n), "x2": rng.normal(size=n)}
    lines = [",".join(["t", *columns])]
    lines += [",".join([repr(k / 100.0)] + [repr(float(v[k])) for v in columns.values()]) for k in range(n)]
    (folder / "data.csv").write_text("\n".join(lines) + "\n")
    raw = {
        "data": {"file": "data.csv", "fs": 100.0, "inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}},
        "nsi": {"block_rows": 10, "order": 4},
        "candidates": [{"name": "cubic", "terms": [{"expr": "x1**3", "at": 1}]}],
    }
    if edit is not None:
        edit(raw)
    path = folder / "experiment.toml"
    path.write_text(dump_config(raw))
    return path


def _set(section, key, value):
    return lambda raw: raw[section].__setitem__(key, value)


@pytest.mark.parametrize(
    "edit, message",
    [
        (_set("data", "outputs", {"x1": 1, "x9": 2}), r"column\(s\) \['x9'\] not found; available columns"),
        (_set("data", "inputs", {"force": 2}), r"column\(s\) \['force'\] not found"),
    ],
)
def test_unknown_columns_in_the_mapping(tmp_path, edit, message):
    from bayesnsi.io import load_config, load_signals

    with pytest.raises(InputDataError, match=message + r".*fix \[data\]"):
        load_signals(load_config(_experiment(tmp_path, edit)))


@pytest.mark.parametrize(
    "edit, message",
    [
        (_set("data", "outputs", {"x1": 0, "x2": 2}), "DOF number >= 1"),
        (_set("data", "outputs", {"x1": 2, "x2": 2}), "DOF 2 is mapped twice"),
        (lambda raw: raw["candidates"][0].__setitem__("terms", [{"expr": "x1**3", "at": 5}]), "neither forced nor measured"),
        (lambda raw: raw["candidates"][0].__setitem__("terms", [{"expr": "x7**3", "at": 1}]), "reads DOF.*7"),
        (_set("nsi", "order", 999), "at most block_rows x outputs"),
        (lambda raw: raw.__setitem__("candidates", []), "no candidate models"),
        (lambda raw: raw["candidates"][0].__setitem__("terms", [{"expr": "x1.real", "at": 1}]), "terms"),
        (lambda raw: raw["candidates"][0].__setitem__("terms", [{"expr": "x1**99999", "at": 1}]), "terms"),
    ],
)
def test_config_dofs_orders_candidates(tmp_path, edit, message):
    from bayesnsi.exceptions import ConfigError
    from bayesnsi.io import load_config

    with pytest.raises(ConfigError, match=message):
        load_config(_experiment(tmp_path, edit))


def test_all_zero_channel_in_a_file(tmp_path):
    from bayesnsi.io import load_config, load_signals

    rng = np.random.default_rng(2)
    columns = {"f2": rng.normal(size=300), "x1": np.zeros(300), "x2": rng.normal(size=300)}
    with pytest.raises(InputDataError, match="constant.*remove it from the config"):
        load_signals(load_config(_experiment(tmp_path, csv_columns=columns)))


def test_nan_in_a_file_names_the_line(tmp_path):
    from bayesnsi.io import load_config, load_signals

    rng = np.random.default_rng(3)
    x1 = rng.normal(size=300)
    x1[17] = np.inf
    columns = {"f2": rng.normal(size=300), "x1": x1, "x2": rng.normal(size=300)}
    with pytest.raises(InputDataError, match=r"'x1' has 1 missing or non-finite.*sample 17 \(line 19\).*fill or remove"):
        load_signals(load_config(_experiment(tmp_path, csv_columns=columns)))


def test_empty_candidate_list_in_the_api():
    from bayesnsi.exceptions import ConfigError
    from bayesnsi.run import dictionary_candidates, run_candidates, subset_candidates

    with pytest.raises(ConfigError, match="candidate list is empty; give at least one candidate"):
        run_candidates(_signals(), [])
    with pytest.raises(ConfigError, match="no datasets"):
        from bayesnsi.run import run_datasets

        run_datasets([], [CandidateModel("linear", ())])
    with pytest.raises(ConfigError, match="term dictionary is empty"):
        subset_candidates([])
    with pytest.raises(ConfigError, match="unknown effect type"):
        dictionary_candidates([1, 2], types=["x^7"])
    with pytest.raises(ConfigError, match="lower max_terms"):
        dictionary_candidates([1, 2, 3, 4, 5, 6], max_terms=12)


def test_no_physical_modes():
    # white-noise outputs at order 2: the identified poles are real, none is a structural mode
    with pytest.raises(UnstableModelError, match="no physical mode.*check the order"):
        identify(_signals(), None, NSIOptions(block_rows=5, order=2))


def test_unconverged_mcmc_warns_with_advice():
    from bayesnsi import simulate_case
    from bayesnsi.evidence import candidate_evidence
    from bayesnsi.exceptions import ConvergenceWarning

    case = simulate_case("two-dof", seed=0, duration=5.0)
    case_signals = case.signals
    result = identify(case_signals, case.candidates[0], NSIOptions(block_rows=20, order=4))
    options = EvidenceOptions(likelihood="white", compare=(), n_walkers=8, n_steps=20, n_burn=5)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        candidate_evidence(result, case_signals, options)
    messages = [str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning)]
    assert any(re.search(r"MCMC not converged.*Run about \d+x more steps", m) for m in messages), messages


def test_unreachable_scheduler_and_bad_jobs(tmp_path, monkeypatch, capsys):
    from bayesnsi.cli import main
    from bayesnsi.run import backends

    monkeypatch.setattr(backends, "CONNECT_TIMEOUT_S", 1.0)
    config = _experiment(tmp_path)
    code = main(["identify", str(config), "--out", str(tmp_path / "o"), "--quiet", "--scheduler", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert code == 2 and "cannot reach the Dask scheduler" in err and "drop --scheduler" in err
    assert "Traceback" not in err
    assert main(["identify", str(config), "--out", str(tmp_path / "p"), "--quiet", "--jobs", "0"]) == 2
    assert "jobs must be a positive integer" in capsys.readouterr().err


def test_cli_exits_2_in_one_line_and_debug_shows_the_traceback(tmp_path, capsys):
    from bayesnsi.cli import main

    config = _experiment(tmp_path, lambda raw: raw["candidates"][0].__setitem__("terms", [{"expr": "__import__('os')", "at": 1}]))
    assert main(["select", str(config), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bayesnsi select: error:") and "unknown name" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert main(["--debug", "select", str(config), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "ConfigError" in err
    assert not (tmp_path / "o" / "results.json").exists()


def test_expression_dof_bounds_and_missing_rows():
    from bayesnsi.exceptions import ShapeError

    with pytest.raises(ExpressionError, match="beyond"):
        parse_expression("x999999999")
    with pytest.raises(ShapeError, match="reads DOFs"):
        parse_expression("x3**2").evaluate(np.zeros((2, 5)), np.zeros((2, 5)))
