"""The report of a periodic run shows the best linear approximation and the distortion level."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from bayesnsi.cli import main
from bayesnsi.models import Term
from bayesnsi.report.document import Report
from bayesnsi.report.periodic import HEADING, periodic_section
from bayesnsi.signals import Signals
from bayesnsi.simulate import add_output_noise, chain_system, multisine, simulate_response

FS, P, N_PERIODS, TRANSIENT = 100.0, 1000, 6, 4
MCK = chain_system([1.0, 1.5], [800.0, 1000.0], [2.0, 2.0])  # the two-DOF chain of the frequency-route tests


def _record(k3: float, seed: int = 2) -> Signals:
    """Random-odd multisine (0.5-20 Hz, 10 N rms) on the two-DOF chain, cubic spring k3 at DOF 1, 2 % noise."""
    rng = np.random.default_rng(seed)
    force = multisine(P, FS, (0.5, 20.0), 10.0, rng, n_periods=N_PERIODS + TRANSIENT, kind="random-odd")
    terms = [Term("x1**3", 1)] if k3 else []
    response = simulate_response(*MCK, [2], force.fine, FS * force.oversample, force.oversample, terms,
                                 [k3] if k3 else [])
    signals = Signals(force=response.force, displacement=add_output_noise(response.displacement, 2.0, rng),
                      fs=FS, input_dofs=(2,), output_dofs=(1, 2), period=P)
    return signals.segment(TRANSIENT * P, (N_PERIODS + TRANSIENT) * P)


def _table(report):
    blocks = next(b for _, name, b in report.sections if name == HEADING)
    return blocks, next(b for b in blocks if hasattr(b, "columns"))


@pytest.mark.parametrize("k3, nonlinear", [(0.0, False), (1e5, True)])
def test_bla_section_says_whether_there_is_distortion(k3, nonlinear):
    report = Report("t")
    assert periodic_section(report, _record(k3))
    blocks, table = _table(report)
    odd = table["unexcited odd lines: power / noise"].to_numpy()
    if nonlinear:  # the cubic spring at DOF 1 puts power on the odd lines, most at DOF 1
        assert odd[0] > 5.0 and odd[0] == odd.max()
    else:  # a linear system: the empty lines hold noise only
        assert np.all(odd < 2.0) and np.all(table["unexcited even lines: power / noise"].to_numpy() < 2.0)
    figures = [b for b in blocks if hasattr(b, "savefig")]
    assert len(figures) == 1 and len(figures[0].axes) == 2 and "Best linear approximation" in figures[0].get_label()
    assert any(isinstance(b, str) and b.startswith("Distortion level") for b in blocks)


def test_no_bla_section_without_a_period():
    record = _record(0.0)
    aperiodic = Signals(force=record.force, displacement=record.displacement, fs=FS, input_dofs=(2,),
                        output_dofs=(1, 2))
    report = Report("t")
    assert not periodic_section(report, aperiodic) and not report.sections


def test_identify_report_of_a_periodic_config_has_the_bla_figure(tmp_path):
    record = _record(1e5)
    rows = ["f2,x1,x2"] + [f"{f:.17g},{a:.17g},{b:.17g}" for f, (a, b) in zip(record.force[:, 0], record.displacement)]
    (tmp_path / "data.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "experiment.toml").write_text(
        '[data]\nfile = "data.csv"\nfs = 100.0\nperiod = 1000\ninputs = { f2 = 2 }\noutputs = { x1 = 1, x2 = 2 }\n'
        '[nsi]\ndomain = "frequency"\norder = 4\n[[candidates]]\nname = "linear"\nterms = []\n'
    )
    assert main(["identify", str(tmp_path / "experiment.toml"), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    html = (tmp_path / "out" / "report.html").read_text()
    assert HEADING in html and "Distortion level" in html and "Best linear approximation |G|" in html
