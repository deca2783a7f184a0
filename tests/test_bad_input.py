"""Catalogue of bad inputs: each gets its own error class and a message that says what to do."""

import re
import warnings

import numpy as np
import pytest

from bayesnsi import CandidateModel, Signals, identify
from bayesnsi.exceptions import (
    BlockRowsError,
    ConfigError,
    ExpressionError,
    InputDataError,
    NotIdentifiableError,
    OrderError,
    ShapeError,
    UnstableModelError,
)
from bayesnsi.models import parse_expression
from bayesnsi.nsi import StateSpaceModel
from bayesnsi.options import EvidenceOptions, NSIOptions
from tests._helpers.experiments import experiment_config as _experiment

RNG = np.random.default_rng(0)
F, X = RNG.standard_normal((400, 1)), RNG.standard_normal((400, 2))


@pytest.mark.parametrize(
    "make, error, message",
    [
        (
            lambda: Signals(F, np.where(np.arange(800).reshape(400, 2) == 7, np.nan, X), 100, [1], [1, 2]),
            InputDataError, "NaN/Inf",
        ),
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
    with pytest.raises(ConfigError, match="route"):  # refused where the options are built
        NSIOptions(block_rows=5, route="qr")


def test_unstable_identified_model_is_refused():
    # outputs that grow without bound: no stable underlying linear model explains them
    t = np.arange(400)[:, None]
    growing = np.exp(0.02 * t) * np.c_[np.sin(0.3 * t), np.cos(0.21 * t)] + 1e-3 * X
    with pytest.raises(UnstableModelError, match="unstable") as info:
        identify(Signals(F, growing, 100.0, [1], [1, 2]), None, NSIOptions(block_rows=5, order=2))
    # the message names the unstable pole, the one of largest |z| among them (on a 12-DOF chain it once said
    # "try another order" without a frequency)
    import re

    found = re.search(r"largest \|eigenvalue of A\| = (1\.\d+); unstable poles at [\d.]+ Hz \(\|z\| = (1\.\d+)\)",
                      str(info.value))
    assert found and float(found.group(1)) == pytest.approx(float(found.group(2)), abs=1e-3)


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
# the rest of the catalogue: files and configs, candidate lists, physics, MCMC, CLI


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
        (
            lambda raw: raw["candidates"][0].__setitem__("terms", [{"expr": "x1**3", "at": 5}]),
            "neither forced nor measured",
        ),
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


def test_term_acting_away_from_the_dofs_it_reads_is_kept_with_a_warning(tmp_path):
    from bayesnsi.exceptions import BayesNSIWarning
    from bayesnsi.io import load_config

    def edit(raw):
        raw["candidates"][0]["terms"] = [{"expr": "(x1-x2)**3", "at": 2}, {"expr": "x1**3", "at": 2}]

    with pytest.warns(BayesNSIWarning, match=r"terms\[2\]: 'x1\*\*3' reads DOF\(s\) \[1\] but acts at \[2\].*at = 1"):
        config = load_config(_experiment(tmp_path, edit))  # terms[1] overlaps its DOFs: no warning for it
    assert [t.at for t in config.candidates[0].terms] == [(2,), (2,)]


def test_term_reading_an_unmeasured_dof_names_the_sensors_to_add(tmp_path):
    from bayesnsi.exceptions import ConfigError
    from bayesnsi.io import load_config

    def edit(raw):
        raw["data"].pop("outputs")
        raw["data"]["accelerations"] = {"x1": 1, "x2": 2}
        raw["data"]["integrate"] = {"band_hz": [1.0, 40.0]}
        raw["candidates"][0]["terms"] = [{"expr": "x3**3", "at": 1}]

    with pytest.raises(ConfigError, match=r"reads DOF\(s\) \[3\].*to \[data\] accelerations"):
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
    message = r"'x1' has 1 missing or non-finite.*sample 17 \(line 19\).*fill or remove"
    with pytest.raises(InputDataError, match=message):
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
    from bayesnsi import _dispatch as backends
    from bayesnsi.cli import main

    monkeypatch.setattr(backends, "CONNECT_TIMEOUT_S", 1.0)
    config = _experiment(tmp_path)
    code = main(["identify", str(config), "--out", str(tmp_path / "o"), "--quiet", "--scheduler", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert code == 2 and "cannot reach the Dask scheduler" in err and "drop --scheduler" in err
    assert "Traceback" not in err
    assert main(["identify", str(config), "--out", str(tmp_path / "p"), "--quiet", "--jobs", "0"]) == 2
    assert "jobs: expected an integer in [1, " in capsys.readouterr().err  # ExecutionOptions' message


def test_cli_exits_2_in_one_line_and_debug_shows_the_traceback(tmp_path, capsys):
    from bayesnsi.cli import main

    evil = [{"expr": "__import__('os')", "at": 1}]
    config = _experiment(tmp_path, lambda raw: raw["candidates"][0].__setitem__("terms", evil))
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


# ---------------------------------------------------------------------------------------------
# hostile input: files that are not measurements, huge or deep files, nonsense configs


def _write_raw_config(folder, data_file: str, extra: str = "", fs: str = "100.0"):
    path = folder / "hostile.toml"
    path.write_text(
        f'[data]\nfile = "{data_file}"\nfs = {fs}\ninputs = {{ f2 = 2 }}\noutputs = {{ x1 = 1, x2 = 2 }}\n'
        '\n[[candidates]]\nname = "cubic"\nterms = [{ expr = "x1**3", at = 1 }]\n' + extra
    )
    return path


def test_system_text_file_is_not_echoed(tmp_path, capsys):
    from bayesnsi.cli import main
    from bayesnsi.io import load_config, load_signals

    secret = "secretuser:x:0:0:secret token:/home/secretuser:/bin/bash"
    (tmp_path / "passwd").write_text(secret + "\n" + secret.replace("secretuser", "other") + "\n")
    config = _write_raw_config(tmp_path, "passwd")
    with pytest.raises(InputDataError, match=r"passwd, line 1: expected a CSV header naming") as info:
        load_signals(load_config(config))
    assert "secret" not in str(info.value) and "\n" not in str(info.value)
    assert main(["identify", str(config), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "secret" not in capsys.readouterr().err


def test_long_line_is_refused_before_it_is_read(tmp_path, monkeypatch):
    import tracemalloc

    from bayesnsi.io import _csv, read_csv_columns

    monkeypatch.setattr(_csv, "MAX_LINE_BYTES", 4096)
    header_only = tmp_path / "one_line.csv"
    header_only.write_bytes(b"1" * 2**21)  # 2 MiB without a newline
    in_rows = tmp_path / "long_row.csv"
    in_rows.write_bytes(b"f,x\n1,2\n" + b"3" * 2**21)
    for path, line in ((header_only, 1), (in_rows, 3)):
        tracemalloc.start()
        try:
            with pytest.raises(InputDataError, match=rf"line {line}: longer than 4096 bytes"):
                read_csv_columns(path, ["f"])
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 2**20, peak  # far less than the 2 MiB line


def test_huge_file_without_newlines_is_refused_fast(tmp_path):
    import time

    from bayesnsi.io import read_csv_columns

    path = tmp_path / "huge.csv"
    with open(path, "wb") as fh:  # 2 GB, sparse on most file systems
        fh.truncate(2 * 10**9)
    start = time.perf_counter()
    with pytest.raises(InputDataError, match="line 1: longer than"):
        read_csv_columns(path, ["f"])
    assert time.perf_counter() - start < 5.0


def test_csv_larger_than_the_memory_limit(tmp_path, monkeypatch):
    from bayesnsi.io import read_csv_columns

    path = tmp_path / "data.csv"
    path.write_text("f,x\n" + "1,2\n" * 1000)
    assert read_csv_columns(path, ["f", "x"]).n_samples == 1000
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "10K")
    with pytest.raises(InputDataError, match=r"2 column\(s\) of 1001 lines needs 32032 bytes.*BAYESNSI_MAX_MEMORY"):
        read_csv_columns(path, ["f", "x"])


def test_nul_byte_in_csv(tmp_path):
    from bayesnsi.io import read_csv_columns

    path = tmp_path / "data.csv"
    path.write_bytes(b"f,x\n1,2\n3,\x004\n")
    with pytest.raises(InputDataError, match="line 3: holds a NUL byte"):
        read_csv_columns(path, ["f", "x"])


def test_many_header_columns_are_checked_in_linear_time(tmp_path):
    import time

    from bayesnsi.io import read_csv_columns

    names = [f"c{k}" for k in range(100_000)]
    path = tmp_path / "wide.csv"
    path.write_text(",".join(names + ["c7"]) + "\n" + ",".join(["1"] * (len(names) + 1)) + "\n")
    start = time.perf_counter()
    with pytest.raises(InputDataError, match=r"'c7'.* more than once"):
        read_csv_columns(path, ["c1"])
    assert time.perf_counter() - start < 5.0  # counting with list.count took minutes


@pytest.mark.parametrize("depth", [5000, 100])
def test_deeply_nested_toml(tmp_path, depth, capsys):
    from bayesnsi.cli import main
    from bayesnsi.io import load_config

    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * depth + "]" * depth + "\n")
    with pytest.raises(ConfigError, match="nest"):
        load_config(path)
    assert main(["identify", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize("fs", ["1e308", "1e-300", "inf", "nan", "0.0"])
def test_absurd_sampling_frequency(tmp_path, fs):
    from bayesnsi.io import load_config

    (tmp_path / "data.csv").write_text("f2,x1,x2\n1,2,3\n")
    with pytest.raises(ConfigError, match=r"\[data\] fs: expected a"):
        load_config(_write_raw_config(tmp_path, "data.csv", fs=fs))


def test_absurd_sampling_frequency_of_signals():
    with pytest.raises(InputDataError, match=r"in \[1e-06, 1e\+09\]"):
        Signals(F, X, 1e308, [1], [1, 2])


@pytest.mark.parametrize("name", ["evil\x1b[2J", "two\nlines", "nul\x00", "bidi\u202egnp.exe"])
def test_control_characters_in_names(tmp_path, name):
    from bayesnsi.io import dump_config, load_config

    (tmp_path / "data.csv").write_text("f2,x1,x2\n1,2,3\n")
    raw = {
        "data": {"file": "data.csv", "fs": 100.0, "inputs": {"f2": 2}, "outputs": {"x1": 1, "x2": 2}},
        "candidates": [{"name": name, "terms": []}],
    }
    path = tmp_path / "c.toml"
    path.write_text(dump_config(raw))
    with pytest.raises(ConfigError, match="control character U\\+") as info:
        load_config(path)
    assert name not in str(info.value)  # escaped, never raw
    raw["candidates"][0]["name"] = "ok"
    raw["data"]["outputs"] = {name: 1, "x2": 2}
    path.write_text(dump_config(raw))
    with pytest.raises(ConfigError, match="control character U\\+"):
        load_config(path)
    with pytest.raises(ConfigError, match="control character"):
        CandidateModel(name=name, terms=())


def test_too_many_candidates_are_refused_fast(tmp_path):
    import time

    from bayesnsi.io import load_config
    from bayesnsi.io.config import MAX_CONFIG_CANDIDATES

    (tmp_path / "data.csv").write_text("f2,x1,x2\n1,2,3\n")
    many = "".join(f'\n[[candidates]]\nname = "c{k}"\nterms = []\n' for k in range(100_000))
    path = _write_raw_config(tmp_path, "data.csv", many)
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=rf"100001 \[\[candidates\]\] tables, more than the {MAX_CONFIG_CANDIDATES}"):
        load_config(path)
    assert time.perf_counter() - start < 2.0
    inline = "candidates = [" + ", ".join(f'{{ name = "c{k}", terms = [] }}' for k in range(MAX_CONFIG_CANDIDATES + 1))
    path.write_text('[data]\nfile = "data.csv"\nfs = 100.0\ninputs = { f2 = 2 }\noutputs = { x1 = 1 }\n'
                    .replace("[data]", inline + "]\n\n[data]"))
    with pytest.raises(ConfigError, match=rf"{MAX_CONFIG_CANDIDATES + 1} candidates, more than"):
        load_config(path)


def test_collinear_terms_in_config(tmp_path):
    from bayesnsi.io import load_config

    (tmp_path / "data.csv").write_text("f2,x1,x2\n1,2,3\n")
    extra = '\n[[candidates]]\nname = "split"\nterms = [{ expr = "x1**3", at = 1 }, { expr = "x1*x1*x1", at = 1 }]\n'
    with pytest.raises(ConfigError, match=r"'split'.*x1\*\*3@1 and \(x1\*x1\)\*x1@1 are the same function"):
        load_config(_write_raw_config(tmp_path, "data.csv", extra))


@pytest.mark.parametrize("name", ["passwd.mat", "passwd.uff", "passwd.h5"])
def test_text_file_with_a_binary_extension_is_not_echoed(tmp_path, name):
    from bayesnsi.io import read_columns

    path = tmp_path / name
    path.write_text("secretuser:x:0:0:secret token:/home/secretuser:/bin/bash\n    -1\n    58\nsecret\n    -1\n")
    with pytest.raises(InputDataError) as info:
        read_columns(path, ["x1"])
    assert "secret" not in str(info.value) and "\n" not in str(info.value)
