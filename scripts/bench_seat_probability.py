#!/usr/bin/env python3
"""Seat probability: run time against error for the quadrature's two settings.

    .venv/bin/python scripts/bench_seat_probability.py [--queries 12] [--seed 0]

``seat_probability`` integrates the Gaussian over rays (``rays``, default 128) and bisects
every boundary crossing along a ray ``crossing_steps`` times (default 6). This script draws
random queries that straddle a boundary (0.001 < P < 0.999 at the reference) on the designs
of ``scripts/check_atlas.py``'s probability check and the ROS node's (X 0.25/1), computes a
reference with 1024 rays and 10 crossing steps, and reports for each setting the largest and
the median |P - P_ref| and the median time and simulations per query. The poses and
covariances are drawn as in ``check_atlas.py`` (sigma log-uniform in [0.005, 0.32] D and rad,
correlation in [-0.9, 0.9]), from seat-adjacent poses only (half of that script's draws), since
queries inside one outcome cost one simulation at any setting.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

import xface_core as xf
from xface_core import probability

DESIGNS = (("X", 0.25, 2.0), ("V", 0.5, 1.0), ("S", 1.0, 1.0), ("X", 0.25, 1.0))
REFERENCE = (1024, 10)
RAYS = (16, 32, 64, 128)
STEPS = (3, 4, 6)
#: The defaults of seat_probability.
DEFAULT = (probability.DEFAULT_RAYS, probability.CROSSING_STEPS)


def straddling_queries(
    atlas: xf.AcceptanceAtlas, n: int, rng: np.random.Generator
) -> list[tuple[float, float, np.ndarray]]:
    """``n`` queries (x0 in D, theta0, covariance in D and rad) near SEATED nodes."""
    inside = np.abs(atlas.theta0) <= math.pi / 2
    i, k = np.nonzero(atlas.outcomes[:, inside] == xf.Outcome.SEATED)
    out = []
    for _ in range(n):
        j = int(rng.integers(0, i.size))
        x0 = float(atlas.x0[i[j]] + rng.uniform(-3, 3) * atlas.lateral_step)
        theta0 = float(atlas.theta0[inside][k[j]] + rng.uniform(-3, 3) * atlas.angle_step)
        sx, st = 10 ** rng.uniform(-2.3, -0.5, 2)
        rho = rng.uniform(-0.9, 0.9)
        cov = np.array([[sx * sx, rho * sx * st], [rho * sx * st, st * st]])
        out.append((x0, theta0, cov))
    return out


class Counting:
    """Counts the simulations ``seat_probability`` asks ``predict_batch`` for."""

    def __init__(self) -> None:
        self.sims = 0
        self._inner = probability.predict_batch

    def __call__(self, design, x0, theta0, **kw):  # type: ignore[no-untyped-def]
        self.sims += int(np.size(x0))
        return self._inner(design, x0, theta0, **kw)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=int, default=12, help="straddling queries per design")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    counter = Counting()
    probability.predict_batch = counter  # count the simulations of every call below
    settings = [(r, s) for r in RAYS for s in STEPS]
    errors: dict[tuple[int, int], list[float]] = {key: [] for key in settings}
    times: dict[tuple[int, int], list[float]] = {key: [] for key in settings}
    sims: dict[tuple[int, int], list[int]] = {key: [] for key in settings}
    worst = (-1.0, "")  # the default setting's largest error and its query
    for kind, h, rp in DESIGNS:
        design = xf.make_face(kind, h, rp)
        atlas = xf.build_atlas(design)
        kept = 0
        while kept < args.queries:
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
            for rays, steps in settings:
                counter.sims = 0
                t0 = time.perf_counter()
                p = float(
                    xf.seat_probability(
                        design, x, theta0, c, atlas=atlas, rays=rays, crossing_steps=steps
                    )
                )
                times[(rays, steps)].append(time.perf_counter() - t0)
                sims[(rays, steps)].append(counter.sims)
                errors[(rays, steps)].append(abs(p - ref))
                if (rays, steps) == DEFAULT and abs(p - ref) > worst[0]:
                    sx, st = math.sqrt(c[0, 0]), math.sqrt(c[1, 1])
                    query = (
                        f"{kind} {h:g}/{rp:g} x0 {x0:+.4f} D, theta0 {theta0:+.4f}, sigma "
                        f"{sx:.4f} D / {st:.4f} rad, rho {c[0, 1] / (sx * st):+.2f}: "
                        f"{p:.5f} against {ref:.5f}"
                    )
                    worst = (abs(p - ref), query)
        print(f"{kind} {h:g}/{rp:g}: {kept} straddling queries", flush=True)
    n = len(errors[settings[0]])
    print(f"\n{n} straddling queries over {len(DESIGNS)} designs; reference "
          f"{REFERENCE[0]} rays, {REFERENCE[1]} crossing steps\n")  # fmt: skip
    print("| rays | crossing steps | max abs error | median abs error | median ms | median sims |")
    print("|---:|---:|---:|---:|---:|---:|")
    for key in settings:
        e = errors[key]
        print(
            f"| {key[0]} | {key[1]} | {max(e):.1e} | {statistics.median(e):.1e} | "
            f"{1e3 * statistics.median(times[key]):.1f} | {statistics.median(sims[key]):.0f} |"
        )
    print(f"\nlargest error at the defaults {DEFAULT}: {worst[0]:.1e}, {worst[1]}")


if __name__ == "__main__":
    main()
