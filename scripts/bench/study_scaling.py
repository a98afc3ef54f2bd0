"""Scaling of a design study on Dask: the same sweep on 1 and on 2 workers, side by side.

    python scripts/bench/study_scaling.py [--repeats 3] [--grid 41] [--face X]

Starts a Dask ``LocalCluster`` on loopback (no dashboard) with one worker process and another
with two (one thread each), and runs the face's 121 designs of the paper's table (11 H/D x
11 r_p, a ``--grid`` pose grid each) through each, interleaved (1, 2, 1, 2, ...) so that load
from elsewhere on a shared machine hits both alike. Each run writes a fresh study file; the
tables (time column left out) must be equal bit for bit, else exit 1. Prints the wall time of
every run, the medians, the speed-up (median 1 / median 2), the machine's load, and the median
time one design took on its worker (the table's ``seconds``): when it grows with the second
worker, the two workers were sharing cores with other work rather than running side by side.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from distributed import Client, LocalCluster

import xface_core as xf
from xface_core.study.run import read_study, run_study
from xface_core.study.space import DesignSpace


def _run(workers: int, space: DesignSpace, grid: int, out: Path) -> float:
    with (
        LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
        Client(cluster) as client,
    ):
        client.run(lambda: xf.acceptance_map(xf.x_face(1.0, 1.0), grid=3).M)  # load the engine
        start = time.perf_counter()
        run_study(space, out, grid=grid, executor=client)
        return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--grid", type=int, default=41)
    parser.add_argument("--face", default="X")
    args = parser.parse_args()
    space = DesignSpace(faces=(args.face,), h_over_d=xf.PAPER_H_OVER_D, r_p=xf.PAPER_R_P)
    times: dict[int, list[float]] = {1: [], 2: []}
    per_design: dict[int, list[float]] = {1: [], 2: []}
    tables = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeats):
            for workers in (1, 2):
                out = Path(tmp) / f"study_{workers}_{k}.parquet"
                seconds = _run(workers, space, args.grid, out)
                times[workers].append(seconds)
                tables.append(read_study(out, timing=False))
                per_design[workers] += read_study(out)["seconds"].to_pylist()
                print(f"repeat {k + 1}, {workers} worker(s): {seconds:.2f} s", flush=True)
    equal = all(t.equals(tables[0]) for t in tables)
    m1, m2 = statistics.median(times[1]), statistics.median(times[2])
    print(
        f"{len(space)} designs of the {args.face}-Face table, {args.grid} x {args.grid} poses each;"
        f" {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at the end"
    )
    print(f"median 1 worker {m1:.2f} s, 2 workers {m2:.2f} s: speed-up {m1 / m2:.2f}")
    d1, d2 = (1e3 * statistics.median(per_design[w]) for w in (1, 2))
    print(f"median time of one design on its worker: {d1:.1f} ms (1 worker), {d2:.1f} ms (2)")
    print(f"tables of every run equal bit for bit: {equal}")
    return 0 if equal else 1


if __name__ == "__main__":
    sys.exit(main())
