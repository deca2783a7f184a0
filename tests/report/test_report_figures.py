"""Every figure function labels its axes, with the units of the data; figures go out at 150 dpi."""

from __future__ import annotations

import io

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")  # before pyplot; figures are drawn off screen

import matplotlib.pyplot as plt

from bayesnsi import NSIOptions, identify, simulate_case
from bayesnsi.evidence import ranking_table
from bayesnsi.evidence.decision import decision_table
from bayesnsi.io.units import ChannelUnits, data_units, term_unit
from bayesnsi.nsi import stabilization
from bayesnsi.plots import (
    plot_bayes_factors,
    plot_coefficient_spectrum,
    plot_effect_force,
    plot_frf,
    plot_model_probabilities,
    plot_posterior_pairs,
    plot_reconstruction,
    plot_reconstruction_errors,
    plot_singular_values,
    plot_stabilization,
    plot_traces,
)
from bayesnsi.report.document import FIGURE_DPI, figure_png
from tests._helpers.posteriors import LoopStep as _Step
from tests._helpers.posteriors import posterior_samples as _posterior

SI = ChannelUnits(force="N", displacement="m", velocity="m/s")
VOLTS = ChannelUnits(force="V", displacement="V", velocity="V/s")


@pytest.fixture(scope="module")
def case():
    return simulate_case("two-dof", seed=0)


@pytest.fixture(scope="module")
def results(case):
    options = NSIOptions(block_rows=60, order=4)
    return {c.name: identify(case.signals, c, options) for c in case.candidates}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _labelled(fig):
    """(xlabels, ylabels) of the axes that show data; every such axes has a y label, the figure an x label."""
    axes = [ax for ax in fig.axes if ax.has_data()]
    assert axes, "the figure draws nothing"
    ylabels = [ax.get_ylabel() or _shared_ylabel(ax) for ax in axes]
    xlabels = [ax.get_xlabel() for ax in axes if ax.get_xlabel()]
    assert all(ylabels), f"axes without a y label: {ylabels}"
    assert xlabels, "no x label"
    return xlabels, ylabels


def _shared_ylabel(ax):
    """The y label of an axes that shares its y axis with this one (a row with one label)."""
    return next((other.get_ylabel() for other in ax.get_shared_y_axes().get_siblings(ax) if other.get_ylabel()), "")


def test_frf_has_magnitude_and_phase_for_every_pair_with_data_units(results):
    freqs = np.linspace(0.1, 10.0, 200)
    fig = plot_frf(list(results.values()), freqs, units=SI)
    xlabels, ylabels = _labelled(fig)
    first = next(iter(results.values()))
    n_pairs = len(first.output_dofs) * len(first.input_dofs)
    assert sum("[m/N]" in y for y in ylabels) == n_pairs  # one magnitude panel per output/force pair
    assert sum("[deg]" in y for y in ylabels) == n_pairs  # and one phase panel
    assert {"|H1,2| [m/N]", "|H2,2| [m/N]"} <= set(ylabels)
    assert set(xlabels) == {"frequency [Hz]"}
    volts = plot_frf(first, freqs, output_index=0, input_index=0, units=VOLTS)
    assert "|H1,2| [V/V]" in _labelled(volts)[1]
    unknown = plot_frf(first, freqs, output_index=1, input_index=0)
    assert "|H2,2| [data units]" in _labelled(unknown)[1]


def test_coefficient_spectrum_labels_lambda_with_its_unit(results):
    fig = plot_coefficient_spectrum(results["model 1"], units=SI)
    xlabels, ylabels = _labelled(fig)
    assert ylabels == ["λ(ω) [N/(m/s)^2]"] and xlabels == ["frequency [Hz]"]
    assert _labelled(plot_coefficient_spectrum(results["model 2"], units=SI))[1] == ["λ(ω) [N]"]  # sign(v1)


def test_singular_values_and_stabilisation_are_labelled(results, case):
    res = results["model 1"]
    xlabels, ylabels = _labelled(plot_singular_values(res))
    assert xlabels == ["index"] and "singular value" in ylabels[0]
    sv, diagram = stabilization(case.signals, res.candidate, block_rows=res.block_rows, orders=range(2, 9, 2))
    xlabels, ylabels = _labelled(plot_stabilization(sv, diagram, fmax_hz=10.0))
    assert xlabels == ["frequency [Hz]"] and ylabels == ["model order"]


def test_reconstruction_overlays_measured_and_model_with_units(results, case):
    recs = {name: res.reconstruct(case.signals) for name, res in results.items()}
    fig = plot_reconstruction(recs, case.signals.fs, 1, units=SI, channel_name="x2", max_samples=300)
    xlabels, ylabels = _labelled(fig)
    assert ylabels[0] == "x2 [m]" and ylabels[1:] == ["error [m]"] * len(recs) and xlabels == ["time [s]"]
    top = fig.axes[0]
    assert [line.get_label() for line in top.get_lines()] == ["measured", *recs]
    np.testing.assert_array_equal(top.get_lines()[0].get_ydata(), case.signals.displacement[:300, 1])
    np.testing.assert_array_equal(top.get_lines()[1].get_ydata(), recs["model 1"].predicted[:300, 1])
    assert _labelled(plot_reconstruction_errors(recs, case.signals.fs))[0] == ["time [s]"]


def test_bayes_factors_and_probabilities_are_labelled():
    table = ranking_table(
        ["a", "b", "c"], plain_log_likelihoods=[10.0, 12.0, 9.0],
        evidence={"ar1": ([100.0, 96.5, float("-inf")], [0.01, 0.02, 0.0])}, rng=0,
    )
    fig = plot_bayes_factors(decision_table(table, "ar1"), "a")
    xlabels, _ = _labelled(fig)
    assert xlabels == ["log Bayes factor of a against each candidate [nat]"]
    from matplotlib.container import ErrorbarContainer

    points = [x for c in fig.axes[0].containers if isinstance(c, ErrorbarContainer) for x in c[0].get_xdata()]
    assert points == pytest.approx([3.5])  # b; c failed and is marked, not drawn
    assert any("failed" in t.get_text() for t in fig.axes[0].texts)
    assert _labelled(plot_model_probabilities(table))[1] == ["P(model | data)"]


def test_restoring_force_axes_carry_units(case):
    fig = plot_effect_force(_Step("v1*abs(v1)", 1, 20.0), case.signals, max_points=200, units=SI)
    xlabels, ylabels = _labelled(fig)
    assert xlabels == ["x1 [m]", "v1 [m/s]"] and ylabels == ["effect force λ·n [N]"] * 2


def test_restoring_force_view_of_a_loop_step_carries_units():
    from bayesnsi.loop.forces import ResidualForce

    rng = np.random.default_rng(0)
    x, v = rng.normal(size=(2, 300))
    rf = ResidualForce(location=(1, 2), displacement=x, velocity=v, before=x**3, after=0.1 * x, effect=x**3)

    class Step(_Step):
        residual_force = rf

    fig = plot_effect_force(Step("(x1-x2)**3", [1, 2], 2.0), None, units=SI)
    xlabels, ylabels = _labelled(fig)
    assert set(xlabels) == {"x1 - x2 [m]", "v1 - v2 [m/s]"}
    assert {"residual force before [N]", "force after [N]"} <= set(ylabels)


def _named_posterior(names):
    """Draws of the test posterior under real term names (``expr@location``, as the evidence names them)."""
    import dataclasses

    posterior = _posterior(len(names))
    return dataclasses.replace(
        posterior, coefficient_names=tuple(names), param_names=tuple(names) + posterior.param_names[len(names):]
    )


def test_posterior_figures_name_their_parameters():
    xlabels, _ = _labelled(plot_traces(_posterior(2)))
    assert any("term 0" in x for x in xlabels) and "draw (emcee step after burn-in)" in xlabels
    fig = plot_posterior_pairs(_posterior(2))
    texts = [ax.get_xlabel() + ax.get_ylabel() + ax.get_title() for ax in fig.axes]
    assert any("term 0" in t for t in texts) and any("term 1" in t for t in texts)


def test_posterior_figures_label_each_coefficient_with_its_unit():
    names = ("x1**3@1", "v1*abs(v1)@1")
    cubic, damping = "λ of x1**3@1 [N/m^3]", "λ of v1*abs(v1)@1 [N/(m/s)^2]"  # term_unit of each expression
    posterior = _named_posterior(names)
    # traces (arviz-plots plot_trace_dist): density and trace of each coefficient, both axes named
    xlabels, ylabels = _labelled(plot_traces(posterior, units=SI))
    assert xlabels == [cubic, "draw (emcee step after burn-in)", damping, "draw (emcee step after burn-in)"]
    assert ylabels == ["posterior density", cubic, "posterior density", damping]
    # pairs (arviz-plots plot_pair): densities on the diagonal, the scatter in the coefficients' units
    fig = plot_posterior_pairs(posterior, units=SI)
    xlabels, ylabels = _labelled(fig)
    assert set(xlabels) == {cubic, damping} and set(ylabels) == {"posterior density", damping}
    scatter = next(ax for ax in fig.axes if ax.get_subplotspec().rowspan.start == 1
                   and ax.get_subplotspec().colspan.start == 0)
    assert (scatter.get_xlabel(), scatter.get_ylabel()) == (cubic, damping)
    # one coefficient: its marginal alone, labelled (not titled); volts where the data are in volts
    lone = plot_posterior_pairs(_named_posterior(names[:1]), units=VOLTS)
    assert _labelled(lone) == (["λ of x1**3@1 [V/V^3]"], ["posterior density"]) and not lone.axes[0].get_title()
    # no units stated: the axes say so
    assert _labelled(plot_traces(_named_posterior(names[:1])))[0][0] == "λ of x1**3@1 [data units]"


def test_report_figures_are_written_at_150_dpi():
    from PIL import Image

    assert FIGURE_DPI >= 150
    fig = plt.figure(figsize=(4.0, 3.0))
    fig.add_subplot().plot([0, 1])
    image = Image.open(io.BytesIO(figure_png(fig)))
    assert image.size == (4 * FIGURE_DPI, 3 * FIGURE_DPI)


def test_data_units_from_the_csv_units_row(tmp_path):
    from bayesnsi.io import load_config, write_signals_csv

    case = simulate_case("two-dof", seed=0, duration=2.0)
    table = write_signals_csv(tmp_path / "d.csv", case.signals, units={"f2": "N", "x1": "mm", "x2": "mm"})
    config = tmp_path / "d.toml"
    config.write_text(
        f'[data]\nfile = "d.csv"\nfs = {table["fs"]}\ninputs = {{ f2 = 2 }}\noutputs = {{ x1 = 1, x2 = 2 }}\n'
        '[nsi]\nblock_rows = 20\norder = 4\n[[candidates]]\nname = "linear"\nterms = []\n'
    )
    units = data_units(load_config(config))
    assert (units.force, units.displacement, units.velocity) == ("N", "mm", "mm/s")
    assert units.label("frf") == "[mm/N]" and term_unit("x1**3", units) == "N/mm^3"
    # a gain changes the unit: the file's is dropped unless the config states one
    text = config.read_text()
    config.write_text(text.replace("[nsi]", "scale = { f2 = 2.0 }\n[nsi]"))
    assert data_units(load_config(config)).force == ""
    config.write_text(text.replace("[nsi]", 'scale = { f2 = 2.0 }\nunits = { f2 = "kN" }\n[nsi]'))
    assert data_units(load_config(config)).frf == "mm/kN"
    write_signals_csv(tmp_path / "d.csv", case.signals)  # no units row: nothing claimed
    config.write_text(text)
    assert data_units(load_config(config)) == ChannelUnits()
    config.write_text(text.replace("[nsi]", 'units = { f2 = "V", x1 = "V", x2 = "V" }\n[nsi]'))  # stated by the config
    assert data_units(load_config(config)) == ChannelUnits("V", "V", "V/s")


def test_data_units_in_the_config_are_checked(tmp_path):
    from bayesnsi.exceptions import ConfigError
    from bayesnsi.io import load_config, write_signals_csv

    case = simulate_case("two-dof", seed=0, duration=2.0)
    write_signals_csv(tmp_path / "d.csv", case.signals)
    base = '[data]\nfile = "d.csv"\nfs = 100.0\ninputs = { f2 = 2 }\noutputs = { x1 = 1 }\n{}\n' \
        '[[candidates]]\nname = "linear"\nterms = []\n'
    for bad, words in (('units = { q = "V" }', "not one of the mapped columns"), ("units = { x1 = 3 }", "unit label"),
                       ('units = "V"', "inline table")):
        config = tmp_path / "c.toml"
        config.write_text(base.replace("{}", bad))
        with pytest.raises(ConfigError, match=words):
            load_config(config)


def test_decision_table_compares_every_candidate_with_the_selected_one():
    log_z = {"linear": 260904.3, "cubic": 458019.7, "both": 462449.6, "weak": 462448.0, "failed": float("-inf")}
    table = ranking_table(list(log_z), evidence={"ar1": (list(log_z.values()), [1e-4, 3e-4, 3e-4, 4e-4, 0.0])}, rng=0)
    decision = decision_table(table, "ar1")
    # most probable first, then (probabilities that underflow to 0) by evidence; a failure last
    assert list(decision.index) == ["both", "weak", "cubic", "linear", "failed"]
    np.testing.assert_allclose(decision.loc["cubic", "log_bayes_factor"], 462449.6 - 458019.7)
    np.testing.assert_allclose(decision.loc["weak", "log_bayes_factor_se"], np.hypot(3e-4, 4e-4))
    np.testing.assert_allclose(decision.loc["weak", "posterior_odds"], np.exp(1.6), rtol=1e-6)  # equal priors
    assert list(decision["strength"]) == ["selected", "positive", "very strong", "very strong", "failed (no evidence)"]
    against_weak = decision_table(table, "ar1", selected="weak")
    assert against_weak.loc["both", "strength"] == "none: the data favour this candidate"


def test_overlays_show_the_channels_where_the_terms_act():
    # a 12-DOF chain (outputs at DOFs 1, 3, 4, 6, 8, 9, 11, 12): the overlays show x9 where the term acts, not x1, x3
    from types import SimpleNamespace

    from bayesnsi.models import Term
    from bayesnsi.report.choices import overlay_channels

    signals = SimpleNamespace(output_dofs=(1, 3, 4, 6, 8, 9, 11, 12))
    clearance, pair = Term("x9**3", 9), Term("(x3-x4)**3", [3, 4])
    assert overlay_channels(signals, [clearance]) == [0, 5]
    assert overlay_channels(signals, [pair, clearance]) == [0, 1, 2]  # at most three
    assert overlay_channels(signals, []) == [0, 1]  # linear models only: the first two, as before


def test_coefficient_rows_carry_the_unit_of_lambda():
    # λ of x³ is force over displacement cubed
    from bayesnsi.io.units import ChannelUnits
    from bayesnsi.report.sections import with_unit as _with_unit

    units = ChannelUnits(force="N", displacement="m", velocity="m/s")
    assert _with_unit("x3**3@3", units) == "x3**3@3 [N/m^3]"
    assert _with_unit("v1*abs(v1)@1", units) == "v1*abs(v1)@1 [N/(m/s)^2]"
    assert _with_unit("x1**3@1", ChannelUnits()) == "x1**3@1"  # the data state no units: no label


def test_the_loop_overlay_shows_where_the_added_effect_acts():
    # the overlay took the second output when the effect sat at the first (review of the overlay change)
    from types import SimpleNamespace

    from bayesnsi.models import Term
    from bayesnsi.report.loop import added_channel

    signals = SimpleNamespace(output_dofs=(1, 3, 9))
    assert added_channel(signals, [SimpleNamespace(term=Term("x1**3", 1))]) == 0
    assert added_channel(signals, [SimpleNamespace(term=Term("sign(v9)", 9))]) == 2
    assert added_channel(signals, [SimpleNamespace(term=Term("(x3-x9)**3", [3, 9]))]) == 1


def test_no_figure_of_a_selection_report_clips_a_text():
    """Every title, axis label, tick label and legend of the report's figures lies inside its figure
    (clipped y-labels of the traces and the reconstruction errors were seen in the browser)."""
    import warnings

    import matplotlib

    matplotlib.use("Agg")
    from types import SimpleNamespace

    from bayesnsi import EvidenceOptions, select, simulate_case
    from bayesnsi.exceptions import AdequacyWarning
    from bayesnsi.report import selection_report
    from bayesnsi.report.document import clipped_texts

    case = simulate_case("two-dof", seed=1, duration=6.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdequacyWarning)
        selection = select(case.signals, case.candidates[:2], case.recommended,
                           EvidenceOptions(n_steps=200, n_burn=50, likelihood="white", compare=(), n_replicates=3))
    config = SimpleNamespace(meta={}, candidates=case.candidates, path=SimpleNamespace(name="two_dof.toml"),
                             nsi=case.recommended, evidence=selection.evidence, seed=0,
                             data=SimpleNamespace(integrate=None, period=None, integrated=None))
    from bayesnsi.io.units import ChannelUnits

    report = selection_report(selection, config, "t", units=ChannelUnits(force="N", displacement="m", velocity="m/s"))
    figures = [block for _, _, blocks in report.sections for block in blocks if hasattr(block, "savefig")]
    assert len(figures) >= 8
    for fig in figures:
        assert clipped_texts(fig) == [], (fig.get_label()[:60], clipped_texts(fig))
    import matplotlib.pyplot as plt

    plt.close("all")
