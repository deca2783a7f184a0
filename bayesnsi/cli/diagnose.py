"""``bayesnsi diagnose CONFIG --out DIR``: close the loop from the selected model (SPEC 7)."""

from __future__ import annotations

import numpy as np

from ..io import RESULTS_FILENAME, atomic_write_json, load_validation, to_jsonable, versions
from ..io.schema import term_record
from ._common import add_run_arguments, progress, run_options, start_run
from ._report import identification_report, selection_sections
from ._selection import select_all
from .select import validate

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "diagnose",
        help="close the loop: find an effect the selected model lacks, add it, report before/after",
        description="Select a model as `bayesnsi select` does (or start from --start NAME), then search a "
        "dictionary of effects (x², x|x|, x³, sign(v), v|v|, v³, x²·sign(v), clearances; at each measured DOF "
        "and between neighbouring DOFs) for what its residual lacks; add an effect only when the Bayes factor, "
        "its quality index and its stability across record halves support it; repeat.",
        epilog="example: bayesnsi diagnose workflows/silverbox/silverbox.toml --start linear --out out/sb-loop",
    )
    add_run_arguments(p)
    p.add_argument("--start", default=None, help="candidate to start from (default: the selected one)")
    p.add_argument("--max-steps", type=int, default=3, help="most effects to add (default 3)")
    p.add_argument("--threshold", type=float, default=float(np.log(100.0)), help="log Bayes factor to accept (default log 100)")
    p.add_argument(
        "--screen",
        type=int,
        default=None,
        help="re-identify only the N effects ranked best by the frequency-domain screen (default: close_the_loop's, "
        "6; 0: every effect)",
    )
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    from ..diagnose import close_the_loop
    from ..exceptions import ConfigError

    config, out, signals = start_run(args)
    results, records, evidences, table, opts = select_all(config, signals, quiet=args.quiet, **run_options(args, out))
    ranked = [r for r in records if r["status"] == "ok"]
    if not ranked:
        raise ConfigError("no candidate could be identified, so there is no model to start the loop from")
    start = args.start or max(ranked, key=lambda r: r["posterior"])["name"]
    if start not in results:
        raise ConfigError(f"--start {start!r} is not an identified candidate; choose one of {sorted(results)}")
    progress(f"closing the loop from {start!r} ...", args.quiet)
    loop_options = config.loop.replace(threshold=args.threshold, max_steps=args.max_steps)
    if args.screen is not None:
        loop_options = loop_options.replace(screen=args.screen or None)
    loop = close_the_loop(
        signals,
        results[start].candidate,
        nsi_options=config.nsi,
        evidence_options=opts.replace(residual=loop_options.residual, compare=()),
        threshold=loop_options.threshold,
        max_steps=loop_options.max_steps,
        screen=loop_options.screen,
        seed=config.seed,
        jobs=getattr(args, "jobs", 1),
        scheduler=getattr(args, "scheduler", None),
    )
    validation = load_validation(config)
    steps = []
    for step in loop.steps:
        steps.append(
            {
                "added": term_record(step.term),
                "effect_type": step.effect_type,
                "accepted": step.accepted,
                "reason": step.reason,
                "coefficient": step.coefficient,
                "ci95": list(step.ci95),
                "imag_ratio": step.imag_ratio,
                "half_coefficients": list(step.half_coefficients),
                "bayes_factor_log": step.log_bayes_factor,
                "nrmse_before": step.nrmse_before,
                "nrmse_after": step.nrmse_after,
                "closed_loop_nrmse_before": step.closed_loop_nrmse_before,
                "closed_loop_nrmse_after": step.closed_loop_nrmse_after,
            }
        )
        progress(f"{'added' if step.accepted else 'rejected'} {step.term.name}: {step.reason}", args.quiet)
    payload = {
        "command": "diagnose",
        "config": str(config.path),
        "selected": start,
        "final_model": [term_record(t) for t in loop.final.terms],
        "final_coefficients": [
            {"term": c.term.name, "value": c.value, "imag_ratio": c.imag_ratio} for c in loop.final.coefficients
        ],
        "candidates": records,
        "loop": [s for s in steps if s["accepted"]],
        "loop_rejected": [s for s in steps if not s["accepted"]],
        "validation_before": validate(loop.start, validation),
        "validation": validate(loop.final, validation),
        "settings": {"config": config.raw, "seed": config.seed, "evidence": opts.to_dict(), "loop": to_jsonable(loop.settings)},
        "versions": versions(),
    }
    path = atomic_write_json(out / RESULTS_FILENAME, to_jsonable(payload))
    if not args.no_figures:
        report = identification_report(config, signals, results, records, f"bayesnsi diagnose - {config.path.name}")
        selection_sections(report, signals, results, evidences, table, opts, start)
        _loop_section(report, signals, loop, payload)
        progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    progress(f"wrote {path}", args.quiet)
    return 0


def _loop_section(report, signals, loop, payload):
    import pandas as pd

    from ..plots import plot_effect_force

    blocks = report.section("Closing the loop (SPEC 7)")
    blocks.append(
        "Each row is the best effect of a step; it is added only if the log Bayes factor (Laplace, on the "
        "residual named in the loop settings) exceeds the threshold, its quality index |Im|/|Re| is small and its "
        "coefficient keeps sign and size on both record halves. The credible interval ci95 is sampled (emcee) "
        "for the effects that pass; rejected ones show none. nrmse_before/after: open-loop reconstruction of the "
        "estimation data; closed_loop_nrmse_before/after: closed-loop simulation of it (NaN where the simulation "
        "diverges, e.g. chaotic responses, SPEC 10)."
    )
    rows = payload["loop"] + payload["loop_rejected"]
    if rows:
        blocks.append(pd.DataFrame(rows).drop(columns=["added"]).assign(effect=[r["added"]["expr"] + f" @ {r['added']['at']}" for r in rows]))
    blocks.append(
        pd.DataFrame(
            {
                "before (closed-loop rmse)": {v["name"]: v["rmse"] for v in payload["validation_before"]},
                "after (closed-loop rmse)": {v["name"]: v["rmse"] for v in payload["validation"]},
            }
        )
    )
    if payload["final_coefficients"]:
        final_nsi = loop.settings.get("final_nsi", {})
        note = (
            f" It was re-identified with upsample = {final_nsi['upsample']} because it holds a term that switches "
            "with velocity (coefficients at the data rate are biased by the switching between samples)."
            if final_nsi.get("upsample", 1) > 1 and loop.settings.get("nsi", {}).get("upsample", 1) == 1
            else ""
        )
        blocks.append("Coefficients of the final model (NSI estimate; quality index |Im|/|Re|)." + note)
        blocks.append(pd.DataFrame(payload["final_coefficients"]).set_index("term"))
    for step in loop.steps:
        if step.accepted:
            fig = plot_effect_force(step, signals)
            fig.set_label(
                f"Restoring-force view at the location of {step.term.name}: the residual of the model before the "
                "step as a force (top), and after it the residual (blue), the effect's force (black) and their sum "
                "(red), against displacement and velocity"
            )
            blocks.append(fig)
