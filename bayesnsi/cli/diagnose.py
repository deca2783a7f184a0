"""``bayesnsi diagnose CONFIG --out DIR``: close the loop from the selected model (docs/method.md §7)."""

from __future__ import annotations

from ..options import LoopOptions
from ._common import add_option_flags, add_run_arguments, option_overrides, progress, start_run
from .select import print_selection_warnings, run_selection

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
    p.add_argument("--start", default=None, help="candidate to start from (default: the selected one, or the most "
                   "probable that passes every physical check when the selected one fails one)")
    add_option_flags(
        p, LoopOptions,
        ("max_steps", "threshold", "screen", "residual", "max_imag_ratio", "stability_factor", "max_shared",
         "n_tries", "refine_final", "lookahead", "effects"),
    )
    p.set_defaults(run=run)


def run(args) -> int:
    """Execute the command."""
    from ..diagnose import close_the_loop, loop_effects
    from ..exceptions import ConfigError
    from ..io import RESULTS_FILENAME, atomic_write_json, load_validation, selection_payload, term_record, to_jsonable
    from ..io.posterior import write_posteriors
    from ..options import ExecutionOptions
    from ..validation import validate
    from ._loop_report import loop_sections, loop_summary
    from ._report import (
        answer_data_warnings,
        held_figures,
        identification_report,
        report_units,
        selection_sections,
    )

    config, out, signals = start_run(args)
    names = [c.name for c in config.candidates]
    if args.start is not None and args.start not in names:  # before any work
        raise ConfigError(f"--start {args.start!r} is not a candidate of the config; choose one of {names}")
    loop_options = option_overrides(config.loop, args)
    loop_effects(signals, loop_options.effects)  # unknown effect names: ConfigError before any work
    selection = run_selection(config, signals, args, out)
    print_selection_warnings(selection)  # as select: what the ranking should not be trusted for
    results = selection.results
    if not results:
        raise ConfigError("no candidate could be identified, so there is no model to start the loop from")
    # by default the loop starts from the selected model, or, when that fails a physical check (negative
    # dissipation, quality index: Selection.plausible), from the most probable one that passes
    start = args.start or selection.plausible or selection.selected or next(iter(results))
    if start not in results:
        error = next((o.error for o in selection.outcomes if o.name == start), None)
        raise ConfigError(
            f"--start {start!r} could not be identified ({error or 'no model'}), so the loop cannot start from it; "
            "change [nsi] block_rows or order until it identifies (bayesnsi identify shows each candidate), "
            f"or start from one of {sorted(results)}"
        )
    progress(f"closing the loop from {start!r} ...", args.quiet)
    execution = ExecutionOptions(jobs=getattr(args, "jobs", 1), scheduler=getattr(args, "scheduler", None))
    loop = close_the_loop(
        signals, results[start].candidate, loop_options,
        nsi=config.nsi, evidence=selection.evidence, execution=execution,
    )
    validation = load_validation(config)
    progress(f"loop done ({len(loop.steps)} effects checked); evidence, intervals and check of the final model ...",
             args.quiet)
    final_validation = validate(loop.final, validation)
    final_evidence, final_intervals, final_check = _final_evidence(loop, signals, selection, start, final_validation)
    steps = []
    for step in loop.steps:
        steps.append(
            {
                "added": term_record(step.term),
                "effect_type": step.effect.name,
                "effect": _effect_record(step.effect),
                "accepted": step.accepted,
                "reason": step.reason,
                "coefficient": step.coefficient,
                "ci95": list(step.ci95),
                "imag_ratio": step.imag_ratio,
                "half_coefficients": list(step.half_coefficients),
                "half_block_rows": step.half_block_rows,
                "half_note": step.half_note,
                "bayes_factor_log": step.log_bayes_factor,
                "nrmse_before": step.nrmse_before,
                "nrmse_after": step.nrmse_after,
                "closed_loop_nrmse_before": step.closed_loop_nrmse_before,
                "closed_loop_nrmse_after": step.closed_loop_nrmse_after,
                "error_quantity": step.error_quantity,
                "short_horizon_nrmse_before": step.short_horizon_nrmse_before,
                "short_horizon_nrmse_after": step.short_horizon_nrmse_after,
                "search": step.search,  # the effects that search screened and scored, what became of each
                "screened": [] if step.search is None else loop.search_records(step.search),
            }
        )
        progress(f"{'added' if step.accepted else 'rejected'} {step.term.name}: {step.reason}", args.quiet)
    payload = selection_payload(
        selection,
        "diagnose",
        config,
        start=start,  # "selected" stays the ranking's choice (issue 14: --start is not a selection)
        final_model=[term_record(t) for t in loop.final.terms],
        final_coefficients=_final_coefficients(
            loop, final_intervals, final_evidence or selection.evidences.get(start, {}).get(selection.likelihood)
        ),
        loop=[s for s in steps if s["accepted"]],
        loop_rejected=[s for s in steps if not s["accepted"]],
        validation_before=[e.to_dict() for e in validate(loop.start, validation)],
        validation=[e.to_dict() for e in final_validation],
    )
    payload["settings"]["loop"] = to_jsonable(loop.settings)
    payload["data_warnings"] = list(args.data_warnings)
    if final_intervals is not None:  # as select's "intervals": coefficients and modes, method, windows
        payload["final_intervals"] = to_jsonable(final_intervals.to_dict())
    if final_check is not None:  # the final model's adequacy, as select's model_check of a candidate
        payload["final_model_check"] = to_jsonable(final_check.to_dict())
    posteriors = dict(selection.evidences)
    if final_evidence is not None:  # the model the loop ends with, not only the one it started from
        final_name = "final: " + " + ".join(t.name for t in loop.final.terms)
        posteriors[final_name] = {selection.likelihood: final_evidence}
        payload["final_evidence"] = to_jsonable(final_evidence.to_dict())
    payload["posterior_files"] = write_posteriors(out, posteriors, selection.likelihood)
    payload["loop_scores"] = [loop.search_records(k) for k in range(len(loop.scores))]
    progress(loop_summary(loop, payload, start), args.quiet)
    for record in payload["final_coefficients"]:
        interval = f", 95 % [{record['ci95'][0]:.4g}, {record['ci95'][1]:.4g}]" if "ci95" in record else ""
        progress(f"  final {record['term']} = {record['value']:.4g}{interval} (|Im|/|Re| {record['imag_ratio']:.2g})",
                 args.quiet)
    if not args.no_figures:
        with held_figures():
            units = report_units(config)
            report = identification_report(
                config, signals, results, payload["candidates"], f"bayesnsi diagnose - {config.path.name}", units=units,
                data_warnings=args.data_warnings,
            )
            loop_sections(report, signals, loop, payload, units, has_validation=bool(validation),
                          final_evidence=final_evidence)
            role = ("Starting model, the one selected" if start == selection.selected else
                    "Starting model, the most probable that passes every physical check" if start == selection.plausible
                    else "Starting model")
            selection_sections(report, signals, selection, start, units, role)
            answer_data_warnings(report, args.data_warnings)
            progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    path = atomic_write_json(out / RESULTS_FILENAME, payload)  # last: a complete folder, or a rerun resumes
    progress(f"wrote {path}", args.quiet)
    return 0


def _final_evidence(loop, signals, selection, start, validation=()):
    """Evidence (primary likelihood; None when the final model is the start), intervals and adequacy of the final model.

    The intervals include the linear part's uncertainty (:func:`bayesnsi.diagnose.final_intervals`) and,
    when the final model is not adequate, its model error (:func:`bayesnsi.run.final_adequacy.widen_final`, as
    ``select`` widens a candidate's); when nothing was added the final model is the start, whose intervals the
    selection holds. The adequacy is :func:`bayesnsi.run.adequacy.model_checks` of the final model (None when its
    residual cannot be computed).
    """
    if selection.evidence is None:
        return None, None, None
    if not loop.added and loop.final is loop.start:  # not re-identified (refine_final): the selection's intervals
        return None, selection.outcome(start).intervals, selection.checks.get(start)
    from ..diagnose import final_intervals
    from ..run.final_adequacy import widen_final

    evidence, intervals = final_intervals(loop, signals, selection.evidence)  # its warnings are shown by the report
    limits = {"max_noise_ratio": selection.evidence.max_noise_ratio,
              "max_imag_ratio": selection.evidence.max_imag_ratio}
    return (evidence, *widen_final(loop.final, intervals, signals, **limits,  # as select's: the model error too
                                   validation=validation))


def _final_coefficients(loop, intervals, posterior) -> list:
    """The final coefficients for results.json: NSI value, quality index and, as in select's, ``ci95``/``ci50``/
    ``sd`` (linear-part uncertainty included, ``interval`` says how; centred on ``estimate``, the NSI value),
    ``posterior_mean`` and ``ci95_posterior`` (given the linear part)."""
    ci95 = [] if posterior is None else list(posterior.ci95)
    records = []
    for k, c in enumerate(loop.final.coefficients):
        record = {"term": c.term.name, "value": c.value, "imag_ratio": c.imag_ratio}
        if intervals is not None and k < len(intervals.coefficients):
            iv = intervals.coefficients[k]
            record.update(estimate=iv.estimate, ci95=list(iv.ci95), ci50=list(iv.ci50), sd=iv.sd,
                          interval=intervals.method, posterior_mean=iv.posterior_mean, bias=iv.bias)
            if k < len(ci95):
                record["ci95_posterior"] = [float(ci95[k][0]), float(ci95[k][1])]
        records.append(record)
    return records


def _effect_record(effect) -> dict:
    """Type, location and parameters of a loop effect, as written to results.json."""
    record = {"type": effect.base, "at": list(effect.location), "gap": effect.gap}
    if effect.eps is not None:  # a tanh(v/eps) friction's width
        record["eps"] = effect.eps
    return record
