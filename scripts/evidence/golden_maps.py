"""Golden outputs of the simulator: store them before a behaviour-preserving change, compare after.

For each of the designs in :data:`CASES` (X, V, S and custom faces, flat and tall teeth,
r_p = 0 and large, with and without friction, with a held base and a soft base) it stores

* the 41 x 41 acceptance map (outcome codes, the paper's grid, mirror symmetry as shipped),
* the raw kernel over the same grid without mirroring: outcome, final angles, step and
  event counts per cell,
* full predictions with paths for a few poses per design.

    python scripts/evidence/golden_maps.py --write tests/core/golden/golden_maps.npz
    python scripts/evidence/golden_maps.py --check tests/core/golden/golden_maps.npz [--exact]

``--check`` exits 1 on any difference: outcome codes and counts must be equal; floats must
agree to 1e-9 (or bit for bit with ``--exact``; glibc picks its sin/cos implementation per
CPU, so bitwise equality holds on one machine, not necessarily across machines).
The test ``tests/core/test_golden.py`` runs the same comparison.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import xface_core as xf

GRID = 41
FLOAT_ATOL = 1e-9


def trapezoid_face() -> xf.FaceDesign:
    # A flat-topped tooth with chamfers on the base, its complementary socket on the moving
    # part: the flush edges and convex corners a user's own connector is made of.
    tooth = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.0), (0.2, 0.0), (0.1, 0.3), (-0.1, 0.3),
             (-0.2, 0.0), (-0.5, 0.0)]  # fmt: skip
    socket = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.3), (0.2, 0.3), (0.1, 0.0), (-0.1, 0.0),
              (-0.2, 0.3), (-0.5, 0.3)]  # fmt: skip
    return xf.custom_face([tooth], [socket], mated_distance=0.3, mirror_symmetric=True)


def lopsided_face() -> xf.FaceDesign:
    # An asymmetric single ramp with a step: no mirror symmetry, corners at both ends.
    base = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.4), (0.1, 0.4), (-0.5, 0.0)]
    moving = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.4), (-0.1, 0.0), (-0.5, 0.0)]
    return xf.custom_face([base], [moving], mated_distance=0.4 + 1e-3)


# name -> (design factory, damping ratio, friction)
CASES: dict[str, tuple[Callable[[], xf.FaceDesign], float, float]] = {
    "X_0.25_2": (lambda: xf.x_face(0.25, 2.0), 1.0, 0.0),
    "X_1_1": (lambda: xf.x_face(1.0, 1.0), 1.0, 0.0),
    "X_0.0625_0_flat": (lambda: xf.x_face(0.0625, 0.0), 1.0, 0.0),
    "X_3.0314_5_tall": (lambda: xf.x_face(3.0314, 5.0), 1.0, 0.0),
    "X_0.5_20_large_rp": (lambda: xf.x_face(0.5, 20.0), 1.0, 0.0),
    "X_0.25_2_mu0.2": (lambda: xf.x_face(0.25, 2.0), 1.0, 0.2),
    "X_0.5_1_fixed_base": (lambda: xf.x_face(0.5, 1.0), math.inf, 0.0),
    "V_0.5_1": (lambda: xf.v_face(0.5, 1.0), 1.0, 0.0),
    "V_0.32988_2": (lambda: xf.v_face(0.32988, 2.0), 1.0, 0.0),
    "V_0.0625_0_flat": (lambda: xf.v_face(0.0625, 0.0), 1.0, 0.0),
    "V_3.0314_5_tall": (lambda: xf.v_face(3.0314, 5.0), 1.0, 0.0),
    "V_0.5_1_mu0.3": (lambda: xf.v_face(0.5, 1.0), 1.0, 0.3),
    "V_1_3_damping0.5": (lambda: xf.v_face(1.0, 3.0), 0.5, 0.0),
    "S_0.5_1": (lambda: xf.s_face(0.5, 1.0), 1.0, 0.0),
    "S_0.0625_1_flat": (lambda: xf.s_face(0.0625, 1.0), 1.0, 0.0),
    "S_3.0314_5_tall": (lambda: xf.s_face(3.0314, 5.0), 1.0, 0.0),
    "S_0.5_1_mu0.1": (lambda: xf.s_face(0.5, 1.0), 1.0, 0.1),
    "S_1_0_rp0": (lambda: xf.s_face(1.0, 0.0), 1.0, 0.0),
    "custom_trapezoid": (trapezoid_face, 1.0, 0.0),
    "custom_trapezoid_mu0.15": (trapezoid_face, 1.0, 0.15),
    "custom_lopsided": (lopsided_face, 1.0, 0.0),
}

#: Poses (x0 in D, theta0 in rad) whose full predictions, with paths, are stored per design.
PATH_POSES = ((0.3, 0.2), (-0.6, 0.5), (0.0, -0.9), (0.7, -0.31415926535897931))


def compute(name: str) -> dict[str, np.ndarray]:
    """Every golden array of one case, keyed ``<name>/<field>``."""
    factory, damping, friction = CASES[name]
    design = factory()
    physics: dict[str, Any] = {"damping_ratio": damping, "friction": friction}
    out: dict[str, np.ndarray] = {}
    amap = xf.acceptance_map(design, grid=GRID, **physics)
    out["map"] = amap.outcomes
    X, T = np.meshgrid(amap.x0, amap.theta0, indexing="ij")
    raw = xf.predict_batch(design, X, T, threads=1, **physics)
    out["raw_outcome"] = raw.outcome
    out["raw_phi_b"] = raw.phi_b
    out["raw_phi_m"] = raw.phi_m
    out["raw_steps"] = raw.steps
    out["raw_events"] = raw.events
    for k, (x0, theta0) in enumerate(PATH_POSES):
        p = xf.predict(design, x0 * design.width, theta0, **physics)
        assert p.path is not None
        out[f"pose{k}_summary"] = np.array(
            [p.outcome, p.counters.steps, p.counters.events, p.counters.contact_changes,
             p.counters.rejected_steps], dtype=np.int64)  # fmt: skip
        out[f"pose{k}_final"] = np.array([p.phi_b, p.phi_m, p.pivot_m[1]])
        out[f"pose{k}_path"] = np.column_stack(
            (p.path.descent, p.path.phi_b, p.path.phi_m, p.path.phase)
        )
        out[f"pose{k}_pairs"] = p.path.contact_pairs
    return {f"{name}/{key}": value for key, value in out.items()}


def compute_all() -> dict[str, np.ndarray]:
    arrays: dict[str, np.ndarray] = {}
    for name in CASES:
        arrays.update(compute(name))
    return arrays


def differences(
    stored: dict[str, np.ndarray], current: dict[str, np.ndarray], *, exact: bool = False
) -> list[str]:
    """Human-readable differences between two sets of golden arrays (empty: identical)."""
    problems = []
    for key in sorted(set(stored) | set(current)):
        if key not in stored or key not in current:
            problems.append(f"{key}: only in {'stored' if key in stored else 'current'}")
            continue
        a, b = stored[key], current[key]
        if a.shape != b.shape:
            problems.append(f"{key}: shape {a.shape} != {b.shape}")
            continue
        if a.dtype.kind == "f" and not exact:
            same = np.isclose(a, b, rtol=0.0, atol=FLOAT_ATOL, equal_nan=True)
        else:
            same = (a == b) | (np.isnan(a) & np.isnan(b)) if a.dtype.kind == "f" else a == b
        if not np.all(same):
            bad = np.argwhere(~same)
            first = tuple(int(i) for i in bad[0])
            problems.append(f"{key}: {len(bad)} entries differ, first at {first}")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path, metavar="NPZ", help="store the golden outputs")
    mode.add_argument("--check", type=Path, metavar="NPZ", help="compare with stored outputs")
    parser.add_argument("--exact", action="store_true", help="floats bit for bit")
    args = parser.parse_args(argv)
    current = compute_all()
    if args.write:
        args.write.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(args.write, **current)  # type: ignore[arg-type]
        print(f"wrote {len(current)} arrays for {len(CASES)} designs to {args.write}")
        return 0
    with np.load(args.check) as data:
        stored = {k: data[k] for k in data.files}
    problems = differences(stored, current, exact=args.exact)
    for line in problems:
        print(line)
    print(f"{len(CASES)} designs, {len(current)} arrays: {len(problems)} differ")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
