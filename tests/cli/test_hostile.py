"""Hostile input: output folders, locks, schedulers that hang, signals, exit codes."""

import errno
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from bayesnsi.cli import main
from bayesnsi.exceptions import OutputExistsError
from bayesnsi.io.results import output_folder
from tests._helpers.experiments import EXTRA_CANDIDATES, default_signals
from tests._helpers.experiments import experiment_config as _experiment

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
CLI = [sys.executable, "-m", "bayesnsi.cli"]


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ---------------------------------------------------------------- output folder and its lock


def test_a_users_report_is_not_overwritten_without_force(tmp_path, capsys):
    config = _experiment(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("my own report")
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "report.html" in line and "--force" in line
    assert (out / "report.html").read_text() == "my own report"
    assert not (out / "results.json").exists()


def test_cache_that_is_a_file_or_a_parent_that_is_a_file_is_refused(tmp_path, capsys):
    config = _experiment(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / ".cache").write_text("not a folder")
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 2
    assert ".cache is a file" in _one_line(capsys.readouterr().err)
    assert main(["identify", str(config), "--out", str(tmp_path / "data.csv" / "sub"), "--quiet"]) == 2
    assert "is a file, not a directory" in _one_line(capsys.readouterr().err)


def _holder(out: Path) -> subprocess.Popen:
    """Another process holding the lock of ``out`` until its stdin closes."""
    code = (
        "import sys; from bayesnsi.io.results import output_folder\n"
        f"with output_folder({str(out)!r}, config='other.toml'):\n"
        "    print('held', flush=True); sys.stdin.read()\n"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=ENV
    )
    assert process.stdout.readline().strip() == "held"
    return process


def test_output_folder_is_locked_against_a_second_run_and_released(tmp_path):
    out = tmp_path / "out"
    holder = _holder(out)
    try:
        expected = rf"is in use by another bayesnsi run \(pid {holder.pid}, config other.toml"
        with pytest.raises(OutputExistsError, match=expected):
            with output_folder(out):
                pass
    finally:
        holder.communicate("")
    assert holder.returncode == 0 and not (out / ".bayesnsi.lock").exists()
    with output_folder(out, config="mine.toml") as folder:
        assert json.loads((folder / ".bayesnsi.lock").read_text())["config"] == "mine.toml"
        with output_folder(out):  # reentrant in the process holding it (demo runs select inside)
            pass
        assert (folder / ".bayesnsi.lock").exists()
    assert not (out / ".bayesnsi.lock").exists()


def test_stale_lock_of_a_dead_process_is_taken_over(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    out = tmp_path / "out"
    out.mkdir()
    lock = {"pid": int(dead.stdout), "host": socket.gethostname(), "config": "x.toml", "started": "earlier"}
    (out / ".bayesnsi.lock").write_text(json.dumps(lock))
    with output_folder(out) as folder:
        assert json.loads((folder / ".bayesnsi.lock").read_text())["pid"] == os.getpid()
    # existing outputs are checked under the lock: refused without force, accepted with it
    (out / "results.json").write_text("{}")
    with pytest.raises(OutputExistsError, match="results.json; pass --force"):
        with output_folder(out):
            pass
    assert not (out / ".bayesnsi.lock").exists()
    with output_folder(out, force=True):
        pass


def test_cli_refuses_an_output_folder_in_use(tmp_path, capsys):
    """Needs the commands to run inside ``output_folder`` (the lead wires it in cli/_common.py)."""
    config = _experiment(tmp_path)
    out = tmp_path / "out"
    holder = _holder(out)
    try:
        assert main(["identify", str(config), "--out", str(out), "--quiet", "--no-figures"]) == 2
    finally:
        holder.communicate("")
    line = _one_line(capsys.readouterr().err)
    assert f"is in use by another bayesnsi run (pid {holder.pid}" in line
    assert not (out / "results.json").exists()


# ---------------------------------------------------------------- I/O faults and exit codes


def test_full_disk_exits_74_in_one_line_and_leaves_no_partial_file(tmp_path, monkeypatch, capsys):
    config = _experiment(tmp_path)
    out = tmp_path / "out"

    replace = os.replace

    def no_space(src, dst, *args, **kwargs):  # the disk fills up when results.json is written
        if Path(dst).name == "results.json":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(dst))
        return replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", no_space)
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 74
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("bayesnsi identify: I/O error:") and "No space left on device" in line
    written = sorted(p.name for p in out.iterdir() if not p.name.startswith((".cache", ".bayesnsi")))
    assert written == ["report.html"]
    # the report is bayesnsi's and results.json is missing: the rerun resumes without --force
    monkeypatch.setattr(os, "replace", replace)
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 0
    assert (out / "results.json").exists()


def test_results_json_is_written_last(tmp_path, monkeypatch, capsys):
    """A failure while writing the report leaves no results.json (needs the lead's reordering)."""
    from bayesnsi.report.document import Report

    config = _experiment(tmp_path)
    out = tmp_path / "out"

    def broken(self, path, *args, **kwargs):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))

    monkeypatch.setattr(Report, "write", broken)
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 74
    assert "Read-only file system" in _one_line(capsys.readouterr().err)
    assert not (out / "results.json").exists()


def test_jobs_beyond_the_limit_and_help_lists_exit_codes(tmp_path, capsys):
    from bayesnsi.options import MAX_JOBS

    config = _experiment(tmp_path)
    assert main(["identify", str(config), "--out", str(tmp_path / "o"), "--quiet", "--jobs", "1000000"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "jobs" in line and str(MAX_JOBS) in line and "1000000" in line
    with pytest.raises(SystemExit):
        main(["--help"])
    text = capsys.readouterr().out
    for code in ("0 ", "1 ", "2 ", "74 ", "130 ", "143 "):
        assert f"\n  {code}" in text, text


# ---------------------------------------------------------------- schedulers that never answer


def _server(mode: str):
    """A TCP server on 127.0.0.1: ``silent`` accepts and never answers, ``garbage`` answers junk."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    accepted = []

    def serve():
        while True:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            accepted.append(conn)
            if mode == "garbage":
                try:
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 40)
                except OSError:
                    pass

    threading.Thread(target=serve, daemon=True).start()

    def close():
        listener.close()
        for conn in accepted:
            conn.close()

    return f"tcp://127.0.0.1:{listener.getsockname()[1]}", close


def _dead_address() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp://127.0.0.1:{probe.getsockname()[1]}"


@pytest.mark.parametrize("mode", ["silent", "garbage", "dead", "tls", "malformed"])
def test_bad_scheduler_fails_fast_in_one_line(mode, tmp_path, monkeypatch, capsys):
    import gc

    import distributed.comm  # noqa: F401 - imported before the clock starts (1-2 s on a loaded machine)

    from bayesnsi import _dispatch

    monkeypatch.setattr(_dispatch, "CONNECT_TIMEOUT_S", 1.0)
    close = lambda: None  # noqa: E731
    if mode in ("silent", "garbage"):
        address, close = _server(mode)
    else:
        address = {"dead": _dead_address(), "tls": "tls://127.0.0.1:8786", "malformed": "tcp://host:99999"}[mode]
    config = _experiment(tmp_path, lambda raw: raw["candidates"].append({"name": "linear", "terms": []}))
    start = time.monotonic()
    try:
        code = main(["identify", str(config), "--out", str(tmp_path / "o"), "--quiet", "--scheduler", address])
    finally:
        close()
    elapsed = time.monotonic() - start
    gc.collect()  # a half-built dask Client would print its __del__ traceback here
    line = _one_line(capsys.readouterr().err)
    assert code == 2 and elapsed < 1.0 + 3.0, (code, elapsed, line)
    expected = {"tls": "TLS", "malformed": "not a Dask scheduler address"}.get(mode, "cannot reach the Dask scheduler")
    assert expected in line


def test_garbage_scheduler_command_exits_at_once(tmp_path):
    """The whole process: one line, exit 2, no traceback at exit and no lingering wait."""
    address, close = _server("garbage")
    config = _experiment(tmp_path)
    start = time.monotonic()
    try:
        done = subprocess.run(
            [*CLI, "identify", str(config), "--out", str(tmp_path / "o"), "--quiet", "--scheduler", address],
            capture_output=True, text=True, env=ENV, timeout=120,
        )
    finally:
        close()
    assert done.returncode == 2, done.stderr
    assert "cannot reach the Dask scheduler" in _one_line(done.stderr)
    assert time.monotonic() - start < 30.0


# ---------------------------------------------------------------- signals stop the workers

# the reliability config's candidates with 10x longer MCMC runs: a few seconds per candidate
SLOW_CANDIDATES = EXTRA_CANDIDATES.replace("n_steps = 400", "n_steps = 4000")
assert SLOW_CANDIDATES != EXTRA_CANDIDATES


@pytest.fixture(scope="module")
def slow_config(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile")
    csv = folder / "two_dof.csv"
    assert main(["simulate", "two-dof", "--seed", "1", "--duration", "20", "--out", str(csv), "--quiet"]) == 0
    path = csv.with_suffix(".toml")
    path.write_text(path.read_text() + SLOW_CANDIDATES)
    return path


def _children() -> dict[int, list[int]]:
    tree: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            tree.setdefault(parent, []).append(int(entry.name))
    return tree


def _loky_descendants(root: int) -> set[int]:
    tree, found, stack = _children(), set(), [root]
    while stack:
        for child in tree.get(stack.pop(), []):
            stack.append(child)
            if _alive(child) and "loky" in _cmdline(child):
                found.add(child)
    return found


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process tree from /proc")
@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_stops_the_worker_processes(signum, code, slow_config, tmp_path):
    out = tmp_path / "out"
    command = [*CLI, "select", str(slow_config), "--out", str(out), "--no-figures", "--quiet", "--jobs", "2"]
    process = subprocess.Popen(command, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=default_signals)
    workers: set[int] = set()
    deadline = time.monotonic() + 120
    while len(workers) < 2 and time.monotonic() < deadline and process.poll() is None:
        workers |= _loky_descendants(process.pid)
        time.sleep(0.1)
    if len(workers) < 2:
        process.kill()
        pytest.fail(f"no loky workers appeared: {process.communicate()[1][-2000:]}")
    time.sleep(0.5)
    process.send_signal(signum)
    _, err = process.communicate(timeout=30)
    assert process.returncode == code, err
    assert ("terminated" if signum == signal.SIGTERM else "interrupted") in _one_line(err)
    deadline = time.monotonic() + 5
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in workers if _alive(pid)], [_cmdline(pid) for pid in workers]


def test_missing_dask_extra_is_named(monkeypatch):
    # dask is the optional extra bayesnsi[dask]: without it --scheduler says what to install
    from bayesnsi import _dispatch
    from bayesnsi.exceptions import SchedulerError

    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    with pytest.raises(SchedulerError, match=r"pip install 'bayesnsi\[dask\]'"):
        _dispatch.connect("tcp://127.0.0.1:1")
