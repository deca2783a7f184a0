"""Every file bayesnsi writes: never through a planted link, fixed mode, user files kept, full disks survived."""

from __future__ import annotations

import json
import os
import resource
import stat
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from bayesnsi.cli import main
from bayesnsi.exceptions import OutputExistsError
from bayesnsi.io.posterior import write_posteriors
from bayesnsi.io.results import atomic_write_text, output_folder
from tests._helpers.posteriors import posterior_samples as _posterior

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
CLI = [sys.executable, "-m", "bayesnsi.cli"]

def _evidences():
    posterior = _posterior(1)
    evidence = SimpleNamespace(posterior=posterior, likelihood=posterior.likelihood, log_evidence=-3.0,
                               log_evidence_se=0.01, coefficient_names=posterior.coefficient_names, settings={})
    return {"model 1": evidence}


def _plant_everywhere(folder: Path, victim: Path, names) -> None:
    for name in names:
        link = folder / name
        link.parent.mkdir(parents=True, exist_ok=True)
        if not os.path.lexists(link):
            link.symlink_to(victim)


def _hidden_names(name: str) -> list[str]:
    """Names a writer could use beside ``name``: the fixed ones of earlier versions and common patterns."""
    return [f".{name}.partial", f"{name}.partial", f".{name}.tmp", f"{name}.tmp", f"{name}~", f".{name}"]


# ---------------------------------------------------------------- links planted under the names written


def test_a_link_planted_under_a_temporary_name_leaves_its_target_untouched(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "out"
    with output_folder(out) as folder:  # planted while the run computes, after the folder was checked
        (out / "posterior").mkdir()
        _plant_everywhere(out / "posterior", victim, _hidden_names("model_1.nc"))
        _plant_everywhere(out, victim, [n for base in ("results.json", "report.html") for n in _hidden_names(base)])
        files = write_posteriors(folder, _evidences())
        atomic_write_text(folder / "report.html", "<html></html>")
        atomic_write_text(folder / "results.json", "{}")
    assert victim.read_text() == "precious"
    assert (out / files["model 1"]).is_file() and not (out / files["model 1"]).is_symlink()


def test_a_posterior_folder_that_is_a_link_is_refused_before_the_run(tmp_path, select_config, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "model_1.nc").write_text("someone's data")
    out = tmp_path / "out"
    out.mkdir()
    (out / "posterior").symlink_to(elsewhere, target_is_directory=True)
    assert main(["select", str(select_config), "--out", str(out), "--quiet", "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert "posterior" in err and "symbolic link" in err
    assert (elsewhere / "model_1.nc").read_text() == "someone's data"
    assert not (out / ".cache").exists()  # refused before any candidate ran
    # --force does not make a link a folder
    assert main(["select", str(select_config), "--out", str(out), "--quiet", "--no-figures", "--force"]) == 2
    assert (elsewhere / "model_1.nc").read_text() == "someone's data"


def test_a_posterior_link_made_during_the_run_is_not_followed(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "out"
    with output_folder(out) as folder:
        (folder / "posterior").symlink_to(elsewhere, target_is_directory=True)  # planted after the checks
        with pytest.raises(OutputExistsError, match="symbolic link"):
            write_posteriors(folder, _evidences())
    assert list(elsewhere.iterdir()) == []


def test_a_posterior_that_is_a_file_is_bad_input_before_the_run(tmp_path, select_config, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "posterior").write_text("mine")
    assert main(["select", str(select_config), "--out", str(out), "--quiet", "--no-figures"]) == 2
    assert "posterior" in capsys.readouterr().err
    assert not (out / ".cache").exists()
    assert (out / "posterior").read_text() == "mine"


def test_a_forced_report_over_a_link_to_a_0777_file_gets_a_fixed_mode(tmp_path):
    victim = tmp_path / "victim.html"
    victim.write_text("precious")
    os.chmod(victim, 0o4777)
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").symlink_to(victim)
    with output_folder(out, force=True) as folder:
        atomic_write_text(folder / "report.html", "<html>new</html>")
    umask = os.umask(0)
    os.umask(umask)
    written = out / "report.html"
    assert not written.is_symlink() and written.read_text() == "<html>new</html>"
    assert stat.S_IMODE(written.stat().st_mode) == 0o644 & ~umask
    assert victim.read_text() == "precious" and stat.S_IMODE(victim.stat().st_mode) == 0o4777


# ---------------------------------------------------------------- what the user put in --out


def test_a_users_posterior_file_is_not_overwritten_without_force(tmp_path, select_config, capsys):
    out = tmp_path / "out"
    (out / "posterior").mkdir(parents=True)
    (out / "posterior" / "model_1.nc").write_text("my own file")
    assert main(["select", str(select_config), "--out", str(out), "--quiet", "--no-figures"]) == 2
    line = capsys.readouterr().err.strip()
    assert "posterior/model_1.nc" in line and "--force" in line
    assert (out / "posterior" / "model_1.nc").read_text() == "my own file"


def test_a_users_report_with_the_generator_mark_is_not_overwritten(tmp_path, select_config, capsys):
    out = tmp_path / "out"
    out.mkdir()
    mine = "<!DOCTYPE html><html><head><meta name='generator' content='bayesnsi'></head>my notes</html>"
    (out / "report.html").write_text(mine)
    assert main(["select", str(select_config), "--out", str(out), "--quiet"]) == 2
    assert "report.html" in capsys.readouterr().err
    assert (out / "report.html").read_text() == mine


def test_a_report_bayesnsi_wrote_resumes_but_an_edited_one_does_not(tmp_path):
    out = tmp_path / "out"
    with output_folder(out) as folder:
        atomic_write_text(folder / "report.html", "<html>ours</html>")
    with output_folder(out) as folder:  # no results.json: a run that failed at its end resumes
        atomic_write_text(folder / "report.html", "<html>ours again</html>")
    (out / "report.html").write_text("<html>edited by hand</html>")
    with pytest.raises(OutputExistsError, match="report.html"):
        with output_folder(out):
            pass


def test_an_empty_output_path_is_refused(tmp_path, select_config, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    before = sorted(os.listdir(tmp_path))
    assert main(["select", str(select_config), "--out", "", "--quiet"]) == 2
    assert "empty" in capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == before


# ---------------------------------------------------------------- write faults


def _file_size_limit(n_bytes: int):
    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (n_bytes, n_bytes))

    return limit


def test_a_file_size_limit_while_writing_the_posterior_exits_74_and_leaves_nothing(tmp_path, select_config):
    """``ulimit -f``: the netCDF write fails cleanly (no HDF5 crash), no partial file, the lock released."""
    out = tmp_path / "out"
    command = [*CLI, "select", str(select_config), "--out", str(out), "--quiet", "--no-figures"]
    done = subprocess.run(command, env=ENV, capture_output=True, text=True, timeout=300,
                          preexec_fn=_file_size_limit(64 * 1024))
    assert done.returncode == 74, done.stderr[-2000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("bayesnsi select: I/O error:") and "Traceback" not in done.stderr
    leftovers = [p for p in out.rglob("*") if p.name.endswith((".tmp", ".partial")) or p.name == ".bayesnsi.lock"]
    assert leftovers == []
    assert not (out / "results.json").exists()
    assert not any((out / "posterior").glob("*.nc")) if (out / "posterior").exists() else True


def test_writes_are_complete_files_or_none_on_a_write_error(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with output_folder(out) as folder:
        atomic_write_text(folder / "results.json", json.dumps({"old": 1}))
        real_fsync = os.fsync

        def failing(fd):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(os, "fsync", failing)
        with pytest.raises(OSError, match="No space"):
            atomic_write_text(folder / "results.json", json.dumps({"new": 2}))
        monkeypatch.setattr(os, "fsync", real_fsync)
    assert json.loads((out / "results.json").read_text()) == {"old": 1}
    assert [p.name for p in out.iterdir() if p.name.endswith(".tmp")] == []
