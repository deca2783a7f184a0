"""Result cache under hostile input: entries cannot run code, touch the disk or
allocate beyond the limit; anything not valid is recomputed with a CacheWarning; a cached
outcome is identical to a fresh one."""

import dataclasses
import io
import json
import os
import pickle
import tracemalloc
import warnings
import zipfile

import numpy as np
import pandas as pd
import pytest

from bayesnsi import simulate_case
from bayesnsi.exceptions import CacheWarning, InputDataError
from bayesnsi.findings import Finding
from bayesnsi.io._outcome import schema_fields
from bayesnsi.io._store import MAX_JSON_BYTES, EntryError, write_container
from bayesnsi.io.cache import CACHE_FORMAT, ResultCache, load_entry
from bayesnsi.models import CandidateModel
from bayesnsi.options import EvidenceOptions, ExecutionOptions, NSIOptions
from bayesnsi.run.batch import CandidateOutcome, candidate_seeds, candidate_task, run_candidates

NSI = NSIOptions(block_rows=40, order=4)
EVIDENCE = EvidenceOptions(n_walkers=8, n_steps=40, n_burn=10, compare=("white",))


@pytest.fixture(scope="module")
def case():
    return simulate_case("two-dof", seed=0, duration=10.0)


@pytest.fixture(scope="module")
def fresh(case):
    """Outcomes computed without a cache (the reference numbers)."""
    return run_candidates(case.signals, case.candidates, NSI, EVIDENCE)


def _same(a, b, where="outcome", times=True):
    """Deep equality: arrays bit for bit (same dtype and shape), floats by repr, frames exactly.

    ``times=False`` skips wall times (``seconds``, ``time_*`` settings): for two computations.
    """
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for item in dataclasses.fields(a):
            if item.name != "cached" and not callable(getattr(a, item.name)):  # (compiled expressions)
                if times or item.name != "seconds":
                    _same(getattr(a, item.name), getattr(b, item.name), f"{where}.{item.name}", times)
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, where
        assert a.tobytes() == b.tobytes(), where
    elif isinstance(a, pd.DataFrame):
        pd.testing.assert_frame_equal(a, b, check_exact=True)
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for k in a:
            if times or not str(k).startswith("time_"):
                _same(a[k], b[k], f"{where}[{k!r}]", times)
    elif isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{k}]", times)
    elif isinstance(a, (float, complex, np.floating)):
        assert type(a) is type(b) and repr(a) == repr(b), where
    else:
        assert type(a) is type(b) and a == b, where


def _cached_run(case, folder, expect_warnings=0):
    cache = ResultCache(folder)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcomes = run_candidates(case.signals, case.candidates, NSI, EVIDENCE, execution=ExecutionOptions(cache=cache))
    cache_warnings = [w for w in caught if issubclass(w.category, CacheWarning)]
    assert len(cache_warnings) >= expect_warnings, [str(w.message) for w in caught]
    return outcomes, " | ".join(str(w.message) for w in cache_warnings)


def _keys(case, cache):
    seeds = candidate_seeds(EVIDENCE.seed, len(case.candidates))
    return [cache.key(case.signals, c, NSI, EVIDENCE, s) for c, s in zip(case.candidates, seeds)]


def _entry_bytes(document, arrays=None):
    buffer = io.BytesIO()
    write_container(buffer, document, arrays or {})
    return buffer.getvalue()


# ---------------------------------------------------------------------------------------------
# exact round trip


def test_cached_outcome_is_identical_to_the_fresh_one(case, fresh, tmp_path):
    first, _ = _cached_run(case, tmp_path / "c")
    second, messages = _cached_run(case, tmp_path / "c")
    assert messages == ""
    assert [o.cached for o in first] == [False] * 3 and [o.cached for o in second] == [True] * 3
    assert all(o.evidences for o in second)
    assert all(o.whiteness is not None for o in second)  # the Ljung-Box test travels with the evidence
    for a, b in zip(first, second):
        _same(a, b)  # bit for bit, wall times included
    for a, b in zip(fresh, second):
        _same(a, b, times=False)  # the same numbers as a run without a cache


def test_failed_outcomes_round_trip(case, tmp_path):
    candidate = case.candidates[0]
    cache = ResultCache(tmp_path)
    for k, outcome in enumerate([
        CandidateOutcome(candidate, error="OrderError: no order", failed_stage="identification",
                         findings=(Finding("warning.OrderWarning", "w"),),
                         seconds=0.25),
        CandidateOutcome(candidate, nrmse=float("nan"), nrmse_per_channel=(float("inf"), -0.0), seconds=1e-300,
                         error="InputDataError: é\n\u2028", failed_stage="identification"),
    ]):
        cache.store(f"{k:064x}", outcome)
        _same(outcome, cache.load(f"{k:064x}"))


def test_schema_stores_every_field_of_the_result_classes():
    from bayesnsi.evidence.marginal import EvidenceResult
    from bayesnsi.nsi import NSIResult

    covered = schema_fields()
    for cls in (CandidateOutcome, NSIResult, EvidenceResult, CandidateModel):
        assert covered[cls.__name__] == {f.name for f in dataclasses.fields(cls)}, cls.__name__


# ---------------------------------------------------------------------------------------------
# planted entries: no code, no disk writes, no large allocations


class _Planted:
    def __init__(self, function, *args):
        self.call = (function, args)

    def __reduce__(self):
        return self.call


def test_planted_memmap_entry_cannot_touch_the_disk(case, fresh, tmp_path):
    victim = tmp_path / "victim.bin"
    victim.write_bytes(b"\x07" * 20_000)
    folder = tmp_path / "c"
    folder.mkdir()
    keys = _keys(case, ResultCache(folder))
    planted = _Planted(np.memmap, str(victim), "uint8", "w+", 0, (1,))
    payload = pickle.dumps({"format": 1, "key": keys[0], "outcome": planted})
    (folder / f"{keys[0]}.npz").write_bytes(payload)
    (folder / f"{keys[1]}.pkl").write_bytes(payload)
    before = sorted(p.name for p in tmp_path.iterdir())
    outcomes, messages = _cached_run(case, folder, expect_warnings=2)
    assert victim.stat().st_size == 20_000 and victim.read_bytes() == b"\x07" * 20_000
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert f"{keys[0]}.npz" in messages and f"{keys[1]}.pkl" in messages and "recomputed" in messages
    for a, b in zip(fresh, outcomes):
        _same(a, b, times=False)


@pytest.mark.parametrize("outcome", [
    {"$reduce": ["os", "system", ["touch PWNED"]]},
    {"py/object": "os.system", "args": ["touch PWNED"]},
    {"candidate": {"$class": "bayesnsi.run.batch.ResultCache"}},
])
def test_entry_naming_a_class_or_function_is_refused(tmp_path, outcome):
    cache = ResultCache(tmp_path)
    key = "c" * 64
    cache.path(key).write_bytes(_entry_bytes({"format": CACHE_FORMAT, "key": key, "outcome": outcome}))
    with pytest.warns(CacheWarning, match=f"{key}.npz"):
        assert cache.load(key) is None
    assert not list(tmp_path.rglob("PWNED"))


def _huge_header_entry(dtype, shape):
    """A valid entry whose array member's header claims ``shape`` but holds 8 bytes of data."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": dtype, "fortran_order": False, "shape": shape})
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        document = {"format": CACHE_FORMAT, "key": "d" * 64, "outcome": {"$array": "a0"}}
        archive.writestr("entry.json", json.dumps(document))
        archive.writestr("a0.npy", header.getvalue() + b"\0" * 8)
    return buffer.getvalue()


@pytest.mark.parametrize("dtype, shape, message", [
    ("<f8", (375_000_000,), "claims 3000000000 bytes"),   # 3 GB of float64
    ("|u1", (3 * 10**9,), "dtype uint8"),                 # bytearray(3*10**9)-like
    ("|O", (3,), "dtype object"),
    ("<f8", (10**12, 10**12), "claims"),
])
def test_array_header_claiming_a_huge_array_is_refused_without_allocating(tmp_path, dtype, shape, message):
    path = tmp_path / f"{'d' * 64}.npz"
    path.write_bytes(_huge_header_entry(dtype, shape))
    tracemalloc.start()
    with pytest.raises(EntryError, match=message):
        load_entry(path, "d" * 64)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 2**20


def test_file_above_the_memory_limit_is_not_read(tmp_path, monkeypatch):
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "1M")
    cache = ResultCache(tmp_path)
    key = "e" * 64
    cache.path(key).write_bytes(b"\0" * (3 * 2**20))
    tracemalloc.start()
    with pytest.warns(CacheWarning, match=f"{key}.npz.*above the limit of 1048576 bytes"):
        assert cache.load(key) is None
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 2**20


def test_large_or_deeply_nested_json_is_refused(tmp_path):
    key = "f" * 64
    path = tmp_path / f"{key}.npz"
    path.write_bytes(_entry_bytes({"format": CACHE_FORMAT, "key": key, "outcome": "x" * (MAX_JSON_BYTES + 1)}))
    with pytest.raises(EntryError, match="entry.json"):
        load_entry(path, key)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        nested = "[" * 10**5 + "]" * 10**5
        archive.writestr("entry.json", f'{{"format": {CACHE_FORMAT}, "key": "{key}", "outcome": {nested}}}')
    path.write_bytes(buffer.getvalue())
    with pytest.raises(EntryError, match="nested deeper"):
        load_entry(path, key)


# ---------------------------------------------------------------------------------------------
# wrong content, wrong key, symbolic links: recomputed, never a crash


@pytest.mark.parametrize("outcome", [
    42,
    {"$tuple": [{}, None, None]},
    None,
    {"candidate": {"name": "model 1", "terms": [], "prior": 1.0, "coefficient_prior_scales": []}},
])
def test_well_formed_entry_with_wrong_content_is_recomputed(case, fresh, tmp_path, outcome):
    folder = tmp_path / "c"
    folder.mkdir()
    keys = _keys(case, ResultCache(folder))
    for key in keys:
        (folder / f"{key}.npz").write_bytes(_entry_bytes({"format": CACHE_FORMAT, "key": key, "outcome": outcome}))
    outcomes, messages = _cached_run(case, folder, expect_warnings=3)
    assert all(f"{key}.npz" in messages for key in keys)
    assert [o.cached for o in outcomes] == [False] * 3
    for a, b in zip(fresh, outcomes):
        _same(a, b, times=False)
    assert all(load_entry(folder / f"{key}.npz", key).cached for key in keys)  # rewritten, valid


def test_entry_of_another_key_or_candidate_is_recomputed(case, fresh, tmp_path):
    folder = tmp_path / "c"
    _cached_run(case, folder)
    keys = _keys(case, ResultCache(folder))
    entries = [(folder / f"{key}.npz").read_bytes() for key in keys]
    (folder / f"{keys[0]}.npz").write_bytes(entries[1])  # another key inside
    document = json.loads(zipfile.ZipFile(io.BytesIO(entries[2])).read("entry.json"))
    document["key"] = keys[1]  # candidate 2's outcome, relabelled with candidate 1's key
    with np.load(io.BytesIO(entries[2]), allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files if name != "entry.json"}
    (folder / f"{keys[1]}.npz").write_bytes(_entry_bytes(document, arrays))
    outcomes, messages = _cached_run(case, folder, expect_warnings=2)
    assert "is stored for key" in messages and "holds candidate 'model 3', not 'model 2'" in messages
    assert [o.cached for o in outcomes] == [False, False, True]
    for a, b in zip(fresh, outcomes):
        _same(a, b, times=False)


@pytest.mark.parametrize("edit, message", [
    (lambda doc, arrays: arrays.__setitem__(doc["outcome"]["result"]["model"]["A"]["$array"], np.eye(3)),
     "inconsistent NSIResult: state-space shapes"),
    (lambda doc, arrays: doc["outcome"]["result"]["coefficients"].clear(), "inconsistent NSIResult: 0 coefficients"),
    (lambda doc, arrays: doc["outcome"].__setitem__("error", "X: y"), "an error without a failed stage"),
    (lambda doc, arrays: doc["outcome"]["result"]["candidate"].__setitem__("name", "other"), "another candidate"),
])
def test_entry_with_inconsistent_values_is_recomputed(case, fresh, tmp_path, edit, message):
    """Types right, values that do not fit together: refused before anything downstream uses them."""
    cache = ResultCache(tmp_path)
    key = _keys(case, cache)[0]
    cache.store(key, fresh[0])
    data = cache.path(key).read_bytes()
    document = json.loads(zipfile.ZipFile(io.BytesIO(data)).read("entry.json"))
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        arrays = {name: npz[name] for name in npz.files if name != "entry.json"}
    edit(document, arrays)
    cache.path(key).write_bytes(_entry_bytes(document, arrays))
    with pytest.warns(CacheWarning, match=message):
        assert cache.load(key) is None


def test_symbolic_links_are_never_followed(case, fresh, tmp_path):
    valid = tmp_path / "valid"
    _cached_run(case, valid)
    keys = _keys(case, ResultCache(valid))
    outside = tmp_path / "outside.npz"
    outside.write_bytes((valid / f"{keys[0]}.npz").read_bytes())
    folder = tmp_path / "c"
    folder.mkdir()
    (folder / f"{keys[0]}.npz").symlink_to(outside)
    with pytest.warns(CacheWarning, match="symbolic link"):
        assert ResultCache(folder).load(keys[0]) is None
    ResultCache(folder).store(keys[0], fresh[0])  # replaces the link, never writes through it
    assert not (folder / f"{keys[0]}.npz").is_symlink()
    assert outside.read_bytes() == (valid / f"{keys[0]}.npz").read_bytes()
    linked = tmp_path / "linked"
    linked.symlink_to(valid)
    with pytest.warns(CacheWarning, match="is a symbolic link; it is not used"):
        assert ResultCache(linked).load(keys[0]) is None


def test_store_is_atomic_and_an_unstorable_outcome_only_warns(case, tmp_path):
    cache = ResultCache(tmp_path)
    bad = CandidateOutcome(case.candidates[0], nrmse_per_channel=(object(),))
    with pytest.warns(CacheWarning, match="not cached"):
        cache.store("1" * 64, bad)
    assert list(tmp_path.iterdir()) == []
    cache.store("1" * 64, CandidateOutcome(case.candidates[0], seconds=1.0))
    assert [p.name for p in tmp_path.iterdir()] == ["1" * 64 + ".npz"]
    assert ResultCache(tmp_path, read=False).load("1" * 64) is None
    with pytest.raises(ValueError, match="64 lower-case hex"):
        cache.path("../../etc/passwd")


def test_memory_limit_setting_is_checked(monkeypatch):
    from bayesnsi._limits import DEFAULT_MAX_MEMORY, check_allocation, max_memory_bytes

    monkeypatch.delenv("BAYESNSI_MAX_MEMORY", raising=False)
    assert max_memory_bytes() == DEFAULT_MAX_MEMORY
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "2g")
    assert max_memory_bytes() == 2 * 2**30
    check_allocation(2 * 2**30, "x")
    with pytest.raises(InputDataError, match="cache entry z needs"):
        check_allocation(2 * 2**30 + 1, "cache entry z")
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "lots")
    with pytest.raises(InputDataError, match="BAYESNSI_MAX_MEMORY must be a positive number"):
        max_memory_bytes()


def test_candidate_task_outcome_stores_and_loads(case, tmp_path):
    """A single candidate_task outcome (no batch) round trips too."""
    seeds = candidate_seeds(0, 3)
    outcome = candidate_task(case.signals, case.candidates[1], NSI, EVIDENCE, seeds[1])
    cache = ResultCache(tmp_path)
    key = cache.key(case.signals, case.candidates[1], NSI, EVIDENCE, seeds[1])
    cache.store(key, outcome)
    _same(outcome, cache.load(key))
    assert os.path.getsize(cache.path(key)) < 2**20
