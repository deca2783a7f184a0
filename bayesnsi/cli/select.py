"""``bayesnsi select CONFIG --out DIR``: NSI of every candidate, evidence, ranking, report."""

from __future__ import annotations

import sys
import warnings

from ..exceptions import AdequacyWarning
from ._common import add_run_arguments, execution, progress, refuse_if_nothing_identified, start_run

__all__ = ["add_parser", "run", "run_selection"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "select",
        help="identify every candidate and rank them by Bayesian evidence",
        description="Identify every candidate of CONFIG by NSI, compute the paper's plain Gaussian ranking "
        "and the marginal evidence (MCMC + bridge sampling) under the chosen residual model, and write "
        "DIR/results.json and DIR/report.html.",
        epilog="example: bayesnsi select two_dof.toml --out results/two_dof",
    )
    add_run_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    from ..io import RESULTS_FILENAME, atomic_write_json, selection_payload
    from ..io.posterior import write_posteriors
    from ._report import (
        answer_data_warnings,
        held_figures,
        identification_report,
        report_units,
        selection_sections,
    )

    config, out, signals = start_run(args)
    selection = run_selection(config, signals, args, out)
    payload = selection_payload(selection, "select", config)
    payload["data_warnings"] = list(args.data_warnings)
    payload["posterior_files"] = write_posteriors(out, selection.evidences, selection.likelihood)
    if not args.no_figures:
        with held_figures():
            units = report_units(config)
            report = identification_report(
                config, signals, selection.results, payload["candidates"], f"bayesnsi select - {config.path.name}",
                units=units, data_warnings=args.data_warnings,
            )
            selection_sections(report, signals, selection, selection.selected, units)
            answer_data_warnings(report, args.data_warnings)
            progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    path = atomic_write_json(out / RESULTS_FILENAME, payload)  # last: a complete folder, or a rerun resumes
    progress(f"wrote {path}", args.quiet)
    refuse_if_nothing_identified(selection.outcomes, path, evidence=True)
    progress(f"selected: {selection.selected}{_adequacy_text(selection)}", args.quiet)
    print_selection_warnings(selection)
    return 0


def print_selection_warnings(selection) -> None:
    """The selection's warnings on stderr, shown even with ``--quiet`` (adequacy, issue 15).

    Parameters
    ----------
    selection : Selection
    """
    from ._report_choices import inadequacy_note  # numpy: not on the path of ``--help``

    if selection.checks and selection.plausible != selection.selected:
        print(f"warning: the selected model fails a physical check (warnings below); the most probable candidate "
              f"that passes every check: {selection.plausible or 'none'}"
              f"{inadequacy_note(selection.checks.get(selection.plausible))}", file=sys.stderr)
    from .._text import printable

    for message in selection.warnings:
        print(f"warning: {printable(message)}", file=sys.stderr)


def run_selection(config, signals, args, out):
    """:func:`bayesnsi.selection.select` on a config's candidates with the command line's backend.

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
        warnings.simplefilter("ignore", AdequacyWarning)  # printed once, plainly, by run()
        return select(
            signals, config.candidates, config.nsi, config.evidence, execution=options,
            validation=load_validation(config),
        )


def _adequacy_text(selection) -> str:
    whiteness = selection.adequacy.get(selection.selected)
    check = selection.checks.get(selection.selected)
    if whiteness is None and check is not None:  # e.g. integrated accelerations: no whiteness test (coloured noise)
        return (f" (its open-loop residual is {check.noise_ratio:.3g}x the noise it passes on; sensor noise from "
                f"{check.noise_source})")
    if whiteness is None:
        return ""
    if whiteness.adequate:
        return f" (its {whiteness.residual} residual is white: Ljung-Box p >= {min(whiteness.p_value):.2g})"
    return (
        f" - but its {whiteness.residual} residual is not white (Ljung-Box p = {min(whiteness.p_value):.2g}): "
        "an effect may be missing from every candidate; try `bayesnsi diagnose`"
    )
