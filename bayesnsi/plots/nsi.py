"""Figures of an identification: singular values, stabilisation, FRFs, λ(ω).

Paper Figs. 3-5, 7-8, 11-12. Each function takes results (and an optional Axes), computes
nothing new beyond evaluating the result's own methods on a frequency grid, and returns the
Figure; saving is the caller's job (``bayesnsi.io``).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator, MultipleLocator

from ..io.units import ChannelUnits, term_unit
from ._layout import title_height
from ._ticks import decade_ticks, frequency_ticks

__all__ = ["plot_singular_values", "plot_stabilization", "plot_model_order", "plot_frf", "plot_coefficient_spectrum",
           "plot_coefficient_spectra"]


def _axes(ax, figsize=(6.0, 4.0)):
    if ax is None:
        fig, ax = plt.subplots(figsize=figsize, layout="constrained")
        return fig, ax
    return ax.figure, ax


def plot_singular_values(result, ax=None, max_shown: int = 60):
    """Singular values of the weighted oblique projection with the chosen order (paper Fig. 3).

    Parameters
    ----------
    result : NSIResult
        An identification (:func:`bayesnsi.nsi.identify`).
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure when None.
    max_shown : int
        Number of singular values shown.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (6.0, 3.2))
    s = result.singular_values[:max_shown]
    ax.semilogy(np.arange(1, len(s) + 1), s, "o-", ms=3)
    decade_ticks(ax.yaxis)  # decades ticked and gridded, labelled in plain text (minor ticks: half the drawing time)
    ax.grid(True, which="major", axis="y", color="0.88", lw=0.6)
    ax.axvline(result.order + 0.5, color="C3", ls="--", label=f"order n = {result.order}")
    ax.set_xlabel("index")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("singular value (scaled data, unitless)")
    ax.set_title(f"Singular values - {result.candidate.name}", y=1.0)  # (y given: see _layout.py)
    ax.legend()
    return fig


def plot_stabilization(singular_values, diagram, ax=None, fmax_hz: float | None = None):
    """Stabilisation diagram: physical poles' frequencies against model order.

    Parameters
    ----------
    singular_values : ndarray
    diagram : list of (order, ndarray (k, 2) of (frequency_hz, damping_ratio), spurious)
        As returned by :func:`bayesnsi.nsi.stabilization`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; a new figure when None.
    fmax_hz : float, optional
        Upper frequency limit [Hz].

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7.0, 4.5))
    previous = np.empty((0, 2))
    points: dict[bool, list] = {True: [], False: []}  # (frequency, order) of stable and other poles
    for order, modes, _ in diagram:
        for f, z in modes:
            stable = len(previous) > 0 and bool(np.any(
                (np.abs(previous[:, 0] / f - 1) < 0.01) & (np.abs(previous[:, 1] / max(z, 1e-12) - 1) < 0.05)
            ))
            points[stable].append((f, order))
        previous = modes
    stable_xy, other_xy = (np.array(points[k], dtype=float).reshape(-1, 2) for k in (True, False))
    # one line per kind (a line per order cost most of the figure's drawing time)
    ax.plot(stable_xy[:, 0], stable_xy[:, 1], "k.", ms=5, label="stable (Δf < 1 %, Δζ < 5 %)")
    ax.plot(other_xy[:, 0], other_xy[:, 1], "o", mfc="none", mec="0.6", ms=4, label="new or unstable")
    ax.legend(fontsize=8, loc="lower right", framealpha=0.9)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("model order")
    if fmax_hz:
        ax.set_xlim(0, fmax_hz)
    ax.set_title("Stabilisation diagram (physical poles)", y=1.0)
    return fig


def plot_model_order(result, diagram, fmax_hz: float | None = None):
    """The choice of the model order in one figure: singular values beside the stabilisation diagram.

    Parameters
    ----------
    result : NSIResult
        The identification whose singular values are shown (paper Fig. 3).
    diagram : list of (order, ndarray (k, 2) of (frequency_hz, damping_ratio), spurious)
        As returned by :func:`bayesnsi.nsi.stabilization`.
    fmax_hz : float, optional
        Upper frequency limit of the diagram [Hz].

    Returns
    -------
    matplotlib.figure.Figure
        :func:`plot_singular_values` (left) and :func:`plot_stabilization` (right).
    """
    width, height = 10.5, 3.9
    # fixed margins [in]: constrained layout doubles the drawing time
    fig, (left, right) = plt.subplots(1, 2, figsize=(width, height), gridspec_kw={
        "left": 0.9 / width, "right": 1 - 0.15 / width, "top": 1 - 0.35 / height, "bottom": 0.55 / height,
        "wspace": 0.22})
    plot_singular_values(result, ax=left)
    plot_stabilization(result.singular_values, diagram, ax=right, fmax_hz=fmax_hz)
    return fig


def plot_frf(results, freqs_hz, output_index=None, input_index=None, exact=None, labels=None, units=None,
             measured=None, log_frequency=False):
    """Underlying linear FRF, magnitude and phase, of one or more candidates (paper Figs. 4, 8, 12).

    One magnitude panel (log scale) and one phase panel per input/output pair: every pair by
    default, or the one named by ``output_index`` and ``input_index``.

    Parameters
    ----------
    results : NSIResult or sequence of NSIResult
    freqs_hz : ndarray
    output_index, input_index : int, optional
        Show only this output channel and force column.
    exact : ndarray of complex, shape (n_freq, l, m), or (n_freq,) with one pair, optional
        Reference FRF on ``freqs_hz`` (e.g. :func:`bayesnsi.simulate.underlying_frf`).
    labels : sequence of str, optional
        Legend label of each result.
    units : ChannelUnits, optional
        Units of the data (:func:`bayesnsi.io.units.data_units`); "data units" when not given.
    measured : MeasuredFRF, optional
        The data's FRF without a model (:func:`bayesnsi.curves.measured_frf`), drawn on its own lines
        where the forces explain the output (multiple coherence at least 0.5).
    log_frequency : bool
        A logarithmic frequency axis (a band much wider than the modes).

    Returns
    -------
    matplotlib.figure.Figure
    """
    units = units or ChannelUnits()
    results = results if isinstance(results, (list, tuple)) else [results]
    first = results[0]
    single = output_index is not None or input_index is not None
    outputs = [output_index or 0] if single else range(len(first.output_dofs))
    inputs = [input_index or 0] if single else range(len(first.input_dofs))
    pairs = [(o, i) for o in outputs for i in inputs]
    if exact is not None:
        exact = np.asarray(exact)
        exact = exact.reshape(len(exact), 1, 1) if exact.ndim == 1 else exact
    frfs = [res.underlying_frf(freqs_hz) for res in results]
    height = 3.1 * len(pairs) + 0.75
    # fixed margins [in]: constrained layout costs seconds with the 16 panels of an 8-output structure
    fig = plt.figure(figsize=(6.5, height))
    outer = fig.add_gridspec(
        len(pairs), 1, left=0.8 / 6.5, right=1 - 0.15 / 6.5, top=1 - 0.55 / height, bottom=0.6 / height, hspace=0.42
    )
    for p, (o, i) in enumerate(pairs):
        inner = outer[p].subgridspec(2, 1, height_ratios=[2, 1], hspace=0.06)
        mag = fig.add_subplot(inner[0], sharex=fig.axes[0] if fig.axes else None)
        phase = fig.add_subplot(inner[1], sharex=mag)
        mag.tick_params(labelbottom=False)
        if measured is not None:  # solid where the forces explain the output (coherence >= 0.5), dotted elsewhere
            out = output_index or 0 if single else o
            h1 = measured.frf[:, out, input_index or 0] if single else measured.frf[:, o, i]
            # thousands of lines: those that draw the same curve at the axes' width (the noise's envelope kept)
            kept = _thinned(measured.freqs_hz, np.abs(h1), _FRF_COLUMNS, log_frequency)
            freqs, h1 = measured.freqs_hz[kept], h1[kept]
            shown = measured.coherence[kept, out] >= 0.5
            angle = _phase_degrees(h1)
            mag.semilogy(freqs, np.abs(h1), ":", color="0.6", lw=0.6)
            mag.semilogy(freqs, np.where(shown, np.abs(h1), np.nan), "-", color="0.45", lw=0.8,
                         label="measured (H1; dotted: coherence < 0.5)")
            phase.plot(freqs, np.where(shown, angle, np.nan), "-", color="0.45", lw=0.6)
        if exact is not None:
            ref = exact[:, 0, 0] if single else exact[:, o, i]
            mag.semilogy(freqs_hz, np.abs(ref), "k-", lw=2.5, alpha=0.45, label="exact")
            phase.plot(freqs_hz, _phase_degrees(ref), "k-", lw=2.5, alpha=0.45)
        for k, (res, h) in enumerate(zip(results, frfs)):
            label = labels[k] if labels else res.candidate.name
            style = {"ls": _STYLES[k % len(_STYLES)], "lw": max(0.9, 1.8 - 0.3 * k), "color": f"C{k}"}
            mag.semilogy(freqs_hz, np.abs(h[:, o, i]), label=label, **style)  # line styles: no model hides another
            phase.plot(freqs_hz, _phase_degrees(h[:, o, i]), **style)
        # decades ticked and gridded, in plain text; minor ticks off: 8 per decade on 8 panels cost 0.3 s of drawing
        decade_ticks(mag.yaxis)
        mag.grid(True, which="major", axis="y", color="0.88", lw=0.6)
        pair = f"H{first.output_dofs[o]},{first.input_dofs[i]}"
        mag.set_ylabel(f"|{pair}| {units.label('frf')}")
        mag.set_title(f"output x{first.output_dofs[o]}, force at DOF {first.input_dofs[i]}", fontsize=9, y=1.0)
        phase.set_ylabel(f"∠{pair} [deg]")
        low, high = phase.get_ylim()
        steps = max(1.0, (high - low) / 360)  # 90, 180, 360, 720, ... degrees: at most 5 ticks
        phase.yaxis.set_major_locator(MultipleLocator(90 * 2 ** int(np.ceil(np.log2(steps)))))
        phase.set_xlabel("frequency [Hz]")
        if log_frequency:
            phase.set_xscale("log")
        phase.set_xlim(freqs_hz[0], freqs_hz[-1])
    if log_frequency:  # the panels share this axis: 1, 2, 5 per decade in plain numbers, inside the view
        frequency_ticks(fig.axes[0].xaxis)  # (once, after the scale: setting a scale resets the ticks)
    fig.axes[0].legend(fontsize=8)
    fig.suptitle("Underlying linear FRF", fontsize=11, y=1 - 0.1 / height, va="top")  # above the first title
    return fig


_STYLES = ("-", "--", "-.", ":")
_FRF_COLUMNS = 1000  # columns of a thinned measured FRF: more than the axes' pixels at the report's 150 dpi


def _thinned(x: np.ndarray, y: np.ndarray, columns: int, log: bool = False) -> np.ndarray:
    """Indices of the points of a line that draw it the same at ``columns`` columns across its x range.

    Per column: its first and last points and those of the lowest and highest ``y`` (in x
    order), so that a noisy curve keeps its envelope and a smooth one its shape; a column of up to
    four points keeps them all.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Increasing abscissae (positive when ``log``).
    y : ndarray, shape (n,)
        Finite ordinates.
    columns : int
        Columns across ``x[0] .. x[-1]`` (about the pixel width of the axes, or more).
    log : bool
        Columns of equal width on a logarithmic axis.

    Returns
    -------
    ndarray of int
        Increasing indices into ``x``.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = len(x)
    if n <= 4 * columns:
        return np.arange(n)
    g = np.log10(x) if log else x
    span = g[-1] - g[0]
    column = np.minimum(((g - g[0]) / span * columns).astype(int), columns - 1) if span > 0 else np.zeros(n, int)
    starts = np.flatnonzero(np.r_[True, column[1:] != column[:-1]])
    lengths = np.diff(np.r_[starts, n])
    owner = np.repeat(np.arange(len(starts)), lengths)
    low = np.minimum.reduceat(y, starts)[owner] == y
    high = np.maximum.reduceat(y, starts)[owner] == y
    last = np.r_[starts[1:] - 1, n - 1]
    keep = np.zeros(n, dtype=bool)
    keep[starts] = keep[last] = True
    # the first lowest and first highest point of each column
    for extreme in (low, high):
        where = np.flatnonzero(extreme)
        _, first = np.unique(owner[where], return_index=True)
        keep[where[first]] = True
    return np.flatnonzero(keep)


def _phase_degrees(h: np.ndarray) -> np.ndarray:
    """Phase [deg] in (-180, 180]; NaN just before each wrap, so that no line jumps across the axis."""
    angle = np.degrees(np.angle(h))
    angle[np.flatnonzero(np.abs(np.diff(angle)) > 180.0)] = np.nan  # the line breaks where the phase wraps
    return angle


def plot_coefficient_spectrum(result, freqs_hz=None, axes=None, units=None):
    """Real and imaginary parts of λ_i(ω) with the averaging band (paper Fig. 5).

    Parameters
    ----------
    result : NSIResult
        An identification with at least one nonlinear term.
    freqs_hz : ndarray, optional
        Frequencies [Hz]; by default around the averaging band.
    axes : sequence of matplotlib.axes.Axes, optional
        One per term; a new figure when None.
    units : ChannelUnits, optional
        Units of the data, for the unit of each λ (:func:`bayesnsi.io.units.term_unit`).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        For a linear candidate.
    """
    q = len(result.terms)
    if q == 0:
        raise ValueError("a linear candidate has no nonlinear coefficients to plot")
    if freqs_hz is None:
        lo, hi = result.band_hz
        freqs_hz = np.linspace(0.5 * lo, min(1.3 * hi, 0.5 * (result.fit.fs or 2 * hi)), 400)
    spectrum = result.coefficient_spectrum(freqs_hz)
    if axes is None:
        fig, axes = plt.subplots(q, 1, figsize=(6.0, 2.6 * q), squeeze=False, layout="constrained")
        axes = axes[:, 0]
    else:
        fig = np.atleast_1d(axes)[0].figure
    for k, ax in enumerate(np.atleast_1d(axes)):
        coef = result.coefficients[k]
        ax.plot(freqs_hz, spectrum[:, k].real, label="Re λ(ω)")
        ax.plot(freqs_hz, spectrum[:, k].imag, label="Im λ(ω)")
        ax.axvspan(*result.band_hz, color="0.9", zorder=0, label="averaging band")
        ax.axhline(coef.value, color="C3", ls="--", lw=1, label=f"estimate {coef.value:.4g}")
        ax.set_title(f"{coef.term.name}  (|Im|/|Re| = {coef.imag_ratio:.3f})", fontsize=9, **title_height(ax))
        ax.set_xlabel("frequency [Hz]")
        unit = term_unit(coef.term.expr.text, units or ChannelUnits())
        ax.set_ylabel(f"λ(ω) [{unit or 'force per unit of n(x, v)'}]")
        ax.legend(fontsize=7)
    return fig


def plot_coefficient_spectra(results, units=None):
    """λ(ω) of every term of several candidates in one figure, a panel each, two panels a row (paper Fig. 5).

    Parameters
    ----------
    results : mapping of str to NSIResult
        The candidates by label; linear ones are left out.
    units : ChannelUnits, optional
        Units of the data, for the unit of each λ (:func:`bayesnsi.io.units.term_unit`).

    Returns
    -------
    matplotlib.figure.Figure
        The panels of :func:`plot_coefficient_spectrum`, each titled with its candidate.

    Raises
    ------
    ValueError
        If no candidate has a nonlinear term.
    """
    shown = {name: res for name, res in results.items() if res.terms}
    n = sum(len(res.terms) for res in shown.values())
    if n == 0:
        raise ValueError("no candidate has nonlinear coefficients to plot")
    longest = max(len(name) + len(term.name) for name, res in shown.items() for term in res.terms)
    cols = 2 if n > 1 and longest <= 30 else 1  # side by side while the panels' titles fit their width
    rows = -(-n // cols)
    width, height = (6.5 if cols == 1 else 10.5), 2.7 * rows + 0.2
    # fixed margins [in] (constrained layout doubles the drawing time), room for the labels of λ's units
    left, right, top, bottom, gap_x, gap_y = 1.0, 0.15, 0.35, 0.5, 1.2, 0.85
    panel_width = (width - left - right - gap_x * (cols - 1)) / cols
    panel_height = (height - top - bottom - gap_y * (rows - 1)) / rows
    fig, grid = plt.subplots(rows, cols, figsize=(width, height), squeeze=False, gridspec_kw={
        "left": left / width, "right": 1 - right / width, "top": 1 - top / height, "bottom": bottom / height,
        "wspace": gap_x / panel_width, "hspace": gap_y / panel_height})
    panels = list(grid.ravel())
    for ax in panels[n:]:
        ax.remove()
    start = 0
    for name, res in shown.items():
        axes = panels[start : start + len(res.terms)]
        plot_coefficient_spectrum(res, axes=axes, units=units)
        for ax in axes:
            ax.set_title(f"{name}: {ax.get_title()}", fontsize=9)
        start += len(res.terms)
    return fig
