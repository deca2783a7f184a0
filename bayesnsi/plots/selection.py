"""Figures of a model selection: probabilities, reconstruction errors, posteriors."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..curves import effect_curve
from ..exceptions import InputDataError
from ..io.units import ChannelUnits, term_unit
from ._layout import fit_margins
from ._ticks import in_view

__all__ = [
    "plot_model_probabilities",
    "plot_reconstruction_errors",
    "plot_posterior_pairs",
    "plot_traces",
    "plot_effect_force",
]


def plot_model_probabilities(table, ax=None):
    """Posterior model probabilities per ranking (plain Eq. 4 and evidence per likelihood).

    Parameters
    ----------
    table : pandas.DataFrame
        From :func:`bayesnsi.evidence.ranking_table` (columns ``p_plain``, ``p_<likelihood>``
        and ``p_<likelihood>_sd``).
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure when None.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig, ax = plt.subplots(figsize=(6.5, 3.8), layout="constrained")
    else:
        fig = ax.figure
    columns = [c for c in table.columns if c.startswith("p_") and not c.endswith("_sd")]
    width = 0.8 / len(columns)
    x = np.arange(len(table))
    for k, col in enumerate(columns):
        sd = table[f"{col}_sd"] if f"{col}_sd" in table else None
        label = "plain (paper Eq. 4)" if col == "p_plain" else f"evidence, {col[2:]} residuals"
        ax.bar(x + k * width, table[col], width, yerr=sd, label=label, capsize=3)
    ax.set_xticks(x + width * (len(columns) - 1) / 2, table.index, rotation=15)
    ax.set_xlabel("candidate")
    ax.set_ylabel("P(model | data)")
    ax.set_ylim(0, 1.05)
    ax.legend(fontsize=8)
    ax.set_title("Posterior model probabilities")
    return fig


def plot_reconstruction_errors(reconstructions, fs: float, channel: int = 0, max_seconds: float | None = None):
    """Reconstruction error time histories per candidate (paper Figs. 9, 13).

    Parameters
    ----------
    reconstructions : mapping name -> Reconstruction
    fs : float
        Sampling frequency [Hz].
    channel : int
        Output channel shown.
    max_seconds : float, optional
        Show only the first seconds.

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = len(reconstructions)
    fig, axes = plt.subplots(
        n, 1, figsize=(7.0, 1.8 * n + 0.6), sharex=True, sharey=True, squeeze=False, layout="constrained"
    )
    for ax, (name, rec) in zip(axes[:, 0], reconstructions.items()):
        err = rec.residual[:, channel]
        t = np.arange(len(err)) / fs
        if max_seconds:
            keep = t <= max_seconds
            t, err = t[keep], err[keep]
        ax.plot(t, err, lw=0.6)
        ax.set_ylabel("error")
        ax.set_title(f"{name}: NRMSE {rec.nrmse_per_channel[channel]:.4f}", fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    return fig


def plot_posterior_pairs(posterior, max_params: int = 4, units=None):
    """Pair plot of the coefficient posterior (arviz-plots ``plot_pair``; all walkers pooled).

    Parameters
    ----------
    posterior : PosteriorSamples
        Draws of :func:`bayesnsi.evidence.candidate_evidence` (``EvidenceResult.posterior``).
    max_params : int
        Show the first ``max_params`` coefficients.
    units : ChannelUnits, optional
        Units of the data, for the unit of each λ (:func:`bayesnsi.io.units.term_unit`);
        "data units" when not given.

    Returns
    -------
    matplotlib.figure.Figure
        Marginal densities on the diagonal ("posterior density") and pairwise scatter below it;
        with one coefficient, its marginal density alone. Coefficient axes read ``λ of <term>
        [<unit>]``.

    Raises
    ------
    InputDataError
        If the candidate has no coefficient.
    """
    import arviz_plots

    terms = _coefficient_terms(posterior, max_params)
    size = 2.4 * len(terms) + 0.6
    common: dict = dict(var_names=["coefficient"], coords={"term": terms}, backend="matplotlib")
    if len(terms) == 1:  # a pair plot needs two variables
        stats: dict = {"point_estimate": {"round_to": _significant_digits(posterior, terms)}}
        plot = arviz_plots.plot_dist(posterior.to_datatree(), figure_kwargs={"figsize": (5.0, 3.4)}, stats=stats,
                                     **common)  # (its margins fitted below)
    else:
        plot = arviz_plots.plot_pair(posterior.to_datatree(), figure_kwargs=_figure_kwargs(size, size), **common)
    fig = plot.viz["figure"].item()
    _coefficient_labels(fig, terms, units)
    for ax in fig.axes:  # the diagonal (and a lone marginal) shows densities, whatever arviz names its rows
        spec = ax.get_subplotspec()
        if ax.has_data() and (len(terms) == 1 or spec.rowspan.start == spec.colspan.start):
            ax.set_ylabel("posterior density")
    if len(terms) == 1:  # a lone marginal: margins fitted once (constrained layout costs a third of its drawing)
        in_view(fig.axes[0].xaxis, 5)  # at most 6 labels: long values (-0.8975) no longer overlap
        fit_margins(fig.axes[0])
    return fig


def plot_traces(posterior, max_params: int = 4, max_chains: int = 6, units=None):
    """Trace and per-walker density of each coefficient (arviz-plots ``plot_trace_dist``).

    Parameters
    ----------
    posterior : PosteriorSamples
        Draws of :func:`bayesnsi.evidence.candidate_evidence` (one chain per emcee walker).
    max_params : int
        Show the first ``max_params`` coefficients, one row each.
    max_chains : int
        Show the first ``max_chains`` walkers.
    units : ChannelUnits, optional
        Units of the data, for the unit of each λ (:func:`bayesnsi.io.units.term_unit`);
        "data units" when not given.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InputDataError
        If the candidate has no coefficient.
    """
    import arviz_plots

    terms = _coefficient_terms(posterior, max_params)
    chains = list(range(min(int(max_chains), posterior.coefficients.shape[0])))
    plot = arviz_plots.plot_trace_dist(
        posterior.to_datatree(),
        var_names=["coefficient"],
        coords={"term": terms, "chain": chains},
        compact=False,
        backend="matplotlib",
        figure_kwargs=_figure_kwargs(8.0, 1.9 * len(terms) + 0.6),
    )
    fig = plot.viz["figure"].item()
    _coefficient_labels(fig, terms, units)
    for ax in fig.axes:  # arviz leaves the density panels' y axis unnamed, and names the draws "Draw"
        if ax.has_data() and not ax.get_ylabel():
            ax.set_ylabel("posterior density")
        if ax.get_xlabel() == "Draw":
            ax.set_xlabel("draw (emcee step after burn-in)")
    return fig


def _coefficient_terms(posterior, max_params: int) -> list:
    if not posterior.coefficient_names:
        raise InputDataError("the candidate has no nonlinear coefficient to plot")
    return list(posterior.coefficient_names)[: max(1, int(max_params))]


def _significant_digits(posterior, terms) -> str:
    """arviz's ``round_to`` for the point estimates of ``terms``: rounding moves none by more than 0.1 sd.

    arviz rounds the point estimate it draws (not only its label) to ``stats.round_to``, "2g" by
    default: a posterior mean of 30 896 with an sd of 3 was drawn at 31 000, outside its density.
    """
    digits = 2
    for k, name in enumerate(posterior.coefficient_names):
        if name in terms:
            draws = np.asarray(posterior.samples[..., k], dtype=float)
            mean, sd = abs(float(np.mean(draws))), float(np.std(draws))
            if mean > 0 and sd > 0:
                digits = max(digits, int(np.floor(np.log10(mean / sd))) + 3)
    return f"{min(digits, 12)}g"


def _coefficient_labels(fig, terms, units) -> None:
    """Axis labels and titles arviz writes as ``coefficient\\n<term>`` become ``λ of <term> [<unit>]``."""
    units = units or ChannelUnits()
    names = {}
    for term in terms:
        unit = term_unit(str(term).rsplit("@", 1)[0], units)
        names[f"coefficient\n{term}"] = f"λ of {term} [{unit or 'data units'}]"
    for ax in fig.axes:
        for get, put in ((ax.get_xlabel, ax.set_xlabel), (ax.get_ylabel, ax.set_ylabel)):
            if get() in names:
                put(names[get()])
        title = ax.get_title()
        if title in names:  # a lone marginal is titled, not labelled
            ax.set_title("")
            ax.set_xlabel(names[title])


def _figure_kwargs(width: float, height: float) -> dict:
    return {"figsize": (width, height), "layout": "constrained"}


def plot_effect_force(step, signals, max_points: int = 4000, units=None):
    """Restoring-force view of an added effect at its location, before and after (docs/method.md §7).

    With the step's :class:`~bayesnsi.loop.forces.ResidualForce` (accepted steps of
    :func:`bayesnsi.loop.close_the_loop`): top row, the residual of the model without the
    effect as a force at the location; bottom row, the residual after (blue), the effect's force
    λ·n through the same filter (black), their sum, the component-plus-residual (red), and the
    effect's own law λ·n(x, v) on the measured states (orange: the step of a Coulomb friction, the
    stiffening of a cubic spring), against the displacement and the velocity at the location.
    Without it, λ·n(x, v) alone (:func:`bayesnsi.curves.effect_curve`).

    Parameters
    ----------
    step : loop step
        Has ``term``, ``coefficient`` and optionally ``residual_force``.
    signals : Signals or None
        The measured signals (None with a ``residual_force``: the effect's law is not drawn).
    max_points : int
        At most this many points per scatter.
    units : ChannelUnits, optional
        Units of the data (:func:`bayesnsi.io.units.data_units`); "data units" when not given.

    Returns
    -------
    matplotlib.figure.Figure
    """
    units = units or ChannelUnits()
    rf = getattr(step, "residual_force", None)
    if rf is None:
        return _plot_effect_curve(step, signals, max_points, units)
    pick = np.linspace(0, len(rf.after) - 1, min(max_points, len(rf.after))).astype(int)
    pair = len(rf.location) == 2
    j = rf.location[0]
    names = (f"x{j} - x{rf.location[1]}", f"v{j} - v{rf.location[1]}") if pair else (f"x{j}", f"v{j}")
    labels = (f"{names[0]} {units.label('displacement')}", f"{names[1]} {units.label('velocity')}")
    law = _effect_law(step, signals, max_points)
    fig, axes = plt.subplots(2, 2, figsize=(8.0, 6.0), layout="constrained", sharey="row")
    for col, abscissa in enumerate((rf.displacement, rf.velocity)):
        top, bottom = axes[0, col], axes[1, col]
        top.plot(abscissa[pick], rf.before[pick], ".", ms=2, color="0.45")
        bottom.plot(abscissa[pick], rf.component_plus_residual[pick], ".", ms=2, color="C3", alpha=0.5,
                    label="effect + residual after")
        bottom.plot(abscissa[pick], rf.effect[pick], ".", ms=1.5, color="k", label="effect λ·n (filtered)")
        bottom.plot(abscissa[pick], rf.after[pick], ".", ms=2, color="C0", alpha=0.6, label="residual after")
        if law is not None:
            states = law.displacement if col == 0 else law.velocity
            bottom.plot(states, law.force, ".", ms=1.5, color="C1", label="effect law λ·n(x, v)")
        bottom.set_xlabel(labels[col])
    axes[0, 0].set_ylabel(f"residual force before {units.label('force')}")
    axes[1, 0].set_ylabel(f"force after {units.label('force')}")
    axes[1, 0].legend(fontsize=7, markerscale=4, loc="best")
    fig.suptitle(f"{step.term.name}: λ = {step.coefficient:.4g}; residual as a force at the location", fontsize=10)
    return fig


def _effect_law(step, signals, max_points: int):
    """λ·n(x, v) on the measured states at the effect's location (None where the location is not measured)."""
    from ..exceptions import InputDataError

    if signals is None:
        return None
    try:
        return effect_curve(step, signals, max_points)
    except InputDataError:
        return None


def _plot_effect_curve(step, signals, max_points, units):
    """λ·n(x, v) of an effect against x and v at its location (:func:`bayesnsi.curves.effect_curve`)."""
    curve = effect_curve(step, signals, max_points)
    fig, axes = plt.subplots(1, 2, figsize=(8.0, 3.4), layout="constrained")
    axes[0].plot(curve.displacement, curve.force, ".", ms=2)
    axes[0].set_xlabel(f"{curve.displacement_label} {units.label('displacement')}")
    axes[1].plot(curve.velocity, curve.force, ".", ms=2, color="C1")
    axes[1].set_xlabel(f"{curve.velocity_label} {units.label('velocity')}")
    for ax in axes:
        ax.set_ylabel(f"effect force λ·n {units.label('force')}")
    fig.suptitle(curve.title, fontsize=10)
    return fig
