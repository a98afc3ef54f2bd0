"""Check the atlas against the exact computations it replaces (issue 11's "must show").

1. Margins: ``margins_from_atlas`` against the exact search ``outcome_margins`` on random
   poses over several designs; a pose agrees when all four distances are equal within the
   search's resolution (1e-4 D, 1e-5 rad) or both infinite. Every disagreement is printed
   with the atlas's outcomes around it so it can be explained.
2. Probability: ``seat_probability`` against plain Monte Carlo (``predict_batch`` on samples
   of the Gaussian) on random poses and covariances over X, V and S designs; with
   ``--boundary atlas`` the boundaries drawn from the atlas's checked chords (as the ROS node
   asks, on atlases with every flip), and the node's X 0.25/1 among the designs.
3. Chords: on atlases with every flip, per design, the boundary cells, those whose chord
   failed its check (``AcceptanceAtlas.checked_chords``) and the check's time, and for
   random poses in boundary cells the share on the wrong side of their cell's chord, before
   the check and after it (the poses of cells set aside are simulated).

Usage::

    python scripts/evidence/check_atlas.py [--poses 1000] [--queries 30] [--samples 20000]
        [--seed 0] [--every-flip] [--boundary exact|atlas] [--skip margins|probability|chords]

``--every-flip`` builds the margins' atlases with every grid-line flip bisected
(``build_atlas(every_flip=True)``, as the ROS node does).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import numpy.typing as npt

import xface_core as xf
from xface_core.atlas.margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION

#: The designs of the margins check: X, V and S, several H/D and r_p.
MARGIN_DESIGNS = (
    ("X", 0.25, 2.0),
    ("X", 1.0, 0.5),
    ("V", 0.5, 1.0),
    ("V", 2.0, 0.0),
    ("S", 1.0, 1.0),
    ("S", 0.25, 3.0),
)
PROBABILITY_DESIGNS = (("X", 0.25, 2.0), ("V", 0.5, 1.0), ("S", 1.0, 1.0))
#: The chords' designs: those, and the ROS node's X 0.25/1, whose SEATED and BAD_MATE bands
#: interleave within cells near |theta0| = 0.6-0.7 rad.
CHORD_DESIGNS = (*PROBABILITY_DESIGNS, ("X", 0.25, 1.0))


def random_poses(
    atlas: xf.AcceptanceAtlas, n: int, rng: np.random.Generator
) -> npt.NDArray[np.float64]:
    """(n, 2) poses (x0 in D, theta0): half uniform over |x0| <= L + 0.1 D, |theta0| <= pi/2,
    half near SEATED nodes (:func:`near_seated_poses`), where the boundaries are."""
    half = n // 2
    reach = atlas.design.mated_distance + 0.1
    uniform = np.column_stack(
        (rng.uniform(-reach, reach, half), rng.uniform(-math.pi / 2, math.pi / 2, half))
    )
    return np.vstack((uniform, near_seated_poses(atlas, n - half, rng)))


def near_seated_poses(
    atlas: xf.AcceptanceAtlas, n: int, rng: np.random.Generator
) -> npt.NDArray[np.float64]:
    """(n, 2) poses (x0 in D, theta0) within 3 grid steps of SEATED nodes, |theta0| <= pi/2
    at the node."""
    inside = np.abs(atlas.theta0) <= math.pi / 2
    i, k = np.nonzero(atlas.outcomes[:, inside] == xf.Outcome.SEATED)
    pick = rng.integers(0, i.size, n)
    return np.column_stack(
        (
            atlas.x0[i[pick]] + rng.uniform(-3, 3, n) * atlas.lateral_step,
            atlas.theta0[inside][k[pick]] + rng.uniform(-3, 3, n) * atlas.angle_step,
        )
    )


def random_covariance(rng: np.random.Generator) -> npt.NDArray[np.float64]:
    """A 2 x 2 covariance of (x0 in D, theta0): standard deviations log-uniform in
    [0.005, 0.32] (D, rad), correlation uniform in [-0.9, 0.9]."""
    sx, st = 10 ** rng.uniform(-2.3, -0.5, 2)
    rho = rng.uniform(-0.9, 0.9)
    return np.array([[sx * sx, rho * sx * st], [rho * sx * st, st * st]])


def _values(m: xf.Margins) -> npt.NDArray[np.float64]:
    return np.array([m.lateral_minus, m.lateral_plus, m.angle_minus, m.angle_plus])


def check_margins(n_poses: int, rng: np.random.Generator, every_flip: bool = False) -> None:
    per = math.ceil(n_poses / len(MARGIN_DESIGNS))
    total = agree = 0
    tol = np.array([LATERAL_RESOLUTION] * 2 + [ANGLE_RESOLUTION] * 2) * (1 + 1e-9)
    for kind, h, rp in MARGIN_DESIGNS:
        design = xf.make_face(kind, h, rp)
        atlas = xf.build_atlas(design, every_flip=every_flip)
        poses = random_poses(atlas, per, rng)
        t_atlas = t_exact = 0.0
        bad = 0
        for x0, theta0 in poses:
            outcome = xf.predict(design, x0, theta0, path=False).outcome
            t0 = time.perf_counter()
            fast = _values(xf.margins_from_atlas(atlas, x0, theta0, outcome))
            t1 = time.perf_counter()
            exact = _values(xf.outcome_margins(design, x0, theta0, outcome))
            t2 = time.perf_counter()
            t_atlas += t1 - t0
            t_exact += t2 - t1
            same = fast == exact
            diff = np.subtract(fast, exact, out=np.zeros(4), where=~same)
            ok = bool(np.all(same | (np.abs(diff) <= tol)))
            total += 1
            agree += ok
            if not ok:
                bad += 1
                print(
                    f"  DIFF {kind} {h} {rp} x0={x0!r} theta0={theta0!r} {outcome.name}\n"
                    f"       atlas {fast.tolist()}\n       exact {exact.tolist()}"
                )
        print(
            f"margins {kind} H/D={h} r_p={rp}: atlas {atlas.outcomes.shape} "
            f"built in {atlas.build_seconds:.2f} s ({atlas.simulations} simulations); "
            f"{per - bad}/{per} poses agree; time atlas {t_atlas:.1f} s, exact {t_exact:.1f} s"
        )
    print(f"MARGINS: {agree}/{total} poses agree ({100.0 * agree / total:.2f} %)")


def check_probability(
    n_queries: int, n_samples: int, rng: np.random.Generator, boundary: str = "exact"
) -> None:
    designs = CHORD_DESIGNS if boundary == "atlas" else PROBABILITY_DESIGNS
    per = math.ceil(n_queries / len(designs))
    worst = 0.0
    within = total = 0
    for kind, h, rp in designs:
        design = xf.make_face(kind, h, rp)
        atlas = xf.build_atlas(design, every_flip=boundary == "atlas")
        for x0, theta0 in random_poses(atlas, per, rng):
            cov = random_covariance(rng)
            sx, st = math.sqrt(cov[0, 0]), math.sqrt(cov[1, 1])
            rho = cov[0, 1] / (sx * st)
            t0 = time.perf_counter()
            p = float(xf.seat_probability(design, x0, theta0, cov, atlas=atlas, boundary=boundary))
            elapsed = time.perf_counter() - t0
            samples = rng.multivariate_normal([x0, theta0], cov, size=n_samples)
            mc = float(
                np.mean(
                    xf.predict_batch(design, samples[:, 0], samples[:, 1]).outcome
                    == xf.Outcome.SEATED
                )
            )
            se = math.sqrt(max(mc * (1 - mc), 1e-12) / n_samples)
            diff = p - mc
            worst = max(worst, abs(diff))
            total += 1
            within += abs(diff) <= 0.01
            print(
                f"  prob {kind} x0={x0:+.3f} th={theta0:+.3f} sx={sx:.4f} st={st:.4f} "
                f"rho={rho:+.2f}: atlas {p:.4f} MC {mc:.4f} (se {se:.4f}) diff {diff:+.4f} "
                f"[{elapsed * 1e3:.0f} ms]"
            )
    print(
        f"PROBABILITY (boundary {boundary}): {within}/{total} within 0.01 of Monte Carlo "
        f"({n_samples} samples); largest |difference| {worst:.4f}"
    )


def check_chords(n_poses: int, rng: np.random.Generator) -> None:
    """Per design: boundary cells, cells whose chord failed its check, the check's time, and
    the share of ``n_poses`` random poses in boundary cells on the wrong side of their
    chord, unchecked and checked (with the share left to simulation)."""
    for kind, h, rp in CHORD_DESIGNS:
        design = xf.make_face(kind, h, rp)
        atlas = xf.build_atlas(design, every_flip=True)
        t0 = time.perf_counter()
        trusted = atlas.checked_chords()
        check_s = time.perf_counter() - t0
        s = atlas.outcomes == xf.Outcome.SEATED
        corners = s[:-1, :-1].astype(int) + s[1:, :-1] + s[:-1, 1:] + s[1:, 1:]
        cells = np.argwhere((corners > 0) & (corners < 4))
        pick = cells[rng.integers(0, len(cells), n_poses)]
        i, k = pick[:, 0], pick[:, 1]
        x = atlas.x0[i] + rng.random(n_poses) * atlas.lateral_step
        t = atlas.theta0[k] + rng.random(n_poses) * atlas.angle_step
        exact = xf.predict_batch(design, x, t).outcome == xf.Outcome.SEATED
        unchecked = atlas._chord_side(x, t, i, k)
        checked = atlas.seated_by_flips(x, t)
        wrong_before = np.mean((unchecked >= 0) & (unchecked != exact))
        wrong_after = np.mean((checked >= 0) & (checked != exact))
        print(
            f"CHORDS {kind} {h:g}/{rp:g}: {len(cells)} boundary cells, "
            f"{np.count_nonzero(~trusted)} set aside by the check ({check_s:.2f} s); of "
            f"{n_poses} poses in boundary cells on the wrong side: {wrong_before:.2%} "
            f"unchecked, {wrong_after:.2%} checked ({np.mean(checked < 0):.1%} simulated)"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1000)
    parser.add_argument("--queries", type=int, default=30)
    parser.add_argument("--samples", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--skip", choices=("margins", "probability", "chords"), default=None)
    parser.add_argument(
        "--boundary", choices=("exact", "atlas"), default="exact",
        help="the probability check's boundary (atlas: the ROS node's, chords checked)",
    )  # fmt: skip
    parser.add_argument("--every-flip", action="store_true", help="atlases with every flip")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    if args.skip != "margins":
        check_margins(args.poses, rng, args.every_flip)
    if args.skip != "probability":
        check_probability(args.queries, args.samples, rng, args.boundary)
    if args.skip != "chords":
        check_chords(args.poses, rng)


if __name__ == "__main__":
    main()
