"""Running a function over many jobs on an executor, with retries when a worker dies.

The unit of work of a study is one design (a whole pose grid), so a job takes tens of
milliseconds to minutes and the overhead of a future per job does not matter. Three kinds of
executor are accepted:

- ``None``: local processes (forked, one per core by default) that this module owns. When one
  of them dies (killed, out of memory), the pool breaks; it is started again and the jobs
  that had not finished are submitted again, each at most ``retries`` more times.
- a :class:`LocalPool` of the caller's: the same, but the workers outlive the call.
- any :class:`concurrent.futures.Executor` (threads, processes, ``mpi4py``'s, ...): used as
  given, never shut down here.
- a ``dask.distributed.Client`` (anything else with ``submit``, ``cancel`` and ``loop``): its
  own futures, waited on with ``distributed.as_completed``. Dask itself runs the tasks of a dead
  worker again (up to its ``allowed-failures``), so a ``KilledWorker`` reaching us is final.
  Not the client's ``concurrent.futures`` wrapper (``get_executor``): distributed 2026.8's
  ``ClientExecutor`` reads a future's status again after fetching its result, and when the
  worker that held the result dies in between (status "lost") it unpacks the result as an
  error triple and fails a design that had finished. dask is imported only on this path.

Results are handed to ``on_result`` in the calling thread as they arrive, in completion
order; callers that need an order sort afterwards.
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import get_context
from typing import Any, Protocol, TypeVar

from xface_core.errors import XfaceError
from xface_core.runner import process_count

__all__ = ["ClientLike", "LocalPool", "WorkerLost", "execute"]

J = TypeVar("J")
R = TypeVar("R")

#: Extra submissions of a job whose worker died, for the local pool.
DEFAULT_RETRIES = 3


class ClientLike(Protocol):
    """What a ``dask.distributed.Client`` offers that we use."""

    #: The client's event loop (``distributed.as_completed`` needs it: a client made with
    #: ``set_as_default=False``, as ``--scheduler``'s is, is not found otherwise).
    loop: Any

    def submit(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any: ...

    def cancel(self, futures: list[Any], **kwargs: Any) -> Any: ...


class WorkerLost(XfaceError):
    """A job's worker died more often than the retries allow (or Dask gave up on it)."""


def _ignore_interrupts() -> None:
    # Ctrl-C reaches the whole process group: the workers finish their design and the main
    # process decides what to keep, so a keyboard interrupt loses nothing that was running.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class LocalPool:
    """Forked worker processes that can be started again after one of them died.

    :func:`execute` makes one per call when given no executor; a caller that calls it many
    times over (a search, one generation of designs per call) passes one of its own and
    keeps the workers, and the engine they loaded, between calls (a context manager: the
    workers end with it).
    """

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.executor = self._start()

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close(wait=exc_info[0] is None)

    def _start(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            self.workers, mp_context=get_context("fork"), initializer=_ignore_interrupts
        )

    def restart(self) -> None:
        self.executor.shutdown(wait=True, cancel_futures=True)
        self.executor = self._start()

    def close(self, *, wait: bool) -> None:
        self.executor.shutdown(wait=wait, cancel_futures=True)


def _is_lost_worker(exc: BaseException) -> bool:
    # dask.distributed's KilledWorker, recognised by name so that dask stays optional.
    return type(exc).__name__ == "KilledWorker"


def _result(fut: Any, job: object) -> Any:
    """The future's result; Dask giving up on the job (``KilledWorker``) as WorkerLost."""
    try:
        return fut.result()
    except Exception as exc:
        if _is_lost_worker(exc):
            raise WorkerLost(f"{job}: the cluster gave up on it ({exc})") from None
        raise


def execute(
    fn: Callable[[J], R],
    jobs: Sequence[J],
    on_result: Callable[[J, R], None],
    *,
    executor: Executor | ClientLike | LocalPool | None = None,
    workers: int | None = None,
    retries: int = DEFAULT_RETRIES,
) -> None:
    """Call ``on_result(job, fn(job))`` for every job, running ``fn`` on the executor.

    On KeyboardInterrupt the jobs not yet started are cancelled, the running ones are
    awaited and handed to ``on_result`` (on a Dask client: the finished ones are handed
    over and the rest cancelled, running or not), and the interrupt is raised again.

    Raises
    ------
    WorkerLost
        A job's worker died more than ``retries`` times (local pool), or Dask gave up on it.
    """
    if not jobs:
        return
    n_workers = process_count(workers)
    if executor is None and n_workers <= 1:
        for job in jobs:
            on_result(job, fn(job))
        return
    pool: LocalPool | None = None
    owned = executor is None  # a pool made here ends here; a caller's stays up
    target: Executor
    if executor is None:
        # Several asked for run in worker processes even for one job (a job that kills its
        # process is then WorkerLost, not the caller's end), but never more than the jobs.
        pool = LocalPool(min(n_workers, len(jobs)))
        target = pool.executor
    elif isinstance(executor, LocalPool):
        pool = executor
        target = pool.executor
    elif isinstance(executor, Executor):
        target = executor
    else:
        _execute_on_client(fn, jobs, on_result, executor)
        return
    attempts = [0] * len(jobs)
    todo = list(range(len(jobs)))
    interrupted = False
    try:
        while todo:
            futures = {target.submit(fn, jobs[i]): i for i in todo}
            todo = _collect(futures, jobs, on_result, attempts, retries)
            if todo:
                if pool is None:
                    raise WorkerLost("the executor broke (a worker died) and cannot be restarted")
                pool.restart()
                target = pool.executor
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        if pool is not None and owned:
            pool.close(wait=not interrupted)


def _execute_on_client(
    fn: Callable[[J], R],
    jobs: Sequence[J],
    on_result: Callable[[J, R], None],
    client: ClientLike,
) -> None:
    """``execute`` on a Dask client's own futures (see the module docstring for why).

    On KeyboardInterrupt the results already computed are handed over and the rest cancelled.
    """
    from distributed import as_completed  # a client implies distributed is installed

    futures = {client.submit(fn, job, pure=False): i for i, job in enumerate(jobs)}
    handled: set[Any] = set()
    try:
        for fut in as_completed(list(futures), loop=client.loop):  # type: ignore[no-untyped-call]
            handled.add(fut)
            i = futures[fut]
            # The client's result(): it fetches again, after the task runs again, when the
            # result's worker dies before the fetch.
            on_result(jobs[i], _result(fut, jobs[i]))
    except KeyboardInterrupt:
        pending = [f for f in futures if f not in handled]
        finished = {f for f in pending if f.status == "finished"}  # read once: it can change
        client.cancel([f for f in pending if f not in finished])  # one call for them all
        for fut in finished:
            on_result(jobs[futures[fut]], fut.result())
        raise


def _collect(
    futures: dict[Future[R], int],
    jobs: Sequence[J],
    on_result: Callable[[J, R], None],
    attempts: list[int],
    retries: int,
) -> list[int]:
    """Hand the results over as they arrive; the jobs of a broken pool, to be run again."""
    again: list[int] = []
    handled: set[Future[R]] = set()
    try:
        for fut in as_completed(futures):
            handled.add(fut)
            i = futures[fut]
            try:
                result = _result(fut, jobs[i])
            except BrokenProcessPool:
                attempts[i] += 1
                if attempts[i] > retries:
                    raise WorkerLost(
                        f"{jobs[i]}: its worker died {attempts[i]} times; giving up"
                    ) from None
                again.append(i)
                continue
            on_result(jobs[i], result)
    except KeyboardInterrupt:
        pending = {f: i for f, i in futures.items() if f not in handled}
        _drain(pending, jobs, on_result)
        raise
    return sorted(again)


def _drain(
    futures: dict[Future[R], int], jobs: Sequence[J], on_result: Callable[[J, R], None]
) -> None:
    """After an interrupt: cancel what has not started, keep what was running."""
    for fut in futures:
        fut.cancel()
    for fut, i in futures.items():
        if fut.cancelled():
            continue
        try:
            result = fut.result()
        except Exception:  # a worker lost to the same interrupt: the design is in flight
            continue
        on_result(jobs[i], result)
