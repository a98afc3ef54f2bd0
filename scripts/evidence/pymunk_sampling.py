#!/usr/bin/env python3
"""How well the grid's diagonal samples the pymunk scene's time per map (docs/bench.md;
the measurement: docs/notes/2026-11-23-pymunk-whole-map.md).

    .venv/bin/python scripts/evidence/pymunk_sampling.py      # the bench's four designs, 41 x 41
    .venv/bin/python scripts/evidence/pymunk_sampling.py --grid 11 --design X 0.25 2

For each design, runs every cell of the map in the pymunk scene of the crosscheck extra (one
thread, each cell timed) and prints: the map's time, the diagonal's estimate of it (its cells'
mean time times the number of cells, as ``xface bench --quick`` estimates), their ratio, and
the mean time of a cell by the scene's outcome and by whether x0 and theta0 have the same sign.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict

import numpy as np

from xface_core.cli.bench import BENCH_DESIGNS
from xface_core.geometry import make_face
from xface_core.maps.grids import theta_grid, x0_grid


def sample(face: str, h_over_d: float, r_p: float, grid: int) -> dict[str, object]:
    """Every cell of the ``grid x grid`` map timed in the pymunk scene (:func:`summarise`)."""
    from xface_core.crosscheck import run_cell  # the crosscheck extra (pymunk)

    design = make_face(face, h_over_d, r_p)
    x0s, thetas = x0_grid(grid), theta_grid(grid)
    seconds = np.zeros((grid, grid))
    outcomes = np.empty((grid, grid), dtype=object)
    for i, x0 in enumerate(x0s):
        for j, theta0 in enumerate(thetas):
            t0 = time.perf_counter()
            run = run_cell(design, float(x0), float(theta0))
            seconds[i, j] = time.perf_counter() - t0
            outcomes[i, j] = run.outcome.name
    return {"design": f"{face} {h_over_d:g}/{r_p:g}"} | summarise(seconds, outcomes, x0s, thetas)


def summarise(
    seconds: np.ndarray, outcomes: np.ndarray, x0s: np.ndarray, thetas: np.ndarray
) -> dict[str, object]:
    """The map's time from each cell's (``seconds[i, j]`` at ``x0s[i]``, ``thetas[j]``), the
    diagonal's estimate of it, and a cell's mean time by outcome and by the signs of x0 and
    theta0 (cells on either axis left out of both)."""
    by_outcome: dict[str, list[float]] = defaultdict(list)
    for name, t in zip(outcomes.ravel(), seconds.ravel(), strict=True):
        by_outcome[str(name)].append(float(t))
    signs = np.sign(x0s)[:, None] * np.sign(thetas)[None, :]
    return {
        "map_s": float(seconds.sum()),
        "diagonal_estimate_s": float(np.diag(seconds).mean() * seconds.size),
        "cell_ms_by_outcome": {k: 1e3 * float(np.mean(v)) for k, v in sorted(by_outcome.items())},
        "cell_ms_same_sign": 1e3 * float(seconds[signs > 0].mean()),
        "cell_ms_opposite_sign": 1e3 * float(seconds[signs < 0].mean()),
    }


def line(r: dict[str, object]) -> str:
    outcomes = ", ".join(
        f"{k} {v:.1f} ms"
        for k, v in r["cell_ms_by_outcome"].items()  # type: ignore[attr-defined]
    )
    return (
        f"{r['design']}: map {r['map_s']:.1f} s, diagonal's estimate "
        f"{r['diagonal_estimate_s']:.1f} s (map / estimate "
        f"{r['map_s'] / r['diagonal_estimate_s']:.2f}); a cell by outcome: {outcomes}; "  # type: ignore[operator]
        f"x0 and theta0 of the same sign {r['cell_ms_same_sign']:.1f} ms, of opposite signs "
        f"{r['cell_ms_opposite_sign']:.1f} ms"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--grid", type=int, default=41, help="odd node count (default 41)")
    parser.add_argument(
        "--design", nargs=3, metavar=("FACE", "H_OVER_D", "R_P"), help="one design only"
    )
    args = parser.parse_args(argv)
    if args.grid < 3 or args.grid % 2 == 0:
        parser.error(f"--grid must be an odd integer >= 3, got {args.grid}")
    try:
        import pymunk  # noqa: F401
    except ImportError:
        print("needs the crosscheck extra: pip install 'xface[crosscheck]'", file=sys.stderr)
        return 2
    designs = (
        [(args.design[0], float(args.design[1]), float(args.design[2]))]
        if args.design
        else list(BENCH_DESIGNS)
    )
    for face, h, rp in designs:
        print(line(sample(face, h, rp, args.grid)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
