"""Bench the acceptance atlas: its build time, and the per-query cost of margins from the
atlas against the exact margin search, and of the seat probability.

Reports medians (and the simulations each margins call ran) on random poses of each design;
the ratio is exact search over atlas. Then a robot's stream: poses jittered around a held pose
(0.01 D, 0.005 rad standard deviation), over the second half of the queries of each held pose
(the first half has bisected the grid-line flips around it): the margins' time and
simulations per query, and what one of the confirmation simulations costs against the
query's own simulation (each timed alone, one thread).
Times are wall times of this machine as it is: on a shared, loaded machine they are upper
bounds, say so when quoting them.

Usage::

    python scripts/bench/bench_atlas.py [--poses 60] [--builds 3] [--held 5] [--stream 40]
        [--seed 1] [--every-flip]
"""

from __future__ import annotations

import argparse
import contextlib
import math
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

import xface_core as xf
import xface_core.atlas.lookup as atlas_margins_module
import xface_core.runner as runner_module
from xface_core.atlas.build import build_atlas

DESIGNS = (("X", 0.25, 2.0), ("V", 0.5, 1.0), ("S", 1.0, 1.0))


class SimulationCounter:
    """Counts the poses and engine calls of every simulation, from any module and thread
    (:func:`xface_core.runner.count_engine_calls`: single poses and batches alike), between
    two :meth:`take` calls."""

    def __init__(self) -> None:
        self._calls: runner_module.EngineCalls | None = None
        self._block = contextlib.ExitStack()

    def install(self) -> None:
        self._calls = self._block.enter_context(runner_module.count_engine_calls())

    def take(self) -> tuple[int, int]:
        """(poses, calls) since the last take, and start again from zero."""
        calls = self._calls
        if calls is None:
            raise RuntimeError("SimulationCounter.take before install")
        out = (calls.poses, calls.calls)
        calls.poses = calls.calls = 0
        return out


def timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def single_time(design: xf.FaceDesign, x0: float, theta0: float, repeats: int = 3) -> float:
    """Fastest of ``repeats`` one-pose, one-thread simulations (s)."""
    return min(
        timed(lambda: xf.predict_batch(design, [x0], [theta0], threads=1)) for _ in range(repeats)
    )


def stream(
    design: xf.FaceDesign,
    atlas: xf.AcceptanceAtlas,
    held: int,
    per_pose: int,
    rng: np.random.Generator,
    counter: SimulationCounter,
) -> None:
    """Margins for a stream of jittered poses around ``held`` random seated poses."""
    confirmations: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = []
    real_split = atlas_margins_module._outcomes_split

    def capture(a: xf.AcceptanceAtlas, xs: Any, ts: Any, sims: Any) -> Any:
        confirmations.append((xs * a.design.width, ts))
        return real_split(a, xs, ts, sims)

    atlas_margins_module._outcomes_split = capture  # type: ignore[assignment]
    times, sims, ratios = [], [], []
    seated = np.argwhere(atlas.outcomes == xf.Outcome.SEATED)
    seated = seated[np.abs(atlas.theta0[seated[:, 1]]) <= math.pi / 2]
    for i, k in seated[rng.integers(0, len(seated), held)]:
        x_held, t_held = atlas.x0[i] * design.width, atlas.theta0[k]
        for n in range(per_pose):
            x0 = x_held + rng.normal(0.0, 0.01) * design.width
            theta0 = t_held + rng.normal(0.0, 0.005)
            outcome = xf.predict(design, x0, theta0, path=False).outcome
            counter.take()
            confirmations.clear()
            t = timed(lambda: xf.margins_from_atlas(atlas, x0, theta0, outcome))  # noqa: B023
            if n < per_pose // 2:  # warm-up: the grid-line flips around the held pose
                continue
            times.append(t)
            sims.append(counter.take()[0])
            if confirmations:
                xs, ts = confirmations[0]
                own = single_time(design, x0, theta0)
                each = [single_time(design, x, t) for x, t in zip(xs, ts, strict=True)]
                ratios.append(statistics.mean(each) / own)
    atlas_margins_module._outcomes_split = real_split  # type: ignore[assignment]
    print(
        f"  stream ({held} held poses x {per_pose} jittered queries, the last "
        f"{per_pose - per_pose // 2} of each): margins median "
        f"{statistics.median(times) * 1e3:.1f} ms, {statistics.median(sims):.0f} simulations "
        f"(mean {statistics.mean(sims):.1f}); a confirmation simulation costs "
        f"{statistics.median(ratios):.1f}x the query's own (median; 10-90 %: "
        f"{np.percentile(ratios, 10):.1f}-{np.percentile(ratios, 90):.1f}x)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=60)
    parser.add_argument("--builds", type=int, default=3)
    parser.add_argument("--held", type=int, default=5, help="held poses of the stream")
    parser.add_argument("--stream", type=int, default=40, help="jittered queries per held pose")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--every-flip",
        action="store_true",
        help="build with every grid-line flip bisected (build_atlas(every_flip=True), as the node)",
    )
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    counter = SimulationCounter()
    counter.install()
    for kind, h, rp in DESIGNS:
        design = xf.make_face(kind, h, rp)
        builds = [build_atlas(design, every_flip=args.every_flip) for _ in range(args.builds)]
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
        second_t, second_n = [], []
        for _ in range(args.poses):
            x0 = rng.uniform(-1.0, 1.0)
            theta0 = rng.uniform(-math.pi / 2, math.pi / 2)
            outcome = xf.predict(design, x0, theta0, path=False).outcome
            counter.take()
            fast_t.append(timed(lambda: xf.margins_from_atlas(atlas, x0, theta0, outcome)))  # noqa: B023
            fast_n.append(counter.take())
            # A second query beside the first (a planner's next candidate start): on an atlas
            # built without every flip, it bisects the grid lines around both.
            x1, t1 = x0 + 1e-3, theta0 + 1e-3
            outcome1 = xf.predict(design, x1, t1, path=False).outcome
            counter.take()
            second_t.append(timed(lambda: xf.margins_from_atlas(atlas, x1, t1, outcome1)))  # noqa: B023
            second_n.append(counter.take())
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
            f"  margins of a second query 1e-3 D and 1e-3 rad beside it (median): "
            f"{statistics.median(second_t) * 1e3:.1f} ms "
            f"({statistics.median(p for p, _ in second_n):.0f} simulations in "
            f"{statistics.median(c for _, c in second_n):.0f} batches)"
        )
        print(
            f"  seat_probability per query, sigma 0.05 D and 0.05 rad (median): "
            f"{statistics.median(prob_t) * 1e3:.1f} ms"
        )
        stream(design, atlas, args.held, args.stream, rng, counter)


if __name__ == "__main__":
    main()
