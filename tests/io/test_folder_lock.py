"""The output folder's lock: planted lock files of every kind, bounded reads, one holder among concurrent takers."""

from __future__ import annotations

import json
import multiprocessing
import os
import socket
import subprocess
import sys
import threading
import time

import pytest

from bayesnsi.cli import main
from bayesnsi.exceptions import OutputExistsError
from bayesnsi.io._lock import LOCK_FILENAME, folder_lock
from bayesnsi.io.results import output_folder
from tests._helpers.experiments import experiment_config as _experiment

pytestmark = pytest.mark.skipif(os.name != "posix", reason="lock takeover and file types are POSIX")


def _dead_pid() -> int:
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def _stale_lock(folder) -> None:
    lock = folder / LOCK_FILENAME
    lock.write_text(json.dumps({"pid": _dead_pid(), "host": socket.gethostname(), "config": None, "started": "x"}))


def test_a_lock_that_is_a_directory_is_bad_input(tmp_path, capsys):
    config = _experiment(tmp_path)
    out = tmp_path / "out"
    (out / LOCK_FILENAME).mkdir(parents=True)
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "not a regular file" in err and "a directory" in err


@pytest.mark.parametrize("kind", ["dev-zero link", "fifo", "huge sparse file"])
def test_a_planted_lock_is_never_read_whole_and_never_hangs(tmp_path, kind):
    out = tmp_path / "out"
    out.mkdir()
    lock = out / LOCK_FILENAME
    if kind == "dev-zero link":
        lock.symlink_to("/dev/zero")
    elif kind == "fifo":
        os.mkfifo(lock)
    else:
        with open(lock, "wb") as fh:
            fh.truncate(2**30)  # 1 GiB, sparse
        old = time.time() - 3600
        os.utime(lock, (old, old))
    outcome: dict = {}

    def take():
        try:
            with output_folder(out):
                outcome["held"] = True
        except OutputExistsError as err:
            outcome["error"] = str(err)

    thread = threading.Thread(target=take, daemon=True)
    start = time.monotonic()
    thread.start()
    thread.join(10.0)
    assert not thread.is_alive(), f"taking a {kind} lock hangs"
    assert time.monotonic() - start < 5.0
    if kind == "huge sparse file":  # an old unreadable regular file is stale: taken over, not read whole
        assert outcome == {"held": True}
    else:
        assert "not a regular file" in outcome["error"]
        assert os.path.lexists(lock)  # left for the user to look at


def test_the_fields_of_a_live_lock_are_printed_without_control_characters(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        fields = {"pid": holder.pid, "host": socket.gethostname(), "config": "\x1b]0;owned\x07\x1b[2J.toml",
                  "started": "\x1b[31mnow\r"}
        (out / LOCK_FILENAME).write_text(json.dumps(fields))
        with pytest.raises(OutputExistsError) as caught:
            with folder_lock(out):
                pass
    finally:
        holder.kill()
        holder.wait()
    message = str(caught.value)
    assert "\x1b" not in message and "\r" not in message and "\x07" not in message
    assert "\\x1b]0;owned" in message


def test_a_stale_lock_is_taken_over_and_released(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    _stale_lock(out)
    with folder_lock(out) as path:
        assert json.loads(path.read_text())["pid"] == os.getpid()
    assert not os.path.lexists(out / LOCK_FILENAME)


def _taker(folder, barrier, gate, holders, most, trials):
    for _ in range(trials):
        barrier.wait()
        try:
            with folder_lock(folder):
                with gate:
                    holders.value += 1
                    most.value = max(most.value, holders.value)
                time.sleep(0.02)
                with gate:
                    holders.value -= 1
        except OutputExistsError:
            pass
        barrier.wait()  # the parent plants the next stale lock
        barrier.wait()


def test_concurrent_takers_of_a_stale_lock_never_both_hold_it(tmp_path):
    """3 processes x 40 trials of taking over one stale lock at once: never two holders."""
    context = multiprocessing.get_context("fork")
    trials, n_takers = 40, 3
    barrier = context.Barrier(n_takers + 1)
    gate = context.Lock()
    holders, most = context.Value("i", 0), context.Value("i", 0)
    out = tmp_path / "out"
    out.mkdir()
    workers = [context.Process(target=_taker, args=(out, barrier, gate, holders, most, trials))
               for _ in range(n_takers)]
    _stale_lock(out)
    for worker in workers:
        worker.start()
    try:
        for _ in range(trials):
            barrier.wait(timeout=30)  # go
            barrier.wait(timeout=30)  # all done
            if os.path.lexists(out / LOCK_FILENAME):
                (out / LOCK_FILENAME).unlink()
            _stale_lock(out)
            barrier.wait(timeout=30)
    finally:
        for worker in workers:
            worker.join(timeout=30)
            if worker.is_alive():
                worker.kill()
    assert most.value == 1


def test_a_file_system_without_hard_links_still_gets_an_exclusive_lock(tmp_path, monkeypatch):
    import errno

    def no_links(*args, **kwargs):
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_links)
    out = tmp_path / "out"
    out.mkdir()
    with folder_lock(out) as path:
        assert json.loads(path.read_text())["pid"] == os.getpid()
        assert [p.name for p in out.iterdir()] == [LOCK_FILENAME]  # no temporary file left
        other = subprocess.run([sys.executable, "-c", f"from bayesnsi.io._lock import folder_lock\n"
                                f"with folder_lock({str(out)!r}): pass"], capture_output=True, text=True,
                               env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
        assert other.returncode != 0 and "is in use by another bayesnsi run" in other.stderr  # a second holder
    assert not os.path.lexists(out / LOCK_FILENAME)
