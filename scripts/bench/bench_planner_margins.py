#!/usr/bin/env python3
"""A planner's margins questions on the node's design, on an atlas built lazily and one built
with every grid-line flip (``build_atlas(every_flip=True)``, as the ROS node builds it).

For ``--poses`` random starts (x0 uniform in [-D, D], theta0 in [-pi/2, pi/2]), each a place
no query has been near before, times ``margins_from_atlas`` on one thread (the node's
``margin_threads``) for the start and for a second start 1e-3 D and 1e-3 rad beside it (a
planner's next candidate). Prints medians, 90th percentiles and maxima (wall time of this
machine as it is: upper bounds on a shared machine). docs/ros.md quotes it.

Usage::

    python scripts/bench/bench_planner_margins.py [--poses 60] [--seed 7] [--face X --h-over-d 0.25
        --r-p 1 --width 0.05]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

import xface_core as xf
from xface_core.atlas.build import build_atlas


def _timed_margins(atlas: xf.AcceptanceAtlas, x0: float, theta0: float) -> float:
    outcome = xf.predict(atlas.design, x0, theta0, path=False).outcome
    t0 = time.perf_counter()
    xf.margins_from_atlas(atlas, x0, theta0, outcome, threads=1)
    return time.perf_counter() - t0


def _summary(times: list[float]) -> str:
    ms = np.asarray(times) * 1e3
    return (
        f"median {statistics.median(ms):.2f} ms (p90 {np.percentile(ms, 90):.1f}, "
        f"max {ms.max():.1f})"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=60)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--face", choices=["X", "V", "S"], default="X")
    parser.add_argument("--h-over-d", type=float, default=0.25)
    parser.add_argument("--r-p", type=float, default=1.0)
    parser.add_argument("--width", type=float, default=0.05, help="D in metres (config/xface.yaml)")
    args = parser.parse_args()
    design = xf.make_face(args.face, args.h_over_d, args.r_p, width=args.width)
    for every_flip in (False, True):
        rng = np.random.default_rng(args.seed)
        atlas = build_atlas(design, every_flip=every_flip)
        first, second = [], []
        for _ in range(args.poses):
            x0 = rng.uniform(-1.0, 1.0) * design.width
            theta0 = rng.uniform(-math.pi / 2, math.pi / 2)
            first.append(_timed_margins(atlas, x0, theta0))
            second.append(_timed_margins(atlas, x0 + 1e-3 * design.width, theta0 + 1e-3))
        print(
            f"every_flip={every_flip}: build {atlas.build_seconds:.2f} s; margins on one "
            f"thread, first query {_summary(first)}, second query beside it {_summary(second)}"
        )


if __name__ == "__main__":
    main()
