"""Property-based fuzzing of what bayesnsi writes: the safe writer and the folder lock, against planted files.

Whatever is planted in the output folder (links to a victim file, folders, FIFOs, regular files,
under the target's name or beside it) and whatever is written, a write either completes (a
regular file with exactly the content written, never a link) or fails with an ``OSError``
(:class:`~bayesnsi.exceptions.OutputExistsError` included); the victim is never touched, no
temporary file is left, and the lock is released. Whatever a lock file holds or is, taking it
ends within seconds with the lock held or an ``OutputExistsError``. The number of examples
follows the hypothesis profile of conftest.py; the long profile (``BAYESNSI_HYPOTHESIS_PROFILE=long``,
thousands of examples) is the ``slow`` test at the end.
"""

from __future__ import annotations

import json
import os
import socket
import tempfile
import threading
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayesnsi.exceptions import OutputExistsError
from bayesnsi.io._lock import LOCK_FILENAME, folder_lock
from bayesnsi.io.results import atomic_open, output_folder

pytestmark = pytest.mark.skipif(os.name != "posix", reason="links, FIFOs and flock are POSIX")

_NAME = st.text(alphabet="abcxyz0123456789._-", min_size=1, max_size=12).filter(
    lambda n: n not in (".", "..") and not n.startswith(".bayesnsi")
)
_KIND = st.sampled_from(["link", "dangling link", "folder", "fifo", "file", "nothing"])
_PLANT = st.tuples(st.sampled_from(["target", "hidden", "beside"]), _KIND)


def _plant(folder: Path, name: str, kind: str, victim: Path) -> None:
    path = folder / name
    if os.path.lexists(path) or kind == "nothing":
        return
    if kind == "link":
        path.symlink_to(victim)
    elif kind == "dangling link":
        path.symlink_to(folder / "nowhere" / "x")
    elif kind == "folder":
        path.mkdir()
    elif kind == "fifo":
        os.mkfifo(path)
    else:
        path.write_bytes(b"the user's own file")


def _names(where: str, target: str) -> list[str]:
    return {"target": [target], "hidden": [f".{target}.partial", f".{target}.tmp", f"{target}.tmp"],
            "beside": ["results.json", "report.html", f"{target}~"]}[where]


def _check_write(target_name, sub, plants, content, force):
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        victim = root / "victim"
        victim.write_bytes(b"precious")
        os.chmod(victim, 0o600)
        out = root / "out"
        folder = out / "posterior" if sub else out
        with output_folder(out, force=force):
            folder.mkdir(exist_ok=True)
            for where, kind in plants:
                for name in _names(where, target_name):
                    _plant(folder, name, kind, victim)
            planted = set(os.listdir(folder))
            at_target = next((kind for where, kind in plants if where == "target" and kind != "nothing"), None)
            try:
                with atomic_open(folder / target_name, "wb") as fh:
                    fh.write(content)
            except OSError as err:
                failure: OSError | None = err
            else:
                failure = None
        # what was there decides: nothing -> written; a folder -> never replaced; anything else -> only with force
        if at_target is None or (force and at_target != "folder"):
            assert failure is None, failure
        elif at_target == "folder":
            assert failure is not None and (folder / target_name).is_dir()
        else:
            assert isinstance(failure, OutputExistsError) and "--force" in str(failure)
        assert victim.read_bytes() == b"precious" and (victim.stat().st_mode & 0o777) == 0o600
        if failure is None:
            target = folder / target_name
            assert not target.is_symlink() and target.is_file() and target.read_bytes() == content
        assert [n for n in os.listdir(folder) if n.endswith(".tmp") and n not in planted] == []
        assert not os.path.lexists(out / LOCK_FILENAME)


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_NAME, st.booleans(), st.lists(_PLANT, max_size=4), st.binary(max_size=2000), st.booleans())
def test_fuzz_writes_never_follow_a_planted_name_and_leave_nothing_behind(target_name, sub, plants, content, force):
    _check_write(target_name, sub, plants, content, force)


_JSON_VALUE = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats() | st.text(max_size=40),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=12,
)
_LOCK_FIELDS = st.fixed_dictionaries({}, optional={
    "pid": st.integers(-5, 2**40) | _JSON_VALUE, "host": st.just(socket.gethostname()) | st.text(max_size=30),
    "config": _JSON_VALUE, "started": _JSON_VALUE,
})
_LOCK_BYTES = (st.binary(max_size=6000) | _LOCK_FIELDS.map(lambda d: json.dumps(d).encode())
               | _JSON_VALUE.map(lambda v: json.dumps(v).encode()))


def _check_lock(kind, data, old):
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "out"
        out.mkdir()
        lock = out / LOCK_FILENAME
        if kind == "file":
            lock.write_bytes(data)
            if old:
                os.utime(lock, (time.time() - 3600,) * 2)
        elif kind == "folder":
            lock.mkdir()
        elif kind == "fifo":
            os.mkfifo(lock)
        elif kind == "link to /dev/zero":
            lock.symlink_to("/dev/zero")
        else:
            lock.symlink_to(out / "nowhere")
        outcome: list = []

        def take():
            try:
                with folder_lock(out) as path:
                    outcome.append(("held", json.loads(path.read_text())["pid"]))
            except OutputExistsError as err:
                outcome.append(("refused", str(err)))
            except BaseException as err:  # noqa: BLE001 - reported by the assertion below
                outcome.append(("other", repr(err)))

        thread = threading.Thread(target=take, daemon=True)
        thread.start()
        thread.join(5.0)
        assert not thread.is_alive(), f"taking a {kind} lock hangs"
        [(result, detail)] = outcome
        assert result in ("held", "refused"), detail
        if result == "held":
            assert detail == os.getpid() and kind == "file"
        if result == "refused":
            assert "\x1b" not in detail and "\n" not in detail


@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["file", "file", "file", "folder", "fifo", "link to /dev/zero", "dangling link"]),
       _LOCK_BYTES, st.booleans())
def test_fuzz_a_planted_lock_is_taken_or_refused_within_seconds(kind, data, old):
    _check_lock(kind, data, old)


@pytest.mark.slow
@settings(max_examples=10_000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_NAME, st.booleans(), st.lists(_PLANT, max_size=6), st.binary(max_size=5000), st.booleans(),
       st.sampled_from(["file", "folder", "fifo", "link to /dev/zero", "dangling link"]), _LOCK_BYTES, st.booleans())
def test_fuzz_writers_and_lock_long(target_name, sub, plants, content, force, kind, data, old):
    """The long profile of both properties (``pytest -m slow tests/io/test_fuzz_writers.py``)."""
    _check_write(target_name, sub, plants, content, force)
    _check_lock(kind, data, old)
