"""Report sections every command shares: identified models, figures, data and settings, versions.

Sections are placed by ``order`` (:class:`bayesnsi.report.document.Report`): the answer (0), the loop of
``diagnose`` (10), before the loop (15), the evidence of every candidate (20), the identified models
(30), figures (40), posteriors (50), data and settings (80), versions (90). Numbers come from the
library's typed results; this module arranges and words them.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from ..findings import Finding
from ..io import versions
from ..io.units import ChannelUnits
from ..nsi import stabilization
from .choices import frf_band, measured_text, overlay_channels
from .document import Report
from .periodic import periodic_section
from .text import options_toml

__all__ = [
    "ANSWER", "LOOP", "BEFORE", "EVIDENCE", "MODELS", "FIGURES", "POSTERIOR", "SETTINGS", "VERSIONS",
    "data_sections", "held_figures", "model_sections", "reconstruction_figures", "report_units", "with_unit",
]

ANSWER, LOOP, BEFORE, EVIDENCE, MODELS, FIGURES, POSTERIOR, SETTINGS, VERSIONS = 0, 10, 15, 20, 30, 40, 50, 80, 90
_RECONSTRUCTION_SAMPLES = 400  # samples shown in the measured-vs-model overlays


@contextlib.contextmanager
def held_figures():
    """A report's figures stay open until it is written (each is closed as it is rendered).

    Matplotlib warns past 20 open figures; a ``diagnose`` report with posteriors of many
    candidates holds more, on purpose, so the warning is off inside this block only. The objects
    the run made before are set aside from the garbage collector meanwhile (:func:`gc.freeze`):
    the figures' tens of thousands of short-lived artists trigger a full collection, which would
    otherwise scan the run's long-lived objects again (0.08 s of the 1 s a two-DOF report costs).
    """
    import gc

    from ..plots.rendering import many_open_figures

    gc.freeze()
    try:
        with many_open_figures():
            yield
    finally:
        gc.unfreeze()


def report_units(config) -> ChannelUnits:
    """Units the config's data file states (empty where it states none or cannot be read again).

    Parameters
    ----------
    config : ExperimentConfig

    Returns
    -------
    ChannelUnits
    """
    from ..exceptions import BayesNSIError
    from ..io.units import data_units

    try:
        return data_units(config)
    except (BayesNSIError, OSError, KeyError):
        return ChannelUnits()


def with_unit(term_name: str, units: ChannelUnits | None) -> str:
    """``"x3**3@3 [N/m^3]"``: a coefficient's label with the unit of λ when the data state units.

    Parameters
    ----------
    term_name : str
        A term's name (``expr@at``).
    units : ChannelUnits or None

    Returns
    -------
    str
    """
    from ..io.units import term_unit

    unit = term_unit(term_name.rsplit("@", 1)[0], units or ChannelUnits())
    return f"{term_name} [{unit}]" if unit else term_name


def _exact(config):
    meta = config.meta or {}
    if "exact_frequencies_hz" not in meta:
        return None, None, None
    coefs = None
    if meta.get("true_model"):
        cand = next((c for c in config.candidates if c.name == meta["true_model"]), None)
        if cand is not None and len(cand.terms) == len(meta.get("true_coefficients", [])):
            coefs = {t.name: v for t, v in zip(cand.terms, meta["true_coefficients"])}
    return meta["exact_frequencies_hz"], meta.get("exact_damping_ratios"), coefs


def exact_frf(config, result, freqs):
    """Exact underlying FRF (n_freq, l, m) of a simulated case whose matrices are in the config's [meta].

    Parameters
    ----------
    config : ExperimentConfig
    result : NSIResult
    freqs : ndarray

    Returns
    -------
    ndarray or None
    """
    meta = config.meta or {}
    dofs = tuple(result.output_dofs) + tuple(result.input_dofs)
    if not all(k in meta for k in ("M", "C", "K")) or len(meta["M"]) < max(dofs):
        return None
    from ..simulate import underlying_frf  # (imported only for a simulated case)

    return underlying_frf(meta["M"], meta["C"], meta["K"], freqs, result.output_dofs, result.input_dofs)


def model_sections(report: Report, config, signals, outcomes: Sequence, units: ChannelUnits,
                   figures: bool = True) -> None:
    """The identified models (tables), and their figures: FRF beside the data's, λ(ω), stabilisation.

    Parameters
    ----------
    report : Report
    config : ExperimentConfig
    signals : Signals
    outcomes : sequence of CandidateOutcome
    units : ChannelUnits
    figures : bool
        Draw the figures (a report without figures is written with ``--no-figures``).
    """
    import pandas as pd

    from ..tables import coefficients_table, modes_table, physical_table

    results = {o.name: o.result for o in outcomes if o.result is not None}
    periodic_section(report, signals, units, figures)  # periodic data: BLA figure and distortion level
    if not results:
        answer = report.section("Answer", ANSWER)
        answer.append(("warning", "No candidate could be identified (see Data and settings)."))
        return
    exact_f, exact_z, exact_coefs = _exact(config)
    tables = report.section("Identified models (paper Tables 3-4, 6-7, 9-10)", MODELS)
    tables.append("Natural frequencies and damping ratios of each candidate's underlying linear model.")
    tables.append(modes_table(results, exact_f, exact_z))
    physical = physical_table(results)
    if not physical.empty:  # one-DOF models (e.g. a free body, whose rigid-body pole is no mode)
        tables.append("Lumped parameters of the one-DOF models from the identified FRF (1/H = K - Mω² + jωC).")
        tables.append(physical)
    elif any(len(r.rigid_body_poles) for r in results.values()):  # a free body with several DOFs
        tables.append(_rigid_body_note(results))
    if any(r.terms for r in results.values()):
        tables.append("Nonlinear coefficients: the NSI estimate (mean real part of λ(ω) over the band of the modes) "
                      "and its quality index |Im|/|Re| (small is good).")
        frame = coefficients_table({k: r for k, r in results.items() if r.terms}, exact_coefs)
        tables.append(frame.rename(index=lambda t: with_unit(t, units)))
    nrmse = {o.name: o.nrmse for o in outcomes}
    tables.append(pd.DataFrame({"open-loop reconstruction error (NRMSE)": nrmse}).rename_axis("candidate"))
    if figures:
        _model_figures(report, config, signals, results, units)


def _model_figures(report: Report, config, signals, results: Mapping, units: ChannelUnits) -> None:
    from ..plots import plot_coefficient_spectra, plot_frf, plot_model_order

    figs = report.section("Figures", FIGURES)
    fmax, measured, wide = frf_band(signals, results)
    freqs = np.geomspace(fmax / 400, fmax, 600) if wide else np.linspace(fmax / 400, fmax, 600)
    first_name, first = next(iter(results.items()))
    fig = plot_frf(list(results.values()), freqs, exact=exact_frf(config, first, freqs), units=units,
                   measured=measured, log_frequency=wide, labels=list(results))
    fig.set_label("Underlying linear FRF of each candidate, magnitude and phase, every force/response pair "
                  "(paper Figs. 4, 8, 12), over the band the force excites, beside the data's own FRF (grey, H1: "
                  "Welch cross spectra, no model, shown where its coherence is at least 0.5; for a nonlinear "
                  "structure the linearisation at the test's level). A peak of the data that no model has is a mode "
                  "the models lack (a higher [nsi] order)")
    figs.append(fig)
    if any(res.terms for res in results.values()):
        fig = plot_coefficient_spectra(results, units=units)
        fig.set_label("Re and Im of λ(ω) of each candidate's terms: the estimate averages Re λ over the grey band "
                      "(paper Fig. 5)")
        figs.append(fig)
    _, diagram = stabilization(signals, first.candidate, block_rows=first.block_rows,
                               velocity_method=first.options.velocity_method)
    fig = plot_model_order(first, diagram, fmax_hz=fmax)
    fig.set_label(f"The model order, {first_name}: singular values (paper Figs. 3, 7, 11; the candidates' differ "
                  "little) and the stabilisation diagram")
    figs.append(fig)


def reconstruction_figures(report: Report, signals, results: Mapping, units: ChannelUnits,
                           order: int = FIGURES, heading: str = "Figures") -> None:
    """Measured responses against each model's open-loop reconstruction, on a few channels.

    Parameters
    ----------
    report : Report
    signals : Signals
    results : mapping of str to NSIResult
        The models shown, by label.
    units : ChannelUnits
    order : int
        Place of the section.
    heading : str
        Its heading.
    """
    if not results:
        return
    from ..plots import plot_reconstruction

    figs = report.section(heading, order)
    recs = {name: res.reconstruct(signals) for name, res in results.items()}
    names = list(signals.output_names)
    terms = [t for res in results.values() for t in res.terms]
    channels = overlay_channels(signals, terms)  # a few outputs, side by side: the report stays quick
    labels = [names[channel] for channel in channels]
    fig = plot_reconstruction(recs, signals.fs, channels, units=units, channel_name=labels,
                              max_samples=_RECONSTRUCTION_SAMPLES)
    fig.set_label(f"Measured {', '.join(labels)} and each model's open-loop reconstruction, with the errors, over "
                  f"the first {_RECONSTRUCTION_SAMPLES} samples (paper Figs. 9, 13)")
    figs.append(fig)


def data_sections(report: Report, config, signals, outcomes: Sequence, units: ChannelUnits,
                  data_findings: Iterable[Finding] = (), loop=None) -> None:
    """Data and settings (as TOML, the [diagnose] table included), failed candidates, versions.

    Parameters
    ----------
    report : Report
    config : ExperimentConfig
    signals : Signals
    outcomes : sequence of CandidateOutcome
    units : ChannelUnits
    data_findings : iterable of Finding
        What loading the data found (an integration band starting in the noise, a period the force
        does not repeat).
    loop : LoopOptions, optional
        The loop's settings (``diagnose``).
    """
    intro = report.section("Data and settings", SETTINGS)
    for finding in data_findings:
        intro.append(("warning", f"Loading the data: {finding.message}"))
    stated = ", ".join(f"{q} in {getattr(units, q)}" for q in ("force", "displacement") if getattr(units, q))
    intro.append(
        f"{signals.n_samples} samples at {signals.fs:g} Hz; forces at DOFs {list(signals.input_dofs)}, "
        f"displacements at DOFs {list(signals.output_dofs)}{measured_text(config)}; "
        + (f"units from the data file: {stated}; " if stated else "the data file states no units; ")
        + f"config {config.path.name}; seed {config.seed}."
    )
    intro.append(("pre", options_toml(config.nsi, config.evidence, loop)))
    failed = [o for o in outcomes if o.status == "failed"]
    if failed:
        intro.append(("warning", "Failed candidates: " + "; ".join(f"{o.name}: {o.error}" for o in failed)))
    listed = "\n".join(f"{k} {v}" for k, v in versions().items())
    report.section("Versions", VERSIONS).append(("pre", listed))


def answer_data_findings(report: Report, data_findings: Sequence[Finding]) -> None:
    """Close the Answer with a pointer to what loading the data found (shown in "Data and settings").

    Parameters
    ----------
    report : Report
    data_findings : sequence of Finding
    """
    if data_findings:
        report.section("Answer", ANSWER).append(("warning", f"Loading the data gave {len(data_findings)} warning(s), "
                                                 "shown under Data and settings: read them before the answer above "
                                                 "(e.g. an integration band that starts in the sensors' noise)."))


def _rigid_body_note(results) -> str:
    """Which candidates hold rigid-body poles (free body, several DOFs: no lumped parameters)."""
    parts = [
        f"{name}: {', '.join(f'{p.real:.3g}' + (f'{p.imag:+.3g}j' if p.imag else '') for p in r.rigid_body_poles)}"
        for name, r in results.items() if len(r.rigid_body_poles)
    ]
    return ("Rigid-body poles s [1/s] (a free body: identified with a virtual spring on the input, removed again; "
            "not modes): " + "; ".join(parts) + ".")
