"""``xface sweep`` and ``xface design``: design studies from the command line.

Comma lists form the product of designs (``--face X,V --h-over-d 0.25,0.5``); face files
(``--face-file a.yaml,b.yaml``) are fixed designs, one each per friction and damping ratio
(H/D and r_p do not apply to them; docs/study.md). Results go to
a Parquet table as they arrive (``--out``), and running the same command again resumes. Local
processes by default, a Dask cluster with ``--scheduler tcp://HOST:8786`` (the ``cluster``
extra). A progress bar goes to stderr when it is a terminal (``--quiet``: never). SIGINT and
SIGTERM stop a sweep after the designs running are written (exit code 130).
"""

from __future__ import annotations

import argparse
import errno
import json
import math
import os
import secrets
import signal
import sys
import warnings
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, suppress
from functools import partial
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from xface_core.errors import XfaceValueError, XfaceWarning
from xface_core.facefile import load_face
from xface_core.maps.grids import PAPER_GRID_SIZE
from xface_core.maps.paper import DEPARTURE_FROM_PAPER
from xface_core.runner import MAX_LOCAL_WORKERS
from xface_core.study.noise import PoseNoise
from xface_core.study.run import MAX_STUDY_GRID, StudyProgress, read_study, run_study
from xface_core.study.search import (
    CRITERIA,
    PAPER_BOX_H_OVER_D,
    PAPER_BOX_R_P,
    DesignSearch,
    rank_face_files,
    search_designs,
)
from xface_core.study.space import DesignSpace, FileFace, parse_face_list, parse_number_list

from . import progress

__all__ = ["add_study_commands", "atomic_output", "json_default"]

#: Exit code of a run stopped by SIGINT or SIGTERM (128 + SIGINT, the shell's convention).
EXIT_INTERRUPTED = 130

#: ``--workers``' help (``what``: the processes it counts), for every command that has it.
WORKERS_HELP = (
    "{what}, 1 to " + str(MAX_LOCAL_WORKERS) + ", never more than there are jobs "
    "(default: one per core)"
)


class ProgressBar(progress.ProgressBar):
    """A study's progress bar: designs done, to do, already there, time left."""

    def __call__(self, p: StudyProgress) -> None:
        self.draw(p.done, p.total, p.elapsed, f" ({p.skipped} already done)")


def _progress(args: argparse.Namespace, label: str) -> AbstractContextManager[ProgressBar | None]:
    return progress.terminal_progress(args.quiet, partial(ProgressBar, label=label))


@contextmanager
def _executor(args: argparse.Namespace) -> Iterator[Any]:
    """The Dask client of ``--scheduler`` (closed afterwards), or None for local processes."""
    if args.scheduler is None:
        yield None
        return
    from xface_core.study.cluster import connect

    client = connect(args.scheduler)
    try:
        yield client
    finally:
        client.close()


@contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """An :class:`XfaceWarning` (a damaged part of the study moved aside, ...) as one line
    ``xface: warning: ...`` on stderr, when it happens; other warnings as Python shows them."""
    with warnings.catch_warnings():
        warnings.simplefilter("always", XfaceWarning)
        show = warnings.showwarning

        def show_line(
            message: Warning | str,
            category: type[Warning],
            filename: str,
            lineno: int,
            file: TextIO | None = None,
            line: str | None = None,
        ) -> None:
            if issubclass(category, XfaceWarning):
                print(f"xface: warning: {message}", file=sys.stderr)
            else:
                show(message, category, filename, lineno, file, line)

        warnings.showwarning = show_line
        yield


def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


@contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """SIGTERM (a batch system's or ``kill``'s stop) behaves like Ctrl-C while this runs."""
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _interrupted(out: str) -> int:
    print(
        f"xface: interrupted: the designs finished so far are in {out}; "
        "run the same command again to resume",
        file=sys.stderr,
    )
    return EXIT_INTERRUPTED


# Here rather than in cli: cli and bench use it too, and cli imports this module.
@contextmanager
def atomic_output(path: str | Path, what: str) -> Iterator[str]:
    """A new file beside ``path`` (hidden, the same suffix, so the writer picks the same
    format) for the block to write instead; renamed onto ``path`` when the block ends, removed
    when it raises (Ctrl-C, a full disk): ``path`` is then its old file or absent, never half
    of a new one that a later run or viewer would take for whole. ``what`` names the file in
    the error (:class:`XfaceValueError`, exit 2) when it cannot be created; the error names
    ``path``, not the file aside."""
    target = Path(path)
    if target.is_dir():
        raise XfaceValueError(f"cannot write {what} {str(path)!r}: {os.strerror(errno.EISDIR)}")
    aside = target.with_name(f".{target.stem}.{secrets.token_hex(4)}.part{target.suffix}")
    try:
        # O_EXCL: a name of our own; 0o666 under the umask, as the file written directly had.
        os.close(os.open(aside, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError as exc:
        raise XfaceValueError(f"cannot write {what} {str(path)!r}: {exc.strerror}") from None
    try:
        yield str(aside)
        os.replace(aside, target)
    except BaseException:
        with suppress(OSError):
            aside.unlink()
        raise


def json_default(o: object) -> object:
    """``json.dumps``'s ``default`` for the commands' outputs: numpy numbers as Python ones,
    a non-finite float as its text (``"nan"``, ``"inf"``: JSON has no number for them)."""
    if isinstance(o, float | np.floating) and not math.isfinite(float(o)):
        return str(float(o))
    if isinstance(o, np.integer | np.floating):
        return o.item()
    raise TypeError(f"not serialisable: {type(o)}")


def _check_grid(grid: int) -> None:
    if grid > MAX_STUDY_GRID:
        raise XfaceValueError(f"--grid must be <= {MAX_STUDY_GRID}, got {grid}")


def _noise(args: argparse.Namespace) -> PoseNoise | None:
    """The pose noise of ``--sigma-x`` and ``--sigma-theta`` (both or neither), validated."""
    given = (args.sigma_x is not None, args.sigma_theta is not None)
    if given == (False, False):
        return None
    if given != (True, True):
        raise XfaceValueError("--sigma-x and --sigma-theta go together: give both")
    return PoseNoise(
        args.sigma_x, args.sigma_theta, samples=args.noise_samples, seed=args.noise_seed
    )


def _cmd_sweep(args: argparse.Namespace) -> int:
    with _warnings_as_lines():
        return _sweep(args)


def _face_files(text: str | None) -> tuple[FileFace, ...]:
    """The face files of ``--face-file a.yaml,b.yaml`` (a comma list of paths), each read and
    checked now (a bad one exits 2 naming it, before anything runs)."""
    if text is None:
        return ()
    paths = [p.strip() for p in text.split(",")]
    if not all(paths):
        raise XfaceValueError(f"--face-file: {text!r} is not a comma list of face files")
    return tuple(FileFace(path, load_face(path)) for path in paths)


def _faces(args: argparse.Namespace, files: tuple[FileFace, ...]) -> tuple[str, ...]:
    """The built-in faces: ``--face``'s, else X, or none when face files are given."""
    if args.face is not None:
        return parse_face_list(args.face)
    return () if files else ("X",)


def _sweep(args: argparse.Namespace) -> int:
    _check_grid(args.grid)
    files = _face_files(args.face_file)
    space = DesignSpace(
        faces=_faces(args, files),
        face_files=files,
        h_over_d=parse_number_list(args.h_over_d, "--h-over-d"),
        r_p=parse_number_list(args.rp, "--rp"),
        friction=parse_number_list(args.friction, "--friction"),
        damping_ratio=parse_number_list(args.damping_ratio, "--damping-ratio"),
    )
    for point in space.points():  # bad input is refused before connecting anywhere
        space.design(point)
    noise = _noise(args)
    try:
        with _sigterm_interrupts(), _executor(args) as client, _progress(args, "sweep") as bar:
            run = run_study(
                space,
                args.out,
                grid=args.grid,
                theta_kind=args.theta_grid,
                noise=noise,
                executor=client,
                workers=args.workers,
                progress=bar,
                allow_version_mix=args.allow_version_mix,
            )
    except KeyboardInterrupt:
        return _interrupted(args.out)
    summary = {
        "out": run.path,
        "designs": len(space),
        "computed": run.computed,
        "skipped": run.skipped,
        "rows": read_study(run.path).num_rows,
        "seconds": run.seconds,
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"sweep: {len(space)} designs on a {args.grid} x {args.grid} pose grid: "
            f"{run.computed} computed, {run.skipped} already in {run.path} "
            f"({summary['rows']} rows there), {run.seconds:.1f} s"
        )
    return 0


def _box(text: str, option: str) -> tuple[float, float]:
    values = parse_number_list(text, option)
    if len(values) != 2:
        raise XfaceValueError(f"{option}: give the box as LO,HI, got {text!r}")
    return values[0], values[1]


def _row_text(row: dict[str, Any]) -> str:
    if row["face_digest"]:  # a face file: its name and digest, no H/D or r_p
        design = f"{row['face']} ({row['face_digest']})"
    else:
        design = f"H/D={row['h_over_d']:<8.5g} r_p={row['r_p']:<7.5g}"
    parts = [f"{design} M={row['M']:<5d}"]
    if row["seat_probability"] is not None:
        parts.append(f"P(seat)={row['seat_probability']:.4f} +- {row['seat_probability_se']:.4f}")
    for region in ("guaranteed", "centred"):
        if row[f"{region}_cells"] == 0:
            parts.append(f"{region}: none")
            continue
        parts.append(
            f"{region}: {row[f'{region}_cells']} cells, x0 [{row[f'{region}_x0_min']:+.3g}, "
            f"{row[f'{region}_x0_max']:+.3g}] D, theta0 [{row[f'{region}_theta0_min']:+.3f}, "
            f"{row[f'{region}_theta0_max']:+.3f}] rad ([{_deg(row[f'{region}_theta0_min'])}, "
            f"{_deg(row[f'{region}_theta0_max'])}] deg)"
        )
    return "  ".join(parts)


def _deg(rad: float) -> str:
    return f"{math.degrees(rad):+.3g}"


def _cmd_design(args: argparse.Namespace) -> int:
    with _warnings_as_lines():
        return _design(args)


def _design(args: argparse.Namespace) -> int:
    _check_grid(args.grid)
    files = _face_files(args.face_file)
    face = args.face if args.face is not None or files else "X"
    if args.png and face is None:
        raise XfaceValueError("--png draws the search's heat map: give --face to search a face")
    run: dict[str, Any] = {
        "criterion": args.criterion,
        "friction": args.friction,
        "damping_ratio": args.damping_ratio,
        "grid": args.grid,
        "theta_kind": args.theta_grid,
        "noise": _noise(args),
        "out": args.out,
        "workers": args.workers,
        "allow_version_mix": args.allow_version_mix,
    }
    box: dict[str, Any] = {
        "h_over_d": _box(args.h_over_d, "--h-over-d"),
        "r_p": _box(args.rp, "--rp"),
    }
    search: dict[str, Any] = {
        "steps": args.steps,
        "refine": args.refine,
        "refine_steps": args.refine_steps,
    }
    found, file_rows = None, []
    try:
        with _sigterm_interrupts(), _executor(args) as client, _progress(args, "design") as bar:
            if face is not None:
                found = search_designs(face, executor=client, progress=bar, **box, **search, **run)
            if files:
                file_rows = rank_face_files(files, executor=client, progress=bar, **run)
    except KeyboardInterrupt:
        if args.out is None:  # the study was in a temporary folder, now removed: no resuming
            raise  # the command line's own "xface: interrupted", exit 130
        return _interrupted(args.out)
    if args.json:
        out = {"criterion": args.criterion} if found is None else _search_json(args, found)
        if files:
            out["face_files"] = file_rows
        print(json.dumps(out))
        return 0
    if found is not None:
        _print_search(args, found)
    if files:
        _print_face_files(args, file_rows)
    if found is not None:
        print(f"xface {DEPARTURE_FROM_PAPER}")
    return 0


def _search_json(args: argparse.Namespace, found: DesignSearch) -> dict[str, Any]:
    """The search's JSON (and its heat map, with ``--png``)."""
    column = CRITERIA[args.criterion]
    if args.png:
        from xface_core.viz.heatmap import save_heatmap_png

        best_index = divmod(int(found.coarse.argmax()), found.coarse.shape[1])
        with atomic_output(args.png, "the picture") as aside:
            save_heatmap_png(
                found.coarse,
                found.h_over_d,
                found.r_p,
                aside,
                best=(int(best_index[0]), int(best_index[1])),
                title=f"{found.face}-Face: {column} (friction {args.friction:g}), best outlined",
            )
    return {
        "criterion": args.criterion,
        "best": found.best,
        "coarse_best": found.coarse_best,
        "runners_up": found.ranked[1 : 1 + max(0, args.top)],
        "designs": len(found.ranked),
        "coarse": {
            "h_over_d": list(found.h_over_d),
            "r_p": list(found.r_p),
            column: found.coarse.tolist(),
        },
    }


def _print_search(args: argparse.Namespace, found: DesignSearch) -> None:
    out = _search_json(args, found)  # writes the heat map too
    print(
        f"design {found.face}-Face by {args.criterion} ({CRITERIA[args.criterion]}), "
        f"friction {args.friction:g}, damping ratio {args.damping_ratio:g}, {args.grid} x "
        f"{args.grid} pose grid: {len(found.h_over_d)} x {len(found.r_p)} coarse grid, "
        f"{found.rounds} refinement round(s), {len(found.ranked)} designs"
    )
    print(f"best         {_row_text(found.best)}")
    print(f"coarse best  {_row_text(found.coarse_best)}")
    for k, row in enumerate(out["runners_up"], start=2):
        print(f"{k:>2}.          {_row_text(row)}")


def _print_face_files(args: argparse.Namespace, rows: list[dict[str, Any]]) -> None:
    print(
        f"face files by {args.criterion} ({CRITERIA[args.criterion]}), friction "
        f"{args.friction:g}, damping ratio {args.damping_ratio:g}, {args.grid} x {args.grid} "
        f"pose grid: {len(rows)} designs, each fixed (H/D and r_p do not apply to a file)"
    )
    for k, row in enumerate(rows, start=1):
        print(f"{k:>2}.          {_row_text(row)}")


def _common_study_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--grid", type=int, default=PAPER_GRID_SIZE, help="pose nodes per axis (odd)")
    p.add_argument("--theta-grid", choices=("symmetric", "paper"), default="symmetric")
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--scheduler", default=None, help="Dask scheduler address tcp://HOST:PORT (cluster extra)"
    )
    where.add_argument(
        "--workers", type=int, default=None, help=WORKERS_HELP.format(what="local processes")
    )
    p.add_argument("--sigma-x", type=float, default=None, help="pose noise: std of x0 (D)")
    p.add_argument("--sigma-theta", type=float, default=None, help="pose noise: std of theta0")
    p.add_argument("--noise-samples", type=int, default=16, help="noisy poses per grid node")
    p.add_argument("--noise-seed", type=int, default=0, help="seed of the noisy poses")
    p.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--allow-version-mix",
        action="store_true",
        help="resume an --out holding rows of another xface or engine version",
    )


def add_study_commands(sub: Any) -> None:
    """Add ``sweep`` and ``design`` to the ``xface`` subcommands."""
    p = sub.add_parser("sweep", help="a design study: every design of the product, to Parquet")
    p.add_argument(
        "--face", default=None, help="comma list of X, V, S (default X, none with --face-file)"
    )
    p.add_argument(
        "--face-file",
        default=None,
        help="comma list of face files (docs/facefile.md): one fixed design each, per friction "
        "and damping ratio; --h-over-d and --rp do not apply to them",
    )
    p.add_argument("--h-over-d", default="0.25", help="comma list of H/D")
    p.add_argument("--rp", default="2", help="comma list of r_p (widths D)")
    p.add_argument("--friction", default="0", help="comma list of Coulomb mu")
    p.add_argument("--damping-ratio", default="1", help="comma list of c_B / c_M (inf: fixed)")
    p.add_argument("--out", required=True, help="the study's Parquet file (resumed if there)")
    _common_study_args(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("design", help="the best H/D and r_p of a face in a box, by a criterion")
    p.add_argument(
        "--face",
        type=str.upper,
        choices=("X", "V", "S"),
        default=None,
        help="the face to search (default X, none with --face-file)",
    )
    p.add_argument(
        "--face-file",
        default=None,
        help="comma list of face files: each a fixed design, ranked by the criterion",
    )
    box_h, box_rp = PAPER_BOX_H_OVER_D, PAPER_BOX_R_P
    p.add_argument("--h-over-d", default=f"{box_h[0]:g},{box_h[1]:g}", help="box LO,HI")
    p.add_argument("--rp", default=f"{box_rp[0]:g},{box_rp[1]:g}", help="box LO,HI (widths D)")
    p.add_argument("--steps", type=int, default=11, help="coarse nodes per axis")
    p.add_argument("--refine", type=int, default=1, help="refinement rounds around the best")
    p.add_argument("--refine-steps", type=int, default=5, help="nodes per axis of a round")
    p.add_argument("--criterion", choices=tuple(CRITERIA), default="M")
    p.add_argument("--friction", type=float, default=0.0, help="Coulomb coefficient mu")
    p.add_argument("--damping-ratio", type=float, default=1.0, help="c_B / c_M (inf: fixed)")
    p.add_argument("--top", type=int, default=5, help="runners-up to print")
    p.add_argument("--out", default=None, help="keep the study table here (resumable)")
    p.add_argument("--png", default=None, help="write the coarse grid as a heat map PNG")
    _common_study_args(p)
    p.set_defaults(func=_cmd_design)
