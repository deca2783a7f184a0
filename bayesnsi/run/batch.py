"""Identify many candidates on one or many datasets, resumably, on any backend.

:func:`run_candidates` (one dataset) and :func:`run_datasets` (many) identify every candidate
by NSI (and, when asked, compute its evidence), dispatching the (dataset, candidate) pairs with
:func:`bayesnsi._dispatch.dispatch`. Each candidate gets its own seed sequence, spawned from the
evidence seed in candidate order (``SeedSequence(seed).spawn(n_candidates)[k]``, the same for
every dataset), so the numbers are identical whatever the backend, the number of workers and
the order in which the tasks finish - and a dataset gives the same numbers alone or in a batch.

With a cache (``ExecutionOptions.cache``, e.g. :class:`bayesnsi.io.cache.ResultCache`), a
finished candidate is stored as soon as it arrives, and candidates already stored are loaded
instead of recomputed.

Failures never stop the batch. A :class:`~bayesnsi.exceptions.BayesNSIError` (or a singular
matrix) becomes the candidate's outcome with the stage that failed: ``identification`` (no
model) or ``evidence`` (the identified model is kept). Any other exception - a bug - is recorded
as stage ``internal`` with its traceback, and not cached, so that a rerun tries again.
"""

from __future__ import annotations

import time
import traceback
import warnings
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .._dispatch import dispatch
from .._measured import measured_error
from ..exceptions import BayesNSIError, ConfigError, IntervalWarning
from ..findings import Finding, emit, finding_from_warning
from ..models import CandidateModel
from ..nsi import identify
from ..options import EvidenceOptions, ExecutionOptions, NSIOptions

__all__ = ["CandidateOutcome", "candidate_seeds", "candidate_task", "failure_summary", "run_candidates", "run_datasets"]

FAILED_STAGES = ("identification", "evidence", "internal")
"""Stages a candidate can fail at (:attr:`CandidateOutcome.failed_stage`)."""


@dataclass(frozen=True)
class CandidateOutcome:
    """What one candidate gave: its NSI result, evidences, errors and cost.

    Attributes
    ----------
    candidate : CandidateModel
    result : NSIResult or None
        None when the identification failed.
    evidences : mapping of str to EvidenceResult, or None
        Per likelihood (``EvidenceOptions.likelihood`` and ``compare``); None without evidence
        options or when the evidence failed.
    nrmse : float or None
        NRMSE of the open-loop reconstruction of the estimation data (paper Eq. 5.1).
    nrmse_per_channel : tuple of float
    error : str or None
        ``"<ExceptionType>: <message>"`` of the failure, None when everything succeeded.
    failed_stage : str or None
        ``"identification"``, ``"evidence"`` or ``"internal"`` (a bug), None when it succeeded.
    traceback : str or None
        Traceback of an internal error.
    findings : tuple of Finding
        What the identification, evidence and intervals found while the candidate ran (every warning
        they raised, :func:`bayesnsi.findings.finding_from_warning`).
    intervals : Intervals or None
        50 % and 95 % intervals of the coefficients and modes under the primary likelihood
        (:func:`bayesnsi.uncertainty.candidate_intervals`, ``EvidenceOptions.interval``); None without
        evidence.
    whiteness : Whiteness or None
        Ljung-Box test of the residual the evidence scored (innovations or open loop,
        :func:`bayesnsi.checks.validation.whiteness_test`), computed with it; None where the test does not
        apply (:func:`bayesnsi.checks.validation.whiteness_applies`), without evidence, for a free body
        (scored on its force) or a ``"force"`` residual.
    seconds : float
        Wall time of the computation (of the original run for a cached outcome).
    cached : bool
        True when the outcome was loaded from the cache.
    """

    candidate: CandidateModel
    result: Any = None
    evidences: Mapping[str, Any] | None = None
    nrmse: float | None = None
    nrmse_per_channel: tuple[float, ...] = ()
    error: str | None = None
    failed_stage: str | None = None
    traceback: str | None = None
    findings: tuple[Finding, ...] = ()
    intervals: Any = None
    whiteness: Any = None
    seconds: float = 0.0
    cached: bool = False

    def __repr__(self) -> str:
        from .._repr import compact_repr

        return compact_repr(
            self, name=self.name, status=self.status, nrmse=self.nrmse,
            evidences=tuple(self.evidences or ()), error=self.error, cached=self.cached,
        )

    @property
    def status(self) -> str:
        """``"ok"``, ``"failed"`` (no model) or ``"evidence_failed"`` (a model, no evidence)."""
        if self.error is None:
            return "ok"
        return "evidence_failed" if self.result is not None else "failed"

    @property
    def name(self) -> str:
        """Name of the candidate."""
        return self.candidate.name


def candidate_task(
    signals, candidate, nsi: NSIOptions, evidence: EvidenceOptions | None, seed_sequence
) -> CandidateOutcome:
    """Identify one candidate (and compute its evidence); never raises for a failed candidate.

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidate : CandidateModel
        The candidate to identify.
    nsi : NSIOptions
        Settings of :func:`bayesnsi.nsi.identify`.
    evidence : EvidenceOptions or None
        Settings of :func:`bayesnsi.evidence.candidate_evidence`; None: NSI only.
    seed_sequence : numpy.random.SeedSequence
        This candidate's seed sequence.

    Returns
    -------
    CandidateOutcome
        With ``cached = False``.
    """
    start = time.perf_counter()
    found: dict[str, Any] = {"candidate": candidate}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stage = "identification"
        try:
            found["result"] = result = identify(signals, candidate, nsi)
            reconstruction = result.reconstruct(signals)
            found["nrmse"] = float(reconstruction.nrmse)
            found["nrmse_per_channel"] = tuple(float(v) for v in reconstruction.nrmse_per_channel)
            if getattr(signals, "measured", "displacement") != "displacement":  # in the measured quantity
                measured = measured_error(reconstruction.measured, reconstruction.predicted, signals)
                found["nrmse"], found["nrmse_per_channel"] = measured.nrmse, measured.nrmse_per_channel
            if evidence is not None:
                stage = "evidence"
                from ..evidence import candidate_affine, candidate_evidence

                affine = candidate_affine(result, signals, evidence.residual)
                found["evidences"] = candidate_evidence(result, signals, evidence, seed_sequence, candidate,
                                                        reconstruction=reconstruction, affine=affine)
                found["whiteness"] = _whiteness(result, signals, affine, evidence.residual)
                found["intervals"] = _intervals_or_warning(result, signals, found["evidences"], evidence, nsi)
        except (BayesNSIError, np.linalg.LinAlgError) as err:
            found.update(error=f"{type(err).__name__}: {err}", failed_stage=stage)
        except Exception as err:  # noqa: BLE001 - a bug in one candidate must not lose the others
            found.update(
                error=f"{type(err).__name__}: {err}", failed_stage="internal", traceback=traceback.format_exc()
            )
            for partial in ("evidences", "whiteness", "intervals"):
                found.pop(partial, None)
    return CandidateOutcome(
        **found,
        findings=tuple(finding_from_warning(w) for w in caught),
        seconds=time.perf_counter() - start,
    )


def _whiteness(result, signals, affine, residual: str):
    """Ljung-Box test of the evidence's residual, or None where ``select`` would test another one or none.

    ``select`` tests the displacement residual named by ``[evidence] residual``
    (:func:`bayesnsi.checks.validation.residual_whiteness`): the evidence's own residual is that one except for a free
    body (its force) or the ``"force"`` residual, and the test does not apply to integrated responses.
    """
    from ..checks.validation import whiteness_applies, whiteness_test
    from ..nsi import is_free_body

    if residual not in ("innovations", "reconstruction") or is_free_body(result) or not whiteness_applies(signals):
        return None
    return whiteness_test(affine.measured - affine.predict(affine.estimate), residual)


def _intervals_or_warning(result, signals, evidences, evidence: EvidenceOptions, nsi: NSIOptions):
    """Intervals of one candidate, or None with an :class:`IntervalWarning` when they fail.

    The evidence that succeeded is kept: a failure of the intervals (e.g. record windows too short for
    the block rows) is not a failure of the candidate.
    """
    from ..uncertainty import candidate_intervals

    try:
        return candidate_intervals(result, signals, evidences[evidence.likelihood], evidence, nsi)
    except (BayesNSIError, np.linalg.LinAlgError) as err:
        message = (f"intervals not computed ({type(err).__name__}: {err}); the evidence is kept - see"
                   " [evidence] interval / n_segments")
        emit([Finding("interval.failed", message, result.candidate.name)], IntervalWarning, stacklevel=2)
        return None


def candidate_seeds(seed: int, n_candidates: int) -> list[np.random.SeedSequence]:
    """Seed sequences of the candidates: ``SeedSequence(seed).spawn(n_candidates)``.

    Parameters
    ----------
    seed : int
        Root seed (``EvidenceOptions.seed``).
    n_candidates : int
        Number of candidates.

    Returns
    -------
    list of numpy.random.SeedSequence
        One per candidate, in candidate order.
    """
    return np.random.SeedSequence(seed).spawn(n_candidates)


def run_candidates(
    signals,
    candidates: Sequence,
    nsi: NSIOptions | None = None,
    evidence: EvidenceOptions | None = None,
    *,
    execution: ExecutionOptions | None = None,
) -> list[CandidateOutcome]:
    """Identify every candidate on one dataset (see :func:`run_datasets`).

    Parameters
    ----------
    signals : Signals
        Estimation data.
    candidates : sequence of CandidateModel
        The candidates, e.g. a config's.
    nsi : NSIOptions, optional
        Settings of :func:`bayesnsi.nsi.identify` (default ``NSIOptions()``).
    evidence : EvidenceOptions, optional
        Evidence settings (its ``seed`` is the root of the candidates' seeds); None computes no
        evidence.
    execution : ExecutionOptions, optional
        Backend (``jobs``, ``scheduler``), ``cache`` and ``progress`` callback, called as
        ``progress(candidate_index, outcome)``.

    Returns
    -------
    list of CandidateOutcome
        In the order of ``candidates``.

    Examples
    --------
    >>> from bayesnsi import simulate_case
    >>> case = simulate_case("two-dof", seed=0, duration=10.0)
    >>> out = run_candidates(case.signals, case.candidates, NSIOptions(block_rows=40, order=4))
    >>> [o.status for o in out]
    ['ok', 'ok', 'ok']
    """
    execution = _typed(execution, ExecutionOptions, "execution") or ExecutionOptions()
    if execution.progress is not None:
        callback = execution.progress
        execution = execution.replace(progress=lambda d, k, outcome: callback(k, outcome))
    return run_datasets([signals], candidates, nsi, evidence, execution=execution)[0]


def run_datasets(
    datasets: Sequence,
    candidates: Sequence,
    nsi: NSIOptions | None = None,
    evidence: EvidenceOptions | None = None,
    *,
    execution: ExecutionOptions | None = None,
) -> list[list[CandidateOutcome]]:
    """Identify every candidate on every dataset, in parallel, resumably.

    Parameters
    ----------
    datasets : sequence of Signals
        Estimation data; every candidate is identified on each.
    candidates : sequence of CandidateModel
        E.g. a config's candidates, or :func:`bayesnsi.run.dictionary_candidates`.
    nsi : NSIOptions, optional
        Settings of :func:`bayesnsi.nsi.identify` (default ``NSIOptions()``).
    evidence : EvidenceOptions, optional
        Evidence settings; None computes no evidence. Its ``seed`` roots the candidates' seed
        sequences (:func:`candidate_seeds`; seed 0 without evidence).
    execution : ExecutionOptions, optional
        ``jobs`` local worker processes or a Dask ``scheduler``; a ``cache`` (any object with
        ``key(signals, candidate, nsi, evidence, seed_sequence)``, ``load(key)`` and
        ``store(key, outcome)``, e.g. :class:`bayesnsi.io.cache.ResultCache`); a ``progress``
        callable, called as ``progress(dataset_index, candidate_index, outcome)`` when each
        candidate is available (cached ones first).

    Returns
    -------
    list of list of CandidateOutcome
        ``outcomes[d][k]``: dataset ``d``, candidate ``k``, in input order.

    Raises
    ------
    ConfigError
        For an empty candidate list or dataset list, candidate names used twice, or options of
        the wrong type.
    SchedulerError
        If the Dask scheduler cannot be used.
    """
    datasets, candidates = list(datasets), list(candidates)
    _check_inputs(datasets, candidates)
    nsi = _typed(nsi, NSIOptions, "nsi") or NSIOptions()
    evidence = _typed(evidence, EvidenceOptions, "evidence")
    execution = _typed(execution, ExecutionOptions, "execution") or ExecutionOptions()
    cache, progress = execution.cache, execution.progress
    seeds = candidate_seeds(0 if evidence is None else evidence.seed, len(candidates))
    outcomes: list[list[CandidateOutcome | None]] = [[None] * len(candidates) for _ in datasets]
    keys: dict[tuple[int, int], str] = {}
    pending = []
    for d, signals in enumerate(datasets):
        for k, candidate in enumerate(candidates):
            stored = None
            if cache is not None:
                keys[d, k] = cache.key(signals, candidate, nsi, evidence, seeds[k])
                stored = cache.load(keys[d, k])
            if stored is None:
                pending.append((d, k))
                continue
            outcomes[d][k] = stored = replace(stored, cached=True)
            if progress is not None:
                progress(d, k, stored)
    tasks = [(d, candidates[k], nsi, evidence, seeds[k]) for d, k in pending]
    task_bytes = _task_bytes(evidence, [candidates[k] for _, k in pending])
    for index, outcome in dispatch(
        _dataset_task, tasks, context=tuple(datasets), jobs=execution.jobs, scheduler=execution.scheduler,
        task_bytes=task_bytes,
    ):
        d, k = pending[index]
        if cache is not None and outcome.failed_stage != "internal":
            cache.store(keys[d, k], outcome)
        outcomes[d][k] = outcome
        if progress is not None:
            progress(d, k, outcome)
    return outcomes  # type: ignore[return-value]


def failure_summary(outcomes: Sequence[CandidateOutcome], evidence: bool = False) -> str | None:
    """One line summing up a run in which every candidate failed; None when one succeeded.

    Parameters
    ----------
    outcomes : sequence of CandidateOutcome
    evidence : bool
        A candidate counts as failed when its evidence failed too (a selection needs it).

    Returns
    -------
    str or None
        ``"every candidate failed (3 of 3): a: <error>; b: <error>; ..."`` (errors shortened).
    """
    def failed(outcome: CandidateOutcome) -> bool:
        return outcome.result is None or (evidence and not outcome.evidences)

    if not outcomes or not all(failed(o) for o in outcomes):
        return None
    parts = []
    for outcome in outcomes[:5]:
        error = " ".join(str(outcome.error or "no evidence").split())
        parts.append(f"{outcome.name}: {outcome.failed_stage or 'evidence'} - {error[:160]}")
    more = f"; and {len(outcomes) - 5} more" if len(outcomes) > 5 else ""
    return f"every candidate failed ({len(outcomes)} of {len(outcomes)}): {'; '.join(parts)}{more}"


def _task_bytes(evidence: EvidenceOptions | None, candidates) -> int:
    """Estimated memory of one candidate's evidence (its samplers' chains), refused above the limit before any run.

    The parameters of the largest candidate are bounded below by its terms and one noise scale,
    so a refusal never blames a run that would fit.
    """
    from ..evidence import chain_bytes, check_chain_memory

    if evidence is None or not candidates:
        return 0
    ndim = max(len(c.terms) for c in candidates) + 1
    runs = len(evidence.likelihoods)
    check_chain_memory(evidence.n_walkers, evidence.n_steps, ndim, "one candidate's evidence", runs=runs)
    return runs * chain_bytes(evidence.n_walkers, evidence.n_steps, ndim)


def _dataset_task(datasets, d, candidate, nsi, evidence, seed_sequence) -> CandidateOutcome:
    return candidate_task(datasets[d], candidate, nsi, evidence, seed_sequence)


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
    counts = Counter(c.name for c in candidates)
    repeated = sorted(name for name, count in counts.items() if count > 1)
    if repeated:
        raise ConfigError(f"candidate name(s) {repeated} are used more than once; give each candidate its own name")
