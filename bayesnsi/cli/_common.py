"""Orchestration shared by the commands: identify the candidates of a config, progress lines."""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from ..exceptions import BayesNSIError
from ..io.schema import candidate_record, failed_candidate_record
from ..nsi import identify

__all__ = ["add_run_arguments", "start_run", "identify_all", "nsi_options", "progress"]


def add_run_arguments(parser) -> None:
    """Arguments shared by the commands that run a config: CONFIG, --out, --force, --quiet."""
    parser.add_argument("config", help="experiment config (TOML)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--force", action="store_true", help="overwrite an existing results.json in DIR")
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    parser.add_argument("--no-figures", action="store_true", help="skip the report and its figures")


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
    """One progress line on stderr (suppressed by --quiet)."""
    if not quiet:
        print(message, file=sys.stderr, flush=True)


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


def identify_all(config, signals, quiet=False):
    """Identify every candidate; failures are recorded with their reason, never raised.

    Returns
    -------
    results : dict name -> NSIResult (successful candidates only)
    records : list of dict (results.json candidate records, in config order)
    """
    results, records = {}, []
    options = nsi_options(config)
    for k, candidate in enumerate(config.candidates, 1):
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                result = identify(signals, candidate, **options)
                reconstruction = result.reconstruct(signals)
            except (BayesNSIError, np.linalg.LinAlgError) as err:
                records.append(failed_candidate_record(candidate, err))
                progress(f"[{k}/{len(config.candidates)}] {candidate.name}: failed - {err}", quiet)
                continue
        record = candidate_record(result, reconstruction)
        record["warnings"] = [str(w.message) for w in caught]
        record["seconds"] = time.perf_counter() - start
        results[candidate.name] = result
        records.append(record)
        progress(
            f"[{k}/{len(config.candidates)}] {candidate.name}: order {result.order}, "
            f"NRMSE {reconstruction.nrmse:.4f} ({record['seconds']:.2f} s)",
            quiet,
        )
    return results, records
