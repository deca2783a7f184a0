"""User text is shown as text: labels never parsed as mathtext, no control character reaches the terminal."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from bayesnsi._text import printable
from bayesnsi.cli import main
from tests._helpers.experiments import experiment_config as _experiment

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _run(*args) -> subprocess.CompletedProcess:
    """The command line in its own process: warnings reach stderr as a user sees them."""
    return subprocess.run([sys.executable, "-m", "bayesnsi.cli", *map(str, args)], env=ENV, capture_output=True,
                          text=True, timeout=300)


def _no_raw_controls(text: str) -> None:
    assert not any(c in text for c in ("\x1b", "\x07", "\r", "\u202e")), repr(text[-500:])


@pytest.mark.parametrize("unit", ["$x^$", "$\\frac{a}{$", "$\\sqrt$", "a $b$ c $"])
def test_no_unit_or_name_crashes_the_report(tmp_path, unit):
    def edit(raw):
        raw["data"]["units"] = {"f2": unit, "x1": f"m{unit}", "x2": f"m{unit}"}
        raw["candidates"][0]["name"] = f"cubic {unit}"

    config = _experiment(tmp_path, edit)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out), "--quiet"]) == 0
    assert (out / "report.html").stat().st_size > 10_000  # figures embedded
    assert json.loads((out / "results.json").read_text())["candidates"][0]["name"] == f"cubic {unit}"


def test_a_units_row_with_escape_sequences_reaches_the_terminal_escaped(tmp_path):
    config = _experiment(tmp_path)
    data = tmp_path / "data.csv"
    lines = data.read_text().splitlines()
    lines.insert(1, "s,\x1b[31mN\x07,\x1b]0;pwned\x07m,\x1b]0;pwned\x07m")
    data.write_text("\n".join(lines) + "\n")
    done = _run("identify", config, "--out", tmp_path / "out", "--quiet")
    assert done.returncode == 0, done.stderr[-2000:]
    _no_raw_controls(done.stderr)
    _no_raw_controls(done.stdout)


def test_a_data_path_with_escape_sequences_is_printed_escaped(tmp_path, capsys):
    config = _experiment(tmp_path, lambda raw: raw["data"].__setitem__("file", "gone\x1b[2J\x1b]0;x\x07.csv"))
    assert main(["identify", str(config), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    _no_raw_controls(err)
    assert "gone\\x1b[2J" in err


def test_a_planted_cache_entry_cannot_print_escape_sequences(tmp_path):
    from bayesnsi.io._store import write_container

    config = _experiment(tmp_path)
    out = tmp_path / "out"
    assert main(["identify", str(config), "--out", str(out), "--quiet", "--no-figures"]) == 0
    [entry] = list((out / ".cache").glob("*.npz"))
    with open(entry, "wb") as fh:
        write_container(fh, {"format": "\x1b[2J\x1b]0;owned\x07", "key": "k", "outcome": {}}, {})
    done = _run("identify", config, "--out", out, "--quiet", "--force", "--no-figures")
    assert done.returncode == 0, done.stderr[-2000:]
    assert "ignoring cache entry" in done.stderr
    _no_raw_controls(done.stderr)


def test_printable_escapes_controls_bidi_and_undecodable_bytes():
    assert printable("a\x1b[2Jb") == "a\\x1b[2Jb"
    assert printable("x\u202ey") == "x\\u202ey"
    assert printable("caf\udce9") == "caf\\udce9"
    assert printable("line\nnext") == "line\nnext" and printable("line\nnext", keep_newlines=False) == "line\\x0anext"
    assert printable("plain $x^2$ ü") == "plain $x^2$ ü"
    assert printable(np.float64(1.5)) == "1.5"
