"""Orchestration shared by the commands: identify the candidates of a config, progress lines."""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from ..exceptions import BayesNSIError
from ..io.schema import candidate_record, failed_candidate_record
from ..nsi import identify

__all__ = ["add_run_arguments", "start_run", "identify_all", "nsi_options", "progress", "progress_bar"]


def add_run_arguments(parser) -> None:
    """Arguments shared by the commands that run a config: CONFIG, --out, --force, --quiet."""
    parser.add_argument("config", help="experiment config (TOML)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--force", action="store_true", help="overwrite an existing results.json in DIR")
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.add_argument("--no-figures", action="store_true", help="skip the report and its figures")
    parser.add_argument("--jobs", type=int, default=1, help="candidates run in parallel processes (default 1)")


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


def nsi_options(config) -> dict:
    """Keyword arguments of :func:`bayesnsi.nsi.identify` from the config's [nsi] table."""
    s = config.nsi
    return dict(
        block_rows=s.block_rows,
        order=s.order,
        max_order=s.max_order,
        band_hz=s.band_hz,
        velocity_method=s.velocity_method,
        bd_method=s.bd_method,
        zero_feedthrough=s.zero_feedthrough,
        input_hold=s.input_hold,
    )


def _candidate_task(signals, candidate, options, evidence_options, seed_sequence):
    """Identify one candidate (and compute its evidence); runs in a worker process for --jobs.

    Returns
    -------
    record : dict
    result : NSIResult or None
    evidences : dict likelihood -> EvidenceResult, or None
    seconds : float
    """
    start = time.perf_counter()
    result = evidences = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = identify(signals, candidate, **options)
            record = candidate_record(result, result.reconstruct(signals))
            if evidence_options is not None:
                from ..evidence import candidate_evidence

                evidences = candidate_evidence(result, signals, evidence_options, seed_sequence, candidate)
        except (BayesNSIError, np.linalg.LinAlgError) as err:
            stage = "evidence: " if result is not None else ""
            record = failed_candidate_record(candidate, err)
            record["error"] = stage + record["error"]
            result = evidences = None
    record["warnings"] = [str(w.message) for w in caught]
    record["seconds"] = time.perf_counter() - start
    return record, result, evidences


def identify_all(config, signals, quiet=False, jobs: int = 1, evidence_options=None):
    """Identify every candidate (and its evidence); failures are recorded, never raised.

    Candidates run in ``jobs`` worker processes; each has its own seed sequence spawned from the
    config's seed in config order, so the numbers do not depend on ``jobs``.

    Returns
    -------
    results : dict name -> NSIResult (successful candidates only)
    records : list of dict (results.json candidate records, in config order)
    evidences : dict name -> dict likelihood -> EvidenceResult (empty without evidence_options)
    """
    options = nsi_options(config)
    seeds = np.random.SeedSequence(config.seed).spawn(len(config.candidates))
    tasks = [(signals, cand, options, evidence_options, seed) for cand, seed in zip(config.candidates, seeds)]
    outcomes = []
    with progress_bar(len(tasks), "candidates", quiet) as bar:
        if jobs > 1 and len(tasks) > 1:
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(max_workers=jobs) as pool:
                futures = [pool.submit(_candidate_task, *task) for task in tasks]
                for k, future in enumerate(futures, 1):
                    outcomes.append(future.result())
                    _report_progress(k, len(tasks), config.candidates[k - 1], outcomes[-1], evidence_options, quiet)
                    bar.update()
        else:
            for k, task in enumerate(tasks, 1):
                outcomes.append(_candidate_task(*task))
                _report_progress(k, len(tasks), config.candidates[k - 1], outcomes[-1], evidence_options, quiet)
                bar.update()
    results, records, evidences = {}, [], {}
    for candidate, (record, result, evidence) in zip(config.candidates, outcomes):
        records.append(record)
        if result is not None:
            results[candidate.name] = result
        if evidence is not None:
            evidences[candidate.name] = evidence
    return results, records, evidences


def _report_progress(k, total, candidate, outcome, evidence_options, quiet):
    record, result, evidence = outcome
    if result is None:
        progress(f"[{k}/{total}] {candidate.name}: failed - {record['error']}", quiet)
        return
    text = f"[{k}/{total}] {candidate.name}: order {result.order}, NRMSE {record['nrmse']:.4f}"
    if evidence:
        primary = evidence[evidence_options["likelihood"]]
        text += f", log Z ({primary.likelihood}) = {primary.log_evidence:.2f} ± {primary.log_evidence_se:.2f}"
    progress(f"{text} ({record['seconds']:.1f} s)", quiet)
