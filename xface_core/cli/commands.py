"""The ``xface`` command line: predict one dock, map a design, tabulate M, benchmark,
cross-check xface against an independent engine, and run design studies (``sweep``,
``design``: :mod:`xface_core.cli.study`).

Lengths are in units of D unless ``--width`` gives D in metres (or any unit): then x0 and
y-start are read, and lengths printed, in that unit. Plain text by default, ``--json`` for
machines. Recordings (``--rrd``), pictures (``--png``, ``--svg``) and the bench plot need the
``viz`` extra (rerun-sdk, matplotlib); without it they exit with code 2 and say so, before
simulating.
``xface crosscheck`` needs the ``crosscheck`` extra (pymunk) in the same way, ``xface draw
--dxf`` the ``cad`` extra (ezdxf).
A number takes every spelling ``float`` reads, negative ones too (``--x0 -1e-3``). The names
given to ``--png``, ``--svg``, ``--rrd``, ``--dxf`` and ``--out`` are checked before anything runs
(docs/recording.md: not empty, UTF-8, a file not ending in a separator, the format's suffix).

Exit codes: 0 done; 2 a user error (one ``xface: error: ...`` line on stderr), also for a
closed stdout (``>&-``: the answer would be lost, so nothing runs); 130 interrupted (Ctrl-C;
a study also on SIGTERM): one ``xface: interrupted`` line, no traceback; 141 the reader of
stdout went away (``| head``): quiet, what a shell reports for a writer killed by SIGPIPE.
A closed stderr (``2>&-``) changes nothing but the messages, which are lost. Files named by
``--png``, ``--svg`` and ``--rrd`` (and the bench's) are written aside and renamed when whole:
an interrupted or failed run leaves the old file or none, never half of a new one.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.metadata
import json
import math
import multiprocessing
import os
import re
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import replace
from functools import partial
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from xface_core.codes import CROSSCHECK_CONVERGE_BY, Outcome
from xface_core.errors import XfaceError, XfaceValueError
from xface_core.facefile import load_face
from xface_core.frames import NotFacingError, check_facing
from xface_core.geometry import FaceDesign, make_face
from xface_core.maps.acceptance import AcceptanceMap, MTable, Progress, acceptance_map, m_table
from xface_core.maps.grids import ThetaGridKind
from xface_core.maps.paper import (
    DEPARTURE_FROM_PAPER,
    PAPER_MEAN_RATIO_XS,
    PAPER_MEAN_RATIO_XV,
    mean_ratio,
    paper_table,
)
from xface_core.physics import DEFAULT_PHYSICS, Physics
from xface_core.predict import predict
from xface_core.runner import MAX_LOCAL_WORKERS, engine_is_cached, xface_version

from .optimize import add_optimize_command
from .progress import ProgressBar, terminal_progress
from .study import (
    EXIT_INTERRUPTED,
    WORKERS_HELP,
    add_study_commands,
    atomic_output,
    json_default,
)

__all__ = ["main"]

#: What to install for the options that record or draw.
_VIZ_HINT = "pip install '.[viz]' in the xface checkout"

#: Options that record or draw: (argument name, option, the module of xface_core.viz it needs).
_VIZ_OPTIONS = (
    ("png", "--png", "mapimage"),
    ("svg", "--svg", "mapimage"),
    ("rrd", "--rrd", "recording"),
)


#: What to install for ``xface crosscheck``.
#: The top package (its name, so that a renamed copy of it, as the side-by-side bench makes,
#: finds its own extras).
_CORE = __name__.partition(".")[0]
_CROSSCHECK_HINT = "pip install '.[crosscheck]' in the xface checkout"


class _VizMissing(Exception):
    """An option needs the viz extra, which is not installed (``args[0]`` names it)."""


class _CrosscheckMissing(Exception):
    """``xface crosscheck`` needs the crosscheck extra, which is not installed."""


def _check_viz(args: argparse.Namespace) -> None:
    """Import the viz modules the chosen options need, before any simulation runs."""
    # draw's pictures: facedraw imports matplotlib only when it draws (its DXF must not need
    # it), so the check imports the module every picture draws through.
    pictures = {"design": "heatmap", "compare": "comparefig", "draw": "figures"}
    needed = [
        (option, pictures.get(args.command, module) if name != "rrd" else module)
        for name, option, module in _VIZ_OPTIONS
        if getattr(args, name, None)
    ]
    if args.command == "bench":  # the bench always draws its work-precision plot
        needed.append(("bench", "benchplot"))
    if args.command == "optimize":  # it draws the best face's maps and outlines
        needed.append(("optimize", "comparefig"))
    for option, module in needed:
        try:
            importlib.import_module(f"{_CORE}.viz.{module}")
        except ImportError as exc:
            if (exc.name or "").partition(".")[0] == _CORE:
                raise  # a bug of ours, not a missing extra
            raise _VizMissing(option) from None


#: Maps with at least this many nodes per axis show a progress bar (a 201 x 201 map takes a
#: few seconds on two cores).
MAP_PROGRESS_GRID = 201


def _chunked(grid: int) -> Progress | None:
    """For a map of ``grid`` nodes per axis without a bar: a progress callback that draws
    nothing, so that a large map runs in chunks (sweep.PROGRESS_CHUNK poses) and Ctrl-C ends
    it between two, instead of after the whole map's engine calls (the rest of 20 s for
    1001 x 1001 here); the map takes as long either way. None for a small map."""
    return (lambda done, total: None) if grid >= MAP_PROGRESS_GRID else None


def _check_workers(args: argparse.Namespace) -> None:
    """``--workers``, where a command has it, counts processes: at least one, at most
    ``MAX_LOCAL_WORKERS`` (the core checks the same; here the message names the flag)."""
    workers = getattr(args, "workers", None)
    # sweep, design and optimize check theirs in the core (run_study, optimize_face).
    if args.command in ("table", "crosscheck") and workers is not None:
        if not 1 <= workers <= MAX_LOCAL_WORKERS:
            raise XfaceValueError(f"--workers must be in [1, {MAX_LOCAL_WORKERS}], got {workers}")


def _check_crosscheck(args: argparse.Namespace) -> None:
    """Import the cross-check (and so pymunk) before anything runs, if the command needs it."""
    if args.command != "crosscheck" and not (args.command == "optimize" and not args.no_crosscheck):
        return
    try:
        importlib.import_module(f"{_CORE}.crosscheck.compare")
    except ImportError as exc:
        if (exc.name or "").partition(".")[0] != "pymunk":
            raise  # a bug of ours, not a missing extra
        raise _CrosscheckMissing from None


#: The format each file option writes: its suffix (which the name must end in, case aside:
#: the format follows the option, and PNG bytes in ``out.jpg`` would mislead every reader)
#: and what it is. ``--out`` (a study's Parquet file, the bench's folder) has no suffix rule.
_OUTPUT_FORMATS = {
    "png": (".png", "a PNG picture"),
    "svg": (".svg", "an SVG picture"),
    "rrd": (".rrd", "a rerun recording"),
    "dxf": (".dxf", "a DXF drawing"),
}


def _shown_name(name: str) -> str:
    """``name`` quoted for a message, its undecodable bytes as ``\\xff`` (the bytes the user
    typed) and a NUL as ``\\0``: text any terminal shows."""
    try:
        raw = os.fsencode(name)
    except UnicodeEncodeError:  # a lone surrogate no decoding made (main() called from Python)
        raw = name.encode("utf-8", "backslashreplace")
    return "'" + raw.decode("utf-8", "backslashreplace").replace("\0", "\\0") + "'"


def _check_output_name(name: str, option: str, *, folder: bool) -> None:
    """Refuse (exit 2, before anything runs) an output name that cannot be written as asked:
    empty, holding NUL or bytes that are not UTF-8 text (pyarrow and the printed summaries
    take text only), or, for a file, ending in a separator (``somedir/`` became a file
    ``somedir``) or in a suffix other than its format's (:data:`_OUTPUT_FORMATS`)."""
    shown = _shown_name(name)
    if not name:
        raise XfaceValueError(f"{option}: the name is empty")
    if "\0" in name:
        raise XfaceValueError(f"{option} {shown}: a name cannot hold a NUL character")
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        raise XfaceValueError(f"{option} {shown}: the name is not UTF-8 text; rename it") from None
    if folder:
        return
    if name.endswith(tuple(sep for sep in (os.sep, os.altsep) if sep)):
        raise XfaceValueError(f"{option} {shown}: ends in a separator (a folder): give a file name")
    suffix, what = _OUTPUT_FORMATS.get(option.removeprefix("--"), (None, ""))
    if suffix is not None and Path(name).suffix.lower() != suffix:
        raise XfaceValueError(f"{option} {shown}: {option} writes {what}: name it *{suffix}")


def _check_output_names(args: argparse.Namespace) -> None:
    """Every file or folder the command will write is named well (:func:`_check_output_name`):
    ``--png``, ``--svg``, ``--rrd``, ``--dxf``, and ``--out`` (a study's Parquet file; the
    bench's folder)."""
    for name in ("png", "svg", "rrd", "dxf", "out"):
        value = getattr(args, name, None)
        if value is not None:
            folder = name == "out" and args.command in ("bench", "optimize")
            _check_output_name(value, f"--{name}", folder=folder)


#: The built-in design the commands default to: the node's (config/xface.yaml).
DEFAULT_H_OVER_D = 0.25
DEFAULT_R_P = 1.0


def _face_args(p: argparse.ArgumentParser) -> None:
    """--face/--h-over-d/--rp, or --face-file (a connector of one's own)."""
    p.add_argument("--face", type=str.upper, choices=("X", "V", "S"), default="X")
    p.add_argument(
        "--h-over-d", type=float, default=DEFAULT_H_OVER_D, help="profile height H / width D"
    )
    p.add_argument(
        "--rp", type=float, default=DEFAULT_R_P, help="pivot to profile base, in widths D"
    )
    p.add_argument(
        "--face-file",
        default=None,
        help="a face file (YAML, docs/facefile.md) instead of --face/--h-over-d/--rp",
    )


def _width_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--width",
        type=float,
        default=None,
        help="face width D (length unit; default 1, or the face file's)",
    )


def _design_args(p: argparse.ArgumentParser) -> None:
    _face_args(p)
    _width_arg(p)
    _physics_args(p)
    p.add_argument("--json", action="store_true", help="machine-readable output")


def _design(args: argparse.Namespace) -> FaceDesign:
    """The command's design: the face file's, or the built-in face (errors exit 2)."""
    if args.face_file is not None:
        design = load_face(args.face_file)
        if getattr(args, "width", None) is not None:
            design = design.with_width(args.width)  # checked: finite and > 0
        return design
    width = getattr(args, "width", None)
    return make_face(args.face, args.h_over_d, args.rp, width=1.0 if width is None else width)


def _design_label(design: FaceDesign, *, width: bool = True) -> str:
    """``X-Face H/D=0.25 r_p=1 D=1``, a face file's design by its name (``lopsided notch
    D=0.05``); without ``D=`` if not ``width``."""
    d = f" D={design.width:g}" if width else ""
    if design.kind == "custom":
        return f"{design.display_name}{d}"
    return f"{design.kind}-Face H/D={design.h_over_d:g} r_p={design.r_p:g}{d}"


def _angle_text(rad: float, spec: str = "+.4g") -> str:
    """An angle for people: radians, the unit of every number xface reads and writes, with
    degrees in brackets (``+0.2 rad (+11.46 deg)``); JSON keeps radians alone."""
    return f"{rad:{spec}} rad ({math.degrees(rad):{spec}} deg)"


def _length_text(
    design: FaceDesign, *values: float, spec: str = ".4g", sep: str = " / ", interval: bool = False
) -> str:
    """Lengths for people, in the design's unit: ``0.2 D`` when D is 1, else ``0.01 / 0.012
    (0.2 / 0.24 D)``: a face file names no unit (its ``width`` is D in the designer's own,
    metres on the node), so the values in that unit are followed by the same in D.
    ``interval``: ``[lo, hi]`` for two ends."""

    def joined(scale: float) -> str:
        text = sep.join(f"{v / scale:{spec}}" for v in values)
        return f"[{text}]" if interval else text

    if design.width == 1.0:
        return f"{joined(1.0)} D"
    return f"{joined(1.0)} ({joined(design.width)} D)"


def _units_line(design: FaceDesign) -> str | None:
    """The line that says what a length means when D is not 1 (None when it is)."""
    if design.width == 1.0:
        return None
    return (
        f"units     lengths in the unit of the width D = {design.width:g} "
        "(the face file's or --width), in D in brackets; angles in rad (deg)"
    )


def _physics_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--damping-ratio", type=float, default=1.0, help="c_B / c_M (inf: base fixed)")
    p.add_argument("--friction", type=float, default=0.0, help="Coulomb coefficient mu (>= 0)")


def _physics(args: argparse.Namespace) -> Physics:
    """The command's physics, validated (an XfaceValueError exits 2 with its message)."""
    return Physics(damping_ratio=args.damping_ratio, friction=args.friction)


def _prediction_json(pred: Any) -> dict[str, Any]:
    out: dict[str, Any] = {
        "outcome": pred.outcome.name,
        "seated": pred.seated,
        "reason": pred.reason,
        "x0": pred.x0,
        "theta0": pred.theta0,
        "y_start": pred.y_start,
        "final": {"phi_b": pred.phi_b, "phi_m": pred.phi_m, "pivot_m": list(pred.pivot_m)},
        "counters": vars(pred.counters),
    }
    if pred.margins is not None:
        m = pred.margins
        out["margins"] = {
            "lateral": m.lateral,
            "angle": m.angle,
            "lateral_minus": m.lateral_minus,
            "lateral_plus": m.lateral_plus,
            "angle_minus": m.angle_minus,
            "angle_plus": m.angle_plus,
        }
    if pred.path is not None:
        path = pred.path
        out["path"] = {
            "samples": len(path),
            "descent": path.descent.tolist(),
            "phi_b": path.phi_b.tolist(),
            "phi_m": path.phi_m.tolist(),
            "y_m": path.pivot_m[:, 1].tolist(),
            "phase": path.phase.tolist(),
        }
    return out


def _cmd_predict(args: argparse.Namespace) -> int:
    try:
        check_facing(args.theta0)
    except NotFacingError as exc:  # the ROS node's not_facing input error, same reason
        print(f"xface: {Outcome.INVALID_INPUT.name}: {exc}", file=sys.stderr)
        return 2
    physics = _physics(args)
    design = _design(args)
    pose = {"x0": args.x0, "theta0": args.theta0, "y_start": args.y_start, "physics": physics}
    pred = predict(design, **pose, margins=False)
    if pred.outcome is Outcome.INVALID_INPUT:
        # Nothing was simulated: no margins, and the exit code says the input was refused.
        if args.json:
            print(json.dumps(_prediction_json(pred), default=json_default))
        print(f"xface: {Outcome.INVALID_INPUT.name}: {pred.reason}", file=sys.stderr)
        return 2
    if not args.no_margins:
        pred = predict(design, **pose, margins=True)
    uncertainty = _pose_uncertainty(args, design, physics)
    if args.rrd:
        from xface_core.viz.recording import log_prediction, new_recording

        with atomic_output(args.rrd, "the recording") as aside:
            rec = new_recording(path=aside)
            log_prediction(rec, pred)
            rec.flush()
            rec.disconnect()
    if args.json:
        out = _prediction_json(pred)
        if uncertainty is not None:
            out["uncertainty"] = uncertainty
        print(json.dumps(out, default=json_default))
        return 0
    print(_design_label(design))
    units = _units_line(design)
    if units is not None:
        print(units)
    y_text = _length_text(design, pred.y_start, spec=".6g")
    print(
        f"start     x0={_length_text(design, pred.x0, spec='+.6g')}  "
        f"theta0={_angle_text(pred.theta0, '+.6g')}  y={y_text}"
    )
    print(f"outcome   {pred.outcome.name}: {pred.reason}")
    print(
        f"final     phi_b={_angle_text(pred.phi_b, '+.6f')}  "
        f"phi_m={_angle_text(pred.phi_m, '+.6f')}  "
        f"pivot_m=({pred.pivot_m[0]:+.6g}, {pred.pivot_m[1]:.6g})"
    )
    if pred.margins is not None:
        m = pred.margins
        lateral = _length_text(design, -m.lateral_minus, m.lateral_plus, spec="+.4g")
        print(
            f"margins   lateral {lateral}   "
            f"angle -{m.angle_minus:.4g} / +{m.angle_plus:.4g} rad "
            f"(-{math.degrees(m.angle_minus):.4g} / +{math.degrees(m.angle_plus):.4g} deg)"
        )
    if uncertainty is not None:
        u = uncertainty
        sigma_x = _length_text(design, u["sigma_x"], spec="g")
        print(
            f"P(seat)   {u['seat_probability']:.4f} for sigma_x {sigma_x}, "
            f"sigma_theta {_angle_text(u['sigma_theta'], 'g')}"
        )
        if u["suggestion"] is None:
            print(f"suggest   nothing: P(seat) already >= {u['level']:g}")
        elif u["suggestion"]["reached"]:
            g = u["suggestion"]
            print(
                f"suggest   dx {_length_text(design, g['dx'], spec='+.4g')}, "
                f"dtheta {_angle_text(g['dtheta'])} "
                f"({g['distance']:.3g} sigma) -> P(seat) {g['seat_probability']:.4f}"
            )
        else:
            print(f"suggest   no correction reaches P(seat) >= {u['level']:g}")
    c = pred.counters
    path = pred.path
    # In the order the path goes through them (a phase met twice is named once).
    phases = "" if path is None else ", ".join(dict.fromkeys(_phase_name(p) for p in path.phase))
    print(
        f"path      {0 if path is None else len(path)} samples, {c.steps} steps, "
        f"{c.events} events, {c.contact_changes} contact changes; phases: {phases}"
    )
    return 0


def _pose_uncertainty(
    args: argparse.Namespace, design: FaceDesign, physics: Physics
) -> dict[str, Any] | None:
    """With ``--sigma-x``/``--sigma-theta``: the seat probability under that pose noise and
    the correction that brings it to ``--level`` (None without them)."""
    if args.sigma_x is None and args.sigma_theta is None:
        return None
    from xface_core.atlas.approach import suggest_approach
    from xface_core.atlas.build import build_atlas
    from xface_core.atlas.probability import seat_probability

    sx = 0.0 if args.sigma_x is None else args.sigma_x
    st = 0.0 if args.sigma_theta is None else args.sigma_theta
    if not (math.isfinite(sx) and math.isfinite(st) and sx >= 0.0 and st >= 0.0):
        raise XfaceValueError("--sigma-x and --sigma-theta must be finite and >= 0")
    if not 0.0 < args.level < 1.0:
        raise XfaceValueError(f"--level must be in (0, 1), got {args.level}")
    if not (math.isfinite(sx * sx) and math.isfinite(st * st)):
        raise XfaceValueError(
            f"--sigma-x {sx:g} and --sigma-theta {st:g}: their squares (the covariance) "
            "overflow; at most about 1e150"
        )
    cov = [[sx * sx, 0.0], [0.0, st * st]]
    # One atlas for both questions (each would otherwise build its own: seconds).
    atlas = build_atlas(design, physics=physics)
    p = float(seat_probability(design, args.x0, args.theta0, cov, physics=physics, atlas=atlas))
    out: dict[str, Any] = {
        "sigma_x": sx,
        "sigma_theta": st,
        "seat_probability": p,
        "level": args.level,
        "suggestion": None,
    }
    if p < args.level:
        g = suggest_approach(
            design, args.x0, args.theta0, cov, level=args.level, physics=physics, atlas=atlas,
            probability=p,
        )  # fmt: skip
        out["suggestion"] = {
            "dx": g.dx,
            "dtheta": g.dtheta,
            "distance": g.distance,
            "metric": g.metric,
            "reached": g.reached,
            "seat_probability": g.seat_probability,
        }
    return out


def _phase_name(code: int) -> str:
    from xface_core.result import Phase

    return Phase(int(code)).name.lower()


def _map_json(amap: AcceptanceMap) -> dict[str, Any]:
    names = np.array([o.name for o in Outcome])
    return {
        "face": amap.design.kind,
        "label": _design_label(amap.design),  # a face file's design by its name
        "h_over_d": amap.design.h_over_d,
        "r_p": amap.design.r_p,
        "width": amap.design.width,
        "x0": amap.x0.tolist(),
        "theta0": amap.theta0.tolist(),
        "outcomes": names[amap.outcomes].tolist(),
        "M": amap.M,
        "counts": {o.name: n for o, n in amap.counts().items()},
        "guaranteed": _rect_json(amap, amap.guaranteed),
        "guaranteed_centred": _rect_json(amap, amap.centred),
    }


def _rect_json(amap: AcceptanceMap, rect: Any) -> dict[str, Any] | None:
    extent = amap.region_extent(rect)
    if extent is None:
        return None
    rows, cols = rect
    return {
        "rows": [rows.start, rows.stop],
        "cols": [cols.start, cols.stop],
        "cells": len(rows) * len(cols),
        "x0": [extent[0], extent[1]],
        "theta0": [extent[2], extent[3]],
    }


def _cmd_map(args: argparse.Namespace) -> int:
    physics = _physics(args)
    design = _design(args)
    quiet = args.quiet or args.grid < MAP_PROGRESS_GRID
    with terminal_progress(quiet, partial(ProgressBar, label="map", unit="poses")) as bar:
        amap = acceptance_map(
            design,
            grid=args.grid,
            theta_kind=args.theta_grid,
            physics=physics,
            coarse=args.coarse,
            progress=_chunked(args.grid) if bar is None else bar.step,
        )
    if args.png or args.svg:
        from xface_core.viz.mapimage import save_map_picture

        for target, fmt in ((args.png, "png"), (args.svg, "svg")):
            if target:
                with atomic_output(target, "the picture") as aside:
                    save_map_picture(amap, aside, fmt=fmt)  # type: ignore[arg-type]
    if args.rrd:
        from xface_core.viz.recording import default_blueprint, log_acceptance_map, new_recording

        with atomic_output(args.rrd, "the recording") as aside:
            # Its own application id: the viewer keeps one layout per id, so a map opens on
            # the map tab even in a viewer that showed predictions.
            rec = new_recording(
                application_id="xface-map", path=aside, blueprint=default_blueprint(active="map")
            )
            log_acceptance_map(rec, amap)
            rec.flush()
            rec.disconnect()
    if args.json:
        print(json.dumps(_map_json(amap)))
        return 0
    symbols = {
        Outcome.SEATED: "#",
        Outcome.BAD_MATE: ".",
        Outcome.PASSED: "p",
        Outcome.NO_CONTACT: "n",
        Outcome.OUT_OF_REACH: "o",
        Outcome.INVALID_INPUT: "!",
        Outcome.UNRESOLVED: "?",
    }
    print(
        f"{_design_label(design)}: M = {amap.M} of {amap.outcomes.size}  (rows x0 from "
        f"{_length_text(design, amap.x0[-1], spec='g')} down to {amap.x0[0]:g}, columns theta0 "
        f"from {_angle_text(amap.theta0[0])} to {_angle_text(amap.theta0[-1])})"
    )
    # Largest x0 on top, as in the PNG picture (x0 up, theta0 to the right).
    for i in range(len(amap.x0) - 1, -1, -1):
        row = amap.outcomes[i]
        print(f"{amap.x0[i]:+8.4f} " + "".join(symbols[Outcome(int(c))] for c in row))
    print("legend: " + "  ".join(f"{s} {o.name}" for o, s in symbols.items()))
    for label, rect in (("guaranteed", amap.guaranteed), ("centred", amap.centred)):
        ext = amap.region_extent(rect)
        if ext is None:
            print(f"{label}: none")
        else:
            rows, cols = rect  # type: ignore[misc]
            x_range = _length_text(design, ext[0], ext[1], spec="+.4g", sep=", ", interval=True)
            print(
                f"{label}: x0 in {x_range}, "
                f"theta0 in [{ext[2]:+.4f}, {ext[3]:+.4f}] rad ([{math.degrees(ext[2]):+.4g}, "
                f"{math.degrees(ext[3]):+.4g}] deg) ({len(rows)} x {len(cols)} cells)"
            )
    return 0


def _compare_args(p: argparse.ArgumentParser) -> None:
    """Design B of ``xface compare``: each --vs-* option replaces A's value, the rest is A's."""
    p.add_argument("--vs-face", type=str.upper, choices=("X", "V", "S"), default=None)
    p.add_argument("--vs-h-over-d", type=float, default=None, help="B's H/D (default: A's)")
    p.add_argument("--vs-rp", type=float, default=None, help="B's r_p in D (default: A's)")
    p.add_argument("--vs-face-file", default=None, help="B's face file (default: A's face)")
    p.add_argument("--vs-damping-ratio", type=float, default=None, help="B's c_B / c_M")
    p.add_argument("--vs-friction", type=float, default=None, help="B's Coulomb mu")
    p.add_argument("--grid", type=int, default=41, help="nodes per axis (odd)")
    p.add_argument("--theta-grid", choices=("symmetric", "paper"), default="symmetric")
    p.add_argument("--png", default=None, help="write A, B and the difference map as PNG")
    p.add_argument("--svg", default=None, help="the same picture as SVG")


#: What a --vs-* option of ``xface compare`` replaces in design B (``--vs-h-over-d``: h_over_d).
_VS_NAMES = ("face", "h_over_d", "rp", "face_file", "damping_ratio", "friction")


def _check_compare(args: argparse.Namespace) -> None:
    """``xface compare`` without a --vs-* option would compare a design with itself: refused
    (exit 2), before either map runs."""
    if args.command == "compare" and all(getattr(args, f"vs_{n}") is None for n in _VS_NAMES):
        options = ", ".join("--vs-" + n.replace("_", "-") for n in _VS_NAMES)
        raise XfaceValueError(
            f"compare needs a design B that differs from A: give at least one of {options}"
        )


def _compare_b(args: argparse.Namespace) -> argparse.Namespace:
    """The arguments of design B: A's, with every --vs-* option given put in."""
    b = argparse.Namespace(**vars(args))
    for name in _VS_NAMES:
        value = getattr(args, f"vs_{name}")
        if value is not None:
            setattr(b, name, value)
    if args.vs_face_file is None and (
        args.vs_face is not None or args.vs_h_over_d is not None or args.vs_rp is not None
    ):
        b.face_file = None  # B is a built-in face even when A is read from a file
    return b


def _widths_note(a: FaceDesign, b: FaceDesign) -> str | None:
    """When A and B differ in width: the line that says how they are compared (cell by cell
    at the same x0 / D, each map over its own -D..D), and how to compare at one width."""
    if a.width == b.width:
        return None
    return (
        f"widths   A D={a.width:g}, B D={b.width:g}: compared in units of D (the same x0 / D "
        "per cell, each map from -D to D); --width W gives both the width W"
    )


def _cmd_compare(args: argparse.Namespace) -> int:
    from xface_core.viz.mapdiff import SeatedIn, map_difference

    b_args = _compare_b(args)
    sides = [(args, _physics(args), _design(args)), (b_args, _physics(b_args), _design(b_args))]
    maps = [
        acceptance_map(
            design,
            grid=args.grid,
            theta_kind=args.theta_grid,
            physics=physics,
            progress=_chunked(args.grid),
        )
        for _, physics, design in sides
    ]
    diff = map_difference(maps[0], maps[1])
    labels = [
        f"{_design_label(d)}, damping ratio {ph.damping_ratio:g}, friction {ph.friction:g}"
        for _, ph, d in sides
    ]
    if args.png or args.svg:
        from xface_core.viz.comparefig import save_comparison
        from xface_core.viz.mapimage import design_title

        # The panels name the physics when it is not the paper's: a comparison with and
        # without friction would otherwise show two identical titles.
        widths_differ = sides[0][2].width != sides[1][2].width
        titles = [
            design_title(d)
            + (f", D = {d.width:g}" if widths_differ else "")
            + (f", friction {ph.friction:g}" if ph.friction else "")
            + (f", c_B/c_M {ph.damping_ratio:g}" if ph.damping_ratio != 1.0 else "")
            for _, ph, d in sides
        ]
        for target, fmt in ((args.png, "png"), (args.svg, "svg")):
            if target:
                with atomic_output(target, "the picture") as aside:
                    save_comparison(maps[0], maps[1], aside, labels=(titles[0], titles[1]), fmt=fmt)  # type: ignore[arg-type]
    counts = {
        "both": diff.count(SeatedIn.BOTH),
        "only_a": diff.count(SeatedIn.ONLY_A),
        "only_b": diff.count(SeatedIn.ONLY_B),
        "neither": diff.count(SeatedIn.NEITHER),
    }
    if args.json:
        # Each map without its grid: the counts, M and regions are the comparison.
        summary = [
            {k: v for k, v in _map_json(amap).items() if k not in ("x0", "theta0", "outcomes")}
            for amap in maps
        ]
        out = {
            "a": {**summary[0], "label": labels[0]},
            "b": {**summary[1], "label": labels[1]},
            "seated": counts,
            "same_outcome": diff.same_outcome,
        }
        print(json.dumps(out))
        return 0
    cells = maps[0].outcomes.size
    print(f"A  {labels[0]}: M = {diff.M_a} of {cells}")
    print(f"B  {labels[1]}: M = {diff.M_b} of {cells}")
    widths = _widths_note(sides[0][2], sides[1][2])
    if widths is not None:
        print(widths)
    print(
        f"seated in both {counts['both']}, only in A {counts['only_a']}, only in B "
        f"{counts['only_b']}, in neither {counts['neither']}; same outcome in "
        f"{diff.same_outcome} of {cells} cells"
    )
    return 0


def _table_for(
    face: str, args: argparse.Namespace, physics: Physics, progress: Progress | None
) -> MTable:
    method = args.method
    if method == "bound" and face == "X":
        method = "sim"  # the X-Face has no closed-form bound; the paper simulated it
    theta: ThetaGridKind = args.theta_grid or ("paper" if method == "bound" else "symmetric")
    return m_table(
        face,
        method=method,
        theta_kind=theta,
        physics=physics,
        workers=args.workers,
        progress=progress,
    )


def _cmd_table(args: argparse.Namespace) -> int:
    physics = _physics(args)
    if args.method == "bound" and physics != DEFAULT_PHYSICS:
        raise XfaceValueError(
            "the closed-form bound assumes the paper's physics: --damping-ratio and --friction "
            "apply to --method sim"
        )
    faces = ["X", "V", "S"] if args.face == "ALL" else [args.face]
    tables = {}
    for f in faces:
        quiet = args.quiet or args.method != "sim"  # the bound is closed-form: instant
        bar_kind = partial(ProgressBar, label=f"{f}-Face table")
        with terminal_progress(quiet, bar_kind) as bar:
            tables[f] = _table_for(f, args, physics, None if bar is None else bar.step)
    if args.json:
        out = {
            f: {
                "face": f,
                "method": t.method,
                "theta_grid": t.theta_kind,
                "h_over_d": t.h_over_d.tolist(),
                "r_p": t.r_p.tolist(),
                "M": t.M.tolist(),
            }
            for f, t in tables.items()
        }
        print(json.dumps(out[faces[0]] if len(faces) == 1 else out))
        return 0
    for f, t in tables.items():
        paper = paper_table(f).M  # type: ignore[arg-type]
        print(
            f"M({f}-Face), {t.method} on the {t.theta_kind} theta grid: "
            "ours / paper (difference); rows H/D, columns r_p"
        )
        print("H/D      " + "".join(f"{int(r):>16d}" for r in t.r_p))
        for i, h in enumerate(t.h_over_d):
            cells = []
            for j in range(len(t.r_p)):
                ours = int(t.M[i, j])
                ref = paper[i, j]
                cells.append(
                    f"{ours:>6d}/   --     "
                    if not np.isfinite(ref)
                    else f"{ours:>6d}/{int(ref):<4d}({ours - int(ref):+4d})"
                )
            print(f"{h:<8g} " + "".join(f"{c:>16s}" for c in cells))
        known = np.isfinite(paper)
        same = int(np.count_nonzero(t.M[known] == paper[known]))
        diff = np.abs(t.M[known] - paper[known])
        print(
            f"cells equal to the paper: {same} of {int(known.sum())}; "
            f"max |dM| {int(diff.max())}, mean |dM| {diff.mean():.1f}\n"
        )
    if "X" in tables:
        x = tables["X"].M.astype(float)
        for other, paper_ratio in (("V", PAPER_MEAN_RATIO_XV), ("S", PAPER_MEAN_RATIO_XS)):
            if other in tables:
                ratio = mean_ratio(x, tables[other].M.astype(float))
                print(f"mean X/{other} ratio: {ratio:.4f} (paper {paper_ratio})")
    if any(t.method == "sim" for t in tables.values()):
        print(f"xface {DEPARTURE_FROM_PAPER}")
    return 0


def _crosscheck_cells(args: argparse.Namespace) -> list[tuple[float, float]] | None:
    if args.seed < 0:  # numpy's generators take none (a ValueError from deep inside)
        raise XfaceValueError(f"--seed must be >= 0, got {args.seed}")
    if args.cells is None:
        return None
    if args.cells < 1:
        raise XfaceValueError(f"--cells must be >= 1, got {args.cells}")
    from xface_core.crosscheck.compare import random_cells

    x0, theta0 = random_cells(args.cells, seed=args.seed)
    return list(zip(x0.tolist(), theta0.tolist(), strict=True))


def _cmd_crosscheck(args: argparse.Namespace) -> int:
    from xface_core.crosscheck.compare import crosscheck, result_json, stderr_progress
    from xface_core.crosscheck.scene import DEFAULT_ENGINE

    physics = _physics(args)
    design = _design(args)
    if args.grid is not None and args.grid < 3:
        raise XfaceValueError(f"--grid must be an odd integer >= 3, got {args.grid}")
    if args.converge_by != "grid" and not args.converged:
        raise XfaceValueError(f"--converge-by {args.converge_by} needs --converged")
    settings = DEFAULT_ENGINE
    if args.step is not None:
        # The slop keeps its ratio to the step (docs/crosscheck.md: step / slop = 100).
        ratio = DEFAULT_ENGINE.step / DEFAULT_ENGINE.slop
        settings = replace(DEFAULT_ENGINE, step=args.step, slop=args.step / ratio)
    result = crosscheck(
        design,
        physics,
        grid=41 if args.grid is None else args.grid,
        cells=_crosscheck_cells(args),
        settings=settings,
        converged=args.converged,
        converge_by=args.converge_by,
        workers=args.workers,
        progress=None if args.quiet else stderr_progress,
    )
    if args.json:
        print(json.dumps(result_json(result), default=json_default))
        return 0
    for line in _crosscheck_lines(result):
        print(line)
    return 0


def _crosscheck_lines(r: Any) -> list[str]:
    """The plain-text report of a :class:`~xface_core.crosscheck.CrosscheckResult`."""
    d, s = r.design, r.settings
    where = f"{r.grid} x {r.grid} grid" if r.grid is not None else "random cells"
    conv = {None: "", True: ", converged", False: ", NOT converged"}[r.converged]
    lines = [
        (
            f"crosscheck {_design_label(d, width=False)} "
            f"(damping ratio {r.physics.damping_ratio:g}, friction {r.physics.friction:g}): "
            f"{r.n_cells} cells ({where}), {r.seconds:.0f} s"
        ),
        (
            f"engine    Chipmunk2D, step {s.step:g} D{conv}, slop {s.slop:g} D, "
            f"sharp and {r.rounding:g} D rounded corners"
        ),
    ]
    only = " (only the cells the halving before changed)" if r.converge_by == "cells" else ""
    for n, (step, changed) in enumerate(r.step_history):
        lines.append(
            f"          step (and slop) halved to {step:g} D: {changed} cells changed"
            + (only if n else "")
        )
    if r.stall_changes is not None:
        lines.append(
            f"          jams run again at 1/100 of the stall speed: {r.stall_changes} cells changed"
        )
    if r.knife_edges is not None:
        lines.append(
            f"          disagreements whose engine answer flips within {r.rounding:g} D of x0: "
            f"{r.knife_edges} (counted ambiguous)"
        )
    m_xface, m_engine, m_rounded = r.m_values()
    lines += [
        (
            f"agreement {100 * r.agreement:.2f} % of {r.n_unambiguous} unambiguous cells "
            f"(SEATED or not); exact outcome {100 * r.outcome_agreement:.2f} %"
        ),
        f"ambiguous {r.n_ambiguous} (sharp and rounded corners disagree, budget, or unconverged)",
        f"false SEATED {r.false_seated}   false failures {r.false_failures}",
        f"M         xface {m_xface}, engine {m_engine} sharp / {m_rounded} rounded",
    ]
    if r.disagreements:
        lines.append("disagreements: x0 (D), theta0 (rad); final phi_b, phi_m (rad), y_m (D)")
    for g in r.disagreements:
        x, e = g.xface, g.engine
        lines.append(
            f"  x0={g.x0:+.4f} theta0={g.theta0:+.4f}  {g.kind}: "
            f"xface {x.outcome.name} ({x.phi_b:+.3f}, {x.phi_m:+.3f}, {x.y_m:.3f}) | "
            f"engine {e.outcome.name} ({e.phi_b:+.3f}, {e.phi_m:+.3f}, {e.y_m:.3f}) {e.reason}"
        )
    return lines


#: What to install for ``xface draw --dxf``.
_CAD_HINT = "pip install '.[cad]' in the xface checkout"


def _cmd_draw(args: argparse.Namespace) -> int:
    """``xface draw``: the design's outlines as pictures and a DXF (docs/recording.md)."""
    if not (args.png or args.svg or args.dxf):
        raise XfaceValueError("draw needs at least one of --png, --svg, --dxf")
    if (args.x0 is None) != (args.theta0 is None):
        raise XfaceValueError("draw: give both --x0 and --theta0 (a start pose), or neither")
    if args.dxf:
        try:
            importlib.import_module(f"{_CORE}.viz.facecad")
        except ImportError as exc:
            if (exc.name or "").partition(".")[0] != "ezdxf":
                raise  # a bug of ours, not a missing extra
            _say(f"xface: --dxf needs the cad extra: {_CAD_HINT}")
            return 2
    from xface_core.viz.facedraw import face_drawing, save_face_picture

    design = _design(args)  # a face file's design carries its name (FaceDesign.name)
    pose = None if args.x0 is None else (args.x0, args.theta0)
    drawing = face_drawing(design, pose=pose)
    writers: dict[str, tuple[str, Callable[[str], object]]] = {
        "png": ("the picture", partial(save_face_picture, drawing, fmt="png")),
        "svg": ("the picture", partial(save_face_picture, drawing, fmt="svg")),
    }
    if args.dxf:
        from xface_core.viz.facecad import save_face_dxf

        writers["dxf"] = ("the drawing", partial(save_face_dxf, drawing))
    for option, (what, write) in writers.items():
        target = getattr(args, option)
        if target:
            with atomic_output(target, what) as aside:
                write(aside)
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from .bench import run_bench

    return run_bench(args)


def version_text() -> str:
    """``xface <version>`` and ``engine: <state>`` (ready, or compiles on first use, and how
    long): the two things a first run depends on. Reads numba's cache and the install; it
    neither simulates nor imports an extra."""
    from xface_core.runner import engine_state  # only here: every other run would pay for the look

    return f"xface {xface_version()}\nengine: {engine_state().describe()}"


class _VersionAction(argparse.Action):
    """``--version``: print :func:`version_text` and exit 0, without a subcommand."""

    def __init__(self, option_strings: Sequence[str], dest: str, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(version_text(), flush=True)  # flushed here: a dead pipe shows inside main
        parser.exit(0)


#: An argument that is a number, not an option, although it starts with ``-``: every spelling
#: of a negative float (``-1``, ``-.5``, ``-1e-3``, ``-2.5E+2``, ``-inf``, ``-nan``), or a comma
#: list of numbers starting with one (``--h-over-d -0.5,1`` of sweep, refused by its own check).
#: argparse's own pattern takes only ``-1`` and ``-.5``, so that ``--x0 -1e-3`` was "expected
#: one argument" while ``--x0=-1e-3`` worked.
_NUMBER = r"(?:(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?|inf(?:inity)?|nan)"
NEGATIVE_NUMBER = re.compile(rf"^-{_NUMBER}(?:\s*,\s*[-+]?{_NUMBER})*$", re.IGNORECASE)


class _Parser(argparse.ArgumentParser):
    """argparse's parser with two changes, which every subcommand's parser has too
    (``add_subparsers`` makes them of the parent's class):

    - a value that is a negative number in any spelling (:data:`NEGATIVE_NUMBER`) is a value,
      not an unknown option: argparse decides this with ``_negative_number_matcher`` alone
      (no option of xface looks like a number, so nothing else changes);
    - its messages (usage errors, help) reach a stream that cannot encode every character
      (a closed stderr's stand-in, a strict one) with those characters escaped, not as a
      UnicodeEncodeError: ``unrecognized arguments`` quotes the user's bytes as they are."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def _print_message(self, message: str, file: Any = None) -> None:
        stream = sys.stderr if file is None else file
        super()._print_message(_escaped(message, stream), stream)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``xface`` (exposed for the docs and the tests)."""
    parser = _Parser(prog="xface", description="Predict passive docking of planar connector faces.")
    parser.add_argument(
        "--version",
        action=_VersionAction,
        help="the installed version, and whether the first simulation compiles the engine",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("predict", help="predict one dock: outcome, reason, margins, path")
    _design_args(p)
    p.add_argument("--x0", type=float, required=True, help="lateral offset (length)")
    p.add_argument("--theta0", type=float, required=True, help="initial angle (rad)")
    p.add_argument("--y-start", type=float, default=None, help="start height (length)")
    p.add_argument("--no-margins", action="store_true", help="skip the margin search")
    p.add_argument(
        "--sigma-x", type=float, default=None, help="pose noise: std of x0 (length); prints P(seat)"
    )
    p.add_argument(
        "--sigma-theta", type=float, default=None, help="pose noise: std of theta0 (rad)"
    )
    p.add_argument(
        "--level", type=float, default=0.9, help="P(seat) a suggested correction reaches"
    )
    p.add_argument("--rrd", default=None, help="write a rerun recording to this file")
    p.set_defaults(func=_cmd_predict)

    p = sub.add_parser("map", help="acceptance map of one design over a grid")
    _design_args(p)
    p.add_argument("--grid", type=int, default=41, help="nodes per axis (odd)")
    p.add_argument("--theta-grid", choices=("symmetric", "paper"), default="symmetric")
    p.add_argument(
        "--coarse",
        type=int,
        default=None,
        help="boundary-following refinement from this coarse grid (odd, divides the grid)",
    )
    p.add_argument("--png", default=None, help="write a PNG picture of the map")
    p.add_argument("--svg", default=None, help="write an SVG picture of the map")
    p.add_argument("--rrd", default=None, help="write a rerun recording of the map")
    p.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
    p.set_defaults(func=_cmd_map)

    p = sub.add_parser(
        "compare", help="two designs' acceptance maps: where each seats, side by side"
    )
    _design_args(p)
    _compare_args(p)
    p.set_defaults(func=_cmd_compare)

    p = sub.add_parser("table", help="the paper's M tables (rows H/D, columns r_p)")
    p.add_argument("--face", type=str.upper, choices=("X", "V", "S", "ALL"), default="ALL")
    p.add_argument("--method", choices=("sim", "bound"), default="sim")
    p.add_argument(
        "--theta-grid",
        choices=("symmetric", "paper"),
        default=None,
        help="default: paper for bounds, symmetric for simulations",
    )
    _physics_args(p)
    p.add_argument("--workers", type=int, default=None, help=WORKERS_HELP.format(what="processes"))
    p.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_table)

    p = sub.add_parser(
        "crosscheck", help="compare xface with an independent engine (Chipmunk2D), cell by cell"
    )
    _face_args(p)
    _physics_args(p)
    cells = p.add_mutually_exclusive_group()
    cells.add_argument("--grid", type=int, default=None, help="nodes per axis (odd; default 41)")
    cells.add_argument("--cells", type=int, default=None, help="this many random cells")
    p.add_argument("--seed", type=int, default=0, help="seed of the random cells")
    p.add_argument(
        "--step", type=float, default=None, help="engine step (D of free descent; slop = step/100)"
    )
    p.add_argument(
        "--converged", action="store_true", help="halve the step until the map stops changing"
    )
    p.add_argument(
        "--converge-by", choices=CROSSCHECK_CONVERGE_BY, default="grid",
        help="with --converged: each halving runs every cell (grid) or only the cells the "
        "halving before changed (cells: faster)",
    )  # fmt: skip
    p.add_argument("--workers", type=int, default=None, help=WORKERS_HELP.format(what="processes"))
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=_cmd_crosscheck)

    p = sub.add_parser(
        "draw", help="draw a design's two parts, mated and at a start pose (PNG, SVG, DXF)"
    )
    _face_args(p)
    _width_arg(p)
    p.add_argument("--x0", type=float, default=None, help="start pose: lateral offset (length)")
    p.add_argument("--theta0", type=float, default=None, help="start pose: initial angle (rad)")
    p.add_argument("--png", default=None, help="write the drawing as a PNG picture")
    p.add_argument("--svg", default=None, help="write the drawing as an SVG picture")
    p.add_argument("--dxf", default=None, help="write the outlines as a DXF drawing (cad extra)")
    p.set_defaults(func=_cmd_draw)

    add_study_commands(sub)
    add_optimize_command(sub)

    p = sub.add_parser("bench", help="work-precision benchmark and stress summary")
    p.add_argument("--out", default="bench", help="output folder for the table and plot")
    p.add_argument("--quick", action="store_true", help="fewer designs and settings")
    p.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
    p.set_defaults(func=_cmd_bench)
    return parser


#: Said on a terminal before a run that compiles the simulator (runner.engine_is_cached).
COMPILING_NOTICE = (
    "xface: compiling the simulator first (once per install: 1-2 minutes on 2 cores; "
    "later runs load it from numba's cache)"
)


def _say_if_compiling(args: argparse.Namespace) -> None:
    """On a terminal, say that this run compiles the simulator before it answers, when
    numba's cache holds none of it (a fresh install: the first ``xface predict`` took 99 s,
    silent, on this 2-core machine). Not with ``--quiet``, nor for the paper's bound."""
    if getattr(args, "quiet", False) or getattr(args, "method", "sim") == "bound":
        return
    if sys.stderr.isatty() and not engine_is_cached():
        print(COMPILING_NOTICE, file=sys.stderr, flush=True)


def _descriptor_closed(fd: int) -> bool:
    try:
        os.fstat(fd)
    except OSError:
        return True
    return False


def _to_devnull(fd: int) -> None:
    """Point descriptor ``fd`` at /dev/null: what is still buffered for it, and Python's own
    flush at exit, then go nowhere instead of failing (exit 120 and an 'Exception ignored'
    message after the run's end)."""
    null = os.open(os.devnull, os.O_WRONLY)
    if null != fd:
        os.dup2(null, fd)
        os.close(null)


def _null_closed_streams() -> bool:
    """Make a closed stdout or stderr (``>&-``, ``2>&-``) a stream to /dev/null, and say
    whether stdout was closed. Python starts with ``sys.stderr`` None then, and
    ``print(file=None)`` writes to stdout; the descriptor gets /dev/null before anything
    opens a file that would take its number (a recording that would receive rerun's
    warnings)."""
    lost = set()
    for fd, name in ((1, "stdout"), (2, "stderr")):
        closed = _descriptor_closed(fd)
        if closed:
            _to_devnull(fd)
        if closed or getattr(sys, name) is None:
            # Escaping as Python's stderr does: a message quoting undecodable bytes must not
            # raise here, where nobody would see why the exit code is 1.
            stand_in = open(os.devnull, "w", errors="backslashreplace")  # noqa: SIM115 (open until exit)
            setattr(sys, name, stand_in)
            lost.add(name)
    return "stdout" in lost


def _escaped(text: str, stream: object) -> str:
    """``text`` as ``stream`` can encode it: what its encoding cannot hold (the undecodable
    bytes of a name, as surrogates) as backslash escapes, the way Python's own stderr writes
    them."""
    encoding = getattr(stream, "encoding", None) or "utf-8"
    try:
        return text.encode(encoding, "backslashreplace").decode(encoding)
    except LookupError:  # a stream naming an encoding Python does not know
        return text.encode("ascii", "backslashreplace").decode("ascii")


def _one_line(message: str) -> str:
    """``message`` on one line: its lines joined by a space, stripped, without the lines that
    only point with carets (YAML's ``^`` under a column), so that an error quoting a parser's
    report (a face file's syntax error) is still the one ``xface: error:`` line."""
    lines = (line.strip() for line in message.splitlines())
    return " ".join(line for line in lines if line.strip("^"))


def _say(line: str) -> None:
    """``line`` on stderr, escaped as it can take it; a stderr that cannot take it at all (a
    dead pipe, a closed file) goes to /dev/null, so that neither this nor Python's flush at
    exit turns the run's end into a traceback."""
    try:
        print(_escaped(line, sys.stderr), file=sys.stderr, flush=True)
    except (OSError, ValueError):
        _to_devnull(2)


class _Interrupt:
    """Whether SIGINT arrived during :func:`main`."""

    seen = False


@contextlib.contextmanager
def _sigint_raises() -> Iterator[_Interrupt]:
    """For the block, SIGINT raises KeyboardInterrupt in this process and is remembered: an
    error that follows it (numba interrupted while compiling raises RuntimeError) is the
    interrupt's doing, not a bug to show. Left as it is when SIGINT is ignored (a background
    job of a shell without job control) or handled by someone else.

    A process forked meanwhile inherits the handler and there ignores the interrupt, which a
    terminal sends to the whole group: m_table's pool workers would each print a traceback,
    and one that exits breaks the pool, whose manager thread then races the futures being
    cancelled (InvalidStateError, 1 Ctrl-C in 5). They finish the maps handed to them (a
    second here) while the pool shuts down. An interrupt raised where Python swallows
    exceptions (the at-fork callbacks while a pool starts: "Exception ignored in
    _releaseLock", and the table ran on to its end, 1 Ctrl-C in 5 at that moment) is raised
    again 50 ms later, by SIGALRM, until it lands where it propagates."""
    interrupt = _Interrupt()
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
        or signal.getsignal(signal.SIGALRM) != signal.SIG_DFL
    ):
        yield interrupt
        return
    owner = os.getpid()

    def on_sigint(signum: int, frame: FrameType | None) -> None:
        if os.getpid() != owner:
            return  # a forked worker: its main process decides
        interrupt.seen = True
        raise KeyboardInterrupt

    def on_unraisable(unraisable: sys.UnraisableHookArgs) -> None:
        if issubclass(unraisable.exc_type, KeyboardInterrupt) and os.getpid() == owner:
            signal.setitimer(signal.ITIMER_REAL, 0.05)  # not now: still in the callbacks
            return
        previous_hook(unraisable)

    previous_hook = sys.unraisablehook
    signal.signal(signal.SIGINT, on_sigint)
    signal.signal(signal.SIGALRM, on_sigint)
    sys.unraisablehook = on_unraisable
    try:
        yield interrupt
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        sys.unraisablehook = previous_hook


def _child_pids() -> set[int]:
    """This process's children: multiprocessing's and, on Linux, every one (a pool's worker
    is forked before its pool records it)."""
    pids = {child.pid for child in multiprocessing.active_children() if child.pid is not None}
    for children in Path(f"/proc/{os.getpid()}/task").glob("*/children"):
        with contextlib.suppress(OSError, ValueError):
            pids.update(int(pid) for pid in children.read_text().split())
    return pids


def _end_children(before: set[int]) -> None:
    """Kill the child processes the interrupted command started (not in ``before``). An
    interrupt can land while a process pool starts its workers, before the pool can stop
    them: they would wait for work, and Python's exit for them, for ever (2 Ctrl-Cs in 60
    at that moment). A pool that shut down left none."""
    for pid in _child_pids() - before:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


#: Exit code when the reader of stdout went away: 128 + SIGPIPE, what a shell reports for a
#: writer the pipe killed (Python ignores SIGPIPE and sees EPIPE instead).
EXIT_BROKEN_PIPE = 141


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``xface`` console script; returns the exit code (the module
    docstring lists them)."""
    if _null_closed_streams():
        _say("xface: error: stdout is closed: nowhere to write the answer")
        return 2
    children = _child_pids()
    with _sigint_raises() as interrupt:
        try:
            return _run(argv)
        except KeyboardInterrupt:
            pass
        except BrokenPipeError:
            # The reader went away (``xface ... | head``): nothing more to say, and Python's
            # flush at exit must not raise again on the dead descriptor.
            _to_devnull(1)
            _to_devnull(2)
            return EXIT_BROKEN_PIPE
        except Exception:
            if not interrupt.seen:
                raise
        _end_children(children)
        _say("xface: interrupted")
        return EXIT_INTERRUPTED


def _run(argv: Sequence[str] | None) -> int:
    """Parse ``argv`` and run its command; user errors are one line on stderr and exit 2."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version or a usage error: said already
        sys.stdout.flush()
        return exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 2
    try:
        _check_workers(args)
        _check_output_names(args)
        _check_compare(args)
        _check_viz(args)
        _check_crosscheck(args)
        _say_if_compiling(args)
        result: int = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, inside main, not at exit
    except BrokenPipeError:
        raise  # main's: not a user error
    except OSError as exc:  # an unwritable --out/--png/--rrd, a missing file, a full disk
        where = f"{exc.filename}: " if exc.filename else ""
        _say(f"xface: error: {_one_line(f'{where}{exc.strerror or exc}')}")
        return 2
    except _VizMissing as exc:
        _say(f"xface: {exc.args[0]} needs the viz extra: {_VIZ_HINT}")
        return 2
    except _CrosscheckMissing:
        if args.command == "crosscheck":
            _say(f"xface: crosscheck needs the crosscheck extra: {_CROSSCHECK_HINT}")
        else:
            _say(
                f"xface: optimize's cross-check needs the crosscheck extra: {_CROSSCHECK_HINT} "
                "(or --no-crosscheck)"
            )
        return 2
    except XfaceError as exc:  # a FaceFileError quoting YAML's report too: one line
        _say(f"xface: error: {_one_line(str(exc))}")
        return 2
    return result
