"""Figures that answer "which model, how sure, how well": Bayes factors and measured-vs-model overlays.

They draw what the library returns (:func:`bayesnsi.evidence.decision_table`,
:class:`bayesnsi.nsi.Reconstruction`) and compute nothing numerical.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import NullLocator, ScalarFormatter

from ..io.units import ChannelUnits
from ._layout import fit_margins
from ._ticks import frequency_ticks, in_view

__all__ = ["plot_band_ratios", "plot_bayes_factors", "plot_reconstruction"]


def plot_bayes_factors(decision, selected: str, ax=None):
    """Log Bayes factor of the selected model against each other candidate, with Kass-Raftery bands.

    Parameters
    ----------
    decision : pandas.DataFrame
        From :func:`bayesnsi.evidence.decision_table` (columns ``log_bayes_factor``,
        ``log_bayes_factor_se``, ``strength``).
    selected : str
        The selected candidate (left out: its factor against itself is 0).
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure when None.

    Returns
    -------
    matplotlib.figure.Figure
        One point per candidate [nat] with ±2 standard errors and a thin stem from 0, over the bands
        1, 3, 5 nat that separate "barely worth mentioning", "positive", "strong" and "very strong"
        (the bands stay visible behind every point). A candidate that failed (factor ∞) is marked as
        such.
    """
    others = decision.drop(index=selected, errors="ignore")
    alone = ax is None
    if alone:
        fig, ax = plt.subplots(figsize=(7.5, 0.55 * len(others) + 1.6))
    else:
        fig = ax.figure
    values = others["log_bayes_factor"].to_numpy(dtype=float)
    finite = np.isfinite(values)
    top = max(6.0, float(np.max(values[finite], initial=0.0)) * 1.15)
    y = np.arange(len(others))
    ax.hlines(y[finite], 0.0, values[finite], color="C0", lw=1.2, zorder=2)
    ax.errorbar(values[finite], y[finite], xerr=2 * others["log_bayes_factor_se"].to_numpy(dtype=float)[finite],
                fmt="o", color="C0", ms=6, capsize=3, zorder=3)
    for k in np.flatnonzero(~finite):
        ax.annotate("  failed: no evidence (factor ∞)", (0.0, y[k]), ha="left", va="center", fontsize=8)
    bands = ((1.0, 3.0, "positive", "#e8f0e8"), (3.0, 5.0, "strong", "#cfe3cf"), (5.0, top, "very strong", "#b3d4b3"))
    for low, high, word, colour in bands:
        ax.axvspan(low, high, color=colour, zorder=0, label=f"{word} (> {low:g} nat)")
        ax.text((low * high) ** 0.5 if low > 0 else 0.5 * (low + high), len(others) - 0.5, word, ha="center",
                va="bottom", fontsize=7, color="0.3", zorder=1)
    ax.set_yticks(y, [str(name) for name in others.index])
    ax.set_ylim(len(others) - 0.5 + 0.35, -0.6)
    ax.set_ylabel("candidate")
    if top > 20.0:  # factors of hundreds beside the bands at 1-5 nat: linear to 10, logarithmic beyond
        ax.set_xscale("symlog", linthresh=10.0)
        ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.set_xlim(min(0.0, float(np.min(values[finite], initial=0.0)) * 1.15), top)
    ax.set_xlabel(f"log Bayes factor of {selected} against each candidate [nat]")
    ax.set_title(f"How sure: evidence for {selected}", fontsize=10, y=1.0)  # (y given: see _layout.py)
    legend = ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,  # never over a bar
                       title="Kass and Raftery", title_fontsize=7)
    if alone:
        fit_margins(ax, legend)
    return fig


def plot_reconstruction(reconstructions, fs: float, channel=0, units=None, max_samples: int = 400,
                        channel_name=None):
    """Measured response against each candidate's open-loop reconstruction, and the errors (paper Figs. 9, 13).

    Parameters
    ----------
    reconstructions : mapping of str to Reconstruction
        :meth:`bayesnsi.nsi.NSIResult.reconstruct` of each candidate on the same data.
    fs : float
        Sampling frequency [Hz].
    channel : int or sequence of int
        Output channel shown, or channels side by side (one column each).
    units : ChannelUnits, optional
        Units of the data; "data units" when not given.
    max_samples : int
        Show the first ``max_samples`` samples (the whole record when shorter).
    channel_name : str or sequence of str, optional
        Name of the channel (e.g. ``"x1"``), or of each channel.

    Returns
    -------
    matplotlib.figure.Figure
        Per channel (a column): top, the measured response (grey) and each candidate's
        reconstruction; below, one panel per candidate with its error ``y - ŷ`` on a common scale,
        titled with its NRMSE.
    """
    units = units or ChannelUnits()
    channels = [int(channel)] if np.ndim(channel) == 0 else [int(c) for c in channel]
    names = [channel_name] if isinstance(channel_name, str) or channel_name is None else list(channel_name)
    names = [(names[k] if k < len(names) and names[k] else f"output {c + 1}") for k, c in enumerate(channels)]
    n, cols = len(reconstructions), len(channels)
    width, height = (7.0 if cols == 1 else 10.5), 2.4 + 1.35 * n
    gap = 0.9  # between columns [in]: the next column's tick labels and y label
    panel = (width - 0.85 - 0.15 - gap * (cols - 1)) / cols
    # fixed margins [in] (constrained layout costs more than the drawing)
    fig, axes = plt.subplots(
        n + 1, cols, figsize=(width, height), sharex=True, squeeze=False,
        gridspec_kw={"height_ratios": [2.2] + [1.0] * n, "left": 0.85 / width, "right": 1 - 0.15 / width,
                     "top": 1 - 0.35 / height, "bottom": 0.5 / height, "hspace": 0.45, "wspace": gap / panel},
    )
    first = next(iter(reconstructions.values()))
    shown = slice(0, min(int(max_samples), len(first.measured)))
    t = np.arange(len(first.measured))[shown] / fs
    for col, (index, name) in enumerate(zip(channels, names)):
        top = axes[0, col]
        top.plot(t, first.measured[shown, index], color="0.55", lw=3.0, label="measured")
        for k, (label, rec) in enumerate(reconstructions.items()):
            top.plot(t, rec.predicted[shown, index], lw=1.0, ls=("-", "--", "-.", ":")[k % 4], color=f"C{k}",
                     label=label)
            ax = axes[k + 1, col]
            ax.plot(t, rec.residual[shown, index], lw=0.6, color=f"C{k}")
            ax.set_ylabel(f"error {units.label('displacement')}", fontsize=8)
            ax.set_title(f"{label}: NRMSE {rec.nrmse_per_channel[index]:.4f}", fontsize=8, y=1.0)
        for ax in axes[2:, col]:
            ax.sharey(axes[1, col])
        in_view(axes[0, col].yaxis, 6)
        in_view(axes[1, col].yaxis, 2)  # (the error panels below share its y axis)
        top.set_ylabel(f"{name} {units.label('displacement')}")
        axes[-1, col].set_xlabel("time [s]")
    in_view(axes[0, 0].xaxis, 8)  # shared by every panel
    top = axes[0, 0]
    top.legend(fontsize=7, ncols=min(4, n + 1), loc="upper right")
    title = "Measured and reconstructed (open loop)"
    if cols == 1:
        top.set_title(title, fontsize=10, y=1.0)
    else:
        fig.suptitle(title, fontsize=10, y=1 - 0.08 / height, va="top")
    return fig


def plot_band_ratios(check, channel_names, limit: float, ax=None):
    """A model's residual over the noise it passes on, band by band and channel by channel.

    Parameters
    ----------
    check : ModelCheck
        :func:`bayesnsi.checks.adequacy.model_checks` of the model (``band_edges_hz``, ``band_ratios``).
    channel_names : sequence of str
        Name of each output channel.
    limit : float
        The ratio above which the model misses something in a band
        (:data:`bayesnsi.checks.residual_bands.MAX_BAND_RATIO`), drawn as a dashed line.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure when None.

    Returns
    -------
    matplotlib.figure.Figure
        One step line per channel on log-log axes; 1 is the level of a model that explains the data.
    """
    alone = ax is None
    if alone:
        fig, ax = plt.subplots(figsize=(7.5, 3.4))
    else:
        fig = ax.figure
    edges = np.asarray(check.band_edges_hz, dtype=float)
    ratios = np.asarray(check.band_ratios, dtype=float).reshape(len(edges) - 1, -1)
    for k in range(ratios.shape[1]):
        name = channel_names[k] if k < len(channel_names) else f"output {k + 1}"
        ax.stairs(ratios[:, k], edges, label=name, linewidth=1.4, baseline=None)
    ax.axhline(1.0, color="0.5", linewidth=0.8)
    ax.axhline(limit, color="C3", linestyle="--", linewidth=1.0, label=f"{limit:g}x: something missing")
    ax.set_xscale("log")
    ax.set_yscale("log")
    frequency_ticks(ax.xaxis)  # plain numbers, inside the view (a log axis's default ticks cost most of the figure)
    low, high = min(0.5, float(np.nanmin(ratios)) * 0.8), max(2 * limit, float(np.nanmax(ratios)) * 1.3)
    ax.set_ylim(low, high)
    ticks = [t * 10.0**e for e in range(-1, 5) for t in (1, 2, 5) if low <= t * 10.0**e <= high]
    ax.set_yticks(ticks, [f"{t:g}" for t in ticks])
    ax.yaxis.set_minor_locator(NullLocator())
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("residual / noise passed on")
    ax.set_title(f"{check.name}: residual over the noise it passes on, band by band", fontsize=10, y=1.0)
    legend = ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    if alone:
        fit_margins(ax, legend)
    return fig
