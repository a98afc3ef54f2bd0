"""xface against Chipmunk2D, cell by cell: :func:`crosscheck`.

Every cell (a start pose x0, theta0) runs three times: in xface (:func:`predict_batch`), in
the engine with sharp corners and in the engine with corners rounded by ``rounding`` D
(:mod:`xface_core.crosscheck.scene`). A cell is **ambiguous** when the two engine runs
disagree on whether the parts seat, when either ran out of its budget, or (``converged``)
when the last halving of the step still changed it: the engine's answer there depends on an
artefact, so xface is not judged on it. On the other cells the engine's answer is that of
the sharp run (both runs agree on it), and the report counts

- ``agreement``: the fraction of unambiguous cells where xface and the engine agree on
  SEATED or not (what the acceptance metric M counts);
- ``false_seated``: xface says SEATED where the engine's answer is a failure (the worst
  error of a docking predictor: the robot moves and the dock fails);
- ``false_failures``: xface says a failure where the engine seats;
- ``outcome_agreement``: the same over the exact outcome (BAD_MATE, PASSED, ...), on the
  unambiguous cells whose two engine runs also agree on the outcome.

Lengths in units of D (the cells' x0 too: the design's width does not enter), angles in rad.
"""

from __future__ import annotations

import math
import multiprocessing
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from xface_core.codes import CROSSCHECK_CONVERGE_BY, Outcome
from xface_core.geometry import FaceDesign
from xface_core.maps.grids import theta_grid, x0_grid
from xface_core.physics import Physics
from xface_core.predict import predict
from xface_core.runner import outcomes_at, process_count

from .journal import RunJournal
from .scene import (
    DEFAULT_ENGINE,
    DEFAULT_ROUNDING,
    JAM_REASON,
    EngineRun,
    EngineSettings,
    run_cell,
)

__all__ = [
    "CrosscheckResult",
    "Disagreement",
    "EngineMap",
    "XfaceEnd",
    "compare_with_engine",
    "confirm_stalls",
    "crosscheck",
    "drop_knife_edges",
    "engine_map",
    "random_cells",
    "result_json",
    "stderr_progress",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
Progress = Callable[[int, int, float], None]

#: Runs below which the engine runs in this process instead of a pool.
INLINE_RUNS = 8

#: Halvings of the step that ``converged=True`` tries at most.
MAX_HALVINGS = 3

#: ``converged=True`` runs every jammed cell again with the stall speed times this: a run
#: that only crept (a two-contact path near a fold can need hundreds of rad per D of
#: descent, the pivot then moving at 1e-6 of its free speed) is no jam.
STALL_CONFIRM = 0.01


@dataclass(frozen=True)
class XfaceEnd:
    """xface's final state of one cell (lengths in D)."""

    outcome: Outcome
    reason: str
    phi_b: float
    phi_m: float
    y_m: float


@dataclass(frozen=True)
class Disagreement:
    """One cell where xface and the engine's unambiguous answer differ on seating."""

    index: int
    """Cell index (row-major over the grid: ``index = row * grid + column``)."""
    x0: float
    theta0: float
    xface: XfaceEnd
    engine: EngineRun
    """The sharp run (the rounded one agrees on seating)."""
    engine_rounded: EngineRun

    @property
    def kind(self) -> str:
        """``"false SEATED"`` or ``"false failure"`` (xface's side)."""
        return "false SEATED" if self.xface.outcome is Outcome.SEATED else "false failure"


@dataclass(frozen=True)
class CrosscheckResult:
    """Per-cell outcomes of xface and the engine, and the comparison (flat over the cells;
    for a grid, row-major with rows x0 and columns theta0, see :meth:`grid_of`)."""

    design: FaceDesign
    physics: Physics
    settings: EngineSettings
    """The engine settings of the reported runs (their ``step`` is the one used)."""
    rounding: float
    x0: FloatArray
    theta0: FloatArray
    grid: int | None
    xface: npt.NDArray[np.int8]
    engine: npt.NDArray[np.int8]
    engine_rounded: npt.NDArray[np.int8]
    ambiguous: BoolArray
    sharp_runs: tuple[EngineRun, ...] = field(repr=False)
    rounded_runs: tuple[EngineRun, ...] = field(repr=False)
    disagreements: tuple[Disagreement, ...] = field(repr=False)
    converged: bool | None = None
    """None without ``converged``; else whether the last halving changed no cell."""
    step_history: tuple[tuple[float, int], ...] = ()
    """(step, cells that changed when the step was halved to it) per halving."""
    stall_changes: int | None = None
    """``converged``: cells whose seating changed when their jams ran again at a lower stall
    speed (:func:`confirm_stalls`)."""
    knife_edges: int | None = None
    """``converged``: disagreeing cells found ambiguous because the sharp engine's seating
    flips within ``rounding`` of the cell's x0 (:func:`drop_knife_edges`)."""
    seconds: float = 0.0
    converge_by: str = "grid"
    """How ``converged``'s halvings chose their cells
    (:data:`xface_core.codes.CROSSCHECK_CONVERGE_BY`)."""

    @property
    def n_cells(self) -> int:
        return int(self.x0.size)

    @property
    def n_ambiguous(self) -> int:
        return int(self.ambiguous.sum())

    @property
    def n_unambiguous(self) -> int:
        return self.n_cells - self.n_ambiguous

    @property
    def agreement(self) -> float:
        """Fraction of the unambiguous cells where both agree on SEATED or not (nan if none)."""
        if self.n_unambiguous == 0:
            return math.nan
        return 1.0 - len(self.disagreements) / self.n_unambiguous

    @property
    def false_seated(self) -> int:
        return sum(1 for d in self.disagreements if d.xface.outcome is Outcome.SEATED)

    @property
    def false_failures(self) -> int:
        return len(self.disagreements) - self.false_seated

    @property
    def outcome_agreement(self) -> float:
        """Fraction of the unambiguous cells whose two engine runs agree on the outcome where
        xface gives that same outcome (nan if none)."""
        same = ~self.ambiguous & (self.engine == self.engine_rounded)
        n = int(same.sum())
        return math.nan if n == 0 else float((self.xface[same] == self.engine[same]).sum()) / n

    def m_values(self) -> tuple[int, int, int]:
        """SEATED cells of xface, of the sharp engine runs and of the rounded ones."""
        seated = int(Outcome.SEATED)
        return (
            int((self.xface == seated).sum()),
            int((self.engine == seated).sum()),
            int((self.engine_rounded == seated).sum()),
        )

    def grid_of(self, values: npt.NDArray[np.generic]) -> npt.NDArray[np.generic]:
        """A per-cell array as the (grid, grid) map (rows x0, columns theta0)."""
        if self.grid is None:
            raise ValueError("these cells are not a grid")
        return values.reshape(self.grid, self.grid)


# --------------------------------------------------------------------------------------------
# Cells
# --------------------------------------------------------------------------------------------


def grid_cells(grid: int) -> tuple[FloatArray, FloatArray]:
    """The cells of :func:`xface_core.acceptance_map`'s grid, row-major (rows x0 in D)."""
    X, T = np.meshgrid(x0_grid(grid), theta_grid(grid), indexing="ij")
    return X.ravel(), T.ravel()


def random_cells(k: int, seed: int = 0) -> tuple[FloatArray, FloatArray]:
    """``k`` cells drawn uniformly from x0 in [-1, 1] D and theta0 in [-pi/2, pi/2].

    Examples
    --------
    >>> x, t = random_cells(3, seed=1)
    >>> x.shape, bool((abs(x) <= 1).all() and (abs(t) <= 1.5708).all())
    ((3,), True)
    """
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, k), rng.uniform(-math.pi / 2, math.pi / 2, k)


# --------------------------------------------------------------------------------------------
# Running the engine over many cells
# --------------------------------------------------------------------------------------------

_WORKER: dict[str, object] = {}


def _init_worker(design: FaceDesign, physics: Physics) -> None:
    _WORKER["design"] = design
    _WORKER["physics"] = physics


def _run_task(task: tuple[float, float, EngineSettings]) -> EngineRun:
    design = _WORKER["design"]
    physics = _WORKER["physics"]
    assert isinstance(design, FaceDesign)
    assert isinstance(physics, Physics)
    x0, theta0, settings = task
    return run_cell(design, x0, theta0, physics=physics, settings=settings)


def stderr_progress(done: int, total: int, elapsed: float) -> None:
    """Progress with an estimate of the time left, on stderr."""
    left = elapsed / done * (total - done) if done else math.nan
    print(
        f"crosscheck: {done}/{total} engine runs, {elapsed:.0f} s, about {left:.0f} s left",
        file=sys.stderr,
        flush=True,
    )


def run_engine(
    design: FaceDesign,
    physics: Physics,
    tasks: Sequence[tuple[float, float, EngineSettings]],
    *,
    workers: int | None = None,
    progress: Progress | None = None,
    journal: RunJournal | None = None,
) -> list[EngineRun]:
    """The engine over ``tasks`` (x0 in D, theta0, settings), in processes when worth it.

    With a ``journal``, a task it holds a run for is answered from it, and every other run
    is added to it the moment it ends (:mod:`.journal`): an interrupted map resumes there."""
    known: list[EngineRun | None] = (
        [None] * len(tasks) if journal is None else [journal.get(t) for t in tasks]
    )
    todo = [i for i, run in enumerate(known) if run is None]
    runs = _runs(design, physics, [tasks[i] for i in todo], workers, progress)
    for i, run in zip(todo, runs, strict=True):
        if journal is not None:
            journal.add(tasks[i], run)
        known[i] = run
    return [run for run in known if run is not None]


def _runs(
    design: FaceDesign,
    physics: Physics,
    tasks: Sequence[tuple[float, float, EngineSettings]],
    workers: int | None,
    progress: Progress | None,
) -> Iterator[EngineRun]:
    """:func:`run_engine`'s runs of ``tasks``, in their order, each as it ends."""
    n_workers = process_count(workers, len(tasks))
    start = time.monotonic()
    if n_workers == 1 or len(tasks) <= INLINE_RUNS:
        _init_worker(design, physics)
        for i, task in enumerate(tasks):
            yield _run_task(task)
            if progress is not None and (i + 1) % 50 == 0:
                progress(i + 1, len(tasks), time.monotonic() - start)
        return
    # Interleaved order spreads slow regions of a map over the workers; small chunks keep
    # the estimate honest.
    # fork where there is one: no re-import of the caller's main module (scripts without a
    # ``__main__`` guard work), and the workers inherit the compiled xface and pymunk.
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    chunk = max(1, min(16, len(tasks) // (8 * n_workers)))
    report_every = max(1, len(tasks) // 20)
    with ProcessPoolExecutor(
        n_workers, mp_context=context, initializer=_init_worker, initargs=(design, physics)
    ) as pool:
        for i, run in enumerate(pool.map(_run_task, tasks, chunksize=chunk)):
            yield run
            if progress is not None and ((i + 1) % report_every == 0 or i + 1 == len(tasks)):
                progress(i + 1, len(tasks), time.monotonic() - start)


def _engine_pass(
    design: FaceDesign,
    physics: Physics,
    x0: FloatArray,
    theta0: FloatArray,
    settings: EngineSettings,
    rounding: float,
    workers: int | None,
    progress: Progress | None,
    journal: RunJournal | None = None,
) -> tuple[list[EngineRun], list[EngineRun]]:
    """Sharp and rounded runs of every cell at one step size."""
    sharp = settings.with_step(settings.step)
    rounded = settings.rounded(rounding)
    tasks = [
        (float(x), float(t), s) for s in (sharp, rounded) for x, t in zip(x0, theta0, strict=True)
    ]
    runs = run_engine(design, physics, tasks, workers=workers, progress=progress, journal=journal)
    n = len(x0)
    return runs[:n], runs[n:]


def _codes(runs: Sequence[EngineRun]) -> npt.NDArray[np.int8]:
    return np.array([int(r.outcome) for r in runs], dtype=np.int8)


def _seated(codes: npt.NDArray[np.int8]) -> BoolArray:
    return np.asarray(codes == int(Outcome.SEATED))


def _ambiguous(sharp: Sequence[EngineRun], rounded: Sequence[EngineRun]) -> BoolArray:
    s, r = _codes(sharp), _codes(rounded)
    unresolved = (s == int(Outcome.UNRESOLVED)) | (r == int(Outcome.UNRESOLVED))
    return np.asarray((_seated(s) != _seated(r)) | unresolved)


def _verdicts(sharp: Sequence[EngineRun], rounded: Sequence[EngineRun]) -> npt.NDArray[np.int8]:
    """The engine's map as the comparison reads it: -1 ambiguous, 1 seated, 0 a failure."""
    seated = _seated(_codes(sharp)).astype(np.int8)
    return np.where(_ambiguous(sharp, rounded), np.int8(-1), seated).astype(np.int8)


def _xface_end(design: FaceDesign, x0: float, theta0: float, physics: Physics) -> XfaceEnd:
    p = predict(design, x0 * design.width, theta0, physics=physics, margins=False)
    return XfaceEnd(p.outcome, p.reason, p.phi_b, p.phi_m, p.pivot_m[1] / design.width)


@dataclass(frozen=True)
class EngineMap:
    """The engine's side of a comparison: its runs over some cells, before xface is asked.

    It depends only on the design's polygons, the physics and the engine's settings, so it
    can be stored and compared with xface again after xface changes (see
    ``scripts/evidence/accuracy_table.py``).
    """

    x0: FloatArray
    theta0: FloatArray
    grid: int | None
    sharp: tuple[EngineRun, ...]
    rounded: tuple[EngineRun, ...]
    settings: EngineSettings
    """The settings of the runs kept (after ``converged``'s halvings, the finest; with
    ``converge_by="cells"`` a cell's runs stop at the step its own last halving confirmed)."""
    rounding: float
    changed: BoolArray
    """Cells the last halving of the step still changed (ambiguous)."""
    converged: bool | None
    step_history: tuple[tuple[float, int], ...]
    seconds: float
    stall_changes: int | None = None
    """Cells whose seating changed when their jams were run again at a lower stall speed
    (``converged``; None when not done)."""
    converge_by: str = "grid"
    """How the halvings chose their cells (:data:`~xface_core.codes.CROSSCHECK_CONVERGE_BY`)."""

    @property
    def ambiguous(self) -> BoolArray:
        return _ambiguous(self.sharp, self.rounded) | self.changed


def _cells(
    grid: int | None, cells: Sequence[tuple[float, float]] | None
) -> tuple[FloatArray, FloatArray, int | None]:
    if cells is not None:
        arr = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
        return arr[:, 0].copy(), arr[:, 1].copy(), None
    if grid is None:
        raise ValueError("give a grid size or cells")
    x0, theta0 = grid_cells(grid)
    return x0, theta0, grid


def engine_map(
    design: FaceDesign,
    physics: Physics | None = None,
    *,
    grid: int | None = 41,
    cells: Sequence[tuple[float, float]] | None = None,
    settings: EngineSettings = DEFAULT_ENGINE,
    rounding: float = DEFAULT_ROUNDING,
    converged: bool = False,
    converge_by: str = "grid",
    workers: int | None = None,
    progress: Progress | None = None,
    journal: RunJournal | None = None,
) -> EngineMap:
    """The engine's runs over the cells (the arguments as for :func:`crosscheck`); with a
    ``journal`` every run is kept there as it ends and taken from there when it holds it
    (:func:`run_engine`), so a map interrupted resumes where it stopped."""
    if converge_by not in CROSSCHECK_CONVERGE_BY:
        raise ValueError(
            f"converge_by must be one of {CROSSCHECK_CONVERGE_BY}, got {converge_by!r}"
        )
    phys = Physics() if physics is None else physics
    start = time.monotonic()
    x0, theta0, n_grid = _cells(grid, cells)
    sharp, rounded = _engine_pass(
        design, phys, x0, theta0, settings, rounding, workers, progress, journal
    )
    history: list[tuple[float, int]] = []
    changed = np.zeros(x0.size, dtype=bool)
    is_converged: bool | None = None
    used = settings
    if converged:
        is_converged = False
        active = np.arange(x0.size)  # the cells the next halving runs
        for _ in range(MAX_HALVINGS):
            # The slop goes down with the step: at a fixed slop a step of a few slops lets a
            # corner one slop deep catch at the end of its edge (seen at 1e-6 D slop below
            # 2e-5 D steps), an artefact of the pair, not of the step.
            finer = replace(used, step=used.step / 2.0, slop=used.slop / 2.0)
            f_sharp, f_rounded = _engine_pass(
                design, phys, x0[active], theta0[active], finer, rounding, workers, progress,
                journal,
            )  # fmt: skip
            before = _verdicts([sharp[i] for i in active], [rounded[i] for i in active])
            moved = _verdicts(f_sharp, f_rounded) != before
            for j, i in enumerate(active):
                sharp[i], rounded[i] = f_sharp[j], f_rounded[j]
            changed = np.zeros(x0.size, dtype=bool)
            changed[active[moved]] = True
            history.append((finer.step, int(moved.sum())))
            used = finer
            if not moved.any():
                is_converged = True
                break
            if converge_by == "cells":
                active = active[moved]
    result = EngineMap(
        x0=x0,
        theta0=theta0,
        grid=n_grid,
        sharp=tuple(sharp),
        rounded=tuple(rounded),
        settings=used,
        rounding=rounding,
        changed=changed,
        converged=is_converged,
        step_history=tuple(history),
        seconds=time.monotonic() - start,
        converge_by=converge_by,
    )
    if converged:
        result = confirm_stalls(
            design, result, phys, workers=workers, progress=progress, journal=journal
        )
    return result


def confirm_stalls(
    design: FaceDesign,
    engine: EngineMap,
    physics: Physics | None = None,
    *,
    workers: int | None = None,
    progress: Progress | None = None,
    journal: RunJournal | None = None,
) -> EngineMap:
    """The engine map with every jammed cell (a run that stalled away from the mated pose,
    sharp or rounded) run again, both ways, at ``STALL_CONFIRM`` times the stall speed.

    A stall at the default speed can be a creep: near a fold of a two-contact path the
    parts must turn hundreds of rad per D of descent, and the pivot moves at about 1e-6 of
    its free speed (S H/D 0.32988, r_p 2 at x0 = 0.7, theta0 = -pi/10 stalls at 1e-3 and seats
    at 1e-4 and 1e-5). A true jam stalls again at once. ``journal`` as for
    :func:`engine_map`.
    """
    phys = Physics() if physics is None else physics
    start = time.monotonic()
    jammed = [
        i
        for i, (a, b) in enumerate(zip(engine.sharp, engine.rounded, strict=True))
        if a.reason == JAM_REASON or b.reason == JAM_REASON
    ]
    slow = replace(engine.settings, stall_speed=engine.settings.stall_speed * STALL_CONFIRM)
    tasks = [(float(engine.x0[i]), float(engine.theta0[i]), slow) for i in jammed]
    tasks += [
        (float(engine.x0[i]), float(engine.theta0[i]), slow.rounded(engine.rounding))
        for i in jammed
    ]
    runs = run_engine(design, phys, tasks, workers=workers, progress=progress, journal=journal)
    sharp, rounded = list(engine.sharp), list(engine.rounded)
    before = _verdicts(sharp, rounded)
    for k, i in enumerate(jammed):
        sharp[i], rounded[i] = runs[k], runs[len(jammed) + k]
    changes = int((_verdicts(sharp, rounded) != before).sum())
    return replace(
        engine,
        sharp=tuple(sharp),
        rounded=tuple(rounded),
        stall_changes=changes,
        seconds=engine.seconds + time.monotonic() - start,
    )


def compare_with_engine(
    design: FaceDesign, engine: EngineMap, physics: Physics | None = None
) -> CrosscheckResult:
    """xface on the engine map's cells, compared with it (``physics`` as the engine's)."""
    phys = Physics() if physics is None else physics
    start = time.monotonic()
    x0, theta0 = engine.x0, engine.theta0
    ambiguous = engine.ambiguous
    ours = outcomes_at(design, x0, theta0, phys)
    codes = _codes(engine.sharp)
    differ = ~ambiguous & (_seated(ours) != _seated(codes))
    disagreements = tuple(
        Disagreement(
            index=int(i),
            x0=float(x0[i]),
            theta0=float(theta0[i]),
            xface=_xface_end(design, float(x0[i]), float(theta0[i]), phys),
            engine=engine.sharp[i],
            engine_rounded=engine.rounded[i],
        )
        for i in np.flatnonzero(differ)
    )
    return CrosscheckResult(
        design=design,
        physics=phys,
        settings=engine.settings,
        rounding=engine.rounding,
        x0=x0,
        theta0=theta0,
        grid=engine.grid,
        xface=ours,
        engine=codes,
        engine_rounded=_codes(engine.rounded),
        ambiguous=ambiguous,
        sharp_runs=engine.sharp,
        rounded_runs=engine.rounded,
        disagreements=disagreements,
        converged=engine.converged,
        step_history=engine.step_history,
        stall_changes=engine.stall_changes,
        converge_by=engine.converge_by,
        seconds=engine.seconds + time.monotonic() - start,
    )


def knife_edge_cells(result: CrosscheckResult) -> list[tuple[float, float]]:
    """The starts (x0 in D, theta0 in rad) :func:`drop_knife_edges` runs the sharp engine
    from, at ``result.settings``: ``rounding`` either side of every disagreeing cell's x0,
    two per disagreement in order (minus side first)."""
    d = result.rounding
    return [(dis.x0 + side * d, dis.theta0) for dis in result.disagreements for side in (-1.0, 1.0)]


def drop_knife_edges(
    result: CrosscheckResult,
    *,
    workers: int | None = None,
    progress: Progress | None = None,
    known: Mapping[tuple[float, float], EngineRun] | None = None,
) -> CrosscheckResult:
    """The comparison with every disagreeing cell whose engine answer is a knife edge marked
    ambiguous: the sharp engine, started ``rounding`` (0.002 D) either side of the cell's x0,
    does not give the cell's seating on both sides.

    ``known``: sharp runs at ``result.settings`` already made from some of those starts
    (:func:`knife_edge_cells`, e.g. kept by :mod:`~.store`); only the others are run.

    Rounding the corners moves the boundary between two outcomes by about the rounding, so
    a cell exactly on it (a V tip landing exactly on a notch corner, V H/D 0.57435 r_p 1 at
    x0 = -D/2, theta0 = 0: BAD_MATE for x0 < -D/2, SEATED above, in xface and in the sharp
    engine) can have sharp and rounded runs on the same side, and the engine's pick at the
    exact tie is its own (which separating axis its collision test reports). Only
    disagreements are checked: the test is the engine's, but it costs two runs per cell.
    """
    if not result.disagreements:
        return replace(result, knife_edges=0)
    cells = knife_edge_cells(result)
    by_cell = dict(known or {})
    missing = [c for c in cells if c not in by_cell]
    tasks = [(x0, theta0, result.settings) for x0, theta0 in missing]
    ran = run_engine(result.design, result.physics, tasks, workers=workers, progress=progress)
    by_cell.update(zip(missing, ran, strict=True))
    runs = [by_cell[c] for c in cells]
    ambiguous = result.ambiguous.copy()
    kept = []
    for k, dis in enumerate(result.disagreements):
        seated = dis.engine.outcome is Outcome.SEATED
        sides = (runs[2 * k].outcome is Outcome.SEATED, runs[2 * k + 1].outcome is Outcome.SEATED)
        if sides == (seated, seated):
            kept.append(dis)
        else:
            ambiguous[dis.index] = True
    return replace(
        result,
        ambiguous=ambiguous,
        disagreements=tuple(kept),
        knife_edges=len(result.disagreements) - len(kept),
    )


def crosscheck(
    design: FaceDesign,
    physics: Physics | None = None,
    *,
    grid: int | None = 41,
    cells: Sequence[tuple[float, float]] | None = None,
    settings: EngineSettings = DEFAULT_ENGINE,
    rounding: float = DEFAULT_ROUNDING,
    converged: bool = False,
    converge_by: str = "grid",
    workers: int | None = None,
    progress: Progress | None = None,
) -> CrosscheckResult:
    """Run xface and Chipmunk2D on the same cells and compare them.

    Parameters
    ----------
    design, physics
        The dock (default physics: the paper's, ``Physics()``).
    grid : int, default 41
        Cells of :func:`xface_core.acceptance_map`'s grid (rows x0 from -D to D, columns
        theta0 from -pi/2 to pi/2, symmetric theta grid); ignored when ``cells`` is given.
    cells : sequence of (x0, theta0), optional
        Explicit cells instead of a grid (x0 in units of D).
    settings : EngineSettings
        The engine's settings (step, slop, tolerances; see :mod:`~.scene`).
    rounding : float, default 0.002
        Corner radius (D) of each cell's second engine run.
    converged : bool
        Halve the step and the slop together until the engine's map stops changing (per
        cell: ambiguous, SEATED or a failure), at most three times; cells still changing at
        the last halving count as ambiguous.
    converge_by : {"grid", "cells"}
        With ``converged``: each halving runs every cell (``"grid"``, the default) or only
        the cells the halving before changed (``"cells"``: a cell is converged when its own
        last halving left it as it was; the first halving still runs every cell). Their
        maps are compared in docs/crosscheck.md.
    workers : int, optional
        Processes for the engine (default: one per core; 1 runs in this process).
    progress : callable(done, total, seconds), optional
        Called as engine runs finish (:func:`stderr_progress` prints an estimate).

    Examples
    --------
    >>> from xface_core import x_face
    >>> r = crosscheck(x_face(0.25, 2.0), cells=[(0.0, 0.0)], workers=1)
    >>> r.agreement, r.false_seated, r.n_ambiguous
    (1.0, 0, 0)
    """
    engine = engine_map(
        design, physics, grid=grid, cells=cells, settings=settings, rounding=rounding,
        converged=converged, converge_by=converge_by, workers=workers, progress=progress,
    )  # fmt: skip
    result = compare_with_engine(design, engine, physics)
    if converged:
        result = drop_knife_edges(result, workers=workers, progress=progress)
    return result


def _run_json(run: EngineRun) -> dict[str, object]:
    return {
        "outcome": run.outcome.name,
        "reason": run.reason,
        "phi_b": run.phi_b,
        "phi_m": run.phi_m,
        "y_m": run.y_m,
        "descent": run.descent,
        "steps": run.steps,
        "hit_budget": run.hit_budget,
    }


def result_json(result: CrosscheckResult) -> dict[str, object]:
    """The report as plain JSON types (what ``xface crosscheck --json`` prints)."""
    names = np.array([o.name for o in Outcome])
    d = result.design
    s = result.settings
    m_xface, m_engine, m_rounded = result.m_values()
    return {
        "face": d.kind,
        "h_over_d": d.h_over_d,
        "r_p": d.r_p,
        "physics": result.physics.as_dict(),
        "grid": result.grid,
        "cells": result.n_cells,
        "engine": {
            "step": s.step,
            "slop": s.slop,
            "iterations": s.iterations,
            "correction": s.correction,
            "rounding": result.rounding,
            "angle_tol": s.angle_tol,
            "position_tol": s.position_tol,
            "stall_speed": s.stall_speed,
            "max_travel": s.max_travel,
        },
        "converged": result.converged,
        "step_history": [{"step": st, "changed": n} for st, n in result.step_history],
        "converge_by": result.converge_by,
        "stall_changes": result.stall_changes,
        "knife_edges": result.knife_edges,
        "agreement": _finite_or_none(result.agreement),
        "outcome_agreement": _finite_or_none(result.outcome_agreement),
        "unambiguous": result.n_unambiguous,
        "ambiguous": result.n_ambiguous,
        "false_seated": result.false_seated,
        "false_failures": result.false_failures,
        "M": {"xface": m_xface, "engine": m_engine, "engine_rounded": m_rounded},
        "seconds": result.seconds,
        "disagreements": [
            {
                "index": g.index,
                "x0": g.x0,
                "theta0": g.theta0,
                "kind": g.kind,
                "xface": {
                    "outcome": g.xface.outcome.name,
                    "reason": g.xface.reason,
                    "phi_b": g.xface.phi_b,
                    "phi_m": g.xface.phi_m,
                    "y_m": g.xface.y_m,
                },
                "engine": _run_json(g.engine),
                "engine_rounded": _run_json(g.engine_rounded),
            }
            for g in result.disagreements
        ],
        "x0": result.x0.tolist(),
        "theta0": result.theta0.tolist(),
        "xface_outcomes": names[result.xface].tolist(),
        "engine_outcomes": names[result.engine].tolist(),
        "engine_rounded_outcomes": names[result.engine_rounded].tolist(),
        "ambiguous_cells": result.ambiguous.tolist(),
    }


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None
