"""``bayesnsi select CONFIG --out DIR``: NSI of every candidate, evidence, ranking, report."""

from __future__ import annotations

import sys
import warnings

from ..exceptions import AdequacyWarning
from ._common import add_run_arguments, execution, progress, refuse_if_nothing_identified, start_run, write_outputs

__all__ = ["add_parser", "posterior_files", "print_findings", "run", "run_selection"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "select",
        help="identify every candidate and rank them by Bayesian evidence",
        description="Identify every candidate of CONFIG by NSI, compute the paper's plain Gaussian ranking "
        "and the marginal evidence (emcee + bridge sampling) under the chosen residual model, and write "
        "DIR/results.json, DIR/posterior/<candidate>.nc and DIR/report.html.",
        epilog="example: bayesnsi select two_dof.toml --out results/two_dof",
    )
    add_run_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    from ..io import selection_payload
    from ..report.terminal import selection_lines

    config, out, signals, data_findings = start_run(args)
    selection = run_selection(config, signals, args, out)
    payload = selection_payload(selection, "select", config, data_findings)
    path = write_outputs(args, out, config, payload, posterior_files(selection),
                         lambda: _report().selection_report(
                             selection, config, f"bayesnsi select - {config.path.name}",
                             data_findings=data_findings))
    refuse_if_nothing_identified(selection.outcomes, path, evidence=True)
    for line in selection_lines(selection):
        progress(line, args.quiet)
    print_findings(selection)
    return 0


def posterior_files(selection) -> dict:
    """The posterior files of a selection's candidates: name -> (evidence under the primary likelihood, intervals).

    Parameters
    ----------
    selection : Selection

    Returns
    -------
    dict
    """
    return {o.name: (o.evidences[selection.likelihood], o.intervals) for o in selection.outcomes
            if o.evidences is not None and selection.likelihood in o.evidences}


def print_findings(selection) -> None:
    """The selection's findings on stderr, shown even with ``--quiet``.

    Parameters
    ----------
    selection : Selection
    """
    from ..report.choices import inadequacy_note

    if selection.checks and selection.plausible != selection.selected:
        print(f"warning: the selected model fails a physical check (warnings below); the most probable candidate "
              f"that passes every check: {selection.plausible or 'none'}"
              f"{inadequacy_note(selection.checks.get(selection.plausible))}", file=sys.stderr)
    from .._text import printable

    for finding in selection.findings:
        print(f"{finding.severity}: {printable(' '.join(finding.message.split()))}", file=sys.stderr)


def run_selection(config, signals, args, out):
    """:func:`bayesnsi.select` on a config's candidates with the command line's backend.

    Parameters
    ----------
    config : ExperimentConfig
    signals : Signals
        Estimation data of the config.
    args : argparse.Namespace
    out : Path

    Returns
    -------
    Selection
    """
    from ..io import load_validation
    from ..selection import select

    with execution(args, out, config) as options, warnings.catch_warnings():
        warnings.simplefilter("ignore", AdequacyWarning)  # printed once, plainly, from the findings
        return select(
            signals, config.candidates, config.nsi, config.evidence, execution=options,
            validation=load_validation(config),
        )


def _report():
    """The report package, imported only when a report is written (pandas, matplotlib: not with --no-figures)."""
    from .. import report

    return report
