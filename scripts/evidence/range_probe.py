"""A seeded random probe of the engine over the range that FaceDesign and Physics accept (issue 37).

Evidence for docs/model.md ("Range"). Run from the repository root, for example::

    .venv/bin/python scripts/evidence/range_probe.py --runs 2000 --seed 1

Each run draws a design and a pose and checks the bar of issue 37:

- built-in faces X, V, S with H/D and r_p log-uniform up to ``--max-ratio`` (r_p is 0 in one run
  of eight), the width log-uniform from 1e-4 to 1e4; or a random custom face like the
  reproducers in ``../shared/repro/engine_range.py``: a random polyline (2-25 vertices) between
  r_p and r_p + H on top of a body, its partner the exact complement (so they mate flush at
  L = 2 r_p + H, reaching as far as a built-in face of that H/D and r_p), one of three
  mirror-symmetric and claimed so;
- the damping ratio log-uniform over its accepted range (``inf`` one run in ten, 1 one in four),
  friction 0 half of the time, else uniform up to 1 (up to ``--max-friction`` one run in five);
- the pose x0 uniform over the map range (|x0| <= D) and beyond it (|x0| <= L) one run in five,
  theta0 uniform in [-pi/2, pi/2] (in [-pi, pi] one run in five).

Findings, by class:

- ``overlap``: the two parts' outlines overlap deeper than ``OVERLAP_TOL`` (1e-6 D) at some path
  sample. The depth is measured here with shapely alone: the largest distance from a vertex of one
  outline lying inside the other to that other's boundary, and the radius of the largest circle
  inside their intersection (which catches two edges crossing with no vertex inside);
- ``unresolved``: the outcome is UNRESOLVED;
- ``mirror_outcome`` / ``mirror_angles``: a mirror-symmetric design at (-x0, -theta0) gives another
  outcome, or final angles that are not the mirror image of the first run's (beyond
  ``MIRROR_ANGLE_TOL``; negating x is exact in floating point, and a frictionless jam's angles
  mirror to the last bit);
- ``map_symmetry``: for one mirror-symmetric run in ``--map-every``, a 7 x 7 map filled by
  symmetry differs from the same map simulated cell by cell;
- ``timeout``: the run (prediction, mirror and map) did not finish in ``--timeout`` seconds; it
  runs in a worker process that is then killed, so every run of the probe is bounded in time;
- ``error``: the run raised (a design the sampler built but the library refused is skipped, not
  a finding: the sampler draws over the accepted range and the library decides what it accepts).

Prints a table of findings by class and by H/D decade (for a custom face the H/D its profile
was drawn with), the slowest runs, and exits 1 when there is any finding. ``--json FILE`` writes
every finding with its run (a reproducer: design, pose and physics).
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import sys
import time
from collections import Counter
from dataclasses import asdict, dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from xface_core import Outcome, acceptance_map, predict
from xface_core.errors import XfaceError
from xface_core.geometry import FaceDesign, custom_face, make_face
from xface_core.physics import MAX_DAMPING_RATIO, MAX_FRICTION, MIN_DAMPING_RATIO, Physics

FloatArray = npt.NDArray[np.float64]

#: The issue's bar: no interpenetration deeper than this (D).
OVERLAP_TOL = 1e-6
#: Final angles of a mirrored run may differ from the mirror image by this (rad); the
#: seat itself is only tested to the solver's seat_tol (1e-4).
MIRROR_ANGLE_TOL = 1e-4
#: Widths drawn (caller's unit): the width only scales inputs and outputs.
WIDTH_RANGE = (1e-4, 1e4)
#: Smallest H/D and r_p drawn (log-uniform from here to --max-ratio).
MIN_RATIO = 1e-3
#: Grid of the symmetry-filling check's map.
MAP_GRID = 7
#: The kinds of face drawn, equally often.
FACES = ("X", "V", "S", "custom")
CLASSES = (
    "overlap",
    "unresolved",
    "mirror_outcome",
    "mirror_angles",
    "map_symmetry",
    "timeout",
    "error",
)


@dataclass
class Run:
    """One drawn run: a design (built-in or custom), a pose in D and rad, and its physics."""

    index: int
    kind: str
    h_over_d: float
    r_p: float
    width: float
    x0_d: float
    theta0: float
    damping_ratio: float
    friction: float
    check_map: bool
    base: list[list[float]] = field(default_factory=list)
    moving: list[list[float]] = field(default_factory=list)
    mated_distance: float = 0.0
    mirror_symmetric: bool = False

    def design(self) -> FaceDesign:
        """The design (raises the library's error when it refuses it)."""
        if self.kind != "custom":
            return make_face(self.kind, self.h_over_d, self.r_p, width=self.width)
        return custom_face(
            [self.base],
            [self.moving],
            mated_distance=self.mated_distance,
            width=self.width,
            mirror_symmetric=self.mirror_symmetric,
        )


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _random_profile(
    rng: np.random.Generator, h_over_d: float, r_p: float, symmetric: bool
) -> tuple[list[list[float]], list[list[float]], float]:
    """A random polyline top between ``r_p`` and ``r_p + h_over_d`` (D) and its flush complement,
    as the reproducers build them: base outline, moving outline (body frames) and the mated
    distance ``2 r_p + H`` (so the outlines reach as far as a built-in face's of that H/D, r_p)."""
    n = int(rng.integers(1, 13))
    if symmetric:
        xs = np.sort(rng.uniform(0.0, 0.5, n))[::-1]
        heights = r_p + rng.uniform(0.0, 1.0, n) * h_over_d
        top_x = np.concatenate(([0.5], xs, -xs[::-1], [-0.5]))
        top_y = np.concatenate((heights[:1], heights, heights[::-1], heights[:1]))
    else:
        top_x = np.concatenate(([0.5], np.sort(rng.uniform(-0.5, 0.5, 2 * n))[::-1], [-0.5]))
        top_y = r_p + rng.uniform(0.0, 1.0, top_x.size) * h_over_d
    mated = 2.0 * r_p + h_over_d
    body = [[0.5, -1.0], *zip(top_x.tolist(), top_y.tolist(), strict=True), [-0.5, -1.0]]
    # The partner at x is the complement of the base at -x, so the parts mate flush.
    moving_top = [[-x, mated - y] for x, y in zip(top_x, top_y, strict=True)][::-1]
    moving = [[0.5, -1.0], *moving_top, [-0.5, -1.0]]
    return [list(map(float, p)) for p in body], [list(map(float, p)) for p in moving], mated


def draw_run(
    rng: np.random.Generator,
    index: int,
    max_ratio: float,
    max_friction: float,
    map_every: int,
    faces: tuple[str, ...] = FACES,
    min_ratio: float = MIN_RATIO,
) -> Run:
    """One run drawn over the accepted range (see the module docstring for the distributions)."""
    kind = str(rng.choice(list(faces)))
    h = _log_uniform(rng, min_ratio, max_ratio)
    r_p = 0.0 if rng.random() < 0.125 else _log_uniform(rng, MIN_RATIO, max_ratio)
    if rng.random() < 0.1:
        damping = math.inf
    elif rng.random() < 0.25:
        damping = 1.0
    else:
        damping = _log_uniform(rng, MIN_DAMPING_RATIO, MAX_DAMPING_RATIO)
    friction = 0.0
    if rng.random() < 0.5:
        friction = float(rng.uniform(0.0, max_friction if rng.random() < 0.2 else 1.0))
    run = Run(
        index=index,
        kind=kind,
        h_over_d=h,
        r_p=r_p,
        width=_log_uniform(rng, *WIDTH_RANGE),
        x0_d=0.0,
        theta0=float(rng.uniform(-1.0, 1.0) * (math.pi if rng.random() < 0.2 else math.pi / 2)),
        damping_ratio=damping,
        friction=min(friction, MAX_FRICTION),
        check_map=map_every > 0 and index % map_every == 0,
    )
    if kind == "custom":
        symmetric = rng.random() < 1 / 3
        run.base, run.moving, run.mated_distance = _random_profile(rng, h, r_p, symmetric)
        run.mirror_symmetric = symmetric
    reach = 2 * r_p + h
    beyond = rng.random() < 0.2
    run.x0_d = float(rng.uniform(-1.0, 1.0) * (max(reach, 1.0) if beyond else 1.0))
    return run


def overlap_depth(a: FloatArray, b: FloatArray, resolution: float = 0.0) -> float:
    """How deep two simple polygons ((n, 2), same unit) interpenetrate: the largest distance from a
    vertex of one inside the other to the other's boundary, or the radius of the largest circle
    inside their intersection if larger; 0 when they only touch.

    With ``resolution`` > 0 the circle is found to that resolution and only in pieces of the
    intersection large enough to hold a circle of that radius (a sliver along a sliding contact
    cannot), which keeps a long flush contact cheap."""
    pa, pb = shapely.Polygon(a), shapely.Polygon(b)
    inter = shapely.intersection(pa, pb)
    if inter.area <= 0.0:
        return 0.0
    depth = 0.0
    for pts, other in ((a, pb), (b, pa)):
        inside = shapely.contains_xy(other, pts[:, 0], pts[:, 1])
        if inside.any():
            d = shapely.distance(shapely.points(pts[inside]), other.exterior)
            depth = max(depth, float(np.max(d)))
    for part in shapely.get_parts(inter):  # a touching edge makes a GeometryCollection
        if isinstance(part, shapely.Polygon) and part.area > math.pi * resolution**2:
            tolerance = resolution / 10 if resolution > 0 else part.area**0.5 / 100
            circle = shapely.maximum_inscribed_circle(part, tolerance=tolerance)
            depth = max(depth, float(shapely.length(circle)))
    return depth


def path_overlap(design: FaceDesign, x0: float, path: Any) -> tuple[float, int]:
    """The deepest overlap (D) of the parts along a prediction's path and its sample index."""
    w = design.width
    worst, at = 0.0, -1
    for layer in range(design.n_layers):
        base = design.base_outline_path(layer, path.phi_b)
        moving = design.moving_outline_path(layer, x0 / w, path.pivot_m[:, 1] / w, path.phi_m)
        areas = shapely.area(shapely.intersection(shapely.polygons(base), shapely.polygons(moving)))
        for i in np.flatnonzero(areas > 0.0):
            d = overlap_depth(base[i], moving[i], OVERLAP_TOL)
            if d > worst:
                worst, at = d, int(i)
    return worst, at


def check_run(run: Run) -> list[tuple[str, str]]:
    """Every finding of one run as (class, detail); an empty list when it is clean."""
    try:
        design = run.design()
        physics = Physics(damping_ratio=run.damping_ratio, friction=run.friction)
    except XfaceError:
        return [("skipped", "refused by the library")]
    findings: list[tuple[str, str]] = []
    x0 = run.x0_d * design.width
    p = predict(design, x0, run.theta0, physics=physics)
    if p.outcome is Outcome.UNRESOLVED:
        findings.append(("unresolved", p.reason))
    depth, at = path_overlap(design, x0, p.path)
    if depth > OVERLAP_TOL:
        findings.append(("overlap", f"{depth:.3g} D at sample {at}/{len(p.path or ())}"))
    if design.mirror_symmetric:
        q = predict(design, -x0, -run.theta0, physics=physics)
        if q.outcome is not p.outcome:
            findings.append(("mirror_outcome", f"{p.outcome.name} vs {q.outcome.name}"))
        elif p.outcome is not Outcome.UNRESOLVED:
            err = max(abs(p.phi_b + q.phi_b), abs(p.phi_m + q.phi_m))
            if err > MIRROR_ANGLE_TOL:
                findings.append(("mirror_angles", f"final angles differ by {err:.3g} rad"))
        if run.check_map:
            findings.extend(_map_symmetry(design, physics))
    return findings


def _map_symmetry(design: FaceDesign, physics: Physics) -> list[tuple[str, str]]:
    kw: dict[str, Any] = {"grid": MAP_GRID, "theta_kind": "symmetric", "physics": physics}
    filled = acceptance_map(design, use_symmetry=True, threads=1, **kw).outcomes
    simulated = acceptance_map(design, use_symmetry=False, threads=1, **kw).outcomes
    cells = np.argwhere(filled != simulated)
    if not len(cells):
        return []
    i, j = (int(v) for v in cells[0])
    return [
        (
            "map_symmetry",
            (
                f"{len(cells)} cells, e.g. ({i},{j}): filled {Outcome(int(filled[i, j])).name}, "
                f"simulated {Outcome(int(simulated[i, j])).name}"
            ),
        )
    ]


def _worker(conn: Connection) -> None:
    """Run the runs sent over ``conn`` until it closes; answer (findings, seconds) per run."""
    while True:
        try:
            run = conn.recv()
        except EOFError:
            return
        start = time.perf_counter()
        try:
            found = check_run(run)
        except Exception as exc:  # any crash is a finding of the probe
            found = [("error", f"{type(exc).__name__}: {exc}")]
        conn.send((found, time.perf_counter() - start))


class _Slot:
    """One worker process and the run it is busy with; killed and replaced on a timeout."""

    def __init__(self) -> None:
        self.run: Run | None = None
        self.deadline = math.inf
        self._start()

    def _start(self) -> None:
        self.conn, child = mp.get_context("fork").Pipe()
        self.proc = mp.get_context("fork").Process(target=_worker, args=(child,), daemon=True)
        self.proc.start()
        child.close()

    def submit(self, run: Run, timeout: float) -> None:
        self.run, self.deadline = run, time.monotonic() + timeout
        self.conn.send(run)

    def restart(self) -> None:
        self.proc.kill()  # our own worker, by its handle
        self.proc.join()
        self.conn.close()
        self._start()

    def close(self) -> None:
        self.conn.close()
        self.proc.join(timeout=5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()


def probe(runs: list[Run], timeout: float, workers: int) -> list[tuple[Run, list[Any], float]]:
    """Check every run in ``workers`` processes, each run bounded by ``timeout`` seconds."""
    pending = list(reversed(runs))
    slots = [_Slot() for _ in range(max(1, min(workers, len(runs))))]
    results: list[tuple[Run, list[Any], float]] = []
    try:
        while pending or any(s.run is not None for s in slots):
            for s in slots:
                if s.run is None and pending:
                    s.submit(pending.pop(), timeout)
            busy = [s for s in slots if s.run is not None]
            left = max(0.0, min(s.deadline for s in busy) - time.monotonic())
            ready = wait([s.conn for s in busy], timeout=left)
            for s in busy:
                if s.conn in ready:
                    found, seconds = s.conn.recv()
                    results.append((s.run, found, seconds))
                    s.run = None
                elif time.monotonic() >= s.deadline:
                    results.append((s.run, [("timeout", f"> {timeout:g} s")], timeout))
                    s.run = None
                    s.restart()
    finally:
        for s in slots:
            s.close()
    return sorted(results, key=lambda r: r[0].index)


def decade(size: float) -> str:
    """The H/D decade a run falls in, as a column label."""
    k = math.floor(math.log10(size)) if size > 0 else -3
    k = min(max(k, -2), 3)
    return "..1e-1" if k < -1 else f"1e{k}..1e{k + 1}"


def report(results: list[tuple[Run, list[Any], float]]) -> tuple[str, int]:
    """The table of findings by class and H/D decade, and the number of findings."""
    columns = sorted(
        {decade(r.h_over_d) for r, _, _ in results}, key=lambda c: float(c.split("..")[0] or 0)
    )
    runs = Counter(decade(r.h_over_d) for r, _, _ in results)
    skipped = sum(1 for _, f, _ in results if f and f[0][0] == "skipped")
    table = Counter((c, decade(r.h_over_d)) for r, f, _ in results for c, _ in f if c != "skipped")
    lines = [
        f"{len(results)} runs, {skipped} refused by the library (skipped)",
        "| class | " + " | ".join(columns) + " | all |",
        "|---" * (len(columns) + 2) + "|",
        "| runs | " + " | ".join(str(runs[c]) for c in columns) + f" | {len(results)} |",
    ]
    for cls in CLASSES:
        row = [table[(cls, c)] for c in columns]
        lines.append(f"| {cls} | " + " | ".join(map(str, row)) + f" | {sum(row)} |")
    slow = sorted(results, key=lambda r: -r[2])[:3]
    lines.append("slowest runs: " + ", ".join(f"#{r.index} {s:.2f} s" for r, _, s in slow))
    return "\n".join(lines), sum(table.values())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--max-ratio",
        type=float,
        default=None,
        help="largest H/D and r_p drawn (default: geometry.MAX_DESIGN_RATIO, the accepted range)",
    )
    ap.add_argument("--min-ratio", type=float, default=MIN_RATIO, help="smallest H/D drawn")
    ap.add_argument("--max-friction", type=float, default=MAX_FRICTION)
    ap.add_argument("--faces", default=",".join(FACES), help="comma-separated kinds to draw")
    ap.add_argument("--map-every", type=int, default=10, help="symmetry-filling check every N runs")
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds per run before a kill")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--json", type=Path, default=None, help="write every finding with its run")
    args = ap.parse_args(argv)
    from xface_core.geometry import MAX_DESIGN_RATIO

    max_ratio = MAX_DESIGN_RATIO if args.max_ratio is None else args.max_ratio
    rng = np.random.default_rng(args.seed)
    faces = tuple(args.faces.split(","))
    runs = [
        draw_run(rng, i, max_ratio, args.max_friction, args.map_every, faces, args.min_ratio)
        for i in range(args.runs)
    ]
    results = probe(runs, args.timeout, args.workers)
    text, n_findings = report(results)
    print(f"seed {args.seed}, max ratio {max_ratio:g}, max friction {args.max_friction:g}")
    print(text)
    found = [(r, f) for r, f, _ in results if f and f[0][0] != "skipped"]
    for r, f in found[:20]:
        print(
            f"#{r.index} {r.kind} {r.h_over_d:.4g}/{r.r_p:.4g} d={r.damping_ratio:.3g} "
            f"mu={r.friction:.3g} x0={r.x0_d:.4g} D th={r.theta0:.4g}: {f}"
        )
    if args.json is not None:
        rows = [{"run": asdict(r), "findings": f} for r, f in found]
        args.json.write_text(json.dumps(rows, indent=1, default=str) + "\n")
    return 1 if n_findings else 0


if __name__ == "__main__":
    raise SystemExit(main())
