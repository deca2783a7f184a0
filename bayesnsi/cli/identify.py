"""``bayesnsi identify CONFIG --out DIR``: NSI of every candidate, results.json and figures."""

from __future__ import annotations

from ..io import RESULTS_FILENAME, atomic_write_json, to_jsonable, versions
from ._common import add_run_arguments, identify_all, progress, run_options, start_run
from ._report import identification_report

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
    config, out, signals = start_run(args)
    results, records, _ = identify_all(config, signals, quiet=args.quiet, **run_options(args, out))
    payload = {
        "command": "identify",
        "config": str(config.path),
        "selected": None,
        "candidates": records,
        "settings": {"config": config.raw, "seed": config.seed},
        "versions": versions(),
    }
    path = atomic_write_json(out / RESULTS_FILENAME, to_jsonable(payload))
    if not args.no_figures:
        report = identification_report(config, signals, results, records, f"bayesnsi identify - {config.path.name}")
        progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    progress(f"wrote {path}", args.quiet)
    return 0
