"""Where tasks run: in this process, in local worker processes (joblib), or on a Dask cluster.

:func:`dispatch` is the one entry point. It yields ``(index, value)`` as each task finishes, so
the caller can write results (and caches) as they arrive; the values never depend on the
backend, because every task carries its own inputs (including its own seed).

Backends
--------
``serial``
    ``jobs == 1`` and no scheduler: tasks run one after the other in this process.
``loky``
    ``jobs > 1``: joblib's loky process pool on this machine (workers are reused between
    calls; large arrays are memory-mapped, not copied).
``dask``
    ``scheduler`` given: a :class:`dask.distributed.Client` connected to that address
    (``tcp://host:8786``), or an existing Client. The shared context (e.g. the datasets) is
    scattered to the workers once; tasks are submitted and gathered as they complete.
    Workers must run the same bayesnsi code as this process (checked on connection).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..exceptions import ConfigError, SchedulerError

__all__ = ["backend_name", "chunks", "connect", "dispatch"]

CONNECT_TIMEOUT_S = 10.0
"""Seconds to wait for a Dask scheduler before giving up."""

MAX_CHUNK = 16
"""Most tasks sent to a worker in one message (see :func:`chunks`)."""


def backend_name(jobs: int = 1, scheduler=None) -> str:
    """Name of the backend :func:`dispatch` uses for these settings: serial, loky or dask."""
    _check_jobs(jobs)
    if scheduler is not None:
        return "dask"
    return "loky" if jobs > 1 else "serial"


def dispatch(
    function: Callable,
    tasks: Sequence[tuple],
    *,
    context: Any = None,
    jobs: int = 1,
    scheduler=None,
) -> Iterator[tuple[int, Any]]:
    """Run ``function(context, *task)`` for every task; yield ``(index, value)`` as each finishes.

    Parameters
    ----------
    function : callable
        A module-level function (it is pickled to the workers).
    tasks : sequence of tuple
        Positional arguments of each call after ``context``.
    context : object, optional
        Shared by every call (e.g. the datasets); sent to each worker once.
    jobs : int
        Local worker processes (1: run here, serially).
    scheduler : str or dask.distributed.Client, optional
        Address of a Dask scheduler (e.g. ``"tcp://127.0.0.1:8786"``) or a connected Client;
        overrides ``jobs``.

    Yields
    ------
    (int, object)
        Index into ``tasks`` and the function's return value, in order of completion
        (config order for the serial backend).

    Raises
    ------
    SchedulerError
        If the scheduler cannot be reached or its workers cannot import this bayesnsi.
    """
    backend = backend_name(jobs, scheduler)
    if not tasks:
        return iter(())
    if backend == "serial":
        return _serial(function, tasks, context)
    if backend == "loky":
        return _loky(function, tasks, context, jobs)
    return _dask(function, tasks, context, scheduler)


def connect(scheduler):
    """A :class:`dask.distributed.Client` for an address (or the Client itself), checked.

    Raises
    ------
    SchedulerError
        If dask.distributed is missing, the scheduler does not answer within
        :data:`CONNECT_TIMEOUT_S`, it has no workers, or its workers run other bayesnsi code.
    """
    try:
        from dask.distributed import Client
    except ImportError as exc:  # pragma: no cover - a dependency
        raise SchedulerError("--scheduler needs dask.distributed; install it with pip install 'dask[distributed]'") from exc
    if isinstance(scheduler, Client):
        client, owned = scheduler, False
    else:
        try:
            client, owned = Client(str(scheduler), timeout=CONNECT_TIMEOUT_S, set_as_default=False), True
        except (OSError, TimeoutError, ValueError) as exc:
            raise SchedulerError(
                f"cannot reach the Dask scheduler at {scheduler!r} ({type(exc).__name__}: {exc}); start one with "
                "`dask scheduler` and `dask worker ADDRESS`, check the address, or drop --scheduler to run locally"
            ) from exc
    try:
        _check_workers(client, scheduler)
    except BaseException:
        if owned:
            client.close()
        raise
    return client, owned


def _serial(function, tasks, context):
    for index, task in enumerate(tasks):
        yield index, function(context, *task)


def chunks(n_tasks: int, workers: int) -> list[range]:
    """Task indices grouped for the workers: single tasks, or chunks when there are many.

    Sending tasks one by one costs a round trip (and, for joblib, the context) per task; for
    hundreds of short tasks that dominates. With more than ``8 x workers`` tasks they are grouped
    in chunks of at most :data:`MAX_CHUNK` so that each worker still gets at least 8 chunks
    (load balance; an interrupted run loses at most the chunks in flight).
    """
    size = max(1, min(MAX_CHUNK, n_tasks // (8 * max(int(workers), 1))))
    return [range(start, min(start + size, n_tasks)) for start in range(0, n_tasks, size)]


def _run_chunk(function, context, indexed_tasks):
    return [(index, function(context, *task)) for index, task in indexed_tasks]


def _loky(function, tasks, context, jobs):
    from joblib import Parallel, delayed

    parallel = Parallel(n_jobs=jobs, backend="loky", return_as="generator_unordered")
    groups = [[(i, tasks[i]) for i in chunk] for chunk in chunks(len(tasks), jobs)]
    for results in parallel(delayed(_run_chunk)(function, context, group) for group in groups):
        yield from results


def _dask(function, tasks, context, scheduler):
    from dask.distributed import as_completed

    client, owned = connect(scheduler)
    futures = []
    try:
        [shared] = client.scatter([context], broadcast=True, hash=False)
        workers = max(len(client.scheduler_info().get("workers", {})), 1)
        groups = [[(i, tasks[i]) for i in chunk] for chunk in chunks(len(tasks), workers)]
        futures = [client.submit(_run_chunk, function, shared, group, pure=False) for group in groups]
        for future in as_completed(futures, loop=client.loop):
            yield from future.result()
    finally:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        if owned:
            client.close()


def _check_workers(client, scheduler) -> None:
    from ..io.cache import code_fingerprint

    try:
        found = client.run(code_fingerprint)
    except Exception as exc:
        raise SchedulerError(
            f"the workers of {scheduler!r} cannot run bayesnsi ({type(exc).__name__}: {exc}); install the same "
            "bayesnsi on every worker"
        ) from exc
    if not found:
        raise SchedulerError(f"the Dask scheduler {scheduler!r} has no workers; start some with `dask worker ADDRESS`")
    mine = code_fingerprint()
    other = sorted(worker for worker, fingerprint in found.items() if fingerprint != mine)
    if other:
        raise SchedulerError(
            f"worker(s) {other} run different bayesnsi code or numerical packages than this process, so their "
            "results would not be reproducible; install the same versions everywhere"
        )


def _check_jobs(jobs) -> None:
    if not isinstance(jobs, int) or isinstance(jobs, bool) or jobs < 1:
        raise ConfigError(f"jobs must be a positive integer, got {jobs!r}; use --jobs 1 to run serially")
