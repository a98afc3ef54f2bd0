#!/usr/bin/env python3
"""Where a map's time goes by cell: the cost per cell of each outcome and event count.

    .venv/bin/python scripts/bench/map_cost_by_outcome.py [--face X --h-over-d 1 --r-p 1]
        [--grid 41] [--repeats 5] [--tile 5] [--min-cells 20]

One 41 x 41 map of the design (default physics, one thread) is simulated. Its cells are
grouped by outcome and number of events. Each group with at least ``--min-cells`` cells is
then timed as a batch of its own poses, tiled ``--tile`` times (best of ``--repeats``).

A markdown table is printed with one row per group:
- its cells and their mean steps;
- microseconds per cell;
- its share of the map's time: its cells times its cost, over the whole map's best time.

Timings are findings, not checks: they vary with the machine and its load. The rows were
first taken for docs/notes/2026-11-30-where-a-seat-spends.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence

import numpy as np

import xface_core as xf
from xface_core.errors import XfaceError

FACES: dict[str, Callable[[float, float], xf.FaceDesign]] = {
    "X": xf.x_face, "V": xf.v_face, "S": xf.s_face,
}  # fmt: skip
HEADER = (
    "| outcome | events | cells | steps | us per cell | share of the map's time |",
    "|---|---:|---:|---:|---:|---:|",
)


def best_time(design: xf.FaceDesign, xs: np.ndarray, ts: np.ndarray, repeats: int) -> float:
    """The shortest of ``repeats`` one-thread batches of the poses ``xs``, ``ts`` (s)."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        xf.predict_batch(design, xs, ts, threads=1)
        best = min(best, time.perf_counter() - start)
    return float(best)


def rows(
    design: xf.FaceDesign, grid: int, repeats: int, tile: int, min_cells: int
) -> tuple[list[str], float]:
    """The table's rows, and the whole map's best time (s)."""
    X, T = np.meshgrid(xf.x0_grid(grid), xf.theta_grid(grid), indexing="ij")
    xs, ts = (X * design.width).ravel(), T.ravel()
    whole = xf.predict_batch(design, xs, ts, threads=1)
    map_s = best_time(design, xs, ts, repeats)
    outcome, events, steps = whole.outcome.ravel(), whole.events.ravel(), whole.steps.ravel()
    out = []
    for code in np.unique(outcome):
        for n_events in np.unique(events[outcome == code]):
            group = (outcome == code) & (events == n_events)
            n = int(group.sum())
            if n < min_cells:
                continue
            gx, gt = np.tile(xs[group], tile), np.tile(ts[group], tile)
            per_cell = best_time(design, gx, gt, repeats) / gx.size
            out.append(
                f"| {xf.Outcome(code).name} | {n_events} | {n} | {steps[group].mean():.2f} "
                f"| {per_cell * 1e6:.2f} | {n * per_cell / map_s:.2f} |"
            )
    return out, map_s


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )  # fmt: skip
    parser.add_argument("--face", choices=sorted(FACES), default="X")
    parser.add_argument("--h-over-d", type=float, default=1.0)
    parser.add_argument("--r-p", type=float, default=1.0)
    parser.add_argument("--grid", type=int, default=41, help="cells per side (3-401)")
    parser.add_argument("--repeats", type=int, default=5, help="best of this many (1-100)")
    parser.add_argument("--tile", type=int, default=5, help="each group's poses, repeated (1-100)")
    parser.add_argument("--min-cells", type=int, default=20, help="smaller groups are left out")
    args = parser.parse_args(argv)
    for name, low, high in (("grid", 3, 401), ("repeats", 1, 100), ("tile", 1, 100)):
        if not low <= getattr(args, name) <= high:
            parser.error(f"--{name} must lie in {low}..{high}")
    try:
        design = FACES[args.face](args.h_over_d, args.r_p)
    except XfaceError as exc:
        parser.error(str(exc))
    table, map_s = rows(design, args.grid, args.repeats, args.tile, max(args.min_cells, 1))
    n = args.grid * args.grid
    print(f"{args.face} {args.h_over_d:g}/{args.r_p:g}, {args.grid} x {args.grid} map: "
          f"{map_s * 1e3:.2f} ms ({map_s / n * 1e6:.2f} us per cell), one thread")  # fmt: skip
    print("\n".join((*HEADER, *table)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
