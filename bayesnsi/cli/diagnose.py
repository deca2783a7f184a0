"""``bayesnsi diagnose CONFIG --out DIR``: close the loop from the selected model (docs/method.md §7)."""

from __future__ import annotations

import sys
import warnings

from ..exceptions import AdequacyWarning
from ..options import LoopOptions
from ._common import add_option_flags, add_run_arguments, option_overrides, progress, start_run, write_outputs
from .select import posterior_files, print_findings, run_selection

__all__ = ["add_parser", "run"]


def add_parser(sub) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "diagnose",
        help="close the loop: find an effect the selected model lacks, add it, report before/after",
        description="Select a model as `bayesnsi select` does (or start from --start NAME), then search a "
        "dictionary of effects (x², x|x|, x³, sign(v), v|v|, v³, x²·sign(v), clearances, Bouc-Wen hysteresis; at "
        "each measured DOF and between DOFs) for what its residual lacks; add an effect only when the Bayes factor, "
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
    from ..diagnosis import diagnose
    from ..exceptions import ConfigError
    from ..io.loop_record import diagnosis_payload
    from ..loop import loop_effects
    from ..options import ExecutionOptions
    from ..report.terminal import diagnosis_lines, step_line

    config, out, signals, data_findings = start_run(args)
    names = [c.name for c in config.candidates]
    if args.start is not None and args.start not in names:  # before any work
        raise ConfigError(f"--start {args.start!r} is not a candidate of the config; choose one of {names}")
    options = option_overrides(config.loop, args)
    loop_effects(signals, options.effects)  # unknown effect names: ConfigError before any work
    selection = run_selection(config, signals, args, out)
    print_findings(selection)  # as select: what the ranking should not be trusted for
    progress("closing the loop ...", args.quiet)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdequacyWarning)  # printed once, plainly, from the findings
        diagnosis = diagnose(selection, options, start=args.start,
                             execution=ExecutionOptions(jobs=args.jobs, scheduler=args.scheduler))
    for step in diagnosis.loop.steps:
        progress(step_line(step), args.quiet)
    payload = diagnosis_payload(diagnosis, "diagnose", config, data_findings)
    posteriors = posterior_files(selection)
    if diagnosis.final.evidence is not None and diagnosis.added:  # the model the loop ends with
        posteriors[diagnosis.final.name] = (diagnosis.final.evidence, diagnosis.final.intervals)
    write_outputs(args, out, config, payload, posteriors,
                  lambda: _report().diagnosis_report(diagnosis, config, f"bayesnsi diagnose - {config.path.name}",
                                                          data_findings=data_findings))
    for line in diagnosis_lines(diagnosis):
        progress(line, args.quiet)
    for finding in diagnosis.findings:
        print(f"{finding.severity}: {' '.join(finding.message.split())}", file=sys.stderr)
    return 0


def _report():
    """The report package, imported only when a report is written (pandas, matplotlib: not with --no-figures)."""
    from .. import report

    return report
