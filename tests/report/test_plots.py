"""Figures draw what the library returns: effect curves (bayesnsi.curves), arviz-plots posteriors."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure

from bayesnsi.curves import effect_curve
from bayesnsi.exceptions import InputDataError
from bayesnsi.plots import plot_effect_force, plot_posterior_pairs, plot_traces
from bayesnsi.signals import Signals
from tests._helpers.posteriors import LoopStep as _Step
from tests._helpers.posteriors import posterior_samples as _posterior


@pytest.fixture(scope="module")
def signals():
    rng = np.random.default_rng(1)
    n = 500
    return Signals(
        force=rng.normal(size=(n, 1)),
        displacement=rng.normal(size=(n, 2)),
        velocity=rng.normal(size=(n, 2)),
        fs=100.0,
        input_dofs=(2,),
        output_dofs=(1, 2),
    )


def test_effect_curve_is_the_term_force_against_the_state_at_its_location(signals):
    curve = effect_curve(_Step("v1*abs(v1)", 1, 20.0), signals, max_points=100)
    pick = np.linspace(0, signals.n_samples - 1, 100).astype(int)
    v1 = signals.velocity[:, 0]
    np.testing.assert_allclose(curve.force, 20.0 * v1[pick] * np.abs(v1[pick]))
    np.testing.assert_array_equal(curve.velocity, v1[pick])
    np.testing.assert_array_equal(curve.displacement, signals.displacement[pick, 0])
    assert (curve.displacement_label, curve.velocity_label) == ("x1", "v1")


def test_effect_curve_of_a_pair_uses_relative_states(signals):
    curve = effect_curve(_Step("(x1-x2)**3", [1, 2], 2.0), signals, max_points=10_000)
    rel = signals.displacement[:, 0] - signals.displacement[:, 1]
    np.testing.assert_allclose(curve.displacement, rel)
    np.testing.assert_allclose(curve.force, 2.0 * rel**3)
    assert curve.displacement_label == "relative displacement"


def test_effect_curve_refuses_an_unmeasured_dof(signals):
    with pytest.raises(InputDataError, match="DOF 3"):
        effect_curve(_Step("sign(v3)", 3, 1.0), signals)


def test_plot_effect_force_draws_the_library_curve(signals):
    fig = plot_effect_force(_Step("sign(v2)", 2, 1.5), signals, max_points=50)
    try:
        line = fig.axes[0].lines[0]
        curve = effect_curve(_Step("sign(v2)", 2, 1.5), signals, max_points=50)
        np.testing.assert_array_equal(line.get_ydata(), curve.force)
        np.testing.assert_array_equal(line.get_xdata(), curve.displacement)
    finally:
        plt.close(fig)


@pytest.mark.parametrize("q", [1, 2, 3])
def test_posterior_pairs_is_an_arviz_figure(q):
    fig = plot_posterior_pairs(_posterior(q))
    try:
        assert isinstance(fig, Figure)
        labels = " ".join(ax.get_xlabel() + ax.get_ylabel() + ax.get_title() for ax in fig.axes)
        assert all(f"term {k}" in labels for k in range(q))  # arviz labels every coefficient
        assert len(fig.axes) == (1 if q == 1 else q * q)
    finally:
        plt.close(fig)


def test_traces_show_trace_and_density_of_each_coefficient_for_six_walkers():
    fig = plot_traces(_posterior(2))
    try:
        assert isinstance(fig, Figure)
        assert len(fig.axes) == 4  # (density, trace) per coefficient
        traces = [ax for ax in fig.axes if ax.get_xlabel().startswith("draw")]
        assert len(traces) == 2 and all(len(ax.lines) == 6 for ax in traces)
    finally:
        plt.close(fig)


def test_posterior_plots_refuse_a_candidate_without_coefficients():
    with pytest.raises(InputDataError, match="no nonlinear coefficient"):
        plot_traces(_posterior(0))


def test_a_lone_posterior_marks_its_mean_where_the_draws_are():
    # a mean of 30 896 with an sd of 3 must not be marked at 31 000 (arviz rounds the point estimate it
    # draws to 2 significant digits), 35 sd outside the density
    from dataclasses import replace

    base = _posterior(1)
    samples = base.samples.copy()
    samples[..., 0] = 30896.0 + 3.0 * samples[..., 0]
    posterior = replace(base, samples=samples)
    fig = plot_posterior_pairs(posterior)
    try:
        mean, sd = samples[..., 0].mean(), samples[..., 0].std()
        marks = [float(x) for ax in fig.axes for c in ax.collections for x in np.atleast_2d(c.get_offsets())[:, 0]]
        marks += [float(x) for ax in fig.axes for line in ax.lines for x in np.atleast_1d(line.get_xdata())
                  if len(np.atleast_1d(line.get_xdata())) == 1]
        assert marks and min(abs(x - mean) for x in marks) < 0.1 * sd, (marks, mean)
    finally:
        plt.close(fig)
