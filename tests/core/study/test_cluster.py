"""Studies on a Dask cluster: a LocalCluster on loopback (two worker processes; its HTTP
server, which dashboard_address=None does not turn off, on a free loopback port) gives the
same table as local processes, through the API and through ``--scheduler``."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from xface_core.cli import main
from xface_core.errors import XfaceValueError
from xface_core.study.executors import WorkerLost, execute
from xface_core.study.run import StudyProgress, read_study, run_study
from xface_core.study.space import DesignSpace

distributed = pytest.importorskip("distributed")
dask = pytest.importorskip("dask")

#: 24 designs: three faces, two H/D, two r_p, two frictions; a 7 x 7 pose grid keeps it fast.
SPACE = DesignSpace(
    faces=("X", "V", "S"), h_over_d=(0.25, 1.0), r_p=(0.0, 2.0), friction=(0.0, 0.2)
)
GRID = 7


@pytest.fixture(scope="module")
def local_table(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The table of the default executor: two local worker processes (forked before the
    cluster's threads exist)."""
    out = tmp_path_factory.mktemp("local") / "study.parquet"
    run_study(SPACE, out, grid=GRID, workers=2)
    return read_study(out, timing=False)


@pytest.fixture(scope="module")
def client(local_table: Any) -> Iterator[Any]:
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        # The scheduler's HTTP server starts anyway; on 8787 two runs at once collide.
        dashboard_address="127.0.0.1:0",
    )
    # Not the default client: nothing may depend on one (--scheduler's client is not).
    c = distributed.Client(cluster, set_as_default=False)
    try:
        yield c
    finally:
        c.close()
        cluster.close()


def test_the_cluster_listens_on_loopback_only(client: Any) -> None:
    assert client.scheduler.address.startswith("tcp://127.0.0.1:")
    assert client.dashboard_link.startswith("http://127.0.0.1:")
    assert all(w.startswith("tcp://127.0.0.1:") for w in client.scheduler_info()["workers"])


def test_a_sweep_on_the_cluster_equals_the_local_table_bit_for_bit(
    client: Any, local_table: Any, tmp_path: Path
) -> None:
    out = tmp_path / "study.parquet"
    run = run_study(SPACE, out, grid=GRID, executor=client)
    assert run.computed == len(SPACE) >= 20
    assert read_study(out, timing=False).equals(local_table)


def test_the_scheduler_option_runs_the_sweep_on_the_cluster(
    client: Any, local_table: Any, tmp_path: Path
) -> None:
    out = tmp_path / "study.parquet"
    argv = ["sweep", "--face", "X,V,S", "--h-over-d", "0.25,1", "--rp", "0,2"]
    argv += ["--friction", "0,0.2", "--grid", str(GRID), "--out", str(out), "--quiet"]
    assert main([*argv, "--scheduler", client.scheduler.address]) == 0
    assert read_study(out, timing=False).equals(local_table)


def test_an_unreachable_scheduler_is_a_clear_error() -> None:
    from xface_core.study.cluster import connect

    with pytest.raises(XfaceValueError, match="cannot reach the Dask scheduler"):
        connect("tcp://127.0.0.1:9", timeout_s=1.0)


def test_a_scheduler_address_without_a_protocol_is_refused() -> None:
    from xface_core.study.cluster import connect

    with pytest.raises(XfaceValueError, match="tcp://HOST:8786"):
        connect("127.0.0.1:8786")


@pytest.mark.parametrize(
    "address",
    [
        "tcp://host:notaport",
        "tcp://127.0.0.1",
        "tcp://[::1",
        "tcp://a b:8786",
        "tcp://127.0.0.1:99999",
        "tcp://127.0.0.1:0",
        "tcp://:8786",
        "tcp://host:8786/path",
    ],
)
def test_a_malformed_scheduler_address_is_one_line_before_connecting(
    address: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def no_connecting(*args: object, **kwargs: object) -> None:
        raise AssertionError(f"connected to {address!r}")

    monkeypatch.setattr(distributed, "Client", no_connecting)
    argv = ["sweep", "--grid", "5", "--out", str(tmp_path / "s.parquet"), "--quiet"]
    assert main([*argv, "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"xface: error: --scheduler must be an address like tcp://HOST:8786, got {address!r}"
    )
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    "address",
    ["tcp://127.0.0.1:8786", "tcp://[::1]:8786", "tls://sched.example.org:8786", "ws://h:1"],
)
def test_well_formed_scheduler_addresses_pass_the_check(address: str) -> None:
    from xface_core.study.cluster import check_address

    check_address(address)


def test_a_worker_that_dies_mid_sweep_has_its_designs_run_elsewhere(
    client: Any, tmp_path: Path
) -> None:
    # 21 x 21 poses: designs long enough that some are running when the worker dies.
    run_study(SPACE, tmp_path / "serial.parquet", grid=21, workers=1)
    pids = client.run(os.getpid)  # {worker address: pid}: processes of this test's cluster
    killed: list[int] = []

    def kill_a_worker(p: StudyProgress) -> None:
        if p.done == 1 and not killed:
            killed.append(next(iter(pids.values())))
            os.kill(killed[0], signal.SIGKILL)

    out = tmp_path / "study.parquet"
    run = run_study(SPACE, out, grid=21, executor=client, progress=kill_a_worker)
    assert killed
    assert run.computed == len(SPACE)
    expected = read_study(tmp_path / "serial.parquet", timing=False)
    assert read_study(out, timing=False).equals(expected)
    client.wait_for_workers(2, timeout=60)  # the nanny started a new worker
    assert killed[0] not in client.run(os.getpid).values()


def _a_result(job: int) -> dict[str, int]:
    """A result that is not a triple (as a study's row is not)."""
    return {"job": job, "a": 1, "b": 2, "c": 3}


def test_a_result_reported_lost_after_its_fetch_is_still_handed_over(
    client: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The scheduler's report that a result's worker died can reach the client just after
    # the client fetched that result (CI saw it once, mid-sweep). distributed's
    # ClientExecutor then read the status "lost" and unpacked the result as an error.
    fetch = distributed.Future._result

    async def fetch_then_lost(self: Any, raiseit: bool = True) -> Any:
        result = await fetch(self, raiseit=raiseit)
        self._state.lose()  # what the client does on the scheduler's "lost" report
        return result

    monkeypatch.setattr(distributed.Future, "_result", fetch_then_lost)
    got: dict[int, dict[str, int]] = {}
    execute(_a_result, [0, 1, 2], got.__setitem__, executor=client)
    assert got == {j: _a_result(j) for j in range(3)}


def _slow_after_the_first(job: int) -> int:
    if job > 0:
        time.sleep(0.5)
    return job


def test_an_interrupt_on_the_cluster_keeps_what_finished_and_cancels_the_rest(
    client: Any,
) -> None:
    kept: list[int] = []

    def on_result(job: int, result: int) -> None:
        kept.append(result)
        if len(kept) == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        execute(_slow_after_the_first, list(range(40)), on_result, executor=client)
    assert kept[0] == 0
    assert len(set(kept)) == len(kept) < 40  # nothing twice; the queued rest cancelled


def _kill_my_worker(job: int) -> int:
    os._exit(1)


def test_a_job_the_cluster_gives_up_on_is_worker_lost() -> None:
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 0}),
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, host="127.0.0.1", dashboard_address="127.0.0.1:0"
        ) as cluster,
        distributed.Client(cluster, set_as_default=False) as own,
        pytest.raises(WorkerLost, match="the cluster gave up on it"),
    ):
        execute(_kill_my_worker, [1, 2], lambda j, r: None, executor=own)
