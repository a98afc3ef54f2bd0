"""The job runner under studies: local processes that die are restarted, a lost cause is
given up with a clear error, and an interrupt keeps what was running."""

from __future__ import annotations

import functools
import os
import threading
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from xface_core.study import executors
from xface_core.study.executors import LocalPool, WorkerLost, execute


def _die_on_first_call(marker: Path, job: int) -> int:
    """Double ``job``; the first call of all (no marker yet) kills its worker process."""
    try:
        marker.touch(exist_ok=False)
    except FileExistsError:
        return 2 * job
    os._exit(1)


def _always_die(job: int) -> int:
    os._exit(1)


def test_a_worker_that_dies_is_replaced_and_its_job_run_again(tmp_path: Path) -> None:
    results: dict[int, int] = {}
    fn = functools.partial(_die_on_first_call, tmp_path / "died")
    execute(fn, list(range(8)), results.__setitem__, workers=2)
    assert (tmp_path / "died").exists()
    assert results == {j: 2 * j for j in range(8)}


def test_a_job_that_always_kills_its_worker_is_given_up(tmp_path: Path) -> None:
    with pytest.raises(WorkerLost, match="died 2 times"):
        execute(_always_die, [1], lambda j, r: None, workers=2, retries=1)


def test_a_local_pool_has_no_more_processes_than_jobs(monkeypatch: pytest.MonkeyPatch) -> None:
    sizes: list[int] = []

    class CountedPool(LocalPool):
        def __init__(self, workers: int) -> None:
            sizes.append(workers)
            super().__init__(workers)

    monkeypatch.setattr(executors, "LocalPool", CountedPool)
    results: dict[int, int] = {}
    execute(abs, [-1, -2], results.__setitem__, workers=64)
    assert sizes == [2]
    assert results == {-1: 1, -2: 2}


def test_one_worker_runs_in_this_process() -> None:
    seen: list[int] = []
    execute(lambda j: os.getpid(), [1, 2], lambda j, r: seen.append(r), workers=1)
    assert seen == [os.getpid()] * 2


def test_an_interrupt_keeps_the_running_jobs_and_cancels_the_rest() -> None:
    release = threading.Event()
    kept: list[int] = []

    def job(j: int) -> int:
        if j >= 2:  # later jobs wait: they are running or queued when the interrupt comes
            release.wait(timeout=30)
        return j

    def on_result(j: int, result: int) -> None:
        kept.append(j)
        if len(kept) == 2:
            release.set()
            raise KeyboardInterrupt

    with ThreadPoolExecutor(1) as pool, pytest.raises(KeyboardInterrupt):
        execute(job, list(range(50)), on_result, executor=pool)
    assert kept[:2] == [0, 1]
    assert 2 in kept  # running when interrupted: awaited and kept
    assert len(kept) <= 4  # the queued rest was cancelled (one may start before the cancel)
    assert len(set(kept)) == len(kept)  # nothing handed over twice


class _BrokenExecutor(Executor):
    """An executor whose futures fail the way a broken process pool's do."""

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
        from concurrent.futures.process import BrokenProcessPool

        fut: Future[Any] = Future()
        fut.set_exception(BrokenProcessPool("a worker died"))
        return fut


def test_a_broken_executor_of_the_caller_is_not_restarted() -> None:
    with pytest.raises(WorkerLost, match="cannot be restarted"):
        execute(lambda j: j, [1, 2], lambda j, r: None, executor=_BrokenExecutor())


def _worker_pid(job: int) -> int:
    return os.getpid()


def test_a_caller_s_local_pool_serves_calls_after_the_first_with_the_same_workers() -> None:
    with LocalPool(2) as pool:
        first: list[int] = []
        execute(_worker_pid, list(range(8)), lambda _j, pid: first.append(pid), executor=pool)
        again: list[int] = []
        execute(_worker_pid, list(range(8)), lambda _j, pid: again.append(pid), executor=pool)
    assert os.getpid() not in first
    assert len(set(first) | set(again)) <= 2  # no new workers: the pool outlived the first call


def test_a_caller_s_local_pool_replaces_a_worker_that_died(tmp_path: Path) -> None:
    marker = tmp_path / "died"
    results: list[int] = []
    with LocalPool(2) as pool:
        execute(
            functools.partial(_die_on_first_call, marker),
            [1, 2, 3],
            lambda _j, r: results.append(r),
            executor=pool,
        )
        execute(_worker_pid, [1], lambda _j, pid: results.append(pid), executor=pool)
    assert sorted(results[:3]) == [2, 4, 6]
