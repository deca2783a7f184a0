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
    calls; large arrays are memory-mapped, not copied). At most one worker per task and as
    many as the memory limit allows (:func:`worker_count`); every worker watches its parent
    and exits within :data:`PARENT_CHECK_S` when the parent is gone, ``kill -9`` included
    (:func:`_watch_parent`), so no worker outlives the command.
``dask``
    ``scheduler`` given: a :class:`dask.distributed.Client` connected to that address
    (``tcp://host:8786``), or an existing Client. The shared context (e.g. the datasets) is
    scattered to the workers once; tasks are submitted and gathered as they complete.
    Workers must run the same bayesnsi code as this process (checked on connection).
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ._fingerprint import code_fingerprint
from ._limits import DEFAULT_RUN_MEMORY, max_memory_bytes
from .exceptions import ConfigError, SchedulerError
from .options import MAX_JOBS

__all__ = ["PARENT_CHECK_S", "WORKER_BYTES", "backend_name", "chunks", "connect", "dispatch", "shutdown_workers",
           "worker_count"]

WORKER_BYTES = 256 * 2**20
"""Memory counted for one local worker process besides its task (the numerical stack imported: about 120 MiB)."""

PARENT_CHECK_S = 0.5
"""Seconds between a worker's checks that its parent process is alive."""

CONNECT_TIMEOUT_S = 10.0
"""Seconds to wait for a Dask scheduler before giving up."""

MAX_CHUNK = 16
"""Most tasks sent to a worker in one message (see :func:`chunks`)."""


def backend_name(jobs: int = 1, scheduler=None) -> str:
    """Name of the backend :func:`dispatch` uses for these settings.

    Parameters
    ----------
    jobs : int
        Local worker processes, 1 to :data:`bayesnsi.options.MAX_JOBS`.
    scheduler : str or dask.distributed.Client, optional
        Address of a Dask scheduler or a connected Client; overrides ``jobs``.

    Returns
    -------
    str
        ``"dask"`` with a scheduler, else ``"loky"`` for ``jobs > 1``, else ``"serial"``.

    Raises
    ------
    ConfigError
        If ``jobs`` is not an integer in ``[1, MAX_JOBS]``.
    """
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
    task_bytes: int = 0,
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
    task_bytes : int
        Estimated memory of one task [bytes]; with :data:`WORKER_BYTES` it caps the local
        workers (:func:`worker_count`).

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
    if backend == "loky":
        jobs = worker_count(jobs, len(tasks), task_bytes)
        backend = "loky" if jobs > 1 else "serial"
    if backend == "serial":
        return _serial(function, tasks, context)
    if backend == "loky":
        return _loky(function, tasks, context, jobs)
    return _dask(function, tasks, context, scheduler)


def worker_count(jobs: int, n_tasks: int, task_bytes: int = 0) -> int:
    """Local worker processes to start: ``jobs``, at most one per task and as many as memory allows.

    Parameters
    ----------
    jobs : int
        Requested workers (``--jobs``).
    n_tasks : int
        Tasks to run (a worker without a task would only cost memory).
    task_bytes : int
        Estimated memory of one task [bytes].

    Returns
    -------
    int
        ``min(jobs, n_tasks, limit // (WORKER_BYTES + task_bytes))``, at least 1; the limit is
        :func:`bayesnsi._limits.max_memory_bytes` with the default :data:`bayesnsi._limits.DEFAULT_RUN_MEMORY`.

    Examples
    --------
    >>> worker_count(256, 3)
    3
    """
    limit = max_memory_bytes(DEFAULT_RUN_MEMORY)
    by_memory = limit // (WORKER_BYTES + max(int(task_bytes), 0))
    return max(1, min(int(jobs), int(n_tasks), by_memory))


def connect(scheduler):
    """A :class:`dask.distributed.Client` for an address (or the Client itself), checked.

    An address is first checked for its form (``tcp://HOST:PORT``) and probed with one Dask
    ``identity`` request under a hard deadline of :data:`CONNECT_TIMEOUT_S`, so a dead port, a
    socket that accepts and never answers, or a server speaking another protocol fails fast
    with one line instead of hanging inside dask.

    Parameters
    ----------
    scheduler : str or dask.distributed.Client
        ``tcp://HOST:PORT`` (``HOST:PORT`` means tcp) or a connected Client (used as is).

    Returns
    -------
    client : dask.distributed.Client
    owned : bool
        True when the Client was created here (the caller closes it).

    Raises
    ------
    SchedulerError
        If dask.distributed is missing, the address is malformed or uses TLS, the scheduler
        does not answer as a Dask scheduler within :data:`CONNECT_TIMEOUT_S`, it has no
        workers, or its workers run other bayesnsi code.
    """
    try:
        from dask.distributed import Client
    except ImportError as exc:  # the optional extra bayesnsi[dask]
        raise SchedulerError(
            "--scheduler needs dask.distributed, which is not installed; pip install 'bayesnsi[dask]'"
        ) from exc
    if isinstance(scheduler, Client):
        client, owned = scheduler, False
    else:
        address = _probe(_check_address(scheduler))
        try:
            client, owned = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False), True
        except Exception as exc:  # anything dask raises on connection becomes one line
            raise _unreachable(scheduler, exc) from exc
    try:
        _check_workers(client, scheduler)
    except BaseException:
        if owned:
            client.close(timeout=CONNECT_TIMEOUT_S)
        raise
    return client, owned


def _check_address(scheduler) -> str:
    """``tcp://HOST:PORT`` from a scheduler address, or a one-line SchedulerError."""
    text = str(scheduler).strip()
    scheme, sep, location = text.partition("://")
    if not sep:
        scheme, location = "tcp", text
    scheme = scheme.lower()
    if scheme == "tls":
        raise SchedulerError(
            f"--scheduler {text!r}: TLS schedulers need certificates, which the command line does not take; "
            "connect a dask.distributed Client with its Security settings from Python, or use a tcp:// address"
        )
    host, colon, port = location.rpartition(":")
    host = host.strip("[]")
    if scheme != "tcp" or not colon or not host or not port.isdigit() or not 0 < int(port) < 65536 or len(text) > 300:
        raise SchedulerError(
            f"--scheduler {text[:80]!r} is not a Dask scheduler address; expected tcp://HOST:PORT "
            "(e.g. tcp://10.0.0.5:8786)"
        )
    return f"tcp://{location}"


def _probe(address: str) -> str:
    """Ask ``address`` for its identity within :data:`CONNECT_TIMEOUT_S`; return it if a scheduler."""
    import asyncio

    from distributed.comm import connect as comm_connect

    async def ask():
        comm = await comm_connect(address, timeout=CONNECT_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = asyncio.run(asyncio.wait_for(ask(), CONNECT_TIMEOUT_S))
    except TimeoutError as exc:
        raise _unreachable(address, TimeoutError(f"no answer within {CONNECT_TIMEOUT_S:g} s")) from exc
    except Exception as exc:  # junk on the wire can raise anything (MemoryError too)
        raise _unreachable(address, exc) from exc
    found = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
    if found != "Scheduler":
        raise _unreachable(address, ValueError(f"it answered as {found!r}, not as a Dask scheduler"))
    return address


def _unreachable(scheduler, exc: BaseException) -> SchedulerError:
    detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
    return SchedulerError(
        f"cannot reach the Dask scheduler at {str(scheduler)!r} ({detail}); start one with "
        "`dask scheduler` and `dask worker ADDRESS`, check the address, or drop --scheduler to run locally"
    )


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

    parallel = Parallel(
        n_jobs=jobs, backend="loky", return_as="generator_unordered", initializer=_watch_parent, initargs=(os.getpid(),)
    )
    groups = [[(i, tasks[i]) for i in chunk] for chunk in chunks(len(tasks), jobs)]
    for results in parallel(delayed(_run_chunk)(function, context, group) for group in groups):
        yield from results


def _watch_parent(parent_pid: int) -> None:
    """In a worker: exit at once when ``parent_pid`` is no longer this process's parent (it died).

    A daemon thread compares :func:`os.getppid` with the pid of the process that started the
    pool every :data:`PARENT_CHECK_S`; an orphaned worker is re-parented (to init or a
    sub-reaper), so the comparison fails within that time after the parent's death, whatever
    killed it. The worker then kills itself (``SIGKILL``: no clean-up that could hang).
    """
    if os.getppid() != parent_pid:
        _die()

    def watch():
        while True:
            time.sleep(PARENT_CHECK_S)
            if os.getppid() != parent_pid:
                _die()

    threading.Thread(target=watch, name="bayesnsi-parent-watch", daemon=True).start()


def _die() -> None:
    import signal

    os.kill(os.getpid(), getattr(signal, "SIGKILL", signal.SIGTERM))


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


def shutdown_workers() -> None:
    """Kill the local worker processes of the loky backend, if any (after SIGINT or SIGTERM).

    The workers are reused between calls and outlive an interrupted :func:`dispatch`; this
    stops them (and anything they started) at once, so nothing keeps computing after the
    command has exited. Does nothing when no worker was started.
    """
    from joblib.externals.loky import reusable_executor

    executor = getattr(reusable_executor, "_executor", None)
    if executor is None:
        return
    for process in list(getattr(executor, "_processes", {}).values()):
        with contextlib.suppress(Exception):
            process.kill()
    with contextlib.suppress(Exception):
        executor.shutdown(wait=True, kill_workers=True)


def _check_jobs(jobs) -> None:
    if not isinstance(jobs, int) or isinstance(jobs, bool) or jobs < 1:
        raise ConfigError(f"jobs must be a positive integer, got {jobs!r}; use --jobs 1 to run serially")
    if jobs > MAX_JOBS:
        raise ConfigError(
            f"jobs must be at most {MAX_JOBS} local worker processes, got {jobs}; use a Dask cluster "
            "(--scheduler) for more"
        )
