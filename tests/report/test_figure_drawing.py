"""How the report's figures are drawn at little cost with the same reading (docs/measurements.md, "What the report
costs"): log axes labelled in plain text with ticks inside the view only, a measured FRF of thousands of lines
thinned to what the axes' pixels show, margins fitted to the texts instead of constrained layout."""

from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("Agg")  # before pyplot; figures are drawn off screen

import matplotlib.pyplot as plt

from bayesnsi import NSIOptions, identify, simulate_case
from bayesnsi.curves import MeasuredFRF
from bayesnsi.plots import plot_band_ratios, plot_bayes_factors, plot_frf, plot_singular_values
from bayesnsi.plots._ticks import decade_ticks, frequency_ticks, power_of_ten
from bayesnsi.report.document import clipped_texts


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def result():
    case = simulate_case("two-dof", seed=0, duration=20.0)
    return identify(case.signals, case.candidates[0], NSIOptions(block_rows=20, order=4))


def _drawn_labels(axis):
    """The tick labels an axis draws (inside its view), after a draw."""
    low, high = sorted(axis.get_view_interval())
    return [tick.label1.get_text() for tick in axis.get_major_ticks()
            if low * (1 - 1e-9) <= tick.get_loc() <= high * (1 + 1e-9)]


def test_decades_read_as_powers_of_ten_in_plain_text():
    assert [power_of_ten(v) for v in (1e-6, 0.01, 1.0, 10.0, 1e3)] == ["10⁻⁶", "10⁻²", "10⁰", "10¹", "10³"]
    fig, ax = plt.subplots()
    ax.semilogy([1, 2, 3], [2e-7, 1e-3, 0.5])
    decade_ticks(ax.yaxis)
    fig.canvas.draw()
    labels = _drawn_labels(ax.yaxis)
    assert labels and all("$" not in label and label.startswith("10") for label in labels)  # no mathtext
    assert len(ax.yaxis.get_major_ticks()) == len(labels)  # no tick made outside the view
    assert not ax.yaxis.get_minorticklocs().size


@pytest.mark.parametrize(("limits", "major", "minor"), [
    ((0.12, 48.0), ["0.2", "0.5", "1", "2", "5", "10", "20"], []),  # three decades: 1, 2, 5 labelled
    ((0.006, 60.0), ["0.01", "0.1", "1", "10"], [0.02, 0.05, 0.2, 0.5, 2, 5, 20, 50]),  # wider: decades, 2 and 5
])
def test_log_frequency_axes_are_ticked_inside_the_view_in_plain_numbers(limits, major, minor):
    fig, ax = plt.subplots()
    ax.semilogx(limits, [1.0, 2.0])
    ax.set_xlim(*limits)
    frequency_ticks(ax.xaxis)
    fig.canvas.draw()
    assert _drawn_labels(ax.xaxis) == major
    assert len(ax.xaxis.get_major_ticks()) == len(major)  # nothing made beyond the ends
    np.testing.assert_allclose(sorted(ax.xaxis.get_minorticklocs()), minor)


def test_a_measured_frf_of_many_lines_is_thinned_to_its_envelope(result):
    rng = np.random.default_rng(0)
    freqs = np.linspace(0.01, 40.0, 20000)
    h = 1.0 / (1.0 + 1j * freqs) + 1e-3 * (rng.normal(size=freqs.size) + 1j * rng.normal(size=freqs.size))
    frf = np.zeros((freqs.size, 2, 1), dtype=complex)
    frf[:, 0, 0], frf[:, 1, 0] = h, 2 * h
    measured = MeasuredFRF(freqs_hz=freqs, frf=frf, coherence=np.ones((freqs.size, 2)), excited_hz=40.0)
    for log in (False, True):
        fig = plot_frf(result, np.linspace(0.1, 40.0, 300), measured=measured, log_frequency=log)
        line = fig.axes[0].get_lines()[0]  # the dotted measured magnitude of the first pair
        x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
        assert len(x) <= 4000 < freqs.size and np.all(np.diff(x) > 0)
        # the envelope a reader sees: the extremes of the noise and both ends of the curve are kept
        assert y.max() == np.abs(h).max() and y.min() == np.abs(h).min()
        assert (x[0], x[-1]) == (freqs[0], freqs[-1])
        # each column of the axes' width keeps its own extremes
        columns, kept = _columns(freqs, freqs, log), _columns(x, freqs, log)
        crowded = np.flatnonzero(np.bincount(columns, minlength=1000) > 4)  # columns where points were dropped
        for c in crowded[[0, len(crowded) // 2, -1]]:
            inside = np.abs(h)[columns == c]
            assert inside.max() in y[kept == c] and inside.min() in y[kept == c]


def _columns(f, span, log):
    """Which of 1000 columns across ``span`` (equal widths on a log axis when ``log``) each frequency falls in."""
    g, ends = (np.log10(f), np.log10(span[[0, -1]])) if log else (f, span[[0, -1]])
    return np.minimum(((g - ends[0]) / (ends[1] - ends[0]) * 1000).astype(int), 999)


def test_the_report_figures_with_log_axes_draw_no_mathtext(result):
    fig = plot_singular_values(result)
    fig.canvas.draw()
    freqs = np.geomspace(0.1, 40.0, 200)
    frf = plot_frf(result, freqs, log_frequency=True)
    frf.canvas.draw()
    axes = [axis for f in (fig, frf) for ax in f.axes for axis in (ax.xaxis, ax.yaxis)]
    texts = [label for axis in axes for label in _drawn_labels(axis)]
    assert texts and not any("$" in text for text in texts)


def test_fitted_margins_hold_long_names_and_outside_legends():
    names = ["final: v1*abs(v1)@1 + sign(v2)@2 + (x3-x4)**3@[3, 4]", "b", "a much longer linear candidate name"]
    decision = pd.DataFrame({"log_bayes_factor": [0.0, 2.0, 450.0], "log_bayes_factor_se": [0.0, 0.1, 0.2],
                             "strength": ["selected", "positive", "very strong"]}, index=names)
    fig = plot_bayes_factors(decision, names[0])
    assert fig.get_layout_engine() is None and clipped_texts(fig) == []
    ax = fig.axes[0]
    assert ax.get_position().width > 0.3  # the names and the legend leave the bars room

    class Check:  # what plot_band_ratios reads of a ModelCheck
        name = "final model"
        band_edges_hz = np.geomspace(0.01, 500.0, 13)
        band_ratios = np.random.default_rng(1).uniform(0.6, 3.0, size=(12, 8)).ravel()

    channels = [f"accelerometer channel {k} (vertical)" for k in range(8)]
    fig = plot_band_ratios(Check(), channels, 2.0)
    assert fig.get_layout_engine() is None and clipped_texts(fig) == []
    assert fig.axes[0].get_position().width > 0.3
