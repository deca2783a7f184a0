"""``bayesnsi select CONFIG --out DIR``: NSI of every candidate, evidence, ranking, report."""

from __future__ import annotations

import numpy as np

from ..exceptions import BayesNSIError
from ..io import RESULTS_FILENAME, atomic_write_json, load_validation, to_jsonable, versions
from ._common import add_run_arguments, progress, run_options, start_run
from ._report import identification_report, selection_sections
from ._selection import select_all

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "select",
        help="identify every candidate and rank them by Bayesian evidence",
        description="Identify every candidate of CONFIG by NSI, compute the paper's plain Gaussian ranking "
        "and the marginal evidence (emcee + bridge sampling) under the chosen residual model, and write "
        "DIR/results.json and DIR/report.html.",
        epilog="example: bayesnsi select two_dof.toml --out results/two_dof",
    )
    add_run_arguments(p)
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    config, out, signals = start_run(args)
    results, records, evidences, table, opts = select_all(config, signals, quiet=args.quiet, **run_options(args, out))
    ranked = [r for r in records if r.get("posterior") is not None and r["status"] == "ok"]
    selected = max(ranked, key=lambda r: r["posterior"])["name"] if ranked else None
    validation = load_validation(config)
    for record in records:
        if record["name"] in results:
            record["validation"] = validate(results[record["name"]], validation)
    payload = {
        "command": "select",
        "config": str(config.path),
        "selected": selected,
        "selected_gaussian": max(records, key=lambda r: r.get("posterior_gaussian") or 0.0)["name"] if ranked else None,
        "likelihood": opts.likelihood,
        "candidates": records,
        "validation": next((r["validation"] for r in records if r["name"] == selected), []),
        "ranking": to_jsonable(table.reset_index().to_dict(orient="records")),
        "settings": {"config": config.raw, "seed": config.seed, "evidence": opts.to_dict()},
        "versions": versions(),
    }
    path = atomic_write_json(out / RESULTS_FILENAME, to_jsonable(payload))
    progress(f"selected: {selected}", args.quiet)
    if not args.no_figures:
        report = identification_report(config, signals, results, records, f"bayesnsi select - {config.path.name}")
        selection_sections(report, signals, results, evidences, table, opts, selected)
        progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    progress(f"wrote {path}", args.quiet)
    return 0


VALIDATION_INIT_SAMPLES = 50
"""Samples at the start of each validation segment used only to estimate the initial state."""


def validate(result, segments) -> list[dict]:
    """Closed-loop simulation of ``result`` on each validation segment (SPEC 9 ``validation``).

    The first :data:`VALIDATION_INIT_SAMPLES` samples fix the initial state; the errors are
    computed on the rest (rmse in the output's units, nrmse = rms(e)/rms(y)).
    """
    out = []
    for name, signals in segments:
        try:
            rec = result.reconstruct(signals, closed_loop=True, n_init=VALIDATION_INIT_SAMPLES)
        except BayesNSIError as err:
            out.append({"name": name, "rmse": None, "nrmse": None, "error": str(err)})
            continue
        err = rec.residual[VALIDATION_INIT_SAMPLES:]
        meas = rec.measured[VALIDATION_INIT_SAMPLES:]
        rmse = np.sqrt(np.mean(err**2, axis=0))
        out.append(
            {
                "name": name,
                "rmse": float(np.sqrt(np.mean(rmse**2))),
                "nrmse": float(np.sqrt(np.mean(np.mean(err**2, axis=0) / np.mean(meas**2, axis=0)))),
                "rmse_per_channel": rmse.tolist(),
            }
        )
    return out
