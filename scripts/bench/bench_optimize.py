#!/usr/bin/env python3
"""Face search: evaluations per second on 1 and on 2 local workers, and the speed-up.

    .venv/bin/python scripts/bench/bench_optimize.py [--h-over-d 0.25] [--rp 1]
        [--budget 120] [--repeats 3]

Runs ``xface_core.study.optimize.optimize_face`` from scratch (a fresh folder each time, so
every face is simulated) with the same seed and budget on ``--workers`` 1 and on 2, each
``--repeats`` times, alternating, and reports per worker count the median and the least wall
time spent simulating (``FaceSearch.evaluation_seconds``), faces simulated, evaluations per
second, and the speed-up of 2 workers over 1 (of medians and of minima: the machine is shared,
so the minima say more of the code). Both worker counts find the same faces (the search is
deterministic), which the script checks: it exits 1 if they differ.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile

import numpy as np

from xface_core.study.optimize import FaceSearch, ProfileFamily, optimize_face


def one_search(family: ProfileFamily, workers: int, budget: int, grid: int) -> FaceSearch:
    with tempfile.TemporaryDirectory() as out:
        return optimize_face(family, out, grid=grid, budget=budget, workers=workers)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--h-over-d", type=float, default=0.25)
    parser.add_argument("--rp", type=float, default=1.0)
    parser.add_argument("--vertices", type=int, default=3)
    parser.add_argument("--grid", type=int, default=41)
    parser.add_argument("--budget", type=int, default=120)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    family = ProfileFamily(args.h_over_d, args.rp, vertices=args.vertices)
    times: dict[int, list[float]] = {1: [], 2: []}
    found: dict[int, FaceSearch] = {}
    for _ in range(args.repeats):
        for workers in (1, 2):
            search = one_search(family, workers, args.budget, args.grid)
            times[workers].append(search.evaluation_seconds)
            found[workers] = search
    if not np.array_equal(found[1].best_point, found[2].best_point):
        print("1 and 2 workers found different faces: the search is not deterministic")
        return 1
    simulated = found[1].simulated
    print(
        f"face search H/D {args.h_over_d:g} r_p {args.rp:g}, {args.vertices} vertices, "
        f"{args.grid} x {args.grid} grid, budget {args.budget}: {simulated} faces simulated "
        f"per run, best {found[1].criterion} {found[1].score:g} (X-Face {found[1].start_score:g})"
    )
    print("workers  median s  least s  evaluations/s (median)  (least)")
    for workers, ts in times.items():
        med, low = statistics.median(ts), min(ts)
        print(
            f"{workers:>7}  {med:8.2f}  {low:7.2f}  {simulated / med:22.1f}  {simulated / low:7.1f}"
        )
    med_ratio = statistics.median(times[1]) / statistics.median(times[2])
    low_ratio = min(times[1]) / min(times[2])
    print(f"speed-up of 2 workers: {med_ratio:.2f} (medians), {low_ratio:.2f} (minima)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
