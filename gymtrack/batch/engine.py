"""Running many independent tasks on Dask: a LocalCluster of processes or any scheduler.

Paper: none directly; this spreads the routines of Sections III-IV over processes and machines
(the paper's 140 performances; thousands at a championship). Used by the batch
(:mod:`.run`) and the benchmark (``gymtrack benchmark --scheduler``, through :func:`dask_runner`).

* :func:`dask_client`: a ``LocalCluster`` of ``workers`` processes with one thread each (the
  kernels are numba; threads would share the GIL-free loops badly and the caches race), or a
  ``Client`` of a running scheduler (``tcp://host:8786``). The numba cache is warmed in this
  process before any worker starts (parallel first compiles race: numba issues 4807, 10128);
  on a scheduler the first worker warms alone, then the rest.
* :func:`run_tasks`: submits at most one task per worker thread at a time (so a worker that dies
  holds one task only: with ``allowed-failures`` 0 only that task is reported), ``retries=0``,
  and hands each result, or the exception (``KilledWorker`` when the worker died), to a callback
  as it finishes. ``Ctrl-C`` cancels what is queued and returns what finished.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence

from ..errors import InputError

__all__ = ["dask_client", "run_tasks", "warm_numba", "numba_cache_folders", "numba_cache_report", "worker_reports",
           "dask_runner", "TaskOutcome"]


def _need_dask():
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise InputError("running routines on Dask (gymtrack batch, benchmark --jobs/--scheduler) needs the 'batch' extra: "
                         "pip install 'gymtrack[batch]'") from None


def warm_numba() -> None:
    """Compile or load every tracker kernel once in this process (:func:`gymtrack.tracking.warm_up`)."""
    from ..tracking import warm_up

    warm_up()


def numba_cache_folders() -> list[str]:
    """The folders this process's numba kernels are cached in (each compiled dispatcher's cache path:
    ``__pycache__`` beside its module, or under ``$NUMBA_CACHE_DIR``)."""
    import sys

    found = set()
    for name, mod in list(sys.modules.items()):
        if not name.startswith("gymtrack.") or mod is None:
            continue
        for obj in vars(mod).values():
            path = getattr(getattr(obj, "_cache", None), "_cache_path", None)
            if path:
                found.add(str(path))
    return sorted(found)


def numba_cache_report() -> dict:
    """Warm the kernels in this (worker) process and say where their cache is and how long it took."""
    t0 = time.perf_counter()
    warm_numba()
    folders = numba_cache_folders()
    common = os.path.commonpath(folders) if folders else "(none: nothing compiled)"
    return {"host": socket.gethostname(), "pid": os.getpid(), "cache_dir": common, "cache_folders": folders,
            "warm_up_seconds": round(time.perf_counter() - t0, 3)}


def _ignore_sigint_plugin():
    """A worker plugin: the local workers ignore SIGINT. Ctrl-C reaches the whole process group;
    this process cancels the work and closes the cluster, the workers must not die first."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        def setup(self, worker) -> None:
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreSigint()


@contextmanager
def _sigint_held() -> Iterator[None]:
    """Hold SIGINT back while the cluster starts: a Ctrl-C then lands once it is up (and is closed
    in order), never in a half-started cluster."""
    import signal

    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover (Windows)
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None, timeout: float = 30.0,
                worker_timeout: float = 120.0) -> Iterator[Any]:
    """A ``distributed.Client``: of a new LocalCluster (``workers`` processes, one thread each) or of ``scheduler``.

    On exit the client is closed, and the LocalCluster with it. Raises InputError naming
    ``--scheduler`` when it cannot be reached in ``timeout`` s or has no worker after ``worker_timeout`` s.
    """
    _need_dask()
    import dask
    from distributed import Client, LocalCluster

    warm_numba()  # before any worker starts: workers then load the cache instead of racing to write it
    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            raise InputError(f"cannot reach the Dask scheduler {scheduler}: {exc}", field="--scheduler") from None
        try:
            client.wait_for_workers(1, timeout=worker_timeout)
        except TimeoutError:
            client.close()
            raise InputError(f"the Dask scheduler {scheduler} has no worker after {worker_timeout:g} s "
                             "(start some with `dask worker ADDRESS`)", field="--scheduler") from None
    else:
        n = max(1, int(workers or os.cpu_count() or 1))
        # a dead worker fails its task at once (no re-run of a routine that kills workers)
        with dask.config.set({"distributed.scheduler.allowed-failures": 0}), _sigint_held():
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=logging.CRITICAL)
            client = Client(cluster)
            client.register_plugin(_ignore_sigint_plugin(), name="gymtrack-ignore-sigint")
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def worker_reports(client) -> dict[str, dict]:
    """Warm every worker (the first alone, then the rest) and collect :func:`numba_cache_report` from each."""
    addrs = sorted(client.nthreads())
    if not addrs:
        return {}
    out = client.run(numba_cache_report, workers=addrs[:1])
    if len(addrs) > 1:
        out |= client.run(numba_cache_report, workers=addrs[1:])
    return out


class TaskOutcome:
    """What :func:`run_tasks` hands the callback: ``index``, ``result`` or ``error`` (the exception)."""

    __slots__ = ("index", "result", "error")

    def __init__(self, index: int, result: Any = None, error: BaseException | None = None):
        self.index, self.result, self.error = index, result, error


def run_tasks(client, fn: Callable, args: Sequence[tuple], on_done: Callable[[TaskOutcome], None],
              keys: Sequence[str] | None = None) -> bool:
    """Run ``fn(*args[i])`` for every i on the client's workers; ``on_done`` gets each outcome as it ends.

    At most one task per worker thread is in flight. A task whose worker died gets the
    scheduler's ``KilledWorker`` as its error, an exception raised in ``fn`` itself that exception.
    Returns False when interrupted (Ctrl-C): the queued tasks are cancelled, the finished ones
    were handed over.
    """
    from distributed import as_completed

    keys = list(keys) if keys is not None else [f"task-{i}" for i in range(len(args))]
    pending = list(range(len(args)))[::-1]
    stamp = f"{os.getpid()}-{time.time_ns()}"
    index: dict = {}

    def submit_next() -> Any:
        i = pending.pop()
        fut = client.submit(fn, *args[i], key=f"gymtrack-{keys[i]}-{stamp}", pure=False, retries=0)
        index[fut.key] = i
        return fut

    slots = max(1, sum(client.nthreads().values()))
    ac = as_completed([submit_next() for _ in range(min(slots, len(pending)))])
    try:
        for fut in ac:
            i = index.pop(fut.key)
            if fut.status == "finished":
                outcome = TaskOutcome(i, result=fut.result())
            else:
                try:
                    exc = fut.exception()
                except Exception as e:  # a cancelled future: its error is why
                    exc = e
                outcome = TaskOutcome(i, error=exc)
            fut.release()
            if pending:
                ac.add(submit_next())
            on_done(outcome)
        return True
    except KeyboardInterrupt:
        client.cancel(list(ac.futures))
        return False


def dask_runner(workers: int | None = None, scheduler: str | None = None, log: Callable[[str], None] | None = None):
    """A runner for :func:`gymtrack.eval.benchmark.run_suite`: runs its routines on Dask.

    ``runner(fn, args, on_done)`` with ``on_done(i, result_or_exception)``.
    """

    def runner(fn: Callable, args: Sequence[tuple], on_done: Callable[[int, Any], None]) -> None:
        with dask_client(workers, scheduler) as client:
            reports = worker_reports(client)
            if log:
                for addr, rep in sorted(reports.items()):
                    log(f"worker {addr}: numba cache {', '.join(rep['cache_folders']) or rep['cache_dir']} ("
                        f"warm-up {rep['warm_up_seconds']:.2f} s)")
            done = run_tasks(client, fn, args, lambda o: on_done(o.index, o.result if o.error is None else o.error))
            if not done:
                raise KeyboardInterrupt

    return runner
