"""Tests of bayesnsi.io: config, measurements, results (SPEC section 9)."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tomllib
from pathlib import Path

import numpy as np
import pytest

from bayesnsi.exceptions import BayesNSIError, ConfigError, InputDataError, OutputExistsError
from bayesnsi.io import (
    ExperimentConfig,
    atomic_write_json,
    atomic_write_text,
    dump_config,
    load_config,
    load_signals,
    load_validation,
    prepare_output_dir,
    read_csv_columns,
    read_csv_signals,
    to_jsonable,
    versions,
    write_signals_csv,
)
from bayesnsi.options import EvidenceOptions, NSIOptions
from bayesnsi.signals import Signals

FS = 100.0
N_SAMPLES = 200


def _base_config() -> dict:
    """A valid two-DOF configuration as a plain dict (SPEC 8, case 1 layout)."""
    return {
        "seed": 7,
        "data": {
            "file": "data.csv",
            "fs": FS,
            "inputs": {"f2": 2},
            "outputs": {"x1": 1, "x2": 2},
            "estimation": [0, 150],
        },
        "nsi": {"block_rows": 10, "order": 4, "band_hz": [1.0, 10.0]},
        "candidates": [
            {"name": "quadratic damping", "terms": [{"expr": "v1*abs(v1)", "at": 1, "prior_scale": 50.0}]},
            {"name": "friction", "prior": 2.0, "terms": [{"expr": "sign(v1)", "at": 1}]},
            {"name": "both", "terms": [{"expr": "v1*abs(v1)", "at": 1}, {"expr": "sign(v1)", "at": [1, 2]}]},
        ],
        "validation": [{"name": "tail", "start": 150, "stop": 200}],
        "evidence": {"n_walkers": 32, "likelihood": "ar2"},
    }


def _columns(n: int = N_SAMPLES) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {
        "f2": rng.normal(size=n),
        "x1": rng.normal(size=n) + 0.5,
        "x2": rng.normal(size=n) - 0.25,
        "v1": rng.normal(size=n),
        "v2": rng.normal(size=n),
    }


def _write_csv(path: Path, columns: dict, fs: float | None = FS, units: dict | None = None) -> Path:
    n = len(next(iter(columns.values())))
    lines = [",".join((["t"] if fs else []) + list(columns))]
    if units is not None:
        lines.append(",".join((["s"] if fs else []) + [units[c] for c in columns]))
    for k in range(n):
        row = ([repr(k / fs)] if fs else []) + [repr(float(v[k])) for v in columns.values()]
        lines.append(",".join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


def _write_config(folder: Path, config: dict, name: str = "experiment.toml") -> Path:
    path = folder / name
    path.write_text(dump_config(config))
    return path


@pytest.fixture
def experiment(tmp_path) -> Path:
    _write_csv(tmp_path / "data.csv", _columns())
    return _write_config(tmp_path, _base_config())


# ---------------------------------------------------------------------------------------------
# config: valid files and the TOML writer


def test_load_config_fields(experiment):
    config = load_config(experiment)
    assert isinstance(config, ExperimentConfig)
    assert config.path == experiment.resolve()
    assert config.data.file == (experiment.parent / "data.csv").resolve()
    assert config.data.fs == FS
    assert list(config.data.inputs.items()) == [("f2", 2)]
    assert list(config.data.outputs.items()) == [("x1", 1), ("x2", 2)]
    assert config.data.estimation == (0, 150)
    assert config.nsi == NSIOptions(block_rows=10, order=4, band_hz=(1.0, 10.0))
    assert [c.name for c in config.candidates] == ["quadratic damping", "friction", "both"]
    assert config.candidates[0].coefficient_prior_scales == (50.0,)
    assert config.candidates[1].prior == 2.0
    assert config.candidates[2].terms[1].at == (1, 2)
    assert config.validation[0].name == "tail" and (config.validation[0].start, config.validation[0].stop) == (150, 200)
    assert config.evidence == EvidenceOptions(n_walkers=32, likelihood="ar2", seed=7)
    assert config.seed == 7
    assert config.raw == _base_config()
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.seed = 1


def test_defaults(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    del raw["nsi"], raw["validation"], raw["evidence"], raw["seed"], raw["data"]["estimation"]
    config = load_config(_write_config(tmp_path, raw))
    assert config.nsi == NSIOptions()
    assert config.nsi.block_rows == 40 and config.nsi.order == "auto" and config.nsi.zero_feedthrough
    assert config.data.estimation is None and config.data.remove_mean is False
    assert config.validation == () and config.evidence == EvidenceOptions() and config.seed == 0


def test_seed_in_evidence_section(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    del raw["seed"]
    raw["evidence"]["seed"] = 11
    config = load_config(_write_config(tmp_path, raw))
    assert config.seed == 11 and config.evidence == EvidenceOptions(n_walkers=32, likelihood="ar2", seed=11)


def test_dump_config_round_trip(experiment):
    raw = _base_config()
    raw["meta"] = {"case": "two_dof", "truth": {"alpha": 20.0, "modes_hz": [2.46, 7.51]}}
    text = dump_config(raw)
    assert tomllib.loads(text) == raw
    experiment.write_text(text)
    config = load_config(experiment)
    assert config.raw == raw and config.meta == raw["meta"]
    assert tomllib.loads(dump_config(config.raw)) == config.raw


def test_dump_config_awkward_values():
    value = {
        "plain": "quote \" backslash \\ newline \n tab \t bell \x07 del \x7f unicode é ✓",
        "key with spaces": 1,
        "dotted.key": -0.0,
        "": "empty key",
        "floats": [1e-300, 1.7976931348623157e308, 0.1, -2.5e16, 3.0],
        "ints": [0, -1, 2**63 - 1],
        "bools": [True, False],
        "empty_list": [],
        "mixed": [1, "a", {"b": [1, 2]}],
        "numpy": {"x": np.float64(0.25), "n": np.int32(3), "flag": np.bool_(True)},
        "empty_table": {},
        "tables": [{"a": 1, "nested": {"deep": {"er": "x"}}}, {}],
    }
    loaded = tomllib.loads(dump_config(value))
    expected = dict(value, numpy={"x": 0.25, "n": 3, "flag": True})
    assert loaded == expected
    special = tomllib.loads(dump_config({"x": [math.inf, -math.inf, math.nan]}))["x"]
    assert special[0] == math.inf and special[1] == -math.inf and math.isnan(special[2])


def test_dump_config_rejects_none():
    with pytest.raises(ConfigError, match="data.fs is None"):
        dump_config({"data": {"fs": None}})


def test_dump_config_property():
    hypothesis = pytest.importorskip("hypothesis")
    st = hypothesis.strategies
    scalars = (
        st.text(max_size=8) | st.booleans() | st.integers(-(2**63), 2**63 - 1)
        | st.floats(allow_nan=False, allow_infinity=False)
    )
    values = st.recursive(
        scalars,
        lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
        max_leaves=10,
    )
    documents = st.dictionaries(st.text(max_size=6), values, max_size=5)

    @hypothesis.settings(max_examples=200, deadline=None)
    @hypothesis.given(documents)
    def check(document):
        assert tomllib.loads(dump_config(document)) == document

    check()


# ---------------------------------------------------------------------------------------------
# config: every mistake is a ConfigError naming the file, the place and what to do


def _load_with(tmp_path, edit, check_files=True):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    edit(raw)
    path = _write_config(tmp_path, raw)
    return path, lambda: load_config(path, check_files=check_files)


def _assert_config_error(tmp_path, edit, *fragments):
    path, load = _load_with(tmp_path, edit)
    with pytest.raises(ConfigError) as info:
        load()
    message = str(info.value)
    assert str(path) in message, message
    for fragment in fragments:
        assert fragment in message, message
    return message


def test_unknown_key_lists_allowed_keys(tmp_path):
    message = _assert_config_error(tmp_path, lambda r: r["nsi"].update(blok_rows=20), "[nsi]", "'blok_rows'")
    assert "did you mean 'block_rows'" in message and "allowed keys are: block_rows" in message


def test_unknown_top_level_section(tmp_path):
    _assert_config_error(tmp_path, lambda r: r.update(candidate=[{"name": "x"}]), "top level", "'candidate'")


def test_unknown_term_key(tmp_path):
    _assert_config_error(
        tmp_path, lambda r: r["candidates"][0]["terms"][0].update(where=1), "terms[1]", "'where'",
        "expr, at, prior_scale",
    )


def test_missing_data_mapping(tmp_path):
    _assert_config_error(tmp_path, lambda r: r["data"].pop("outputs"), "[data] outputs", "add outputs = {")
    _assert_config_error(tmp_path, lambda r: r.pop("data"), "[data] section is missing")


def test_bad_expression(tmp_path):
    def edit(raw):
        raw["candidates"][1]["terms"][0]["expr"] = "__import__('os')"

    message = _assert_config_error(tmp_path, edit, "[[candidates]] #2 ('friction')", "terms[1]")
    assert "allowed:" in message  # the parser's grammar hint is kept


def test_empty_candidates(tmp_path):
    _assert_config_error(tmp_path, lambda r: r.update(candidates=[]), "add at least one [[candidates]]")
    _assert_config_error(tmp_path, lambda r: r.pop("candidates"), "add at least one [[candidates]]")


def test_candidates_as_single_table(tmp_path):
    _assert_config_error(tmp_path, lambda r: r.update(candidates={"name": "x", "terms": []}), "double brackets")


def test_duplicate_candidate_names(tmp_path):
    _assert_config_error(tmp_path, lambda r: r["candidates"][1].update(name="both"), "'both' is used twice")


def test_repeated_term_in_candidate(tmp_path):
    def edit(raw):
        raw["candidates"][0]["terms"].append({"expr": "v1 * abs(v1)", "at": 1})

    _assert_config_error(tmp_path, edit, "[[candidates]] #1", "repeats a term")


def test_term_reads_unmeasured_dof(tmp_path):
    def edit(raw):
        raw["candidates"][0]["terms"][0]["expr"] = "x3**3"

    _assert_config_error(tmp_path, edit, "terms[1].expr", "DOF(s) [3]", "responses measure only DOFs [1, 2]",
                         "to [data] outputs")


def test_term_acts_at_unknown_dof(tmp_path):
    def edit(raw):
        raw["candidates"][0]["terms"][0]["at"] = [1, 5]

    _assert_config_error(tmp_path, edit, "terms[1].at", "DOF(s) [5]", "neither forced nor measured")


@pytest.mark.parametrize(
    "edit, fragments",
    [
        (lambda r: r["data"]["outputs"].update(x2=1), ("[data] outputs", "DOF 1 is mapped twice")),
        (lambda r: r["data"]["inputs"].update(f2=0), ("[data] inputs.f2", "DOF number >= 1", "found 0")),
        (lambda r: r["data"]["inputs"].update(f2=True), ("inputs.f2", "found True (a boolean)")),
        (lambda r: r["data"].update(velocities={"v1": 1}), ("velocities", "same DOFs as outputs [1, 2]")),
        (lambda r: r["data"].update(accelerations={"x1": 1}), ("accelerations", "'x1' is already used as outputs")),
        (lambda r: r["data"].update(fs="100"), ("[data] fs", "a finite number", "'100' (a string)")),
        (lambda r: r["data"].update(estimation=[10, 5]), ("[data] estimation", "0 <= start < stop")),
        (lambda r: r["nsi"].update(order="4"), ("[nsi] order", 'an integer in [1, 10000] or "auto"')),
        (lambda r: r["nsi"].update(order=30), ("[nsi] order", "block_rows x outputs = 10 x 2 = 20")),
        (lambda r: r["nsi"].update(block_rows=0), ("[nsi] block_rows", "an integer in [1, 100000]")),
        (lambda r: r["nsi"].update(upsample=0), ("[nsi] upsample", "an integer in [1, 64]")),
        (lambda r: r["nsi"].update(refine_poles=[5.0]), ("[nsi] refine_poles", "[low, high] in Hz")),
        (lambda r: r["nsi"].update(c_method="prediction-error"), ("c_method", 'needs bd_method = "prediction-error"')),
        (lambda r: r["nsi"].update(velocity_method="fifth"), ("velocity_method", "'central', 'fourth', 'sixth'")),
        (lambda r: r["nsi"].update(band_hz=[1.0, 80.0]), ("band_hz", "Nyquist frequency 50 Hz")),
        (lambda r: r["nsi"].update(band=[1.0, 5.0]), ("band and band_hz",)),
        (lambda r: r["candidates"][0].update(prior=-1.0), ("prior", "a positive number")),
        (lambda r: r["candidates"][0].pop("terms"), ("terms", "terms = [] for a linear model")),
        (lambda r: r["candidates"][0]["terms"][0].pop("at"), ("terms[1] at", "add at = <DOF>")),
        (lambda r: r["candidates"][0]["terms"][0].update(at=[1, 1]), ("terms[1]", "two different DOFs")),
        (lambda r: r["candidates"][0]["terms"][0].update(prior_scale=0), ("prior_scale", "positive")),
        (lambda r: r["evidence"].update(proposal={"a": 1}), ("[evidence]", "'proposal'")),
        # [evidence] numbers checked at load, not when every candidate has failed
        (
            lambda r: r["evidence"].update(n_burn=2000),
            ("[evidence] n_burn (2000) must be smaller than n_steps (1500)",),
        ),
        (lambda r: r["evidence"].update(n_steps=-5), ("[evidence] n_steps", "an integer in [2, 10000000]")),
        (lambda r: r["evidence"].update(n_walkers=10**9), ("[evidence] n_walkers", "an integer in [4, 10000]")),
        (lambda r: r["evidence"].update(reference_force_rms=-1.0), ("[evidence] reference_force_rms",)),
        (lambda r: r["evidence"].update(likelihood="ar0"), ("likelihood 'ar0' unknown",)),
        (lambda r: r["nsi"].update(block_rows=10**12), ("[nsi] block_rows", "an integer in [1, 100000]")),
        (lambda r: r.update(diagnose={"threshold": -1.0}), ("[diagnose] threshold", ">= 0")),
        (lambda r: r.update(diagnose={"screen": 0}), ("[diagnose] screen", "an integer in [1, 100000]")),
        (lambda r: r["evidence"].update(seed=8), ("seed = 7 disagrees with [evidence] seed = 8",)),
        (lambda r: r.update(seed=-1), ("seed", "integer >= 0")),
        (lambda r: r["validation"].append({"name": "tail", "start": 160, "stop": 170}), ("'tail' is used twice",)),
        (
            lambda r: r["validation"].append({"name": "x", "start": 170}),
            ("[[validation]] #2 stop", "the key is missing"),
        ),
    ],
)
def test_config_mistakes(tmp_path, edit, fragments):
    _assert_config_error(tmp_path, edit, *fragments)


def test_overlapping_validation(tmp_path):
    def edit(raw):
        raw["validation"] = [{"name": "late", "start": 120, "stop": 180}]

    _assert_config_error(tmp_path, edit, "[[validation]] #1", "overlaps the estimation window [0, 150)")


def test_validation_needs_explicit_estimation_window(tmp_path):
    _assert_config_error(tmp_path, lambda r: r["data"].pop("estimation"), "set [data] estimation")


def test_missing_data_file(tmp_path):
    message = _assert_config_error(tmp_path, lambda r: r["data"].update(file="nowhere.csv"), "[data] file")
    assert "relative to the config file's folder" in message
    _, load = _load_with(tmp_path, lambda r: r["data"].update(file="nowhere.csv"), check_files=False)
    assert load().data.file.name == "nowhere.csv"


def test_missing_config_file(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_config(tmp_path / "missing.toml")


def test_invalid_toml(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[data\nfile = 1\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(path)


def test_errors_are_value_errors_and_bayesnsi_errors(tmp_path):
    _, load = _load_with(tmp_path, lambda r: r.update(candidates=[]))
    with pytest.raises(ValueError):
        load()
    with pytest.raises(BayesNSIError):
        load()


# ---------------------------------------------------------------------------------------------
# measurements


def test_load_signals_window_and_names(experiment):
    config = load_config(experiment)
    signals = load_signals(config)
    columns = _columns()
    assert signals.n_samples == 150 and signals.fs == FS
    assert signals.input_dofs == (2,) and signals.output_dofs == (1, 2)
    assert signals.input_names == ("f2",) and signals.output_names == ("x1", "x2")
    np.testing.assert_array_equal(signals.force[:, 0], columns["f2"][:150])
    np.testing.assert_array_equal(signals.displacement[:, 1], columns["x2"][:150])
    assert signals.velocity is None
    [(name, tail)] = load_validation(config)
    assert name == "tail" and tail.n_samples == 50
    np.testing.assert_array_equal(tail.displacement[:, 0], columns["x1"][150:])


def test_remove_mean_uses_estimation_window(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    raw["data"]["remove_mean"] = True
    config = load_config(_write_config(tmp_path, raw))
    signals = load_signals(config)
    np.testing.assert_allclose(signals.displacement.mean(axis=0), 0.0, atol=1e-12)
    columns = _columns()
    [(_, tail)] = load_validation(config)
    expected = columns["x1"][150:] - columns["x1"][:150].mean()
    np.testing.assert_allclose(tail.displacement[:, 0], expected, rtol=1e-12)


def test_velocities_follow_output_order(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    raw["data"]["velocities"] = {"v2": 2, "v1": 1}
    signals = load_signals(load_config(_write_config(tmp_path, raw)))
    np.testing.assert_array_equal(signals.velocity[:, 0], _columns()["v1"][:150])
    np.testing.assert_array_equal(signals.velocity[:, 1], _columns()["v2"][:150])


def test_validation_from_other_file(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    _write_csv(tmp_path / "other.csv", _columns(60))
    raw = _base_config()
    del raw["data"]["estimation"]
    raw["validation"] = [
        {"name": "other", "file": "other.csv"},
        {"name": "part", "file": "other.csv", "start": 10, "stop": 20},
    ]
    config = load_config(_write_config(tmp_path, raw))
    assert [(n, s.n_samples) for n, s in load_validation(config)] == [("other", 60), ("part", 10)]


def test_window_past_end_of_record(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    raw["data"]["estimation"] = [0, 150]
    raw["validation"] = [{"name": "beyond", "start": 150, "stop": 500}]
    config = load_config(_write_config(tmp_path, raw))
    with pytest.raises(ConfigError, match=r"'beyond'.*record of 200 samples"):
        load_validation(config)


def test_unknown_column_lists_available(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns())
    raw = _base_config()
    raw["data"]["outputs"] = {"x1": 1, "X2": 2}
    config = load_config(_write_config(tmp_path, raw))
    with pytest.raises(InputDataError, match=r"\['X2'\] not found; available columns: 't', 'f2', 'x1', 'x2'"):
        load_signals(config)


def test_nan_in_csv(tmp_path):
    columns = _columns()
    columns["x2"][42] = np.nan
    _write_csv(tmp_path / "data.csv", columns)
    config = load_config(_write_config(tmp_path, _base_config()))
    with pytest.raises(InputDataError, match=r"column 'x2' has 1 missing .* sample 42 \(line 44\)"):
        load_signals(config)
    # the same record is fine when the estimation window leaves the bad sample out
    raw = _base_config()
    raw["data"]["estimation"] = [50, 150]
    config = load_config(_write_config(tmp_path, raw))
    assert load_signals(config).n_samples == 100


def test_empty_cell_is_missing(tmp_path):
    path = tmp_path / "gap.csv"
    path.write_text("f,x\n1,2\n,3\n2,5\n")
    with pytest.raises(InputDataError, match=r"'f' has 1 missing .* sample 1 \(line 3\)"):
        read_csv_signals(path, load_config_data(tmp_path, "gap.csv"))


def test_non_numeric_cell(tmp_path):
    path = tmp_path / "text.csv"
    path.write_text("f,x\n1,2\n1.5,oops\n2,5\n")
    with pytest.raises(InputDataError, match=r"column 'x', line 3 \(sample 1\): expected a number") as info:
        read_csv_signals(path, load_config_data(tmp_path, "text.csv"))
    assert "oops" not in str(info.value)  # no file content in messages


def load_config_data(folder: Path, file: str, **data):
    """A DataSpec for a one-force, one-displacement file with columns f and x."""
    raw = {
        "data": {"file": file, "fs": 10.0, "inputs": {"f": 1}, "outputs": {"x": 1}, **data},
        "candidates": [{"name": "linear", "terms": []}],
    }
    return load_config(_write_config(folder, raw, "small.toml")).data


def test_units_row(tmp_path):
    units = {"f2": "N", "x1": "m", "x2": "m", "v1": "m/s", "v2": "m/s"}
    path = _write_csv(tmp_path / "data.csv", _columns(), units=units)
    table = read_csv_columns(path, ["x1"])
    assert table.units == {"t": "s", "f2": "N", "x1": "m", "x2": "m", "v1": "m/s", "v2": "m/s"}
    assert table.first_line == 3 and table.n_samples == N_SAMPLES
    signals = load_signals(load_config(_write_config(tmp_path, _base_config())))
    np.testing.assert_array_equal(signals.displacement[:, 0], _columns()["x1"][:150])


def test_silverbox_header_quirk(tmp_path):
    """Header and rows end with a comma, as in data/silverbox/SNLS80mV.csv."""
    path = tmp_path / "silver.csv"
    path.write_text('"V1","V2",\n0.0057756,0.0093978,\n0.0066102,0.012971,\n0.0059575,0.010825,\n0.0057316,0.004072,\n')
    table = read_csv_columns(path, ["V1", "V2"])
    assert table.names == ("V1", "V2") and table.units == {}
    np.testing.assert_array_equal(table.values["V2"], [0.0093978, 0.012971, 0.010825, 0.004072])
    raw = {
        "data": {
            "file": "silver.csv", "fs": 610.3515625, "inputs": {"V1": 1}, "outputs": {"V2": 1}, "remove_mean": True,
        },
        "candidates": [{"name": "cubic", "terms": [{"expr": "x1**3", "at": 1}]}],
    }
    signals = load_signals(load_config(_write_config(tmp_path, raw)))
    assert signals.n_samples == 4 and signals.fs == 610.3515625
    np.testing.assert_allclose(signals.force.mean(), 0.0, atol=1e-15)


def test_schroeder_sparse_columns_are_ignored(tmp_path):
    """Columns filled on one row only (Schroeder80mV.csv's overload flags) are not parsed."""
    path = tmp_path / "schroeder.csv"
    path.write_text('"Ovld2","Ovld1","V1","V2",\n0,0,0.005885,0.033315,\n,,0.0060811,0.040618,\n,,0.0061,0.041,\n')
    table = read_csv_columns(path, ["V1", "V2"])
    np.testing.assert_array_equal(table.values["V1"], [0.005885, 0.0060811, 0.0061])


def test_time_column_gives_fs(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns(), fs=250.0)
    raw = _base_config()
    del raw["data"]["fs"]
    raw["nsi"].pop("band_hz")
    config = load_config(_write_config(tmp_path, raw))
    assert config.data.fs is None
    assert load_signals(config).fs == pytest.approx(250.0, rel=1e-12)


def test_time_column_rounded_to_few_digits(tmp_path):
    path = tmp_path / "rounded.csv"
    t = np.arange(1000) / 3.0  # 1/3 s steps, written with 6 significant digits
    rng = np.random.default_rng(1)
    rows = [f"{tk:.6g},{a:.17g},{b:.17g}" for tk, a, b in zip(t, rng.normal(size=1000), rng.normal(size=1000))]
    path.write_text("t,f,x\n" + "\n".join(rows) + "\n")
    data = load_config_data(tmp_path, "rounded.csv", fs=3.0)
    assert read_csv_signals(path, data).fs == 3.0
    assert read_csv_signals(path, dataclasses.replace(data, fs=None)).fs == pytest.approx(3.0, rel=1e-6)


def test_non_uniform_time_column(tmp_path):
    path = tmp_path / "jitter.csv"
    t = np.arange(20) * 0.1
    t[7] += 0.004
    rows = [f"{tk:.17g},{k % 3},{k % 5}" for k, tk in enumerate(t)]
    path.write_text("t,f,x\n" + "\n".join(rows) + "\n")
    data = dataclasses.replace(load_config_data(tmp_path, "jitter.csv"), fs=None)
    with pytest.raises(InputDataError, match=r"not uniformly sampled.*line 9"):
        read_csv_signals(path, data)


def test_time_column_disagrees_with_fs(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns(), fs=200.0)
    config = load_config(_write_config(tmp_path, _base_config()))
    with pytest.raises(InputDataError, match=r"gives fs = 200 Hz but \[data\] fs = 100 Hz"):
        load_signals(config)


def test_no_sampling_frequency(tmp_path):
    _write_csv(tmp_path / "data.csv", _columns(), fs=None)
    raw = _base_config()
    del raw["data"]["fs"]
    raw["nsi"].pop("band_hz")
    config = load_config(_write_config(tmp_path, raw))
    with pytest.raises(InputDataError, match="no sampling frequency"):
        load_signals(config)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("1,2\n3,4\n", "must be a header"),
        ("f,f\n1,2\n", "more than once"),
        ("f,x\n", "no data rows"),
        ("", "must be a header"),
    ],
)
def test_malformed_csv(tmp_path, text, fragment):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputDataError, match=fragment):
        read_csv_columns(path, ["f"])


def test_input_file_unchanged(experiment):
    data = experiment.parent / "data.csv"
    before = data.read_bytes(), data.stat().st_mtime_ns
    config = load_config(experiment)
    load_signals(config)
    load_validation(config)
    assert (data.read_bytes(), data.stat().st_mtime_ns) == before


def test_write_signals_csv_round_trip(tmp_path):
    columns = _columns()
    signals = Signals(
        force=columns["f2"], displacement=np.column_stack([columns["x1"], columns["x2"]]),
        velocity=np.column_stack([columns["v1"], columns["v2"]]), fs=FS, input_dofs=[2], output_dofs=[1, 2],
        input_names=["force"], output_names=["x1", "x2"],
    )
    section = write_signals_csv(
        tmp_path / "sim.csv", signals, columns={"a1": columns["v1"] * 2}, units={"force": "N", "x1": "m"},
        float_format="%.17g",
    )
    assert section == {
        "file": "sim.csv", "fs": FS, "inputs": {"force": 2}, "outputs": {"x1": 1, "x2": 2},
        "velocities": {"v1": 1, "v2": 2},
    }
    assert [p.name for p in tmp_path.iterdir()] == ["sim.csv"]
    section["accelerations"] = {"a1": 1}
    raw = {"data": section, "candidates": [{"name": "linear", "terms": []}]}
    back = load_signals(load_config(_write_config(tmp_path, raw)))
    for field in ("force", "displacement", "velocity"):
        np.testing.assert_array_equal(getattr(back, field), getattr(signals, field))
    assert (back.input_names, back.output_names, back.fs) == (signals.input_names, signals.output_names, FS)
    assert read_csv_columns(tmp_path / "sim.csv", ["a1"]).units["force"] == "N"


def test_write_signals_csv_columns_only(tmp_path):
    section = write_signals_csv(tmp_path / "c.csv", columns={"u": [1.0, 2.0, 3.0]}, fs=2.0)
    assert section == {"file": "c.csv", "fs": 2.0}
    assert (tmp_path / "c.csv").read_text() == "t,u\n0,1\n0.5,2\n1,3\n"
    with pytest.raises(InputDataError, match="fs"):
        write_signals_csv(tmp_path / "d.csv", columns={"u": [1.0]})


# ---------------------------------------------------------------------------------------------
# results


def test_atomic_write_leaves_no_temporary_files(tmp_path):
    target = tmp_path / "out.txt"
    atomic_write_text(target, "first")
    atomic_write_text(target, "second")
    assert target.read_text() == "second"
    assert os.listdir(tmp_path) == ["out.txt"]


def test_atomic_write_failure_keeps_old_file(tmp_path):
    target = tmp_path / "results.json"
    atomic_write_json(target, {"a": 1})
    with pytest.raises(TypeError, match=r"object at obj\['bad'\]"):
        atomic_write_json(target, {"bad": object()})
    assert json.loads(target.read_text()) == {"a": 1}
    assert os.listdir(tmp_path) == ["results.json"]


def test_to_jsonable_nan_to_null(tmp_path):
    @dataclasses.dataclass
    class Mode:
        frequency_hz: float
        damping_ratio: float

    obj = {
        "nan": math.nan,
        "inf": -np.inf,
        "array": np.array([[1.0, np.nan], [np.inf, 2.0]]),
        "scalars": (np.float32(0.5), np.int64(3), np.bool_(False)),
        "complex": 1 + 2j,
        "path": Path("a") / "b.csv",
        "modes": [Mode(2.46, 0.0091)],
        5: {1.5},
    }
    assert to_jsonable(obj) == {
        "nan": None,
        "inf": None,
        "array": [[1.0, None], [None, 2.0]],
        "scalars": [0.5, 3, False],
        "complex": {"real": 1.0, "imag": 2.0},
        "path": "a/b.csv",
        "modes": [{"frequency_hz": 2.46, "damping_ratio": 0.0091}],
        "5": [1.5],
    }
    target = atomic_write_json(tmp_path / "r.json", obj)
    text = target.read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text)["nan"] is None


def test_versions():
    found = versions()
    assert {"python", "platform", "bayesnsi", "numpy", "scipy"} <= set(found)
    assert all(isinstance(v, str) for v in found.values())


def test_prepare_output_dir(tmp_path):
    out = prepare_output_dir(tmp_path / "run" / "a")
    assert out.is_dir() and out.is_absolute()
    assert prepare_output_dir(out) == out  # no results yet: fine
    (out / "results.json").write_text("{}")
    with pytest.raises(OutputExistsError, match="--force") as info:
        prepare_output_dir(out)
    assert isinstance(info.value, FileExistsError) and isinstance(info.value, BayesNSIError)
    assert prepare_output_dir(out, force=True) == out
    assert (out / "results.json").read_text() == "{}"
    with pytest.raises(OutputExistsError, match="is a file"):
        prepare_output_dir(out / "results.json")
