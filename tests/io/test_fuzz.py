"""Property-based fuzzing of every file bayesnsi reads: expressions, configs (TOML), CSV files, cache entries.

Whatever the input, the result is a value or a :class:`~bayesnsi.exceptions.BayesNSIError`
subclass - never another exception. The number of examples follows the hypothesis profile
registered in tests/conftest.py (``BAYESNSI_HYPOTHESIS_PROFILE=long`` for thousands).
"""

import functools
import io
import json
import math
import warnings
import zipfile
from pathlib import Path

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st

from bayesnsi.exceptions import BayesNSIError, CacheWarning, InputDataError
from bayesnsi.io import (
    DataSpec,
    dump_config,
    load_config,
    load_signals,
    load_validation,
    read_csv_columns,
    read_signals,
)
from bayesnsi.models import parse_expression
from tests._helpers.fuzz import CACHE_EXAMPLES, FOLDER
from tests._helpers.fuzz import outcome as _outcome
from tests._helpers.fuzz import patched as _patched
from tests._helpers.fuzz import scalars as _scalars

# ---------------------------------------------------------------------------------------------
# expressions

GRAMMAR = ["x1", "x2", "v1", "v12", "abs(", "sign(", "tanh(", "(", ")", "+", "-", "*", "/", "**", "2", "0.5", "1e308",
           "99999", ".", "__import__", "'os'", "lambda", ":", "[", "]", ",", " ", "nan", "inf", "x0", "exp("]


_valid_expr = st.recursive(
    st.sampled_from(["x1", "x2", "v1", "v2", "2", "0.5", "1e-3"]),
    lambda inner: st.tuples(inner, st.sampled_from(["+", "-", "*", "/"]), inner).map(lambda t: f"({t[0]}{t[1]}{t[2]})")
    | st.tuples(st.sampled_from(["abs", "sign", "tanh", "-"]), inner).map(lambda t: f"{t[0]}({t[1]})")
    | st.tuples(inner, st.integers(0, 7)).map(lambda t: f"{t[0]}**{t[1]}"),
    max_leaves=8,
)


@given(st.text(max_size=80) | st.lists(st.sampled_from(GRAMMAR), max_size=25).map("".join) | _valid_expr)
def test_expression_parser_gives_expression_or_bayesnsi_error(text):
    expr = _outcome(lambda: parse_expression(text))
    if isinstance(expr, BayesNSIError):
        return
    n_dofs = max(expr.dofs, default=1)
    if n_dofs > 64:
        return  # parsed; the config refuses DOFs that are not measured
    x = np.linspace(-1.0, 1.0, 4 * n_dofs).reshape(n_dofs, 4)
    with np.errstate(all="ignore"):
        assert expr.evaluate(x, x).shape == (4,)
    assert parse_expression(expr.text).canonical == expr.canonical


# ---------------------------------------------------------------------------------------------
# configs

_values = st.recursive(
    _scalars,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=6,
)
_columns = st.sampled_from(["f2", "x1", "x2", "v1", "v2", "a1", "t", "missing", ""])
_dof_map = st.dictionaries(_columns, st.integers(-1, 4) | _values, max_size=3)
_expr = st.lists(st.sampled_from(GRAMMAR), min_size=1, max_size=8).map("".join) | st.text(max_size=10)
_term = st.fixed_dictionaries(
    {"expr": _expr, "at": st.integers(-1, 4) | st.lists(st.integers(0, 4), max_size=3) | _values},
    optional={"prior_scale": _scalars, "bogus": _scalars},
)
_candidate = st.fixed_dictionaries(
    {"name": st.text(max_size=6) | st.sampled_from(["a", "b"]), "terms": st.lists(_term, max_size=2) | _values},
    optional={"prior": _scalars},
)
_data = st.fixed_dictionaries(
    {"file": st.sampled_from(["data.csv", "data.csv", "nope.csv", "", "."]) | st.text(max_size=6)},
    optional={
        "fs": st.sampled_from([100.0, 100, 50.0, 0.0, -1.0, math.nan, math.inf]) | _scalars,
        "inputs": _dof_map, "outputs": _dof_map, "velocities": _dof_map, "accelerations": _dof_map,
        "estimation": st.lists(st.integers(-5, 200), max_size=3) | _values,
        "remove_mean": _scalars, "decimate": st.integers(-1, 200) | _scalars, "time_column": _columns | _scalars,
        "integrate": st.fixed_dictionaries({}, optional={
            "band_hz": st.lists(st.floats(-1, 80), max_size=3) | _values, "method": _scalars, "taper": _scalars,
            "filter_inputs": _scalars, "filter_order": _scalars, "detrend_order": _scalars,
        }) | _values,
    },
)
_nsi = st.fixed_dictionaries({}, optional={
    "block_rows": st.integers(-1, 200) | _scalars, "order": st.integers(-1, 20) | _scalars,
    "band_hz": st.lists(st.floats(-1, 80), max_size=3) | _values, "band": _values,
    "velocity_method": _scalars, "bd_method": _scalars, "max_order": _scalars, "zero_feedthrough": _scalars,
    "input_hold": _scalars, "upsample": st.integers(-1, 4) | _scalars, "refine_poles": _values, "c_method": _scalars,
})
_validation = st.fixed_dictionaries(
    {"name": st.text(max_size=4)},
    optional={
        "start": st.integers(-2, 150) | _scalars,
        "stop": st.integers(-2, 150) | _scalars,
        "file": st.sampled_from(["data.csv", "x.csv"]),
    },
)
_config = st.fixed_dictionaries(
    {"data": _data | _values},
    optional={
        "seed": _scalars, "nsi": _nsi | _values, "candidates": st.lists(_candidate, max_size=3) | _values,
        "validation": st.lists(_validation, max_size=2) | _values,
        "evidence": st.dictionaries(st.text(max_size=5), _values, max_size=3),
        "meta": _values, "extra": _values,
    },
)


def _load_everything(path):
    config = load_config(path)
    signals = load_signals(config)
    segments = load_validation(config)
    return config, signals, segments


_KEYS = {
    "data": ["file", "fs", "inputs", "outputs", "velocities", "accelerations", "estimation", "remove_mean", "decimate",
             "time_column", "integrate"],
    "nsi": ["block_rows", "order", "band_hz", "band", "velocity_method", "bd_method", "max_order", "zero_feedthrough",
            "input_hold", "unknown"],
    "evidence": ["likelihood", "n_steps", "seed", "compare"],
}
_edit_values = (
    _scalars | _dof_map | st.lists(st.integers(-5, 200), max_size=3) | st.lists(st.floats(-1, 80), max_size=3)
    | st.fixed_dictionaries({"band_hz": st.lists(st.floats(0, 60), min_size=2, max_size=2)})
)


@st.composite
def _single_edit(draw):
    """The sane config with one key of one section changed: reaches the checks behind the first one."""
    section = draw(st.sampled_from(["data", "nsi", "evidence", "candidates", "validation", "seed"]))
    if section in _KEYS:
        return _patched({section: {draw(st.sampled_from(_KEYS[section])): draw(_edit_values)}})
    if section == "candidates":
        return _patched({"candidates": draw(st.lists(_candidate, min_size=1, max_size=2))})
    if section == "validation":
        return _patched({"data": {"estimation": [0, 60]}, "validation": draw(st.lists(_validation, max_size=2))})
    return _patched({"seed": draw(_scalars)})


@given(_config | _config.map(_patched) | _single_edit())
def test_config_loader_on_structured_documents(document):
    path = FOLDER / "structured.toml"
    try:
        text = dump_config(document)
    except BayesNSIError:
        return  # not writable as TOML (e.g. an empty key); nothing to load
    path.write_text(text, encoding="utf-8")
    _outcome(lambda: _load_everything(path))


@given(st.binary(max_size=200) | st.text(max_size=200).map(lambda t: t.encode("utf-8", "surrogatepass")))
def test_config_loader_on_arbitrary_bytes(content):
    path = FOLDER / "raw.toml"
    path.write_bytes(content)
    _outcome(lambda: _load_everything(path))


# ---------------------------------------------------------------------------------------------
# CSV files

_cell = (
    st.floats(allow_nan=True, allow_infinity=True).map(repr)
    | st.integers(-10, 10).map(str)
    | st.sampled_from(
        ["", " ", "nan", "NaN", "inf", "-inf", "1e999", "abc", '"1,5"', '"x"', "0x10", "1_000", "—", "\t", '"']
    )
    | st.text(max_size=4)
)
_header = st.lists(
    st.sampled_from(["t", "f2", "x1", "x2", "v1", "v2", "", "1.5", "x1 ", '"x2"', "ü"]) | st.text(max_size=3),
    min_size=0,
    max_size=7,
)


@st.composite
def _csv_text(draw):
    """Mostly well-formed measurement CSVs with a few mutations (cells, header, rows, endings)."""
    header = list(draw(st.permutations(["t", "f2", "x1", "x2", "v1", "v2"])))
    header = header[: draw(st.integers(1, 6))] + draw(st.lists(_header.map(lambda h: h[0] if h else ""), max_size=1))
    n_rows = draw(st.integers(0, 30))
    rng = np.random.default_rng(draw(st.integers(0, 3)))
    rows = [[repr(k / 100.0) if name == "t" else repr(float(rng.normal())) for name in header] for k in range(n_rows)]
    for row, col, cell in draw(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 7), _cell), max_size=3)):
        if row < n_rows and col < len(header):
            rows[row][col] = cell
    if rows and draw(st.booleans()):
        rows[draw(st.integers(0, n_rows - 1))].append(draw(_cell))  # a ragged row
    lines = [",".join(header)]
    if draw(st.booleans()):
        lines.append(",".join(draw(st.sampled_from(["s", "N", "m", "mm", ""])) for _ in header))
    lines += [",".join(row) for row in rows]
    ending = draw(st.sampled_from(["\n", "\r\n", ",\n", ""]))
    return ending.join(lines) + ending


_specs = st.sampled_from([
    DataSpec(file=Path("unused"), fs=100.0, inputs={"f2": 2}, outputs={"x1": 1, "x2": 2}),
    DataSpec(file=Path("unused"), fs=None, inputs={"f2": 2}, outputs={"x1": 1}),
    DataSpec(
        file=Path("unused"), fs=100.0, inputs={"f2": 2}, outputs={"x1": 1, "x2": 2}, velocities={"v1": 1, "v2": 2}
    ),
    DataSpec(file=Path("unused"), fs=100.0, inputs={"f2": 2}, outputs={"x1": 1}, decimate=2),
])


@given(_csv_text() | st.text(max_size=150), _specs)
def test_csv_loader_gives_signals_or_bayesnsi_error(text, spec):
    path = FOLDER / "fuzz.csv"
    path.write_text(text, encoding="utf-8")
    _outcome(lambda: read_csv_columns(path, ["x1", "f2"]))
    signals = _outcome(lambda: read_signals(path, spec))
    if not isinstance(signals, BayesNSIError):
        assert np.all(np.isfinite(signals.displacement)) and signals.displacement.shape[1] == len(spec.outputs)


@given(st.binary(max_size=300))
def test_csv_loader_on_arbitrary_bytes(content):
    path = FOLDER / "fuzz_bytes.csv"
    path.write_bytes(content)
    _outcome(lambda: read_signals(path, DataSpec(file=path, fs=100.0, inputs={"f2": 2}, outputs={"x1": 1})))


# ---------------------------------------------------------------------------------------------
# cache entries: random bytes and mutated valid entries give an outcome, or None with one
# CacheWarning naming the entry - never another exception, never more than 2 s per entry.
# These run 60 examples by default, 10 000 under BAYESNSI_HYPOTHESIS_PROFILE=long.

_cache_settings = settings(max_examples=CACHE_EXAMPLES, deadline=2000)
CACHE_KEY = "a" * 64


@functools.lru_cache(maxsize=1)
def _valid_entry():
    """Bytes, JSON document and arrays of a real entry (NSI result and two evidences)."""
    from bayesnsi import simulate_case
    from bayesnsi.io.cache import ResultCache
    from bayesnsi.options import EvidenceOptions, NSIOptions
    from bayesnsi.run.batch import candidate_task

    case = simulate_case("two-dof", seed=0, duration=5.0)
    evidence = EvidenceOptions(n_walkers=8, n_steps=12, n_burn=2, compare=("white",))
    outcome = candidate_task(case.signals, case.candidates[0], NSIOptions(block_rows=20, order=4), evidence,
                             np.random.SeedSequence(0))
    assert outcome.error is None and outcome.evidences
    cache = ResultCache(FOLDER / "valid-cache")
    cache.store(CACHE_KEY, outcome)
    data = cache.path(CACHE_KEY).read_bytes()
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files if name != "entry.json"}
    return data, json.loads(zipfile.ZipFile(io.BytesIO(data)).read("entry.json")), arrays


def _load_cache_entry(data: bytes, record=event):
    """Load ``data`` as an entry both ways; judge what comes back."""
    from bayesnsi.io._store import EntryError
    from bayesnsi.io.cache import ResultCache, load_entry
    from bayesnsi.run.batch import CandidateOutcome

    folder = FOLDER / "fuzz-cache"
    folder.mkdir(exist_ok=True)
    path = folder / f"{CACHE_KEY}.npz"
    path.write_bytes(data)
    try:
        outcome = load_entry(path, CACHE_KEY)
    except (EntryError, InputDataError) as err:
        assert str(err).strip()
        record(f"refused: {type(err).__name__}: {str(err).replace(path.name, '').strip(' :')[:32]}")
        outcome = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        loaded = ResultCache(folder).load(CACHE_KEY)
    if outcome is None:
        assert loaded is None
        assert [w.category for w in caught] == [CacheWarning] and path.name in str(caught[0].message)
    else:
        record("loaded")
        assert isinstance(outcome, CandidateOutcome) and outcome.cached and not caught
        assert isinstance(loaded, CandidateOutcome) and loaded.candidate == outcome.candidate


_json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=6)
    | st.sampled_from([{"$array": "a0"}, {"$scalar": "a1"}, {"$tuple": []}, {"$complex": [1.0, "x"]},
                       {"$dict": [[1, 2]]}, {"$frame": {}}, {"$array": "a99"}, "x1**3", "sign(v1)", "identification"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
    max_leaves=5,
)
_replacement_arrays = st.sampled_from([
    np.zeros(0), np.zeros((2, 2)), np.arange(3), np.ones(3, dtype=complex), np.float64(1.5), np.zeros((1, 1, 1)),
])


@st.composite
def _mutated_document(draw):
    """The valid entry with a few values replaced or removed somewhere in its JSON or arrays."""
    _, document, arrays = _valid_entry()
    document, arrays = json.loads(json.dumps(document)), dict(arrays)
    for _ in range(draw(st.integers(1, 3))):
        inside = draw(st.integers(0, 9)) > 0 and "outcome" in document  # mostly a value inside the outcome
        parent, key = (document, "outcome") if inside else (None, None)
        node = document["outcome"] if inside else document
        for _ in range(draw(st.integers(0, 12))):
            children = list(node) if isinstance(node, (dict, list)) else []
            children = list(range(len(node))) if isinstance(node, list) else children
            if not children:
                break
            parent, key = node, children[draw(st.integers(0, len(children) - 1))]
            node = parent[key]
        if parent is None:
            continue
        if isinstance(parent, dict) and draw(st.booleans()):
            del parent[key]
        else:
            parent[key] = json.loads(json.dumps(draw(_json_values)))  # a copy: sampled values are shared
    if arrays and draw(st.booleans()):
        arrays[draw(st.sampled_from(sorted(arrays)))] = draw(_replacement_arrays)
    from bayesnsi.io._store import write_container

    buffer = io.BytesIO()
    write_container(buffer, document, arrays)
    return buffer.getvalue()


@st.composite
def _mutated_bytes(draw):
    """The valid entry with a few bytes changed, and maybe truncated."""
    data = bytearray(_valid_entry()[0])
    for position, value in draw(st.lists(st.tuples(st.integers(0, len(data) - 1), st.integers(0, 255)), max_size=6)):
        data[position] = value
    return bytes(data[: draw(st.integers(0, len(data)))] if draw(st.booleans()) else data)


@_cache_settings
@given(st.binary(max_size=400) | _mutated_bytes())
def test_cache_reader_on_arbitrary_and_mutated_bytes(data):
    _load_cache_entry(data)


@_cache_settings
@given(_mutated_document())
def test_cache_reader_on_mutated_entries(data):
    _load_cache_entry(data)


def test_cache_reader_accepts_the_unmutated_entry():
    _load_cache_entry(_valid_entry()[0], record=print)
