"""Does a held contact let go inside an accepted step? An audit of xface's paths.

    python scripts/evidence/release_dips.py                   # 8 designs x 2 frictions x 40 cells
    python scripts/evidence/release_dips.py --cells 5 --seed 3

xface checks a held contact's force at the end of every trial step, and where it changed sign
through a pole it searches the step for an earlier sign change too. A force that dips below
zero and comes back within one step, with no pole, would go unseen: the contact should have
let go inside the step and the path taken another way.

This script looks for such dips without xface's contact mechanics. For random starts it takes
xface's path (``predict``), and between every two consecutive samples that hold the same
contacts it places states at ``--inner`` heights in between, on the held contacts (the angles
solved so that every touching pair stays closed, ``two_contact_coulomb.on_contacts``, the
pairs found again from the outlines), and solves the quasi-static Coulomb problem there by
enumeration (``two_contact_coulomb.admissible_motions``). A dip is a state where no
admissible motion keeps every held contact closed. Exit 1 if any is found.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from two_contact_coulomb import (
    Motion,
    State,
    admissible_motions,
    find_contacts,
    same_contacts_at,
)

from xface_core import FaceDesign, make_face, predict

#: The designs audited: the bench's four, the flattest and a tall paper design of each face.
DESIGNS = (
    ("X", 0.25, 2.0),
    ("X", 1.0, 1.0),
    ("V", 0.5, 1.0),
    ("S", 0.5, 1.0),
    ("X", 0.0625, 1.0),
    ("V", 0.32988, 2.0),
    ("S", 1.0, 3.0),
    ("X", 3.0314, 5.0),
)
#: Damping ratios c_B / c_M drawn from, per cell.
RATIOS = (0.1, 1.0, 10.0, math.inf)
#: A gap rate this small (D per D of descent) counts as closed for a "separating" contact.
CLOSED_RATE = 1e-9


def keeps_contacts(motions: list[Motion]) -> bool:
    """Does one of ``motions`` keep every contact closed (none separating at a positive
    gap rate)?"""
    return any(
        all(
            mode != "sep" or abs(g) <= CLOSED_RATE
            for mode, g in zip(m.modes, m.gap_rate, strict=True)
        )
        for m in motions
    )


@dataclass(frozen=True)
class Dip:
    """A state inside an accepted step where the held contacts cannot all stay closed."""

    sample: int
    """The path sample the step starts at."""
    y_m: float
    contacts: int


def audit(
    design: FaceDesign, x0: float, theta0: float, mu: float, ratio: float, inner: int = 7
) -> tuple[int, list[Dip]]:
    """(states checked, dips found) on xface's path from ``(x0, theta0)``."""
    path = predict(design, x0, theta0, friction=mu, damping_ratio=ratio).path
    assert path is not None
    checked, dips = 0, []
    for i in range(len(path) - 1):
        held = path.contact_pairs[i]
        k = int((held >= 0).sum())
        if k == 0 or not np.array_equal(held, path.contact_pairs[i + 1]):
            continue
        y0, y1 = float(path.pivot_m[i, 1]), float(path.pivot_m[i + 1, 1])
        if y0 - y1 < 1e-9:
            continue
        start = State(float(path.phi_b[i]), float(path.phi_m[i]), x0, y0)
        contacts = find_contacts(design, start)
        if len(contacts) != k:
            continue  # another pair touches too: not a plain held set
        for j in range(1, inner + 1):
            y = y0 + (y1 - y0) * j / (inner + 1)
            followed = same_contacts_at(design, contacts, start, y)
            if followed is None:
                break  # the held pairs cannot all touch here, or another pair does
            here, found = followed
            checked += 1
            if not keeps_contacts(admissible_motions(found, here, mu, ratio)):
                dips.append(Dip(i, y, k))
    return checked, dips


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=40, help="random starts per design and friction")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--inner", type=int, default=7, help="states checked inside each step")
    args = ap.parse_args(argv)
    if args.cells < 1 or args.inner < 1:
        print("release_dips: error: --cells and --inner must be >= 1", file=sys.stderr)
        return 2
    rng = np.random.default_rng(args.seed)
    t0 = time.monotonic()
    total, cells, bad = 0, 0, 0
    for face, h, rp in DESIGNS:
        design = make_face(face, h, rp)
        for mu in (0.0, 0.2):
            for _ in range(args.cells):
                x0, theta0 = float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-1.2, 1.2))
                ratio = float(rng.choice(RATIOS))
                checked, dips = audit(design, x0, theta0, mu, ratio, args.inner)
                total, cells = total + checked, cells + 1
                for d in dips:
                    bad += 1
                    print(
                        f"dip: {face} {h:g}/{rp:g} mu {mu} ratio {ratio} x0 {x0!r} "
                        f"theta0 {theta0!r}: after sample {d.sample}, y_M {d.y_m:.9f}, "
                        f"{d.contacts} held"
                    )
    print(
        f"{cells} cells, {total} states inside accepted steps checked, {bad} dips "
        f"({time.monotonic() - t0:.0f} s)"
    )
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
