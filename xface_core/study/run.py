"""Design studies: every design of a :class:`~xface_core.study.space.DesignSpace` over one pose
grid, one table row per design, written to Parquet as results arrive and resumable.

A row holds the design's key (face, H/D, r_p, friction, damping ratio, face digest: a face
file's name, null H/D and r_p, and the digest of its geometry), M (SEATED cells), the
count of every outcome, the two guaranteed-acceptance rectangles (cells and extents: x0 in D,
theta0 in rad; null when there is none), with a pose noise the mean seat probability over
the grid and its standard error (:mod:`xface_core.study.noise`; null without), and
``seconds``, the time the design took on its worker. Every column but ``seconds`` is the
same bit for bit whatever the executor and the number of workers: each design runs on one
thread of one worker through the deterministic engine (the noise draws come from a seeded
generator), and the table is sorted by design on reading (:func:`read_study`), not kept in
completion order. ``seconds`` stays in the same table for the user's benefit and is left out
of every equality check (``read_study(path, timing=False)``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Any, NamedTuple

from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign, x_face
from xface_core.maps.acceptance import AcceptanceMap, acceptance_map
from xface_core.maps.grids import MAX_GRID_SIZE, PAPER_GRID_SIZE, ThetaGridKind, theta_grid
from xface_core.maps.regions import CellRect
from xface_core.physics import DEFAULT_SETTINGS, Physics, SolverSettings
from xface_core.runner import process_count

from .executors import ClientLike, execute
from .noise import PoseNoise, mean_seat_probability
from .space import DesignPoint, DesignSpace
from .table import (
    KEY_COLUMNS,
    TIMING_COLUMNS,
    StudyFile,
    outcome_column,
    read_study,
    study_settings,
)

__all__ = [
    "KEY_COLUMNS",
    "MAX_STUDY_GRID",
    "TIMING_COLUMNS",
    "DesignJob",
    "StudyProgress",
    "StudyRun",
    "evaluate_design",
    "read_study",
    "run_study",
]

#: Largest pose grid of a study (nodes per axis): 1001 x 1001 is 1e6 runs per design.
MAX_STUDY_GRID = MAX_GRID_SIZE


@dataclass(frozen=True)
class DesignJob:
    """One unit of work: a design over the study's pose grid (picklable, sent to workers)."""

    point: DesignPoint
    design: FaceDesign
    grid: int
    theta_kind: ThetaGridKind
    settings: SolverSettings
    noise: PoseNoise | None = None

    def __str__(self) -> str:
        return "design " + ", ".join(f"{k}={v}" for k, v in self.point._asdict().items())


def check_study_grid(grid: int, theta_kind: ThetaGridKind) -> None:
    """Refuse a pose grid a study cannot run: a bad size or kind, or above
    :data:`MAX_STUDY_GRID` nodes per axis (:class:`XfaceValueError`)."""
    theta_grid(grid, theta_kind)  # validates the grid size and kind
    if grid > MAX_STUDY_GRID:
        raise XfaceValueError(f"grid must be <= {MAX_STUDY_GRID} nodes per axis, got {grid}")


def load_engine_before_fork() -> None:
    """Load the compiled engine in this process, so that local workers forked after it start
    with it instead of each loading it again."""
    acceptance_map(x_face(1.0, 1.0), grid=3, threads=1)


def evaluate_design(job: DesignJob) -> dict[str, Any]:
    """The table row of one design: its key, M, outcome counts, regions and time (s).

    Runs on one thread: the workers already share the cores, and the outcomes do not depend
    on it anyway.
    """
    start = time.perf_counter()
    physics = Physics(
        damping_ratio=job.point.damping_ratio, friction=job.point.friction, settings=job.settings
    )
    amap = acceptance_map(
        job.design.with_width(1.0),
        grid=job.grid,
        theta_kind=job.theta_kind,
        physics=physics,
        threads=1,
    )
    row: dict[str, Any] = dict(job.point._asdict())
    row["M"] = amap.M
    row.update({outcome_column(o): n for o, n in amap.counts().items()})
    row.update(_region_columns("guaranteed", amap, amap.guaranteed))
    row.update(_region_columns("centred", amap, amap.centred))
    row["seat_probability"] = row["seat_probability_se"] = None
    if job.noise is not None:
        p = mean_seat_probability(
            job.design, job.noise, grid=job.grid, theta_kind=job.theta_kind, physics=physics
        )
        row["seat_probability"], row["seat_probability_se"] = p.mean, p.standard_error
    row["seconds"] = time.perf_counter() - start
    return row


def _region_columns(name: str, amap: AcceptanceMap, rect: CellRect | None) -> dict[str, Any]:
    extent = amap.region_extent(rect)
    cells = 0 if rect is None else len(rect[0]) * len(rect[1])
    keys = ("x0_min", "x0_max", "theta0_min", "theta0_max")
    values = (None,) * 4 if extent is None else extent
    return {f"{name}_cells": cells} | {f"{name}_{k}": v for k, v in zip(keys, values, strict=True)}


class StudyProgress(NamedTuple):
    """Where a running study is: designs finished in this run, to do, already there."""

    done: int
    total: int
    skipped: int
    elapsed: float
    """Seconds since this run started."""


class StudyRun(NamedTuple):
    """What one call of :func:`run_study` did."""

    path: str
    computed: int
    """Designs simulated and written by this run."""
    skipped: int
    """Designs of the space that were already in the output."""
    seconds: float


def run_study(
    space: DesignSpace,
    out: str | os.PathLike[str],
    *,
    grid: int = PAPER_GRID_SIZE,
    theta_kind: ThetaGridKind = "symmetric",
    settings: SolverSettings = DEFAULT_SETTINGS,
    noise: PoseNoise | None = None,
    executor: Executor | ClientLike | None = None,
    workers: int | None = None,
    progress: Callable[[StudyProgress], None] | None = None,
    allow_version_mix: bool = False,
) -> StudyRun:
    """Simulate every design of ``space`` not yet in ``out`` and write its row there.

    ``noise`` adds the mean seat probability over the grid under that pose noise, with its
    standard error (:mod:`xface_core.study.noise`; ``samples`` simulations per grid node).
    ``allow_version_mix`` lets a run add rows to an ``out`` holding rows of another xface
    or engine version (refused by default: they may differ).
    ``executor``: None for local processes (``workers`` of them, default one per core; 1 runs
    in this process), any :class:`concurrent.futures.Executor`, or a
    ``dask.distributed.Client``. Every design is validated (built) before anything runs.
    Rows go to disk as each design finishes (see :mod:`xface_core.study.table`), so a run that
    is interrupted, even killed, loses only the designs in flight; running it again skips
    the designs already there. A KeyboardInterrupt waits for the designs running, writes
    them and is raised again.

    Raises
    ------
    XfaceValueError
        A bad space or grid, an unwritable ``out``, an ``out`` of another study or version,
        a damaged table (a damaged part is moved aside with a warning and its design
        computed again; :mod:`xface_core.study.table`).
    StudyBusy
        Another run is writing ``out`` (:mod:`xface_core.study.lock`).
    WorkerLost
        A design's worker died more often than the retries allow.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> space = DesignSpace(faces=("X", "V"), h_over_d=(0.25,), r_p=(1.0, 2.0))
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = pathlib.Path(tmp) / "study.parquet"
    ...     first = run_study(space, out, grid=7, workers=1)
    ...     again = run_study(space, out, grid=7, workers=1)
    ...     table = read_study(out)
    >>> first.computed, again.computed, again.skipped, table.num_rows
    (4, 0, 4, 4)
    >>> list(zip(table["face"].to_pylist(), table["r_p"].to_pylist(), table["M"].to_pylist()))
    [('V', 1.0, 3), ('V', 2.0, 3), ('X', 1.0, 11), ('X', 2.0, 5)]
    """
    check_study_grid(grid, theta_kind)
    process_count(workers)  # checked before the study file is touched
    points = space.points()
    designs = [space.design(p) for p in points]
    settings_of_study = study_settings(grid, theta_kind, settings, noise)
    with StudyFile(out, settings_of_study, allow_version_mix=allow_version_mix) as study:
        already = study.done()
        jobs = [
            DesignJob(p, d, grid, theta_kind, settings, noise)
            for p, d in zip(points, designs, strict=True)
            if p not in already
        ]
        skipped = len(points) - len(jobs)
        start = time.monotonic()
        done = 0

        def write(job: DesignJob, row: dict[str, Any]) -> None:
            nonlocal done
            study.write_row(row)
            done += 1
            if progress is not None:
                progress(StudyProgress(done, len(jobs), skipped, time.monotonic() - start))

        if progress is not None:
            progress(StudyProgress(0, len(jobs), skipped, 0.0))
        if jobs and executor is None and workers != 1:
            load_engine_before_fork()
        execute(evaluate_design, jobs, write, executor=executor, workers=workers)
        study.compact()
        return StudyRun(str(study.path), done, skipped, time.monotonic() - start)
