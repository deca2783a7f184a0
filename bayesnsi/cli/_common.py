"""Orchestration shared by the commands: load a run, options from the command line, progress lines."""

from __future__ import annotations

import argparse
import contextlib
import sys
import warnings
from dataclasses import fields
from pathlib import Path

__all__ = [
    "add_option_flags",
    "add_run_arguments",
    "execution",
    "option_overrides",
    "progress",
    "progress_bar",
    "refuse_if_nothing_identified",
    "start_run",
    "write_outputs",
]


def add_run_arguments(parser) -> None:
    """Arguments shared by the commands that run a config: CONFIG, --out, --force, --quiet."""
    parser.add_argument("config", help="experiment config (TOML)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument(
        "--force", action="store_true",
        help="overwrite an existing results.json in DIR (finished candidates cached in DIR/.cache are reused)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.add_argument("--no-figures", action="store_true", help="skip the report and its figures")
    parser.add_argument(
        "--jobs", type=int, default=1,
        help="candidates (and the effects of each diagnose step) run in N local worker processes (default 1)",
    )
    parser.add_argument(
        "--scheduler", metavar="ADDRESS", default=None,
        help="run the candidates (and diagnose effects) on a Dask cluster, e.g. tcp://10.0.0.5:8786 (overrides --jobs)",
    )
    parser.add_argument(
        "--no-cache", action="store_true",
        help="recompute every candidate instead of reusing results cached in DIR/.cache by an earlier run",
    )


_NONE = object()  # "none" given on the command line, as opposed to a flag not given


def add_option_flags(parser, options_class, names) -> None:
    """``--field-name`` flags for fields of an options class; help, type and range from the field.

    A flag not given leaves the config's value (:func:`option_overrides`); for fields that may
    be none, the word ``none`` sets none.

    Parameters
    ----------
    parser : argparse.ArgumentParser
    options_class : type
        E.g. :class:`bayesnsi.options.LoopOptions`.
    names : iterable of str
        Field names to expose.
    """
    wanted = set(names)
    for item in fields(options_class):
        if item.name not in wanted:
            continue
        meta = item.metadata
        text = f"{meta['help']} (default: the config's [{options_class.SECTION}] {item.name}, else {item.default!r}"
        text += "; none: 'none')" if meta["none"] else ")"
        flag = "--" + item.name.replace("_", "-")
        if meta["kind"] == "bool":  # --name / --no-name
            parser.add_argument(flag, dest=item.name, action=argparse.BooleanOptionalAction, default=None, help=text)
        elif str(item.type).startswith("tuple"):  # a list of words: --effects 'sign(v)' 'v|v|'
            parser.add_argument(flag, dest=item.name, type=_flag_type(meta), nargs="+", default=None, help=text)
        else:
            parser.add_argument(flag, dest=item.name, type=_flag_type(meta), default=None, help=text)


def option_overrides(options, args):
    """``options`` with the values of the flags given on the command line (:func:`add_option_flags`).

    Parameters
    ----------
    options : options dataclass
        The config's options.
    args : argparse.Namespace

    Returns
    -------
    options dataclass
        Validated again (a bad value raises ConfigError, exit 2).
    """
    given = {name: getattr(args, name) for name in options.names() if getattr(args, name, None) is not None}
    given = {name: _NONE if isinstance(value, list) and _NONE in value else value for name, value in given.items()}
    return options.replace(**{name: None if value is _NONE else value for name, value in given.items()})


def _flag_type(meta):
    convert = {"int": int, "float": float}.get(meta["kind"], str)

    def parse(text: str):
        if meta["none"] and text.strip().lower() == "none":
            return _NONE
        return convert(text)

    parse.__name__ = meta["kind"]  # argparse names the type in its error message
    return parse


def start_run(args):
    """Load the config and its estimation signals, and prepare the output directory.

    Returns
    -------
    config : ExperimentConfig
    out : Path
    signals : Signals
    data_findings : tuple of Finding
        What loading the data found (an integration band starting in the noise, a period the force
        does not repeat): shown as warnings when raised, and kept for the report and results.json.
    """
    from ..exceptions import BayesNSIWarning
    from ..findings import finding_from_warning
    from ..io import load_config, load_signals, prepare_output_dir
    from ..io.results import output_folder
    from ._warnings import periodic_hint

    config = load_config(args.config)
    resources = getattr(args, "resources", None)  # main()'s ExitStack: the folder stays locked until the end
    if resources is not None:
        out = resources.enter_context(output_folder(args.out, args.force, config=config.path))
    else:
        out = prepare_output_dir(args.out, force=args.force)
    with warnings.catch_warnings(record=True) as caught:  # the data's warnings go to the report too
        warnings.simplefilter("always")
        signals = load_signals(config)
    for found in caught:  # shown as before
        warnings.warn_explicit(found.message, found.category, found.filename, found.lineno)
    data_findings = tuple(finding_from_warning(w) for w in caught if issubclass(w.category, BayesNSIWarning))
    hint = periodic_hint(config, signals)
    if hint:  # shown with --quiet too, as warnings are
        print(hint, file=sys.stderr)
    progress(f"{len(config.candidates)} candidates, {signals.n_samples} samples at {signals.fs:g} Hz", args.quiet)
    return config, out, signals, data_findings


def write_outputs(args, out, config, payload, posteriors, build_report):
    """Write a run's files: the posteriors, the report (unless ``--no-figures``), then results.json.

    results.json comes last, so that a folder holding it is complete (a rerun resumes otherwise).

    Parameters
    ----------
    args : argparse.Namespace
    out : Path
    config : ExperimentConfig
        For the units of the data.
    payload : dict
        results.json (:func:`bayesnsi.io.selection_payload` or :func:`bayesnsi.io.diagnosis_payload`);
        ``posterior_files`` is added.
    posteriors : mapping of str to (EvidenceResult, Intervals or None)
        The posterior files to write (``DIR/posterior/<name>.nc``), by model name.
    build_report : callable
        ``build_report() -> Report``.

    Returns
    -------
    Path
        The results.json written.
    """
    from ..io import RESULTS_FILENAME, atomic_write_json

    if posteriors:
        from ..io.posterior import write_posteriors
        from ..report import report_units

        evidences = {name: evidence for name, (evidence, _) in posteriors.items()}
        intervals = {name: found for name, (_, found) in posteriors.items() if found is not None}
        payload["posterior_files"] = write_posteriors(out, evidences, intervals, report_units(config))
    if not args.no_figures:
        from ..report import held_figures

        with held_figures():
            report = build_report()
            progress(f"wrote {report.write(out / 'report.html')}", args.quiet)
    path = atomic_write_json(out / RESULTS_FILENAME, payload)
    progress(f"wrote {path}", args.quiet)
    return path


def progress(message: str, quiet: bool) -> None:
    """One progress line on stderr (suppressed by --quiet); safe beside a running progress bar."""
    if not quiet:
        from tqdm import tqdm

        from .._text import printable

        tqdm.write(printable(message), file=sys.stderr)


def progress_bar(total: int, description: str, quiet: bool):
    """A tqdm progress bar on stderr for a long step (disabled by --quiet or when not a terminal)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=description, unit="candidate", file=sys.stderr, disable=quiet or None, leave=False)


@contextlib.contextmanager
def execution(args, out, config):
    """:class:`~bayesnsi.options.ExecutionOptions` from the command line, with progress output.

    Backend from ``--jobs`` / ``--scheduler``; the result cache lives in ``out/.cache`` (see
    :mod:`bayesnsi.io.cache`; ``--no-cache`` recomputes every candidate, fresh entries are still
    written so an interrupted run stays resumable); each finished candidate prints one line and
    advances a progress bar (both silenced by ``--quiet``).

    Parameters
    ----------
    args : argparse.Namespace
    out : Path
        Output folder.
    config : ExperimentConfig

    Yields
    ------
    ExecutionOptions
    """
    from ..io.cache import CACHE_DIRNAME, ResultCache
    from ..options import ExecutionOptions
    from ..report.terminal import outcome_line

    quiet, total = args.quiet, len(config.candidates)
    options = ExecutionOptions(
        jobs=getattr(args, "jobs", 1),
        scheduler=getattr(args, "scheduler", None),
        cache=ResultCache(Path(out) / CACHE_DIRNAME, read=not getattr(args, "no_cache", False)),
    )
    if total > 1 or options.scheduler is not None:
        progress(f"running {total} candidates ({_backend_text(options)})", quiet)
    with progress_bar(total, "candidates", quiet) as bar:
        done = []

        def report(k, outcome):
            done.append(k)
            progress(f"[{len(done)}/{total}] {outcome_line(outcome, config.evidence.likelihood)}", quiet)
            bar.update()

        yield options.replace(progress=report)


def _backend_text(options) -> str:
    if options.scheduler is not None:
        return f"Dask scheduler {options.scheduler}"
    return f"{options.jobs} local worker processes" if options.jobs > 1 else "serially"


def refuse_if_nothing_identified(outcomes, results_path, evidence: bool = False) -> None:
    """Exit 2 (one line) when no candidate was identified (or, with ``evidence``, scored); results.json has every error.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
    results_path : Path
        Where the errors were written.
    evidence : bool
        A candidate whose evidence failed counts as failed (``select``).

    Raises
    ------
    NotIdentifiableError
        When every candidate failed its identification.
    CandidatesFailedError
        With ``evidence``, when every candidate failed its identification or its evidence.
    """
    from ..exceptions import CandidatesFailedError, NotIdentifiableError
    from ..run.batch import failure_summary

    if outcomes and all(o.result is None for o in outcomes):
        raise NotIdentifiableError(
            f"no candidate could be identified (first error: {outcomes[0].error}); "
            f"every candidate's error is in {results_path}"
        )
    summary = failure_summary(outcomes, evidence=evidence)
    if summary is not None:
        raise CandidatesFailedError(f"{summary}; every error is in {results_path}")

