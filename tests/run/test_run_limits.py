"""Limits that bound what a run holds: workers per task and memory, sampler chains, orphans, all-failed runs."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from bayesnsi._dispatch import WORKER_BYTES, dispatch, shutdown_workers, worker_count
from bayesnsi.cli import main
from bayesnsi.evidence import chain_bytes, check_chain_memory
from bayesnsi.exceptions import InputDataError

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
CLI = [sys.executable, "-m", "bayesnsi.cli"]
LINUX = sys.platform.startswith("linux")


def _children(pid: int) -> set[int]:
    """Pids of the live (not zombie) descendants of ``pid``, from /proc."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[0] != "Z":
            parents[int(entry.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def _alive(pids: set[int]) -> set[int]:
    alive = set()
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.add(pid)
    return alive


def _pid_task(context, k):
    return os.getpid()


# ---------------------------------------------------------------- workers


def test_workers_are_capped_by_tasks_and_by_memory(monkeypatch):
    assert worker_count(256, 3) == 3
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "1G")
    assert worker_count(256, 100) == 2**30 // WORKER_BYTES
    assert worker_count(256, 100, task_bytes=2**30) == 1  # one task at a time when one fills the limit


@pytest.mark.skipif(not LINUX, reason="counts processes in /proc")
def test_jobs_256_with_three_tasks_starts_at_most_three_workers():
    try:
        pids = {value for _, value in dispatch(_pid_task, [(k,) for k in range(3)], jobs=256)}
        workers = {p for p in _children(os.getpid()) if "loky" in Path(f"/proc/{p}/cmdline").read_text(errors="replace")
                   and "resource_tracker" not in Path(f"/proc/{p}/cmdline").read_text(errors="replace")}
    finally:
        shutdown_workers()
    assert len(pids) <= 3 and 1 <= len(workers) <= 3


_ORPHAN_SCRIPT = textwrap.dedent("""
    import time
    from bayesnsi._dispatch import dispatch

    def task(context, k):
        time.sleep(300)
        return k

    if __name__ == "__main__":
        for _ in dispatch(task, [(0,), (1,)], jobs=2):
            pass
""")


@pytest.mark.skipif(not LINUX, reason="counts processes in /proc")
def test_kill_9_of_the_parent_leaves_no_worker_after_10_s(tmp_path):
    script = tmp_path / "orphans.py"
    script.write_text(_ORPHAN_SCRIPT)
    parent = subprocess.Popen([sys.executable, str(script)], env={**ENV, "PYTHONPATH": os.pathsep.join(sys.path)})
    try:
        deadline = time.monotonic() + 120
        while len(_children(parent.pid)) < 3:  # two workers and loky's resource tracker
            assert parent.poll() is None and time.monotonic() < deadline, "the pool did not start"
            time.sleep(0.2)
        time.sleep(1.0)  # the workers are inside their tasks
        spawned = _children(parent.pid)
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 10.0
    while _alive(spawned) and time.monotonic() < deadline:
        time.sleep(0.2)
    left = _alive(spawned)
    for pid in left:  # do not leave them to the next test
        os.kill(pid, signal.SIGKILL)
    assert not left, f"{len(left)} of {len(spawned)} worker processes outlived their parent by 10 s"


# ---------------------------------------------------------------- sampler chains


def test_chain_memory_is_estimated_before_allocation(monkeypatch):
    monkeypatch.delenv("BAYESNSI_MAX_MEMORY", raising=False)
    assert chain_bytes(32, 1500, 4) == 8 * 1500 * 32 * 14
    check_chain_memory(32, 1500, 4)  # the defaults fit
    with pytest.raises(InputDataError, match="n_walkers = 10000 x n_steps = 30000"):
        check_chain_memory(10_000, 30_000, 2)
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "1M")
    with pytest.raises(InputDataError, match="BAYESNSI_MAX_MEMORY"):
        check_chain_memory(32, 1500, 4)


def _address_space(n_bytes: int):
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (n_bytes, n_bytes))

    return limit


@pytest.mark.parametrize("evidence", ["n_walkers = 10000\nn_steps = 30000\nn_burn = 100",
                                      "n_steps = 10000000\nn_burn = 100"])
def test_sampler_settings_within_their_limits_but_too_large_together_are_refused_at_once(
    tmp_path, select_config, evidence
):
    config = tmp_path / "big.toml"
    config.write_text(select_config.read_text().replace("n_steps = 400\nn_burn = 100", evidence)
                      .replace('file = "two_dof.csv"', f'file = "{select_config.parent / "two_dof.csv"}"'))
    command = [*CLI, "select", str(config), "--out", str(tmp_path / "out"), "--quiet", "--no-figures"]
    start = time.monotonic()
    done = subprocess.run(command, env=ENV, capture_output=True, text=True, timeout=120,
                          preexec_fn=_address_space(3 * 2**30))
    assert done.returncode == 2, done.stderr[-2000:]
    assert "n_walkers" in done.stderr and "BAYESNSI_MAX_MEMORY" in done.stderr
    assert time.monotonic() - start < 60


def test_a_run_in_which_every_candidate_failed_exits_2_with_a_summary(tmp_path, select_config, capsys,
                                                                      monkeypatch):
    import bayesnsi.evidence

    def out_of_memory(*args, **kwargs):
        raise InputDataError("the sampler needs more memory than the machine has")

    monkeypatch.setattr(bayesnsi.evidence, "candidate_evidence", out_of_memory)
    assert main(["select", str(select_config), "--out", str(tmp_path / "out"), "--quiet", "--no-figures"]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "every candidate failed (1 of 1)" in line and "model 1: evidence" in line and "more memory" in line
    assert (tmp_path / "out" / "results.json").exists()


# ---------------------------------------------------------------- identification settings


def test_block_rows_and_upsample_are_estimated_against_the_limit(monkeypatch):
    from bayesnsi import CandidateModel, identify
    from bayesnsi.options import NSIOptions
    from bayesnsi.simulate import simulate_case

    signals = simulate_case("two-dof", seed=0, duration=10.0).signals  # 1000 samples; the cubic adds a 4th channel
    cubic = CandidateModel.from_terms("cubic", [("x1**3", 1)])
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "10M")
    start = time.monotonic()
    with pytest.raises(InputDataError, match="Hankel Gram matrix of block_rows = 100"):
        identify(signals, cubic, NSIOptions(block_rows=100, order=4))
    with pytest.raises(InputDataError, match="explicit Hankel matrix of block_rows = 100"):
        identify(signals, cubic, NSIOptions(block_rows=100, order=4, route="lq"))
    monkeypatch.setenv("BAYESNSI_MAX_MEMORY", "4M")
    with pytest.raises(InputDataError, match=r"\[nsi\] upsample = 64"):
        identify(signals, cubic, NSIOptions(block_rows=20, order=4, upsample=64))
    assert time.monotonic() - start < 10.0
    monkeypatch.delenv("BAYESNSI_MAX_MEMORY")
    assert identify(signals, cubic, NSIOptions(block_rows=40, order=4)).order == 4  # the defaults fit
