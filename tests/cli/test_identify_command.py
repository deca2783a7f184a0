"""What the `identify` command costs beyond the identification (benchmarks/identify_command.py).

The command reads plain numeric CSV files with numpy's reader (pandas only for files it does not
take), imports neither pandas, matplotlib nor scipy.signal with ``--no-figures``, and simulates
each candidate once for its reconstruction. And `diagnose` checks ``--start`` before any work.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from bayesnsi import NSIOptions, identify, simulate_case
from bayesnsi.exceptions import InputDataError
from bayesnsi.io import write_signals_csv
from bayesnsi.io._csv import _numeric, _read_frame, read_csv_columns
from bayesnsi.nsi.reconstruct import initial_state


@pytest.fixture(scope="module")
def case():
    return simulate_case("two-dof", seed=0, duration=5.0)


def test_plain_numeric_csv_reads_as_pandas_reads_it(tmp_path, case):
    path = tmp_path / "d.csv"
    write_signals_csv(path, case.signals, units={"f2": "N", "x1": "m", "x2": "m"})
    names = ["x2", "f2", "x1"]
    fast = read_csv_columns(path, names)
    frame = _read_frame(path, [fast.names.index(c) for c in names], 2)  # the reader for any other file
    for name in names:
        reference = _numeric(frame[fast.names.index(name)], name, path, 3)
        np.testing.assert_array_equal(fast.values[name], reference)
        assert fast.values[name].flags.c_contiguous
    np.testing.assert_allclose(fast.values["x1"], case.signals.displacement[:, 0], rtol=1e-11)
    assert {k: fast.units[k] for k in ("t", "f2", "x1", "x2")} == {"t": "s", "f2": "N", "x1": "m", "x2": "m"}


def test_csv_that_numpy_does_not_take_still_reads_with_its_messages(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text("t,f,x\n0,1.5,2\n0.1, ,3\n0.2,2.5,4\n")  # an empty cell: NaN, as before
    values = read_csv_columns(path, ["f", "x"]).values
    np.testing.assert_array_equal(values["x"], [2.0, 3.0, 4.0])
    assert np.isnan(values["f"][1]) and values["f"][2] == 2.5
    path.write_text("t,f,x\n0,1.5,2\n0.1,abc,3\n")
    with pytest.raises(InputDataError, match=r"column 'f', line 3 \(sample 1\): expected a number"):
        read_csv_columns(path, ["f"])
    path.write_text('t,f\n0,"1.5"\n1,2\n# a comment\n')  # a quoted number, a comment line: pandas reads them
    np.testing.assert_array_equal(read_csv_columns(path, ["f"]).values["f"], [1.5, 2.0, np.nan])


def test_open_loop_reconstruction_simulates_once_and_equals_the_two_step_form(case):
    result = identify(case.signals, case.candidates[-1], NSIOptions(block_rows=40, order=4))
    rec = result.reconstruct(case.signals)
    model = result.model
    u = result.extended_input(result.working_signals(case.signals), on_grid=True)
    y = np.asarray(case.signals.displacement)
    x0 = initial_state(model, u, y)  # the forced response computed afresh inside
    np.testing.assert_allclose(rec.x0, x0, rtol=1e-12, atol=1e-15 * np.max(np.abs(x0)))
    np.testing.assert_allclose(rec.predicted, model.simulate(u, x0), rtol=0, atol=1e-12 * np.max(np.abs(y)))


def test_identify_without_figures_imports_no_pandas_matplotlib_scipy_signal_or_optimize(tmp_path, case):
    write_signals_csv(tmp_path / "d.csv", case.signals)
    config = tmp_path / "c.toml"
    config.write_text(
        f'[data]\nfile = "d.csv"\nfs = {case.signals.fs}\ninputs = {{ f2 = 2 }}\noutputs = {{ x1 = 1, x2 = 2 }}\n'
        '[nsi]\nblock_rows = 20\norder = 4\n[[candidates]]\nname = "cubic"\n'
        'terms = [{ expr = "x1**3", at = 1 }]\n'
    )
    args = ["identify", str(config), "--out", str(tmp_path / "o"), "--quiet", "--no-figures"]
    code = (
        "import sys\nfrom bayesnsi.cli import main\n"
        f"assert main({args!r}) == 0\n"
        "heavy = ('pandas', 'matplotlib', 'scipy.signal', 'scipy.optimize', 'arviz_plots')\n"
        "print(sorted(m for m in heavy if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    assert (tmp_path / "o" / "results.json").is_file()


def test_diagnose_refuses_an_unknown_start_before_any_work(tmp_path, capsys, monkeypatch):
    import bayesnsi.cli.diagnose as diagnose_cli
    from bayesnsi.cli import main

    csv = tmp_path / "qd.csv"
    assert main(["simulate", "quadratic-damping", "--seed", "0", "--duration", "5", "--out", str(csv), "--quiet"]) == 0

    def no_selection(*args, **kwargs):  # the selection is the first work: it must not start
        raise AssertionError("the selection ran before --start was checked")

    monkeypatch.setattr(diagnose_cli, "run_selection", no_selection)
    out = tmp_path / "o"
    assert main(["diagnose", str(csv.with_suffix(".toml")), "--out", str(out), "--quiet", "--start", "nope"]) == 2
    assert "--start 'nope' is not a candidate of the config; choose one of" in capsys.readouterr().err
    assert not (out / "results.json").exists() and not (out / ".cache").exists()
