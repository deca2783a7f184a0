"""Orchestration shared by the commands: identify the candidates of a config, progress lines."""

from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["add_run_arguments", "identify_all", "progress", "progress_bar", "run_options", "start_run"]


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
    parser.add_argument("--jobs", type=int, default=1, help="candidates (and the effects of each diagnose step) run in N local worker processes (default 1)")
    parser.add_argument(
        "--scheduler", metavar="ADDRESS", default=None,
        help="run the candidates (and diagnose effects) on a Dask cluster, e.g. tcp://10.0.0.5:8786 (overrides --jobs)",
    )
    parser.add_argument(
        "--no-cache", action="store_true",
        help="recompute every candidate instead of reusing results cached in DIR/.cache by an earlier run",
    )


def start_run(args):
    """Load the config and its estimation signals, and prepare the output directory.

    Returns
    -------
    config : ExperimentConfig
    out : Path
    signals : Signals
    """
    from ..io import load_config, load_signals, prepare_output_dir

    config = load_config(args.config)
    out = prepare_output_dir(args.out, force=args.force)
    signals = load_signals(config)
    progress(f"{len(config.candidates)} candidates, {signals.n_samples} samples at {signals.fs:g} Hz", args.quiet)
    return config, out, signals


def progress(message: str, quiet: bool) -> None:
    """One progress line on stderr (suppressed by --quiet); safe beside a running progress bar."""
    if not quiet:
        from tqdm import tqdm

        tqdm.write(message, file=sys.stderr)


def progress_bar(total: int, description: str, quiet: bool):
    """A tqdm progress bar on stderr for a long step (disabled by --quiet or when not a terminal)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=description, unit="candidate", file=sys.stderr, disable=quiet or None, leave=False)


def run_options(args, out) -> dict:
    """Keyword arguments of :func:`identify_all` from the command line: backend and cache.

    The cache lives in ``out/.cache`` (see :mod:`bayesnsi.io.cache`); ``--no-cache`` recomputes
    every candidate (fresh entries are still written, so an interrupted run stays resumable).
    """
    from ..io.cache import CACHE_DIRNAME, ResultCache

    return dict(
        jobs=getattr(args, "jobs", 1),
        scheduler=getattr(args, "scheduler", None),
        cache=ResultCache(Path(out) / CACHE_DIRNAME, read=not getattr(args, "no_cache", False)),
    )


def identify_all(config, signals, quiet=False, jobs: int = 1, evidence_options=None, scheduler=None, cache=None):
    """Identify every candidate (and its evidence); failures are recorded, never raised.

    Candidates run serially, in ``jobs`` local worker processes, or on the Dask scheduler
    ``scheduler`` (:func:`bayesnsi.run.dispatch`); each has its own seed sequence spawned from
    the config's seed in config order, so the numbers do not depend on the backend. With a
    ``cache`` (:class:`~bayesnsi.io.cache.ResultCache`) finished candidates are stored as they
    arrive and reused by a rerun.

    Returns
    -------
    results : dict name -> NSIResult (successful candidates only)
    records : list of dict (results.json candidate records, in config order)
    evidences : dict name -> dict likelihood -> EvidenceResult (empty without evidence_options)
    """
    from ..run import run_candidates

    total = len(config.candidates)
    if total > 1 or scheduler is not None:
        progress(f"running {total} candidates ({_backend_text(jobs, scheduler)})", quiet)
    with progress_bar(total, "candidates", quiet) as bar:
        done = []

        def report(k, outcome, cached):
            done.append(k)
            _report_progress(len(done), total, config.candidates[k], outcome, evidence_options, quiet, cached)
            bar.update()

        outcomes = run_candidates(
            signals, config.candidates, config.nsi, evidence_options, config.seed,
            jobs=jobs, scheduler=scheduler, cache=cache, on_result=report,
        )
    results, records, evidences = {}, [], {}
    for candidate, (record, result, evidence) in zip(config.candidates, outcomes):
        records.append(record)
        if result is not None:
            results[candidate.name] = result
        if evidence is not None:
            evidences[candidate.name] = evidence
    return results, records, evidences


def _backend_text(jobs, scheduler) -> str:
    if scheduler is not None:
        return f"Dask scheduler {scheduler}"
    return f"{jobs} local worker processes" if jobs > 1 else "serially"


def _report_progress(k, total, candidate, outcome, evidence_options, quiet, cached=False):
    record, result, evidence = outcome
    origin = "cached" if cached else f"{record['seconds']:.1f} s"
    if result is None:
        progress(f"[{k}/{total}] {candidate.name}: failed - {record['error']} ({origin})", quiet)
        return
    text = f"[{k}/{total}] {candidate.name}: order {result.order}, NRMSE {record['nrmse']:.4f}"
    if evidence:
        primary = evidence[evidence_options.likelihood]
        text += f", log Z ({primary.likelihood}) = {primary.log_evidence:.2f} ± {primary.log_evidence_se:.2f}"
    progress(f"{text} ({origin})", quiet)
