#!/usr/bin/env python3
"""Where ``xface table``'s time goes by design: each map's time, and the shares by face and
by r_p.

    .venv/bin/python scripts/bench/table_cost_by_design.py [--faces XVS] [--grid 41]
        [--repeats 2] [--top 15] [--h-over-d 0.25,1 --r-p 0,1]

Every design of the paper's tables (or the ``--h-over-d`` x ``--r-p`` subset) is mapped as
``xface table`` maps it (``acceptance_map``: the symmetric grid, half of it filled by
symmetry where the design is mirror-symmetric, the default physics), on one thread, best of
``--repeats`` after one untimed map. Printed: the sum of the best times, its share per face
and per r_p, and the ``--top`` costliest designs with their M and the mean accepted steps and
rejected trial steps of a cell that touched (from one run of the whole grid without
symmetry).

Timings are findings, not checks: they vary with the machine and its load. First taken for
docs/notes/2026-11-30-three-levers-and-the-tables-cost.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

import xface_core as xf
from xface_core.errors import XfaceError
from xface_core.maps.acceptance import PAPER_H_OVER_D, PAPER_R_P, acceptance_map
from xface_core.physics import Physics
from xface_core.runner import run_flat


@dataclass(frozen=True)
class Cost:
    """One design's map: its best time (s) and M."""

    face: str
    h_over_d: float
    r_p: float
    seconds: float
    m: int


def map_cost(face: str, h_over_d: float, r_p: float, grid: int, repeats: int) -> Cost:
    """The best of ``repeats`` one-thread maps of the design, after one untimed map."""
    design = xf.make_face(face, h_over_d, r_p)
    m = acceptance_map(design, grid=grid, threads=1).M
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        acceptance_map(design, grid=grid, threads=1)
        best = min(best, time.perf_counter() - start)
    return Cost(face, h_over_d, r_p, float(best), int(m))


def steps_per_touching_cell(cost: Cost, grid: int) -> tuple[float, float]:
    """Mean accepted steps and rejected trial steps of the grid's cells that touched."""
    design = xf.make_face(cost.face, cost.h_over_d, cost.r_p)
    X, T = np.meshgrid(xf.x0_grid(grid), xf.theta_grid(grid), indexing="ij")
    runs = run_flat(design, X.ravel(), T.ravel(), Physics(), threads=1)
    touched = runs["had_contact"]
    if not touched.any():
        return 0.0, 0.0
    return float(runs["steps"][touched].mean()), float(runs["rejected_steps"][touched].mean())


def shares(costs: Sequence[Cost], key: str) -> list[tuple[object, float, float]]:
    """``(value, seconds, share)`` of the total per value of the field ``key``."""
    total = sum(c.seconds for c in costs)
    values = sorted({getattr(c, key) for c in costs})
    out = []
    for value in values:
        part = sum(c.seconds for c in costs if getattr(c, key) == value)
        out.append((value, part, part / total))
    return out


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        message = f"not a comma-separated list of numbers: {text!r}"
        raise argparse.ArgumentTypeError(message) from None


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n\n", 1)[1],
    )  # fmt: skip
    parser.add_argument("--faces", default="XVS", help="any of X, V, S (default XVS)")
    parser.add_argument("--grid", type=int, default=41, help="cells per side (3-401)")
    parser.add_argument("--repeats", type=int, default=2, help="best of this many (1-100)")
    parser.add_argument("--top", type=int, default=15, help="costliest designs listed (0-400)")
    parser.add_argument("--h-over-d", type=_floats, default=PAPER_H_OVER_D)
    parser.add_argument("--r-p", type=_floats, default=PAPER_R_P)
    args = parser.parse_args(argv)
    for name, low, high in (("grid", 3, 401), ("repeats", 1, 100), ("top", 0, 400)):
        if not low <= getattr(args, name) <= high:
            parser.error(f"--{name} must lie in {low}..{high}")
    faces = args.faces.upper()
    if not faces or any(f not in "XVS" for f in faces):
        parser.error(f"--faces takes letters of XVS, got {args.faces!r}")
    try:
        costs = [
            map_cost(face, h, rp, args.grid, args.repeats)
            for face in dict.fromkeys(faces)
            for h in args.h_over_d
            for rp in args.r_p
        ]
    except XfaceError as exc:
        parser.error(str(exc))
    total = sum(c.seconds for c in costs)
    print(f"{len(costs)} designs, {args.grid} x {args.grid} maps, one thread: "
          f"{total:.3f} s (best of {args.repeats} each)")  # fmt: skip
    for key in ("face", "r_p"):
        print(f"\n| {key} | s | share |\n|---|---:|---:|")
        for value, part, share in shares(costs, key):
            label = f"{value:g}" if isinstance(value, float) else value
            print(f"| {label} | {part:.3f} | {share:.3f} |")
    if args.top:
        print("\n| design | ms | share | M | steps per touching cell | rejected |"
              "\n|---|---:|---:|---:|---:|---:|")  # fmt: skip
        for c in sorted(costs, key=lambda c: -c.seconds)[: args.top]:
            steps, rejected = steps_per_touching_cell(c, args.grid)
            share = c.seconds / total
            print(f"| {c.face} {c.h_over_d:g}/{c.r_p:g} | {c.seconds * 1e3:.2f} | {share:.3f} "
                  f"| {c.m} | {steps:.1f} | {rejected:.1f} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
