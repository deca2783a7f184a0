"""Nothing lost, reproducible, scale-out: kill/resume, crashing candidates, cache, Dask."""

import dataclasses
import json
import os
import pickle
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from bayesnsi.cli import main
from bayesnsi.exceptions import CacheWarning
from bayesnsi.io.cache import CACHE_DIRNAME, ENTRY_SUFFIX, ResultCache, load_entry
from bayesnsi.options import EvidenceOptions, ExecutionOptions
from tests._helpers.experiments import EXTRA_CANDIDATES, default_signals

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    """Two-DOF case, 20 s record, the paper's 3 candidates + 3 more, short MCMC: ~1 s per candidate."""
    folder = tmp_path_factory.mktemp("reliability")
    csv = folder / "two_dof.csv"
    assert main(["simulate", "two-dof", "--seed", "1", "--duration", "20", "--out", str(csv), "--quiet"]) == 0
    path = csv.with_suffix(".toml")
    path.write_text(path.read_text() + EXTRA_CANDIDATES)
    return path


def _numbers(out):
    results = json.loads((out / "results.json").read_text())
    return [
        (
            c["name"], c["status"], c.get("log_evidence"), c.get("posterior"),
            [k["value"] for k in c["coefficients"]], c["nrmse"],
        )
        for c in results["candidates"]
    ]


def _entries(out):
    folder = out / CACHE_DIRNAME
    return {p.name: p.stat().st_mtime_ns for p in folder.glob(f"*{ENTRY_SUFFIX}")} if folder.is_dir() else {}


def _start_select(config, out):
    command = [sys.executable, "-m", "bayesnsi.cli", "select", str(config), "--out", str(out), "--no-figures"]
    return subprocess.Popen(command, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_signals)


def _wait_for_first_entry(process, out, timeout=180.0):
    start = time.monotonic()
    while not _entries(out):
        if process.poll() is not None:
            pytest.fail(f"select ended before caching a candidate: {process.communicate()[1][-2000:]}")
        if time.monotonic() - start > timeout:
            process.kill()
            pytest.fail("no candidate was cached in time")
        time.sleep(0.05)


def test_killed_select_resumes_without_recomputing(config, tmp_path, capsys):
    out = tmp_path / "killed"
    process = _start_select(config, out)
    _wait_for_first_entry(process, out)
    process.send_signal(signal.SIGKILL)
    process.communicate()
    assert process.returncode == -signal.SIGKILL
    # no results.json, complete or partial, and no temporary file of one
    assert not any("results" in p.name for p in out.iterdir()), sorted(p.name for p in out.iterdir())
    finished = _entries(out)
    assert 1 <= len(finished) < 6
    for name in finished:
        outcome = load_entry(out / CACHE_DIRNAME / name, name[: -len(ENTRY_SUFFIX)])
        assert outcome.status == "ok" and outcome.result is not None and outcome.evidences

    # rerun into the same folder: no --force needed (no results.json), finished ones are reused
    assert main(["select", str(config), "--out", str(out), "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert err.count("(cached)") == len(finished), err
    assert {k: v for k, v in _entries(out).items() if k in finished} == finished  # not rewritten
    assert len(_entries(out)) == 6
    records = json.loads((out / "results.json").read_text())["candidates"]
    assert sum(r["cached"] for r in records) == len(finished)

    # the same numbers as a clean, uninterrupted run
    clean = tmp_path / "clean"
    assert main(["select", str(config), "--out", str(clean), "--no-figures", "--quiet", "--no-cache"]) == 0
    assert _numbers(out) == _numbers(clean)

    # results.json present: a rerun needs --force; with it every candidate comes from the cache
    assert main(["select", str(config), "--out", str(out), "--no-figures", "--quiet"]) == 2
    assert main(["select", str(config), "--out", str(out), "--no-figures", "--force"]) == 0
    assert capsys.readouterr().err.count("(cached)") == 6
    assert _numbers(out) == _numbers(clean)


def test_sigint_stops_cleanly_and_keeps_finished_candidates(config, tmp_path):
    out = tmp_path / "interrupted"
    process = _start_select(config, out)
    _wait_for_first_entry(process, out)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert not (out / "results.json").exists()
    assert _entries(out)


def test_crashing_candidate_is_recorded_and_others_kept(config, tmp_path, monkeypatch, capsys):
    from bayesnsi.run import batch

    real = batch.identify

    def crash_on_cubic(signals, candidate, options=None, **keywords):
        if candidate.name == "cubic 1":
            raise RuntimeError("simulated bug")
        return real(signals, candidate, options, **keywords)

    monkeypatch.setattr(batch, "identify", crash_on_cubic)
    out = tmp_path / "crash"
    assert main(["identify", str(config), "--out", str(out), "--no-figures", "--quiet"]) == 0
    records = {r["name"]: r for r in json.loads((out / "results.json").read_text())["candidates"]}
    crashed = records.pop("cubic 1")
    assert crashed["status"] == "failed" and crashed["internal_error"]
    assert crashed["error"] == "internal error: RuntimeError: simulated bug"
    assert "Traceback" in crashed["traceback"] and "crash_on_cubic" in crashed["traceback"]
    assert all(r["status"] == "ok" for r in records.values())
    assert len(_entries(out)) == 5  # the crash is not cached: a rerun tries again

    monkeypatch.setattr(batch, "identify", real)
    capsys.readouterr()
    assert main(["identify", str(config), "--out", str(out), "--no-figures", "--force"]) == 0
    err = capsys.readouterr().err
    assert err.count("(cached)") == 5 and "cubic 1: order" in err
    assert json.loads((out / "results.json").read_text())["candidates"][4]["status"] == "ok"


def test_corrupt_or_foreign_cache_entries_are_recomputed(config, tmp_path):
    out = tmp_path / "corrupt"
    assert main(["identify", str(config), "--out", str(out), "--no-figures", "--quiet"]) == 0
    names = sorted(_entries(out))
    first, second = (out / CACHE_DIRNAME / n for n in names[:2])
    first.write_bytes(first.read_bytes()[:1000])  # truncated, as by a full disk

    class Exploit:
        def __reduce__(self):
            return (os.system, ("touch " + str(tmp_path / "pwned"),))

    second.write_bytes(pickle.dumps({"format": 1, "key": second.stem, "outcome": Exploit()}))
    before = _numbers(out)
    with pytest.warns(CacheWarning) as caught:
        assert main(["identify", str(config), "--out", str(out), "--no-figures", "--quiet", "--force"]) == 0
    messages = " ".join(str(w.message) for w in caught)
    assert f"{second.name} (EntryError: {second.name} is not an entry archive" in messages
    assert f"{first.name} (EntryError" in messages and "recomputed" in messages
    assert not (tmp_path / "pwned").exists()
    assert _numbers(out) == before
    load_entry(first, first.stem)  # rewritten, valid again


def test_cache_key_covers_data_settings_seed_and_candidate(config):
    from bayesnsi._fingerprint import signals_fingerprint
    from bayesnsi.io import load_config, load_signals
    from bayesnsi.io.cache import candidate_key
    from bayesnsi.options import EvidenceOptions, NSIOptions

    cfg = load_config(config)
    signals = load_signals(cfg)
    seeds = np.random.SeedSequence(1).spawn(2)
    data = signals_fingerprint(signals)
    nsi = NSIOptions(order=4)
    base = candidate_key(data, cfg.candidates[0], nsi, None, seeds[0])
    copy, shifted = signals.segment(0, signals.n_samples), signals.segment(1, signals.n_samples)
    assert base == candidate_key(signals_fingerprint(copy), cfg.candidates[0], nsi, None, seeds[0])
    assert base == ResultCache("unused").key(signals, cfg.candidates[0], nsi, None, seeds[0])
    variants = [
        candidate_key(signals_fingerprint(shifted), cfg.candidates[0], nsi, None, seeds[0]),
        candidate_key(data, cfg.candidates[1], nsi, None, seeds[0]),
        candidate_key(data, cfg.candidates[0], NSIOptions(order=6), None, seeds[0]),
        candidate_key(data, cfg.candidates[0], nsi, EvidenceOptions(n_steps=10, n_burn=0), seeds[0]),
        candidate_key(data, cfg.candidates[0], nsi, None, seeds[1]),
    ]
    assert len({base, *variants}) == 6


def test_result_cache_round_trip_and_read_switch(tmp_path):
    from bayesnsi.models import CandidateModel
    from bayesnsi.run.batch import CandidateOutcome

    cache = ResultCache(tmp_path / "c")
    key = "0" * 64
    assert cache.load(key) is None and cache.keys() == []
    outcome = CandidateOutcome(CandidateModel("m", ()), error="OrderError: x", failed_stage="identification")
    cache.store(key, outcome)
    assert cache.load(key) == dataclasses.replace(outcome, cached=True) and cache.keys() == [key]
    assert ResultCache(tmp_path / "c", read=False).load(key) is None
    with pytest.raises(ValueError, match="64 lower-case hex"):
        cache.path("../../etc/passwd")
    assert not list((tmp_path / "c").glob(".*tmp"))


# ---------------------------------------------------------------------------------------------
# reproducibility and scale-out: serial, joblib and Dask give the same numbers


def _digest(outcomes):
    return [
        (o.name, o.status, o.nrmse, None if o.result is None else [c.value for c in o.result.coefficients],
         None if o.evidences is None else {k: e.log_evidence for k, e in o.evidences.items()})
        for o in outcomes
    ]


@pytest.fixture(scope="module")
def sweep(config):
    from bayesnsi.io import load_config, load_signals
    from bayesnsi.run import dictionary_candidates

    cfg = load_config(config)
    candidates = dictionary_candidates([1, 2], types=["x^3", "v|v|", "sign(v)"], max_terms=1)
    return load_signals(cfg), candidates, cfg.nsi


def test_dictionary_sweep_identical_serial_joblib_and_dask(sweep, config, tmp_path):
    from dask.distributed import LocalCluster

    from bayesnsi.run import run_candidates, run_datasets

    signals, candidates, options = sweep
    assert len(candidates) == 10 and candidates[0].name == "linear"
    evidence = EvidenceOptions(likelihood="white", compare=(), n_walkers=8, n_steps=60, n_burn=20, seed=5)
    few = candidates[:4]
    serial = run_candidates(signals, candidates, options)
    serial_evidence = run_candidates(signals, few, options, evidence)
    seen = []
    local = run_candidates(
        signals, candidates, options, execution=ExecutionOptions(jobs=2, progress=lambda k, o: seen.append(k))
    )
    assert sorted(seen) == list(range(len(candidates)))
    assert _digest(local) == _digest(serial)
    cluster_settings = dict(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None)
    with LocalCluster(**cluster_settings) as cluster:
        address = cluster.scheduler_address
        on_cluster = ExecutionOptions(scheduler=address)
        assert _digest(run_candidates(signals, candidates, options, execution=on_cluster)) == _digest(serial)
        on_cluster_evidence = run_candidates(signals, few, options, evidence, execution=on_cluster)
        assert _digest(on_cluster_evidence) == _digest(serial_evidence)
        # many datasets: each gives the numbers it gives alone
        half = signals.segment(0, signals.n_samples // 2)
        batch = run_datasets([signals, half], few, options, execution=on_cluster)
        assert _digest(batch[0]) == _digest(serial[:4])
        assert _digest(batch[1]) == _digest(run_candidates(half, few, options))
        # the command line through the same cluster
        out = tmp_path / "dask"
        argv = ["identify", str(config), "--out", str(out), "--no-figures", "--quiet", "--scheduler", address]
        assert main(argv) == 0
    reference = tmp_path / "serial"
    assert main(["identify", str(config), "--out", str(reference), "--no-figures", "--quiet"]) == 0
    assert _numbers(out) == _numbers(reference)


def test_ctrl_c_during_sampling_is_raised_after_the_emcee_run():
    # emcee prints a traceback for any exception inside the log-probability function: a Ctrl-C
    # is held until the run ends, then raised as KeyboardInterrupt (no emcee traceback)
    import os

    from bayesnsi._interrupt import interrupt_after

    # Python's own handler, as in a terminal (a shell's background job starts with SIGINT ignored,
    # which interrupt_after leaves alone)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    reached_end = False
    try:
        with pytest.raises(KeyboardInterrupt):
            with interrupt_after():
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.05)  # a pending signal would be delivered here
                reached_end = True
        assert reached_end
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)
