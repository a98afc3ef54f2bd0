"""``xface bench``: run time against error, and the speed targets.

Writes to ``--out`` (default ``bench/``):

- ``work_precision.csv`` / ``.md``: one row per solver setting: median time per 41 x 41 map,
  final-state error against a reference solved at tolerances near machine precision,
  event-location error, constraint violation (overlap area of the parts at the end, by
  shapely), and map mismatches, split into
  nodes on an outcome boundary (the reference flips within 1e-6 of the node) and the rest;
  nodes where the reference is not converged (a second one, 100 times tighter than the
  default, differs from it: ``unconverged_reference``) are counted apart and left out;
- ``work_precision.png``: error against time, log-log;
- ``targets.md``: the speed targets (one prediction with its path, one map, all tables), the
  ablation of the skip techniques that can be switched off, and, with the ``crosscheck``
  extra installed, the time per 41 x 41 map against the pymunk (Chipmunk2D) scene of
  :mod:`xface_core.crosscheck`, both on one thread.

Times are medians of repeats on this machine; they are benchmarks, never test assertions.
A progress bar (steps done of all, time left) goes to stderr when it is a terminal
(``--quiet``: never).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import cast

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.contact import clear_cache
from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign, make_face
from xface_core.maps.acceptance import acceptance_map, m_table
from xface_core.maps.grids import theta_grid, x0_grid
from xface_core.physics import DEFAULT_SETTINGS, Physics, SolverSettings
from xface_core.predict import predict
from xface_core.runner import predict_batch, run_flat

from .progress import ProgressBar, terminal_progress
from .study import atomic_output

__all__ = ["REFERENCE_SETTINGS", "run_bench"]


def tolerances_at(rtol: float) -> SolverSettings:
    """The bench's settings at ``rtol``: atol ``rtol / 100`` (D), events located to
    ``min(1e-12, rtol * 1e-4)`` (D); the rest as :data:`DEFAULT_SETTINGS` (which is the value
    at rtol 1e-8). The references are rows of the same rule, so the reference and the row at
    its rtol are the same settings to the last bit."""
    return replace(DEFAULT_SETTINGS, rtol=rtol, atol=rtol * 1e-2, event_tol=min(1e-12, rtol * 1e-4))


#: The reference: every tolerance 1000 times tighter than the default (rtol 1e-11, events to
#: 1e-15 D); tighter still, the step control stalls on round-off near folds of the path.
REFERENCE_SETTINGS = tolerances_at(1e-11)
#: A second reference, 100 times tighter than the default. A node where the two references
#: differ in outcome or by more than REFERENCE_AGREEMENT (rad, D) in the final state is not
#: converged in the reference (its error there is the reference's: near a pair of contacts
#: whose rotational normals are nearly opposite, round-off amplified by their conditioning
#: reaches rtol 1e-11; or a seat found within the seat tolerance short of the mated pose), so
#: it is counted apart and left out of the errors and mismatches. On the bench's designs the
#: two references agree to 1.6e-8 or better at every other node.
REFERENCE_CHECK_SETTINGS = tolerances_at(1e-10)
REFERENCE_AGREEMENT = 1e-6

BENCH_DESIGNS: tuple[tuple[str, float, float], ...] = (
    ("X", 0.25, 2.0),
    ("X", 1.0, 1.0),
    ("V", 0.5, 1.0),
    ("S", 0.5, 1.0),
)


class _Steps:
    """The bench's steps, counted onto a progress bar (or only counted, without one)."""

    def __init__(self, bar: ProgressBar | None, total: int) -> None:
        self.bar, self.total, self.done = bar, total, 0

    def step(self) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.step(self.done, self.total)

    def print(self, line: str) -> None:
        """``line`` on stdout, the bar (on the same terminal) redrawn under it."""
        if self.bar is not None:
            self.bar.clear()
        print(line, flush=True)
        if self.bar is not None:
            self.bar.step(self.done, self.total)


def _n_steps(n_designs: int, n_rtols: int, quick: bool) -> int:
    """How many times :class:`_Steps` steps in one bench: a reference per design, a row per
    setting (the default once more, without the symmetry skip), then the targets."""
    n_targets = 1 + len(BENCH_DESIGNS) + (0 if quick else 2) + len(BENCH_DESIGNS) + 1
    return n_designs + n_rtols + 1 + n_targets


def _median_time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


@dataclass
class _Finals:
    outcome: npt.NDArray[np.int8]
    phi_b: npt.NDArray[np.float64]
    phi_m: npt.NDArray[np.float64]
    y_m: npt.NDArray[np.float64]
    penetration: npt.NDArray[np.float64]


def _finals(design: FaceDesign, settings: SolverSettings) -> _Finals:
    """Run the 41 x 41 grid and keep final states plus the penetration at the end."""
    X, T = np.meshgrid(x0_grid(41), theta_grid(41), indexing="ij")
    xs, ts = X.ravel(), T.ravel()
    runs = run_flat(design, xs, ts, Physics(settings=settings), threads=1)
    out = _Finals(
        runs["outcome"].astype(np.int8),
        runs["phi_b"].copy(),
        runs["phi_m"].copy(),
        runs["y_m"].copy(),
        np.zeros(xs.size),
    )
    for k in range(xs.size):
        out.penetration[k] = _overlap_area(
            design, float(xs[k]), out.phi_b[k], out.phi_m[k], out.y_m[k]
        )
    return out


def _overlap_area(design: FaceDesign, x0: float, phi_b: float, phi_m: float, y_m: float) -> float:
    """Overlap area (D^2) of equal layers: the constraint violation, measured by shapely
    independently of the kernel's gap functions (exact for non-convex faces too). The overlay
    is snap-rounded to 1e-12 D: GEOS's floating overlay returned the whole area (1.5 D^2)
    for two parts lying flush along one line."""
    import shapely

    def snapped(outline: npt.NDArray[np.float64]) -> shapely.Geometry:
        return shapely.set_precision(shapely.Polygon(outline), 1e-12)

    return max(
        float(
            snapped(design.base_outline_world(k, phi_b))
            .intersection(snapped(design.moving_outline_world(k, x0, y_m, phi_m)))
            .area
        )
        for k in range(design.n_layers)
    )


def _boundary_nodes(ref: _Finals, design: FaceDesign) -> npt.NDArray[np.bool_]:
    """Nodes whose reference outcome flips within 1e-6 (D or rad) along either axis."""
    o = ref.outcome.reshape(41, 41)
    X, T = np.meshgrid(x0_grid(41), theta_grid(41), indexing="ij")
    near = np.zeros((41, 41), dtype=bool)
    for dx, dt in ((1e-6, 0.0), (-1e-6, 0.0), (0.0, 1e-6), (0.0, -1e-6)):
        shifted = predict_batch(design, X + dx, T + dt, settings=REFERENCE_SETTINGS).outcome
        near |= shifted != o
    return near.ravel()


def _unconverged_nodes(ref: _Finals, check: _Finals) -> npt.NDArray[np.bool_]:
    """Nodes where the reference and the check reference (REFERENCE_CHECK_SETTINGS) differ
    in outcome or by more than REFERENCE_AGREEMENT in an angle or the height."""
    off = ref.outcome != check.outcome
    for a, b in ((ref.phi_b, check.phi_b), (ref.phi_m, check.phi_m), (ref.y_m, check.y_m)):
        off |= np.abs(a - b) > REFERENCE_AGREEMENT  # NaN (no state) compares False
    return np.asarray(off)


def _work_precision(
    designs: list[FaceDesign], rtols: list[float], repeats: int, steps: _Steps
) -> list[dict[str, object]]:
    refs, boundary, unconverged = [], [], []
    for d in designs:
        refs.append(_finals(d, REFERENCE_SETTINGS))
        boundary.append(_boundary_nodes(refs[-1], d))
        unconverged.append(_unconverged_nodes(refs[-1], _finals(d, REFERENCE_CHECK_SETTINGS)))
        steps.step()
    n_unconverged = int(sum(np.count_nonzero(u) for u in unconverged))
    rows: list[dict[str, object]] = []
    for rtol in rtols:
        for symmetry in (True, False):
            s = tolerances_at(rtol)
            if not symmetry and rtol != DEFAULT_SETTINGS.rtol:
                continue  # the symmetry skip changes time, not error: one row is enough
            t_map = float(
                np.mean(
                    [
                        _median_time(
                            partial(acceptance_map, d, settings=s, use_symmetry=symmetry),
                            repeats,
                        )
                        for d in designs
                    ]
                )
            )
            err_state, err_p99, err_event, pen = [], [], [], []
            mism_b, mism_nb, dm = 0, 0, 0
            for d, ref, bnd, bad in zip(designs, refs, boundary, unconverged, strict=True):
                f = _finals(d, s)
                same = (f.outcome == ref.outcome) & ~bad
                both = np.r_[same, same]
                diffs = np.abs(np.r_[f.phi_b - ref.phi_b, f.phi_m - ref.phi_m][both])
                err_state.append(float(diffs.max()))
                err_p99.append(float(np.percentile(diffs, 99)))
                err_event.append(float(np.max(np.abs(f.y_m - ref.y_m)[same])))
                pen.append(float(f.penetration.max()))
                differ = (f.outcome != ref.outcome) & ~bad
                mism_b += int(np.count_nonzero(differ & bnd))
                mism_nb += int(np.count_nonzero(differ & ~bnd))
                dm += abs(
                    int(np.count_nonzero(f.outcome == Outcome.SEATED))
                    - int(np.count_nonzero(ref.outcome == Outcome.SEATED))
                )
            rows.append(
                {
                    "rtol": rtol,
                    "atol": s.atol,
                    "event_tol": s.event_tol,
                    "symmetry": symmetry,
                    "default": rtol == DEFAULT_SETTINGS.rtol,
                    "ms_per_map": t_map * 1e3,
                    "max_state_err_rad": max(err_state),
                    "p99_state_err_rad": max(err_p99),
                    "max_event_err_D": max(err_event),
                    "max_overlap_D2": max(pen),
                    "mismatch_boundary": mism_b,
                    "mismatch_other": mism_nb,
                    "sum_abs_dM": dm,
                    "unconverged_reference": n_unconverged,
                }
            )
            steps.step()
            steps.print(
                f"rtol={rtol:.0e} sym={symmetry!s:5} {t_map * 1e3:8.1f} ms/map  "
                f"state err {max(err_state):.1e} (p99 {max(err_p99):.1e})  "
                f"event err {max(err_event):.1e}  "
                f"overlap {max(pen):.1e} D^2  mismatches {mism_nb} (+{mism_b} on boundaries; "
                f"{n_unconverged} nodes left out: reference not converged)"
            )
    return rows


def _write_text(path: Path, text: str) -> None:
    """``path`` holds ``text`` whole, or its old content if interrupted (atomic_output)."""
    with atomic_output(path, "the bench table") as aside:
        Path(aside).write_text(text)


def _write_table(rows: list[dict[str, object]], out: Path) -> None:
    keys = list(rows[0])
    csv = [",".join(keys)] + [",".join(str(r[k]) for k in keys) for r in rows]
    _write_text(out / "work_precision.csv", "\n".join(csv) + "\n")
    md = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        cells = [f"{v:.3g}" if isinstance(v, float) else str(v) for v in r.values()]
        md.append("| " + " | ".join(cells) + " |")
    _write_text(out / "work_precision.md", "\n".join(md) + "\n")


def _targets(quick: bool, repeats: int, steps: _Steps) -> list[str]:
    design = make_face("X", 0.25, 2.0)
    predict(design, 0.3, 0.2)  # compile / load the kernel
    lines = ["| target | measured (median) | goal |", "|---|---|---|"]
    t_pred = _median_time(lambda: predict(design, 0.3, 0.2), max(50, repeats * 20))
    lines.append(
        f"| one prediction with its path (X, H/D 0.25, r_p 2) | {t_pred * 1e6:.0f} us | <= 100 us |"
    )
    t_nopath = _median_time(lambda: predict(design, 0.3, 0.2, path=False), max(50, repeats * 20))
    lines.append(f"| the same without the path | {t_nopath * 1e6:.0f} us | |")
    t_marg = _median_time(lambda: predict(design, 0.3, 0.2, margins=True), max(5, repeats))
    lines.append(f"| the same with margins (4 flip searches) | {t_marg * 1e3:.1f} ms | |")
    steps.step()
    maps = {}
    for face, h, rp in BENCH_DESIGNS:
        d = make_face(face, h, rp)
        maps[(face, h, rp)] = (
            _median_time(partial(acceptance_map, d), repeats),
            _median_time(partial(acceptance_map, d, use_symmetry=False), repeats),
        )
        steps.step()
    for (face, h, rp), (t_sym, t_full) in maps.items():
        lines.append(
            f"| 41 x 41 map, {face} H/D {h:g} r_p {rp:g} (symmetry skip on / off) | "
            f"{t_sym * 1e3:.0f} / {t_full * 1e3:.0f} ms | <= 20 ms |"
        )
    if not quick:
        t0 = time.perf_counter()
        for face in "XVS":
            m_table(face, workers=2)
        lines.append(
            "| all three 11 x 11 tables, 2 workers (one run) | "
            f"{time.perf_counter() - t0:.1f} s | <= 10 s |"
        )
        steps.step()
        t0 = time.perf_counter()
        m_table("S", workers=1)
        lines.append(
            f"| the S table alone, 1 worker (one run) | {time.perf_counter() - t0:.1f} s | |"
        )
        steps.step()
    for face, h, rp in BENCH_DESIGNS:
        d = make_face(face, h, rp)
        full = acceptance_map(d, grid=81)
        refined = acceptance_map(d, grid=81, coarse=41)
        wrong = int(np.count_nonzero(full.outcomes != refined.outcomes))
        t_full = _median_time(partial(acceptance_map, d, grid=81), repeats)
        t_ref = _median_time(partial(acceptance_map, d, grid=81, coarse=41), repeats)
        lines.append(
            f"| 81 x 81 map, {face} H/D {h:g} r_p {rp:g}: exact / refined from 41 x 41 "
            f"({wrong} of 6561 nodes differ) | {t_full * 1e3:.0f} / {t_ref * 1e3:.0f} ms | |"
        )
        steps.step()

    def uncached() -> None:
        clear_cache()
        predict(design, 0.3, 0.2, path=False)

    t_unc = _median_time(uncached, max(20, repeats * 5))
    lines.append(
        "| one prediction without the per-design cache (pair table rebuilt) | "
        f"{t_unc * 1e6:.0f} us | |"
    )
    steps.step()
    return lines


#: The map of the pymunk comparison: 41 x 41, the same grid as xface's.
PYMUNK_GRID = 41


def _pymunk_map_seconds(run_cell: Callable[..., object], d: FaceDesign, quick: bool) -> float:
    """Seconds the pymunk scene takes for the 41 x 41 map of ``d`` on one thread: every cell
    run once (the full bench), or with ``quick`` estimated from the grid's diagonal (cell k, k:
    every offset and every angle once) scaled to the map's cells. The diagonal is not a fair
    sample: the whole map takes the scene 2.3-2.9 times the diagonal's estimate on X 1/1, V
    and S (docs/bench.md)."""
    x0s, thetas = x0_grid(PYMUNK_GRID), theta_grid(PYMUNK_GRID)
    t0 = time.perf_counter()
    if quick:
        for k in range(PYMUNK_GRID):
            run_cell(d, float(x0s[k]), float(thetas[k]))
        return (time.perf_counter() - t0) / PYMUNK_GRID * PYMUNK_GRID**2
    for x0 in x0s:
        for theta0 in thetas:
            run_cell(d, float(x0), float(theta0))
    return time.perf_counter() - t0


def _pymunk_lines(quick: bool, repeats: int) -> list[str]:
    """Time per 41 x 41 map of xface (one thread, as shipped: mirror symmetry on; and every
    cell simulated) and of the pymunk scene of the crosscheck extra (one thread, every cell;
    estimated from the grid's diagonal with ``quick``)."""
    try:
        from xface_core.crosscheck import run_cell  # the crosscheck extra (pymunk, shapely)
    except ImportError:
        return [
            "| pymunk scene per 41 x 41 map | not measured: `pip install 'xface[crosscheck]'` | |"
        ]
    lines = []
    how = "estimated from the diagonal" if quick else "every cell"
    for face, h, rp in BENCH_DESIGNS[:1] if quick else BENCH_DESIGNS:
        d = make_face(face, h, rp)
        t_map = _median_time(partial(acceptance_map, d, threads=1), repeats)
        t_all = _median_time(partial(acceptance_map, d, threads=1, use_symmetry=False), repeats)
        t_pymunk = _pymunk_map_seconds(run_cell, d, quick)
        lines.append(
            f"| 41 x 41 map, {face} H/D {h:g} r_p {rp:g}: xface (symmetry skip on / off) / "
            f"pymunk scene ({how}), one thread each | {t_map * 1e3:.0f} / {t_all * 1e3:.0f} ms "
            f"/ {t_pymunk:.1f} s: {t_pymunk / t_map:.0f}x / {t_pymunk / t_all:.0f}x | >= 1000x |"
        )
    return lines


def loosest_clean_rtol(rows: list[dict[str, object]]) -> float | None:
    """The largest rtol whose map, and the map of every smaller rtol, has no node off an
    outcome boundary that differs from the reference (None if the tightest has some).

    The work falls as rtol grows, so this is the cheapest setting that is safe; picking by
    the measured times instead follows the machine's noise (the map times of one bench moved
    30 % between two runs the same day, and every row was clean)."""
    by_rtol = sorted(
        (cast(float, r["rtol"]), cast(int, r["mismatch_other"])) for r in rows if r["symmetry"]
    )
    loosest = None
    for rtol, mismatches in by_rtol:
        if mismatches:
            break
        loosest = rtol
    return loosest


def run_bench(args: argparse.Namespace) -> int:
    """Entry point of ``xface bench``."""
    out = Path(args.out)
    if not out.parent.is_dir():
        # Only the output folder itself is made: a typo in a parent would otherwise grow a
        # whole tree somewhere unexpected.
        raise XfaceValueError(f"--out {str(out)!r}: the folder {str(out.parent)!r} does not exist")
    out.mkdir(exist_ok=True)
    quick = bool(args.quick)
    repeats = 3 if quick else 5
    designs = [make_face(*d) for d in (BENCH_DESIGNS[:2] if quick else BENCH_DESIGNS)]
    rtols = (
        [1e-3, 1e-5, 1e-8, 1e-10]
        if quick
        else [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]
    )
    if DEFAULT_SETTINGS.rtol not in rtols:
        rtols.append(DEFAULT_SETTINGS.rtol)
    from xface_core.viz.benchplot import work_precision_figure  # matplotlib, from the viz extra
    from xface_core.viz.figures import save

    total = _n_steps(len(designs), len(rtols), quick)
    with terminal_progress(args.quiet, partial(ProgressBar, label="bench", unit="steps")) as bar:
        steps = _Steps(bar, total)
        rows = _work_precision(designs, sorted(rtols, reverse=True), repeats, steps)
        _write_table(rows, out)
        with atomic_output(out / "work_precision.png", "the bench plot") as aside:
            save(work_precision_figure(rows), aside, "png")
        lines = _targets(quick, repeats, steps)
    lines += _pymunk_lines(quick, repeats)
    _write_text(out / "targets.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    loosest = loosest_clean_rtol(rows)
    if loosest is not None:
        print(
            f"loosest setting with zero non-boundary mismatches, and every tighter one: "
            f"rtol {loosest:.0e}"
        )
    print(f"wrote {out}/work_precision.csv, .md, .png and {out}/targets.md")
    return 0
