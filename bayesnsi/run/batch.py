"""Identify many candidates on one or many datasets, resumably, on any backend.

:func:`run_candidates` (one dataset) and :func:`run_datasets` (many) identify every candidate
by NSI (and, when asked, compute its evidence), dispatching the (dataset, candidate) pairs with
:func:`bayesnsi.run.dispatch`. Each candidate gets its own seed sequence, spawned from ``seed``
in candidate order (``SeedSequence(seed).spawn(n_candidates)[k]``, the same for every dataset),
so the numbers are identical whatever the backend, the number of workers and the order in
which the tasks finish - and a dataset gives the same numbers alone or in a batch.

With a :class:`~bayesnsi.io.cache.ResultCache`, a finished candidate is stored as soon as it
arrives, and candidates already stored are loaded instead of recomputed.

Failures never stop the batch: a :class:`~bayesnsi.exceptions.BayesNSIError` (or a singular
matrix) is the candidate's result (``status = "failed"`` with the reason; cached like any
result), and any other exception - a bug - is recorded the same way with ``internal_error``
and its traceback, and not cached, so that a rerun tries again.
"""

from __future__ import annotations

import time
import traceback
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ..exceptions import BayesNSIError, ConfigError
from ..io.cache import ResultCache, candidate_key, signals_fingerprint
from ..io.schema import candidate_record, failed_candidate_record
from ..nsi import identify
from ..options import EvidenceOptions, NSIOptions
from .backends import dispatch

__all__ = ["CandidateOutcome", "candidate_task", "run_candidates", "run_datasets"]


class CandidateOutcome(NamedTuple):
    """What one candidate gave: its results.json record, NSI result and evidences.

    Attributes
    ----------
    record : dict
        results.json candidate record (SPEC 9), with ``status``, ``warnings``, ``seconds``
        and ``cached``.
    result : NSIResult or None
        None when the candidate failed.
    evidences : dict likelihood -> EvidenceResult, or None
        None without evidence settings or when the candidate failed.
    """

    record: dict
    result: Any
    evidences: dict | None


def candidate_task(signals, candidate, options, evidence_options, seed_sequence) -> CandidateOutcome:
    """Identify one candidate (and compute its evidence); never raises for a failed candidate.

    Parameters
    ----------
    signals : Signals
    candidate : CandidateModel
    options : NSIOptions
        Settings of :func:`bayesnsi.nsi.identify`.
    evidence_options : EvidenceOptions or None
        Settings of :func:`bayesnsi.evidence.candidate_evidence`; None: NSI only.
    seed_sequence : numpy.random.SeedSequence
        This candidate's seed sequence.

    Returns
    -------
    CandidateOutcome
    """
    start = time.perf_counter()
    result = evidences = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = identify(signals, candidate, options)
            record = candidate_record(result, result.reconstruct(signals))
            if evidence_options is not None:
                from ..evidence import candidate_evidence

                evidences = candidate_evidence(result, signals, evidence_options, seed_sequence, candidate)
        except (BayesNSIError, np.linalg.LinAlgError) as err:
            record = _failed(candidate, err, "evidence: " if result is not None else "")
            result = evidences = None
        except Exception as err:  # noqa: BLE001 - a bug in one candidate must not lose the others
            record = _failed(candidate, err, "internal error: ")
            record["internal_error"] = True
            record["traceback"] = traceback.format_exc()
            result = evidences = None
    record["warnings"] = [str(w.message) for w in caught]
    record["seconds"] = time.perf_counter() - start
    return CandidateOutcome(record, result, evidences)


def run_candidates(
    signals,
    candidates: Sequence,
    nsi_options: NSIOptions | None = None,
    evidence_options: EvidenceOptions | None = None,
    seed: int = 0,
    *,
    jobs: int = 1,
    scheduler=None,
    cache: ResultCache | str | Path | None = None,
    on_result: Callable | None = None,
) -> list[CandidateOutcome]:
    """Identify every candidate on one dataset (see :func:`run_datasets`).

    Returns
    -------
    list of CandidateOutcome
        In the order of ``candidates``.

    Examples
    --------
    >>> from bayesnsi import simulate_case
    >>> case = simulate_case("two-dof", seed=0, duration=10.0)
    >>> out = run_candidates(case.signals, case.candidates, NSIOptions(block_rows=40, order=4))
    >>> [o.record["status"] for o in out]
    ['ok', 'ok', 'ok']
    """
    callback = None if on_result is None else (lambda d, k, outcome, cached: on_result(k, outcome, cached))
    return run_datasets(
        [signals], candidates, nsi_options, evidence_options, seed,
        jobs=jobs, scheduler=scheduler, cache=cache, on_result=callback,
    )[0]


def run_datasets(
    datasets: Sequence,
    candidates: Sequence,
    nsi_options: NSIOptions | None = None,
    evidence_options: EvidenceOptions | None = None,
    seed: int = 0,
    *,
    jobs: int = 1,
    scheduler=None,
    cache: ResultCache | str | Path | None = None,
    on_result: Callable | None = None,
) -> list[list[CandidateOutcome]]:
    """Identify every candidate on every dataset, in parallel, resumably.

    Parameters
    ----------
    datasets : sequence of Signals
        Estimation data; every candidate is identified on each.
    candidates : sequence of CandidateModel
        E.g. a config's candidates, or :func:`bayesnsi.run.dictionary_candidates`.
    nsi_options : NSIOptions, optional
        Settings of :func:`bayesnsi.nsi.identify` (default ``NSIOptions()``).
    evidence_options : EvidenceOptions, optional
        Evidence settings; None
        computes no evidence.
    seed : int
        Root of the candidates' seed sequences.
    jobs : int
        Local worker processes (joblib loky); 1 runs here.
    scheduler : str or dask.distributed.Client, optional
        Dask scheduler address or Client; overrides ``jobs``.
    cache : ResultCache or path, optional
        Load finished candidates from it and store new ones as they arrive.
    on_result : callable, optional
        Called as ``on_result(dataset_index, candidate_index, outcome, cached)`` when each
        candidate is available (cached ones first), e.g. for progress.

    Returns
    -------
    list of list of CandidateOutcome
        ``outcomes[d][k]``: dataset ``d``, candidate ``k``, in input order.

    Raises
    ------
    ConfigError
        For an empty candidate list or dataset list, or candidate names used twice.
    SchedulerError
        If the Dask scheduler cannot be used.
    """
    datasets, candidates = list(datasets), list(candidates)
    _check_inputs(datasets, candidates)
    options = _typed(nsi_options, NSIOptions, "nsi_options") or NSIOptions()
    evidence = _typed(evidence_options, EvidenceOptions, "evidence_options")
    if isinstance(cache, (str, Path)):
        cache = ResultCache(cache)
    seeds = np.random.SeedSequence(seed).spawn(len(candidates))
    keys = _keys(datasets, candidates, options, evidence, seeds) if cache is not None else None
    outcomes: list[list[CandidateOutcome | None]] = [[None] * len(candidates) for _ in datasets]
    pending = []
    for d in range(len(datasets)):
        for k, candidate in enumerate(candidates):
            stored = cache.load(keys[d][k]) if cache is not None else None
            if stored is None:
                pending.append((d, k))
                continue
            outcome = CandidateOutcome(*stored)
            outcome.record["cached"] = True
            outcomes[d][k] = outcome
            if on_result is not None:
                on_result(d, k, outcome, True)
    tasks = [(d, candidates[k], options, evidence, seeds[k]) for d, k in pending]
    for index, outcome in dispatch(_dataset_task, tasks, context=tuple(datasets), jobs=jobs, scheduler=scheduler):
        d, k = pending[index]
        if cache is not None and not outcome.record.get("internal_error"):
            cache.store(keys[d][k], tuple(outcome))
        outcome.record["cached"] = False
        outcomes[d][k] = outcome
        if on_result is not None:
            on_result(d, k, outcome, False)
    return outcomes


def _dataset_task(datasets, d, candidate, options, evidence_options, seed_sequence) -> CandidateOutcome:
    return candidate_task(datasets[d], candidate, options, evidence_options, seed_sequence)


def _keys(datasets, candidates, options, evidence, seeds) -> list[list[str]]:
    out = []
    for signals in datasets:
        data = signals_fingerprint(signals)
        evidence_dict = None if evidence is None else evidence.to_dict()
        out.append([candidate_key(data, c, options.to_dict(), evidence_dict, s) for c, s in zip(candidates, seeds)])
    return out


def _typed(options, kind: type, name: str):
    if options is not None and not isinstance(options, kind):
        raise ConfigError(f"{name} must be {kind.__name__} or None, got {type(options).__name__}")
    return options


def _check_inputs(datasets, candidates) -> None:
    if not datasets:
        raise ConfigError("no datasets to identify; pass at least one Signals object")
    if not candidates:
        raise ConfigError(
            "the candidate list is empty; give at least one candidate (a linear model is CandidateModel('linear', ()))"
        )
    names = [c.name for c in candidates]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ConfigError(f"candidate name(s) {repeated} are used more than once; give each candidate its own name")


def _failed(candidate, err: BaseException, stage: str) -> dict:
    record = failed_candidate_record(candidate, err)
    record["error"] = stage + record["error"]
    return record
