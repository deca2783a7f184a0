"""``bayesnsi identify CONFIG --out DIR``: NSI of every candidate, results.json and figures."""

from __future__ import annotations

import sys

from ._common import add_run_arguments, execution, refuse_if_nothing_identified, start_run, write_outputs

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "identify",
        help="identify every candidate of a config by NSI",
        description="Identify every candidate of CONFIG by nonlinear subspace identification and write "
        "DIR/results.json (coefficients, modes, NRMSE) with figures.",
        epilog="example: bayesnsi identify two_dof.toml --out results/two_dof",
    )
    add_run_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    from ..io import identification_payload
    from ..nsi.order import order_findings
    from ..run import run_candidates
    from ..run.free_view import one_view

    config, out, signals, data_findings = start_run(args)
    with execution(args, out, config) as options:
        first = run_candidates(signals, config.candidates, config.nsi, execution=options)
        outcomes, view = one_view(signals, first, config.nsi, None, options)  # free bodies: one view
    for finding in (*view, *order_findings(outcomes)):  # order "auto" that may have missed modes, as select says
        print(f"{finding.severity}: {' '.join(finding.message.split())}", file=sys.stderr)
    payload = identification_payload(outcomes, "identify", config, data_findings)
    path = write_outputs(args, out, config, payload, {},
                         lambda: _report().identification_report(
                             outcomes, config, signals, f"bayesnsi identify - {config.path.name}",
                             data_findings=data_findings))
    refuse_if_nothing_identified(outcomes, path)
    return 0


def _report():
    """The report package, imported only when a report is written (pandas, matplotlib: not with --no-figures)."""
    from .. import report

    return report
