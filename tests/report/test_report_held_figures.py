"""A report holds its figures open until it is written: no matplotlib warning past 20 (EMPS diagnose had 20+)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from bayesnsi.report import held_figures


def test_many_open_report_figures_raise_no_warning_and_the_setting_is_restored():
    before = matplotlib.rcParams["figure.max_open_warning"]
    with held_figures():  # the suite turns warnings into errors: a warning would fail here
        figures = [plt.figure() for _ in range(25)]
    for fig in figures:
        plt.close(fig)
    assert matplotlib.rcParams["figure.max_open_warning"] == before
