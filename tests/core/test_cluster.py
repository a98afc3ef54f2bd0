"""Studies on a Dask cluster: a LocalCluster on loopback (two worker processes; its HTTP
server, which dashboard_address=None does not turn off, on a free loopback port) gives the
same table as local processes, through the API and through ``--scheduler``."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from xface_core.cli import main
from xface_core.designspace import DesignSpace
from xface_core.errors import XfaceValueError
from xface_core.study import StudyProgress, read_study, run_study

distributed = pytest.importorskip("distributed")

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
    c = distributed.Client(cluster)
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
    from xface_core.cluster import connect

    with pytest.raises(XfaceValueError, match="cannot reach the Dask scheduler"):
        connect("tcp://127.0.0.1:9", timeout_s=1.0)


def test_a_scheduler_address_without_a_protocol_is_refused() -> None:
    from xface_core.cluster import connect

    with pytest.raises(XfaceValueError, match="tcp://HOST:8786"):
        connect("127.0.0.1:8786")


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
