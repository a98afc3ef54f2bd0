#!/usr/bin/env python3
"""Seat probability: run time against error for the quadrature's settings.

    .venv/bin/python scripts/bench/bench_seat_probability.py [--queries 12] [--seed 0] [--suggest]

``seat_probability`` integrates the Gaussian over rays, adaptive in angle (``ray_tol``, the
default) or ``rays`` evenly spaced ones, and bisects every boundary crossing along a ray
``crossing_steps`` times (default 4). This script draws
random queries that straddle a boundary (0.001 < P < 0.999 at the reference) on the designs
of ``scripts/evidence/check_atlas.py``'s probability check and the ROS node's (X 0.25/1), computes a
reference with 1024 even rays and 10 crossing steps, and reports for each setting the largest
and the median |P - P_ref| and the median time, rays and simulations per query. The poses and
covariances are drawn as in ``check_atlas.py`` (sigma log-uniform in [0.005, 0.32] D and rad,
correlation in [-0.9, 0.9]), from seat-adjacent poses only (half of that script's draws), since
queries inside one outcome cost one simulation at any setting. ``--suggest`` times
``suggest_approach`` at level 0.95 on such queries instead.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import xface_core as xf
from xface_core.atlas import probability
from xface_core.runner import count_engine_calls

# The queries are drawn as the atlas's own check draws them (scripts/evidence/check_atlas.py).
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evidence"))
from check_atlas import near_seated_poses, random_covariance

DESIGNS = (("X", 0.25, 2.0), ("V", 0.5, 1.0), ("S", 1.0, 1.0), ("X", 0.25, 1.0))
REFERENCE = (1024, 10)
RAYS = (16, 32, 64, 128)
STEPS = (3, 4, 6)
RAY_TOLS = (1e-1, 3e-2, 1e-2, 3e-3)
#: Crossing steps of ``boundary="atlas"`` (its bisection costs no simulation in most cells).
ATLAS_STEPS = (4, 8)
#: A setting: even rays (None: adaptive), ray_tol, crossing steps, boundary.
Setting = tuple[int | None, float, int, str]
#: The defaults of seat_probability.
#: The level ``--suggest`` asks for.
SUGGEST_LEVEL = 0.95
DEFAULT: Setting = (None, probability.DEFAULT_RAY_TOL, probability.CROSSING_STEPS, "exact")
#: The defaults with the boundaries drawn from the atlas's flips (the ROS node's setting).
NODE: Setting = (None, probability.DEFAULT_RAY_TOL, probability.CROSSING_STEPS, "atlas")


def straddling_queries(
    atlas: xf.AcceptanceAtlas, n: int, rng: np.random.Generator
) -> list[tuple[float, float, np.ndarray]]:
    """``n`` queries (x0 in D, theta0, covariance in D and rad) near SEATED nodes, drawn by
    ``check_atlas.py``'s own functions."""
    out = []
    for _ in range(n):
        ((x0, theta0),) = near_seated_poses(atlas, 1, rng)
        out.append((float(x0), float(theta0), random_covariance(rng)))
    return out


class Counting:
    """Counts the rays whose masses ``seat_probability`` computes (its simulations are
    counted by ``runner.count_engine_calls``)."""

    def __init__(self) -> None:
        self.rays = 0
        self._masses = probability._ray_masses

    def masses(self, *args):  # type: ignore[no-untyped-def]
        self.rays += int(np.size(args[4]))  # phi
        return self._masses(*args)


def time_suggestions(n: int, rng: np.random.Generator) -> None:
    """Median and largest time of ``suggest_approach(..., level=0.95)`` with the query's
    covariance, on ``n`` straddling queries (drawn as above) per design: as a planner asks
    (cold: the start's probability computed inside), and, on the queries whose probability
    is below the level, as the ROS node asks (the start's probability passed in, as the node
    has computed it for the status)."""
    for kind, h, rp in DESIGNS:
        design = xf.make_face(kind, h, rp)
        atlas = xf.build_atlas(design)
        cold, known = [], []
        for x0, theta0, cov in straddling_queries(atlas, n, rng):
            t0 = time.perf_counter()
            xf.suggest_approach(design, x0, theta0, cov, level=SUGGEST_LEVEL, atlas=atlas)
            cold.append(time.perf_counter() - t0)
            p = float(xf.seat_probability(design, x0, theta0, cov, atlas=atlas))
            if p < SUGGEST_LEVEL:
                t0 = time.perf_counter()
                xf.suggest_approach(
                    design, x0, theta0, cov, level=SUGGEST_LEVEL, atlas=atlas, probability=p
                )
                known.append(time.perf_counter() - t0)
        line = (
            f"{kind} {h:g}/{rp:g}: suggest_approach over {n} queries: median "
            f"{1e3 * statistics.median(cold):.0f} ms, largest {1e3 * max(cold):.0f} ms"
        )
        if known:
            line += (
                f"; the {len(known)} below {SUGGEST_LEVEL:g} with their probability known: "
                f"median {1e3 * statistics.median(known):.0f} ms, "
                f"largest {1e3 * max(known):.0f} ms"
            )
        print(line)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=int, default=12, help="straddling queries per design")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--suggest", action="store_true",
        help="instead: time suggest_approach (level 0.95) on straddling queries per design",
    )  # fmt: skip
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    if args.suggest:
        time_suggestions(args.queries, rng)
        return 0
    counter = Counting()
    probability._ray_masses = counter.masses  # count the rays of every call below
    try:
        work_precision(args.queries, rng, counter)
    finally:
        probability._ray_masses = counter._masses
    return 0


def work_precision(n_queries: int, rng: np.random.Generator, counter: Counting) -> None:
    """The table: every setting on ``n_queries`` straddling queries per design."""
    settings: list[Setting] = [(r, 0.0, s, "exact") for r in RAYS for s in STEPS]
    settings += [(None, t, probability.CROSSING_STEPS, "exact") for t in RAY_TOLS]
    settings += [(None, t, s, "atlas") for t in RAY_TOLS for s in ATLAS_STEPS]
    errors: dict[Setting, list[float]] = {key: [] for key in settings}
    times: dict[Setting, list[float]] = {key: [] for key in settings}
    sims: dict[Setting, list[int]] = {key: [] for key in settings}
    rays_used: dict[Setting, list[int]] = {key: [] for key in settings}
    # The largest error of the defaults, exact and as the node asks, and its query.
    worst = {DEFAULT: (-1.0, ""), NODE: (-1.0, "")}
    for kind, h, rp in DESIGNS:
        design = xf.make_face(kind, h, rp)
        # With every flip, as the ROS node builds it: boundary="atlas" draws its boundaries
        # from them; the exact settings do not read them.
        atlas = xf.build_atlas(design, every_flip=True)
        kept = 0
        while kept < n_queries:
            x0, theta0, cov = straddling_queries(atlas, 1, rng)[0]
            x, c = x0, cov  # make_face's width is 1: x0 and cov are in D already
            ref = float(
                xf.seat_probability(
                    design, x, theta0, c, atlas=atlas, rays=REFERENCE[0],
                    crossing_steps=REFERENCE[1],
                )
            )  # fmt: skip
            if not 0.001 < ref < 0.999:
                continue
            kept += 1
            for key in settings:
                rays, tol, steps, boundary = key
                counter.rays = 0
                with count_engine_calls() as calls:
                    t0 = time.perf_counter()
                    p = float(
                        xf.seat_probability(
                            design, x, theta0, c, atlas=atlas, rays=rays,
                            ray_tol=tol if rays is None else probability.DEFAULT_RAY_TOL,
                            crossing_steps=steps, boundary=boundary,
                        )
                    )  # fmt: skip
                    times[key].append(time.perf_counter() - t0)
                sims[key].append(calls.poses)
                rays_used[key].append(counter.rays)
                errors[key].append(abs(p - ref))
                if key in worst and abs(p - ref) > worst[key][0]:
                    sx, st = math.sqrt(c[0, 0]), math.sqrt(c[1, 1])
                    query = (
                        f"{kind} {h:g}/{rp:g} x0 {x0:+.4f} D, theta0 {theta0:+.4f}, sigma "
                        f"{sx:.4f} D / {st:.4f} rad, rho {c[0, 1] / (sx * st):+.2f}: "
                        f"{p:.5f} against {ref:.5f}"
                    )
                    worst[key] = (abs(p - ref), query)
        print(f"{kind} {h:g}/{rp:g}: {kept} straddling queries", flush=True)
    if not any(sum(s) for s in sims.values()) or not any(sum(r) for r in rays_used.values()):
        raise SystemExit("counted no simulation or no ray: a counter of this bench is broken")
    n = len(errors[settings[0]])
    print(f"\n{n} straddling queries over {len(DESIGNS)} designs; reference "
          f"{REFERENCE[0]} rays, {REFERENCE[1]} crossing steps\n")  # fmt: skip
    print(
        "| rays | boundary | crossing steps | max abs error | median abs error | median ms | "
        "rays, median (max) | median sims |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for key in settings:
        e, n = errors[key], rays_used[key]
        name = f"{key[0]} even" if key[0] is not None else f"adaptive, ray_tol {key[1]:g}"
        print(
            f"| {name} | {key[3]} | {key[2]} | {max(e):.1e} | {statistics.median(e):.1e} | "
            f"{1e3 * statistics.median(times[key]):.1f} | {statistics.median(n):.0f} ({max(n)}) "
            f"| {statistics.median(sims[key]):.0f} |"
        )
    print()
    for key, (error, query) in worst.items():
        print(f"largest error at {key}: {error:.1e}, {query}")


if __name__ == "__main__":
    raise SystemExit(main())
