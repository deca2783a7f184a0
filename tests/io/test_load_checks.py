"""Nonsense refused (or told) at load, before the expensive work; the Python API checks its arrays like the loader."""

from __future__ import annotations

import io
import json
import os
import zipfile

import numpy as np
import pytest

from bayesnsi import CandidateModel, Signals, identify
from bayesnsi.cli import main
from bayesnsi.exceptions import (
    BayesNSIError,
    CacheWarning,
    ConfigError,
    ExpressionError,
    FreeBodyWarning,
    InputDataError,
)
from bayesnsi.io import load_config, load_signals
from bayesnsi.io._store import write_container
from bayesnsi.io.cache import ResultCache
from bayesnsi.options import NSIOptions
from tests._helpers.experiments import experiment_config as _experiment
from tests._helpers.multisine_chain import CUBIC
from tests._helpers.multisine_chain import periodic_record as _record

RNG = np.random.default_rng(0)
F, X = RNG.standard_normal((400, 1)), RNG.standard_normal((400, 2))


# ---------------------------------------------------------------- candidates and expressions


def test_linearly_dependent_terms_are_refused_naming_the_combination(tmp_path):
    def edit(raw):
        raw["candidates"][0]["terms"] = [{"expr": "x1**3", "at": 1}, {"expr": "v1*abs(v1)", "at": 1},
                                         {"expr": "x1**3 + v1*abs(v1)", "at": 1}]

    with pytest.raises(ConfigError, match=r"linearly dependent, 1·\(x1\*\*3@1\) \+ 1·\(v1\*abs\(v1\)@1\) - 1·"):
        load_config(_experiment(tmp_path, edit))


def test_dependence_across_locations_is_found_and_independent_terms_pass():
    # x1**3 at 1, at 2 and between 1 and 2: l1 n - l2 n - l12 n = 0
    with pytest.raises(ConfigError, match="linearly dependent"):
        CandidateModel.from_terms("c", [("x1**3", 1), ("x1**3", 2), ("x1**3", (1, 2))])
    kept = CandidateModel.from_terms("ok", [("x1**3", 1), ("x1**2", 1), ("x1", 1), ("v1*abs(v1)", 1), ("sign(v1)", 1)])
    assert kept.n_terms == 5


@pytest.mark.parametrize("text", ["x\u0661**3", "x1**\u0663", "x\uff11**3"])  # Arabic-Indic, fullwidth digits
def test_digits_other_than_ascii_are_refused(text):
    from bayesnsi.models import parse_expression

    with pytest.raises(ExpressionError, match="0-9"):
        parse_expression(text)


# ---------------------------------------------------------------- paths and mappings


def test_a_config_path_that_is_not_utf8_is_refused_before_any_candidate(tmp_path, capsys):
    config = _experiment(tmp_path)
    odd = os.fsdecode(os.fsencode(str(tmp_path)) + b"/exp\xff.toml")
    os.replace(config, odd)
    out = tmp_path / "out"
    assert main(["identify", odd, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "not UTF-8" in err and "\\udcff" in err
    assert not (out / ".cache").exists()


@pytest.mark.parametrize("copy", ["x1", "f2"])
def test_one_channel_mapped_twice_is_refused_at_load(tmp_path, copy):
    rng = np.random.default_rng(3)
    x1 = rng.normal(size=300)
    columns = {"f2": rng.normal(size=300), "x1": x1}
    columns["x2"] = -2.5 * columns[copy]  # the same channel, through another gain
    config = _experiment(tmp_path, csv_columns=columns)
    with pytest.raises(InputDataError, match=f"channels '{copy}' and 'x2' hold the same samples"):
        load_signals(load_config(config))


def test_a_fixed_virtual_stiffness_on_a_grounded_record_is_told_loudly(tmp_path, select_config):
    config = tmp_path / "grounded.toml"
    text = select_config.read_text().replace('file = "two_dof.csv"', f'file = "{select_config.parent / "two_dof.csv"}"')
    config.write_text(text.replace("[nsi]\n", "[nsi]\nvirtual_stiffness = 1e4\n"))
    with pytest.warns(FreeBodyWarning, match=r"looks grounded.*modes at 2\.4\d Hz, 7\.\d* Hz.*spring of 10000"):
        load_signals(load_config(config))
    plain = tmp_path / "plain.toml"
    plain.write_text(text)
    load_signals(load_config(plain))  # no spring, nothing said (warnings are errors here)


def test_the_frequency_route_records_the_block_rows_it_was_asked_for():
    result = identify(_record(seed=2), CUBIC, NSIOptions(domain="frequency", order=4, block_rows=5000))
    assert result.settings["requested_block_rows"] == 5000
    assert result.block_rows == result.settings["block_rows"] < 5000


# ---------------------------------------------------------------- cached results against their own shapes


@pytest.mark.parametrize("edit, message", [
    (lambda doc, arrays: doc["outcome"]["result"].__setitem__("order", 99), "order 99 for a 4x4 A"),
    (lambda doc, arrays: arrays[doc["outcome"]["result"]["model"]["A"]["$array"]].__setitem__((0, 0), np.nan),
     "NaN or Inf"),
])
def test_a_cached_result_that_contradicts_itself_is_recomputed(tmp_path, edit, message):
    from bayesnsi.run.batch import candidate_seeds, candidate_task

    signals = _record(seed=2)
    cubic = CandidateModel.from_terms("cubic", CUBIC)
    nsi = NSIOptions(block_rows=20, order=4)
    seed = candidate_seeds(0, 1)[0]
    outcome = candidate_task(signals, cubic, nsi, None, seed)
    cache = ResultCache(tmp_path)
    key = cache.key(signals, cubic, nsi, None, seed)
    cache.store(key, outcome)
    data = cache.path(key).read_bytes()
    document = json.loads(zipfile.ZipFile(io.BytesIO(data)).read("entry.json"))
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        arrays = {name: np.array(npz[name]) for name in npz.files if name != "entry.json"}
    edit(document, arrays)
    buffer = io.BytesIO()
    write_container(buffer, document, arrays)
    cache.path(key).write_bytes(buffer.getvalue())
    with pytest.warns(CacheWarning, match=message):
        assert cache.load(key) is None


# ---------------------------------------------------------------- the Python API's arrays


@pytest.mark.parametrize("make, message", [
    (lambda: Signals(F + 1j * F, X, 100.0, [1], [1, 2]), "force holds complex numbers"),
    (lambda: Signals(F, X * (1 + 0j) + 1j, 100.0, [1], [1, 2]), "displacement holds complex numbers"),
    (lambda: Signals(np.ma.masked_array(F, mask=np.arange(400)[:, None] == 7), X, 100.0, [1], [1, 2]),
     "force is a masked array with 1 masked"),
    (lambda: Signals(F, X, 100.0, (True,), [1, 2]), "input_dofs: DOFs are whole numbers"),
    (lambda: Signals(F, X, 100.0, [1], [1, 2.5]), "output_dofs: DOFs are whole numbers"),
    (lambda: Signals(F[:0], X[:0], 100.0, [1], [1, 2]), "force holds no samples"),
    (lambda: Signals(F > 0, X, 100.0, [1], [1, 2]), "force holds booleans"),
    (lambda: Signals(np.array([["a"]] * 400), X, 100.0, [1], [1, 2]), "force must hold real numbers"),
    (lambda: Signals(F, [[1.0, "x"]] * 400, 100.0, [1], [1, 2]), "displacement must hold real numbers"),
])
def test_the_api_refuses_arrays_a_conversion_would_change(make, message):
    with pytest.raises(BayesNSIError, match=message):
        make()


def test_the_api_accepts_what_the_loader_accepts():
    signals = Signals(np.ma.masked_array(F), X.astype(np.float32), 100, [np.int64(1)], [1.0, 2])
    assert signals.force.dtype == np.float64 and signals.input_dofs == (1,) and signals.output_dofs == (1, 2)


def test_the_preprocessing_helpers_refuse_complex_and_empty_input():
    from bayesnsi.preprocess import detrend

    with pytest.raises(InputDataError, match="complex"):
        detrend(np.ones(100) + 1j)
    with pytest.raises(InputDataError, match="no samples"):
        detrend(np.zeros(0))
