"""Readable reports of the library's answers: one self-contained HTML page, and the terminal's lines.

Built only from the typed results (:class:`~bayesnsi.selection.Selection`,
:class:`~bayesnsi.diagnosis.Diagnosis`, the candidates' outcomes), never from results.json, so that
the report, the terminal and the files tell one story:

- :func:`selection_report`: the answer (model, probability, Bayes factor in words, coefficients
  and modes with honest intervals, adequacy), the evidence of every candidate, the models, figures,
  posteriors, data and settings;
- :func:`diagnosis_report`: the final model first, the loop step by step, then the selection it
  started from;
- :func:`identification_report`: the identified candidates without a ranking;
- :mod:`~bayesnsi.report.terminal`: the lines the command line prints.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..findings import Finding

if TYPE_CHECKING:
    from ..io.units import ChannelUnits
    from .document import Report

# submodules are imported on first use (PEP 562): the terminal's lines need neither pandas nor matplotlib
_LAZY = {
    "FIGURE_DPI": "document", "Report": "document", "format_number": "document", "held_figures": "sections",
    "report_units": "sections", "diagnosis_lines": "terminal", "outcome_line": "terminal",
    "selection_lines": "terminal", "step_line": "terminal",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'bayesnsi.report' has no attribute {name!r}")
    return getattr(importlib.import_module(f".{module}", __name__), name)


__all__ = [
    "FIGURE_DPI",
    "Report",
    "diagnosis_lines",
    "diagnosis_report",
    "format_number",
    "held_figures",
    "identification_report",
    "outcome_line",
    "report_units",
    "selection_lines",
    "selection_report",
    "step_line",
]


def selection_report(selection, config, title: str, *, units: ChannelUnits | None = None,
                     data_findings: Sequence[Finding] = (), figures: bool = True) -> Report:
    """The report of a selection (``bayesnsi select``).

    Parameters
    ----------
    selection : Selection
    config : ExperimentConfig
        The config it ran (its data mapping, settings and simulated truth, when it holds one).
    title : str
    units : ChannelUnits, optional
        Units of the data (default: those the config's data file states).
    data_findings : sequence of Finding
        What loading the data found.
    figures : bool
        Draw the figures.

    Returns
    -------
    Report
    """
    from .answer import evidence_sections, posterior_sections, selection_answer
    from .document import Report
    from .sections import answer_data_findings, data_sections, model_sections, reconstruction_figures, report_units

    units = report_units(config) if units is None else units
    report = Report(title, figures=figures)
    signals = selection.signals
    selection_answer(report, selection, units)
    answer_data_findings(report, data_findings)
    evidence_sections(report, selection, units)
    model_sections(report, config, signals, selection.outcomes, units, figures)
    if figures:
        reconstruction_figures(report, signals, selection.results, units)
    if selection.evidence is not None:
        likelihood = selection.evidence.likelihood
        posterior_sections(report, {n: by[likelihood] for n, by in selection.evidences.items()}, likelihood, units)
    data_sections(report, config, signals, selection.outcomes, units, data_findings)
    return report


def diagnosis_report(diagnosis, config, title: str, *, units: ChannelUnits | None = None,
                     data_findings: Sequence[Finding] = (), figures: bool = True) -> Report:
    """The report of a diagnosis (``bayesnsi diagnose``): the final model first.

    Parameters
    ----------
    diagnosis : Diagnosis
    config : ExperimentConfig
    title : str
    units : ChannelUnits, optional
    data_findings : sequence of Finding
    figures : bool

    Returns
    -------
    Report
    """
    from .answer import evidence_sections
    from .document import Report
    from .loop import diagnosis_sections
    from .sections import answer_data_findings, data_sections, model_sections, report_units

    units = report_units(config) if units is None else units
    report = Report(title, figures=figures)
    selection = diagnosis.selection
    diagnosis_sections(report, diagnosis, units)
    answer_data_findings(report, data_findings)
    evidence_sections(report, selection, units)
    model_sections(report, config, selection.signals, selection.outcomes, units, figures)
    data_sections(report, config, selection.signals, selection.outcomes, units, data_findings, diagnosis.options)
    return report


def identification_report(outcomes, config, signals, title: str, *, units: ChannelUnits | None = None,
                          data_findings: Sequence[Finding] = (), figures: bool = True) -> Report:
    """The report of ``bayesnsi identify``: every candidate identified, none ranked.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
    config : ExperimentConfig
    signals : Signals
    title : str
    units : ChannelUnits, optional
    data_findings : sequence of Finding
    figures : bool

    Returns
    -------
    Report
    """
    import pandas as pd

    from .document import Report
    from .sections import (
        ANSWER,
        answer_data_findings,
        data_sections,
        model_sections,
        reconstruction_figures,
        report_units,
    )

    units = report_units(config) if units is None else units
    report = Report(title, figures=figures)
    results = {o.name: o.result for o in outcomes if o.result is not None}
    answer = report.section("Answer", ANSWER)
    answer.append(("lead", f"Identified {len(results)} of {len(outcomes)} candidates by nonlinear subspace "
                           "identification. `bayesnsi identify` does not compare them; `bayesnsi select` ranks them by "
                           "Bayesian evidence."))
    rows = {
        name: {
            "model order": res.order,
            "natural frequencies [Hz]": ", ".join(f"{m.frequency_hz:.4g}" for m in res.modes),
            "coefficients": "; ".join(f"{c.term.name} = {c.value:.4g}" for c in res.coefficients) or "—",
        }
        for name, res in results.items()
    }
    if rows:
        answer.append(pd.DataFrame(rows).T.rename_axis("candidate"))
    answer_data_findings(report, data_findings)
    model_sections(report, config, signals, outcomes, units, figures)
    if figures:
        reconstruction_figures(report, signals, results, units)
    data_sections(report, config, signals, outcomes, units, data_findings)
    return report
