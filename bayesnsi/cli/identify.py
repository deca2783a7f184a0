"""``bayesnsi identify CONFIG --out DIR``: NSI of every candidate, results.json and figures."""

from __future__ import annotations

import sys

from ._common import add_run_arguments, execution, progress, refuse_if_nothing_identified, start_run

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
    from ..io import RESULTS_FILENAME, atomic_write_json, identification_payload
    from ..run import run_candidates
    from ..run.free_view import one_view

    config, out, signals = start_run(args)
    with execution(args, out, config) as options:
        outcomes = run_candidates(signals, config.candidates, config.nsi, execution=options)
        outcomes, notes = one_view(signals, outcomes, config.nsi, None, options)  # free bodies: one view
    from ..nsi.order import order_messages

    for note in (*notes, *order_messages(outcomes)):  # order "auto" that may have missed modes, as select says
        print(f"warning: {note}", file=sys.stderr)
    payload = identification_payload(outcomes, "identify", config)
    payload["data_warnings"] = list(args.data_warnings)
    if not args.no_figures:
        from ._report import (
            answer_data_warnings,
            held_figures,
            identification_answer,
            identification_report,
            report_units,
        )

        with held_figures():
            results = {o.name: o.result for o in outcomes if o.result is not None}
            title = f"bayesnsi identify - {config.path.name}"
            units = report_units(config)
            report = identification_report(config, signals, results, payload["candidates"], title, units=units,
                                           data_warnings=args.data_warnings)
            identification_answer(report, signals, results, payload["candidates"], units)
            answer_data_warnings(report, args.data_warnings)
            progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    path = atomic_write_json(out / RESULTS_FILENAME, payload)  # last: a complete folder, or a rerun resumes
    progress(f"wrote {path}", args.quiet)
    refuse_if_nothing_identified(outcomes, path)
    return 0
