"""Bench the acceptance atlas: its build time, and the per-query cost of margins from the
atlas against the exact margin search, and of the seat probability.

Reports medians (and the simulations each margins call ran) on random poses of each design;
the ratio is exact search over atlas. Times are wall times of this machine as it is: on a
shared, loaded machine they are upper bounds, say so when quoting them.

Usage::

    python scripts/bench_atlas.py [--poses 60] [--builds 3] [--seed 1]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import xface_core as xf
import xface_core.atlas_margins as atlas_margins_module
import xface_core.margins as margins_module
from xface_core.atlas import build_atlas

DESIGNS = (("X", 0.25, 2.0), ("V", 0.5, 1.0), ("S", 1.0, 1.0))


class SimulationCounter:
    """Counts the poses and batch calls that the margin modules send to the engine."""

    def __init__(self) -> None:
        self.poses = 0
        self.calls = 0
        self._real = xf.predict_batch

    def __call__(self, design: xf.FaceDesign, x0: Any, theta0: Any, **kw: Any) -> xf.BatchResult:
        self.calls += 1
        self.poses += int(np.broadcast(np.asarray(x0), np.asarray(theta0)).size)
        return self._real(design, x0, theta0, **kw)

    def install(self) -> None:
        atlas_margins_module.predict_batch = self  # type: ignore[assignment]
        margins_module.predict_batch = self  # type: ignore[assignment]

    def take(self) -> tuple[int, int]:
        out = (self.poses, self.calls)
        self.poses = self.calls = 0
        return out


def timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=60)
    parser.add_argument("--builds", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    counter = SimulationCounter()
    counter.install()
    for kind, h, rp in DESIGNS:
        design = xf.make_face(kind, h, rp)
        builds = [build_atlas(design) for _ in range(args.builds)]
        atlas = builds[-1]
        build_s = statistics.median(b.build_seconds for b in builds)
        n_in_paper_range = int(
            np.count_nonzero(np.abs(atlas.theta0) <= math.pi / 2) * atlas.x0.size
        )
        print(
            f"{kind} H/D={h} r_p={rp}: atlas {atlas.outcomes.shape[0]} x {atlas.outcomes.shape[1]}"
            f" = {atlas.outcomes.size} nodes ({n_in_paper_range} with |theta0| <= pi/2), "
            f"{atlas.simulations} simulated; build median {build_s:.2f} s "
            f"(of {args.builds}: {', '.join(f'{b.build_seconds:.2f}' for b in builds)})"
        )
        fast_t, exact_t, fast_n, exact_n, prob_t = [], [], [], [], []
        for _ in range(args.poses):
            x0 = rng.uniform(-1.0, 1.0)
            theta0 = rng.uniform(-math.pi / 2, math.pi / 2)
            outcome = xf.predict(design, x0, theta0, path=False).outcome
            counter.take()
            fast_t.append(timed(lambda: xf.margins_from_atlas(atlas, x0, theta0, outcome)))  # noqa: B023
            fast_n.append(counter.take())
            exact_t.append(timed(lambda: xf.outcome_margins(design, x0, theta0, outcome)))  # noqa: B023
            exact_n.append(counter.take())
            cov = np.diag([0.05**2, 0.05**2])
            prob_t.append(timed(lambda: xf.seat_probability(design, x0, theta0, cov, atlas=atlas)))  # noqa: B023
        fm, em = statistics.median(fast_t), statistics.median(exact_t)
        print(
            f"  margins per query (median of {args.poses}): atlas {fm * 1e3:.1f} ms "
            f"({statistics.median(p for p, _ in fast_n):.0f} simulations in "
            f"{statistics.median(c for _, c in fast_n):.0f} batches), exact "
            f"{em * 1e3:.1f} ms ({statistics.median(p for p, _ in exact_n):.0f} simulations in "
            f"{statistics.median(c for _, c in exact_n):.0f} batches); ratio {em / fm:.1f}x"
        )
        print(
            f"  seat_probability per query, sigma 0.05 D and 0.05 rad (median): "
            f"{statistics.median(prob_t) * 1e3:.1f} ms"
        )


if __name__ == "__main__":
    main()
