"""Report section of a periodic run: the best linear approximation and the distortion level.

Every run on a record with ``[data] period`` (identify, select, diagnose) shows the FRF averaged
over the periods with its noise and nonlinear-distortion levels (:func:`bayesnsi.plots.periodic.plot_bla`)
and, per response channel, the output power at the unexcited odd and even lines over its noise
level (:meth:`bayesnsi.nsi.BestLinearApproximation.unexcited_ratio`): about 1 means the response is
linear within the noise (a nonlinear model cannot gain anything), well above 1 means distortion a
nonlinear model can explain (docs/method.md §11).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..exceptions import BayesNSIError

__all__ = ["BLA", "distortion_text", "periodic_section"]

BLA = 35
"""Place of the section: after the identified models (30), before the figures (40)."""

HEADING = "Best linear approximation and nonlinear distortion (periodic data)"


def periodic_section(report, signals, units=None, figures: bool = True) -> bool:
    """Add the BLA figure and the distortion levels of ``signals`` to ``report`` (periodic data only).

    Parameters
    ----------
    report : Report
    signals : Signals
        Estimation data; nothing is added without ``signals.period`` or with several forces.
    units : ChannelUnits, optional
    figures : bool
        Draw the BLA figure.

    Returns
    -------
    bool
        True when the section was added.
    """
    import pandas as pd

    from ..nsi import best_linear_approximation
    from ..plots.periodic import plot_bla

    if signals.period is None or signals.force.shape[1] != 1:
        return False
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            bla = best_linear_approximation([signals])
    except BayesNSIError as err:
        report.section(HEADING, BLA).append(("warning", f"No best linear approximation: {err}"))
        return False
    ratios = bla.unexcited_ratio()
    names = [f"x{dof}" for dof in signals.output_dofs]
    table = pd.DataFrame(
        {
            "unexcited odd lines: power / noise": ratios["odd"],
            "unexcited even lines: power / noise": ratios["even"],
        },
        index=pd.Index(names, name="response"),
    )
    if bla.n_realisations > 1:
        table["excited lines: total / noise variance"] = bla.distortion_ratio()
    blocks = report.section(HEADING, BLA)
    blocks.append(distortion_text(ratios, bla.n_periods, bla.n_realisations, len(bla.freqs_hz)))
    blocks.append(table)
    if not figures:
        return True
    fig = plot_bla(bla, units=units, channel_names=names)
    fig.set_label("Best linear approximation |G| with its noise std and the output at the unexcited odd and even "
                  "lines over the force level (nonlinear distortion), per response")
    blocks.append(fig)
    return True


def distortion_text(ratios, n_periods: int, n_realisations: int, n_excited: int) -> str:
    """The sentence of the report that states the distortion level at the unexcited lines.

    A force that excites every line of its band (a full random-phase multisine, as in most
    benchmark records) leaves no unexcited line inside it, so there is no level to state: the
    sentence then says so and points to what can judge the models instead, rather than quoting
    an undefined ratio.

    Parameters
    ----------
    ratios : dict
        ``{"odd": (l,), "even": (l,)}``, the output power over the noise level at the unexcited
        odd and even lines per response (:meth:`bayesnsi.nsi.BestLinearApproximation.unexcited_ratio`;
        NaN where there is no such line).
    n_periods : int
        Periods averaged.
    n_realisations : int
        Realisations (records with new phases).
    n_excited : int
        Number of excited lines.

    Returns
    -------
    str
    """
    counts = f"({n_periods} periods, {n_realisations} realisation(s), {n_excited} excited lines)"
    found = {kind: np.asarray(ratios[kind], dtype=float) for kind in ("odd", "even")}
    levels = [
        f"up to {float(np.nanmax(values)):.3g} times its noise level at the unexcited {kind} lines"
        for kind, values in found.items() if np.any(np.isfinite(values))
    ]
    if not levels:
        return (
            f"Distortion level: not measurable here - the force excites every line of its band {counts}, so no "
            "line is left empty to show the nonlinear distortion apart from the noise (a full multisine; a "
            "random-odd multisine, bayesnsi.simulate.multisine(kind='random-odd'), leaves such lines, and several "
            "realisations separate the distortion on the excited lines). Judge the nonlinearity by the candidates' "
            "residuals against the noise (the adequacy check) instead."
        )
    return (
        f"Distortion level: the response at the lines the force leaves empty is {' and '.join(levels)} {counts}. "
        "About 1: linear within the noise, a nonlinear model cannot gain anything; well above 1: nonlinear "
        "distortion (odd lines: odd nonlinearities such as cubic springs or friction; even lines: even ones such "
        "as quadratic or one-sided contact). The channel with the largest ratio is nearest the nonlinearity."
    )
