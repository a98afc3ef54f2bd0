"""``xface optimize``: search a profile family for a face that beats the X-Face
(:mod:`xface_core.study.optimize`), then write what a designer takes away.

Into ``--out`` (a folder; running the same command again resumes the search from its
``evaluations.parquet``):

- ``best.yaml``: the best face as a face file (docs/facefile.md), at ``--width``;
- ``best_map.png``: its acceptance map; ``compare.png``: the X-Face's, the best face's and
  their difference, on the same grid and physics;
- ``best_face.png`` and ``best_face.dxf``: the drawing of both parts, mated and apart (the
  DXF with the cad extra);
- ``crosscheck.json``: the best face against Chipmunk2D, cell by cell at converged settings
  (the crosscheck extra; ``--no-crosscheck`` skips it): an optimiser finds a model's
  mistakes first, so the winner is confirmed by the independent engine. Each cell is
  converged on its own (:data:`OPTIMIZE_CONVERGE_BY`);
- ``summary.json``: the search (family, settings, evaluations, rate, restarts), the best
  face and the X-Face side by side, and the cross-check's numbers.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from xface_core.codes import CROSSCHECK_CONVERGE_BY
from xface_core.errors import XfaceValueError
from xface_core.facefile import save_face
from xface_core.geometry import FaceDesign, x_face
from xface_core.maps.acceptance import AcceptanceMap, acceptance_map
from xface_core.physics import Physics
from xface_core.study.optimize import (
    EVALUATIONS_FILE,
    FaceSearch,
    ProfileFamily,
    SearchProgress,
    optimize_face,
)
from xface_core.study.search import CRITERIA

from . import progress
from .study import (
    _common_study_args,
    _executor,
    _interrupted,
    _noise,
    _sigterm_interrupts,
    _warnings_as_lines,
    atomic_output,
    json_default,
)

__all__ = ["add_optimize_command"]

#: The search's pose grid.
DEFAULT_GRID = 41

#: The cross-check's pose grid: the accuracy table's (docs/accuracy.md), every other node of
#: the search's 41 x 41. At converged settings Chipmunk2D takes 10-30 min of two cores for all
#: 1681 cells of a searched face; 441 cells keep a search and its check within 15 min.
DEFAULT_CROSSCHECK_GRID = 21


class _Bar(progress.ProgressBar):
    def __call__(self, p: SearchProgress) -> None:
        self.draw(p.evaluations, p.budget, p.elapsed, f", best {p.best:g}")


def _cmd_optimize(args: argparse.Namespace) -> int:
    with _warnings_as_lines():
        return _optimize(args)


def _family(args: argparse.Namespace) -> ProfileFamily:
    return ProfileFamily(
        args.h_over_d,
        args.rp,
        vertices=args.vertices,
        layers=args.layers,
        min_feature=args.min_feature,
        max_wall_deg=args.max_wall_deg,
    )


#: How the winner's cross-check halves the engine step unless ``--crosscheck-converge-by``
#: says otherwise: ``cells``, each cell converged on its own (its verdict unchanged by its
#: own last halving). ``grid`` runs every cell again at every halving until one changes
#: none: where a few cells keep changing (H/D 0.5, r_p 2: 7, 3 and 4 cells at the three
#: halvings) each halving costs twice the one before, and the command took 35 minutes
#: where ``cells`` finishes in well under 15 (docs/design.md). The strict check stays one
#: command away: ``xface crosscheck --face-file best.yaml --converged`` (grid by default).
OPTIMIZE_CONVERGE_BY = "cells"


def _crosscheck_settings(args: argparse.Namespace) -> None:
    """Check the cross-check's options and fill in their defaults: set with
    ``--no-crosscheck`` they would be ignored without a word, so they are refused."""
    given = [
        flag
        for flag, value in (
            ("--crosscheck-grid", args.crosscheck_grid),
            ("--crosscheck-converge-by", args.crosscheck_converge_by),
        )
        if value is not None
    ]
    if args.no_crosscheck and given:
        raise XfaceValueError(
            f"{' and '.join(given)} set how the Chipmunk2D check runs, and --no-crosscheck "
            "skips it: drop one or the other"
        )
    if args.crosscheck_grid is None:
        args.crosscheck_grid = DEFAULT_CROSSCHECK_GRID
    if args.crosscheck_converge_by is None:
        args.crosscheck_converge_by = OPTIMIZE_CONVERGE_BY
    if args.crosscheck_grid < 3 or args.crosscheck_grid % 2 == 0:
        raise XfaceValueError(
            f"--crosscheck-grid must be an odd integer >= 3, got {args.crosscheck_grid}"
        )


def _optimize(args: argparse.Namespace) -> int:
    family = _family(args)
    _crosscheck_settings(args)
    noise = _noise(args)
    physics = Physics(damping_ratio=args.damping_ratio, friction=args.friction)
    width = x_face(1.0, 1.0, width=args.width).width  # checked before the search runs
    if args.criterion == "seat_probability" and noise is None:
        raise XfaceValueError("--criterion seat_probability needs --sigma-x and --sigma-theta")
    label = partial(_Bar, label="optimize", unit="evaluations")
    try:
        with (
            _sigterm_interrupts(),
            _executor(args) as client,
            progress.terminal_progress(args.quiet, label) as bar,
        ):
            found = optimize_face(
                family,
                args.out,
                criterion=args.criterion,
                grid=args.grid,
                theta_kind=args.theta_grid,
                friction=args.friction,
                damping_ratio=args.damping_ratio,
                noise=noise,
                budget=args.budget,
                popsize=args.popsize,
                sigma0=args.sigma0,
                seed=args.seed,
                executor=client,
                workers=args.workers,
                progress=bar,
                allow_version_mix=args.allow_version_mix,
            )
    except KeyboardInterrupt:
        return _interrupted(str(Path(args.out) / EVALUATIONS_FILE))
    folder = Path(args.out)
    best = found.best_design.with_width(width)
    start = x_face(family.h_over_d, family.r_p, width=width)
    maps = [
        acceptance_map(d, grid=args.grid, theta_kind=args.theta_grid, physics=physics)
        for d in (start, best)
    ]
    written = _write_outputs(args, folder, best, start, maps)
    check = None if args.no_crosscheck else _crosscheck(args, folder, best, physics)
    if check is not None:
        written.append(check["file"])
    written.append(str(folder / "summary.json"))
    summary = _summary(args, found, maps, check, written)
    with atomic_output(folder / "summary.json", "the summary") as aside:
        Path(aside).write_text(json.dumps(summary, indent=2) + "\n")
    if args.json:
        print(json.dumps(summary))
    else:
        for line in _summary_lines(found, summary):
            print(line)
    return 0


def _write_outputs(
    args: argparse.Namespace,
    folder: Path,
    best: FaceDesign,
    start: FaceDesign,
    maps: list[AcceptanceMap],
) -> list[str]:
    """The face file, the maps and the drawing; the files written."""
    from xface_core.viz.comparefig import save_comparison
    from xface_core.viz.facedraw import face_drawing, save_face_picture
    from xface_core.viz.mapimage import design_title, save_map_picture

    written = []
    target = folder / "best.yaml"
    with atomic_output(target, "the face file") as aside:
        save_face(best, aside)
    written.append(str(target))
    pictures: dict[str, Callable[[str], object]] = {
        "best_map.png": partial(save_map_picture, maps[1], fmt="png"),
        "compare.png": partial(
            save_comparison,
            maps[0],
            maps[1],
            labels=(design_title(start), design_title(best)),
            fmt="png",
        ),
        "best_face.png": partial(save_face_picture, face_drawing(best), fmt="png"),
    }
    try:
        from xface_core.viz.facecad import save_face_dxf

        pictures["best_face.dxf"] = partial(save_face_dxf, face_drawing(best))
    except ImportError as exc:
        if (exc.name or "").partition(".")[0] != "ezdxf":
            raise
        print("xface: best_face.dxf skipped: the cad extra is not installed", file=sys.stderr)
    for name, write in pictures.items():
        with atomic_output(folder / name, "the picture") as aside:
            write(aside)
        written.append(str(folder / name))
    return written


def _crosscheck(
    args: argparse.Namespace, folder: Path, best: FaceDesign, physics: Physics
) -> dict[str, Any]:
    """The best face against Chipmunk2D on ``--crosscheck-grid``, converged (crosscheck.json)."""
    from xface_core.crosscheck.compare import crosscheck, result_json, stderr_progress

    result = crosscheck(
        best,
        physics,
        grid=args.crosscheck_grid,
        converged=True,
        converge_by=args.crosscheck_converge_by,
        workers=args.workers,
        progress=None if args.quiet or not sys.stderr.isatty() else stderr_progress,
    )
    target = folder / "crosscheck.json"
    with atomic_output(target, "the cross-check") as aside:
        Path(aside).write_text(json.dumps(result_json(result), default=json_default) + "\n")
    m_xface, m_engine, m_rounded = result.m_values()
    return {
        "file": str(target),
        "agreement": result.agreement,
        "unambiguous": result.n_unambiguous,
        "ambiguous": result.n_ambiguous,
        "false_seated": result.false_seated,
        "false_failures": result.false_failures,
        "converged": result.converged,
        "M_xface": m_xface,
        "M_engine": m_engine,
        "M_engine_rounded": m_rounded,
        "seconds": result.seconds,
    }


def _summary(
    args: argparse.Namespace,
    found: FaceSearch,
    maps: list[AcceptanceMap],
    check: dict[str, Any] | None,
    written: list[str],
) -> dict[str, Any]:
    column = CRITERIA[args.criterion]
    gain = found.score / found.x_face_score - 1.0 if found.x_face_score > 0 else None
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    rate = found.simulated / found.evaluation_seconds if found.evaluation_seconds > 0 else None
    return {
        "criterion": args.criterion,
        "column": column,
        "family": found.family.as_dict(),
        "grid": args.grid,
        "theta_kind": args.theta_grid,
        "friction": args.friction,
        "damping_ratio": args.damping_ratio,
        "budget": args.budget,
        "seed": args.seed,
        "evaluations": found.evaluations,
        "simulated": found.simulated,
        "restarts": found.restarts,
        "stop_reasons": list(found.stop_reasons),
        "seconds": found.seconds,
        "evaluations_per_second": rate,
        "workers": None if args.scheduler else workers,
        "x_face": {"score": found.x_face_score, "M": maps[0].M, "row": found.x_face},
        "start": {"score": found.start_score, "row": found.start},
        "best": {
            "name": found.best_design.display_name,
            "score": found.score,
            "M": maps[1].M,
            "gain": gain,
            "point": found.best_point.tolist(),
            "profile": found.family.profile(found.best_point).tolist(),
            "row": found.best,
        },
        "history": [list(h) for h in found.history],
        "crosscheck": check if check is None else {**check, "grid": args.crosscheck_grid},
        "files": [*written],
    }


def _summary_lines(found: FaceSearch, s: dict[str, Any]) -> list[str]:
    f = found.family
    rate = s["evaluations_per_second"]
    where = f"on {s['workers']} workers" if s["workers"] else "on the cluster"
    lines = [
        (
            f"optimize {found.best_design.display_name} by {s['criterion']} ({s['column']}) on a "
            f"{s['grid']} x {s['grid']} pose grid, friction {s['friction']:g}, damping ratio "
            f"{s['damping_ratio']:g}"
        ),
        (
            f"search   {s['evaluations']} evaluations ({s['simulated']} faces simulated in this "
            f"run, {s['restarts']} restarts), {s['seconds']:.0f} s"
            + (f", {rate:.1f} evaluations/s {where}" if rate else "")
        ),
        f"X-Face   H/D {f.h_over_d:g} r_p {f.r_p:g}: {s['column']} = {found.x_face_score:g}"
        + (
            f" (the family's start, {f.layers} layer{'s' if f.layers > 1 else ''}: "
            f"{found.start_score:g})"
            if found.start is not found.x_face
            else ""
        ),
        f"best     {s['column']} = {found.score:g}"
        + (
            f" ({100 * s['best']['gain']:+.1f} % against the X-Face)"
            if s["best"]["gain"] is not None
            else ""
        ),
        "profile  "
        + ", ".join(f"({x:+.4f}, {y:.4f})" for x, y in s["best"]["profile"])
        + " D, first layer, left to right",
    ]
    c = s["crosscheck"]
    if c is not None:
        conv = "converged" if c["converged"] else "NOT converged"
        lines.append(
            f"engine   Chipmunk2D, {c['grid']} x {c['grid']} cells ({conv}): agreement "
            f"{100 * c['agreement']:.2f} % of "
            f"{c['unambiguous']} unambiguous cells, false SEATED {c['false_seated']}, false "
            f"failures {c['false_failures']}, M engine {c['M_engine']} / xface {c['M_xface']}"
        )
    lines.append("wrote    " + ", ".join(s["files"]))
    return lines


def add_optimize_command(sub: Any) -> None:
    """Add ``optimize`` to the ``xface`` subcommands."""
    p = sub.add_parser(
        "optimize", help="search face profiles (CMA-ES from the X-Face) for a better face"
    )
    p.add_argument("--h-over-d", type=float, default=0.25, help="height bound H/D")
    p.add_argument("--rp", type=float, default=1.0, help="pivot to profile base (widths D)")
    p.add_argument("--vertices", type=int, default=3, help="free vertices per half profile")
    p.add_argument(
        "--layers", type=int, choices=(1, 2), default=2, help="2: a mirrored pair (X-Face's)"
    )
    p.add_argument("--min-feature", type=float, default=0.05, help="smallest edge span (D)")
    p.add_argument("--max-wall-deg", type=float, default=75.0, help="steepest edge (deg)")
    p.add_argument("--criterion", choices=tuple(CRITERIA), default="M")
    p.add_argument("--friction", type=float, default=0.0, help="Coulomb coefficient mu")
    p.add_argument("--damping-ratio", type=float, default=1.0, help="c_B / c_M (inf: fixed)")
    p.add_argument("--budget", type=int, default=1500, help="evaluations (faces) to spend")
    p.add_argument("--popsize", type=int, default=None, help="faces per generation")
    p.add_argument("--sigma0", type=float, default=0.15, help="first step (unit box)")
    p.add_argument("--seed", type=int, default=1, help="the optimiser's random numbers")
    p.add_argument("--width", type=float, default=1.0, help="D of the face file written")
    p.add_argument(
        "--crosscheck-grid",
        type=int,
        help=f"the Chipmunk2D check's pose grid (odd; default {DEFAULT_CROSSCHECK_GRID}; 41 checks "
        "every cell of the default search)",
    )
    p.add_argument(
        "--crosscheck-converge-by", choices=CROSSCHECK_CONVERGE_BY,
        help="how the check's halvings of the engine step choose their cells (xface "
        f"crosscheck --converge-by; default {OPTIMIZE_CONVERGE_BY}: only those the halving "
        "before changed, each cell converged on its own; grid: every cell at every halving "
        "until one changes none, stricter and up to twice as long per halving)",
    )  # fmt: skip
    p.add_argument("--no-crosscheck", action="store_true", help="skip the Chipmunk2D check")
    p.add_argument("--out", required=True, help="output folder (the search resumes from it)")
    _common_study_args(p)
    p.set_defaults(func=_cmd_optimize, grid=DEFAULT_GRID)
