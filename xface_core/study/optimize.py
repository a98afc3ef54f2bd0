"""Face search: a better profile than the X-Face's, by CMA-ES over a family that contains it.

The family (:class:`ProfileFamily`) is the X-Face's, made free. Each layer's profile is a
polyline over the width D, between the base line ``y = r_p D`` and the height bound
``r_p D + H``, and *point-symmetric* about the centre of the face, ``(0, r_p D + H/2)``:
its right half is its left half turned 180 degrees. That is what makes a part mate with a
copy of itself (genderless): turned 180 degrees and put at the pivot distance
``L = 2 r_p D + H``, the copy's profile is exactly the complement of this one, with no gap
and no overlap. The left half holds ``vertices`` free vertices between ``x = -D/2`` and the
centre; the search moves them in x and y. With ``layers=2`` (the default) the second layer
is the mirror image of the first (x -> -x), as the X-Face's is, so the design is
mirror-symmetric and its maps simulate half of their poses. The X-Face is in the family
(its ramp is a polyline with every free vertex on one straight line), and the search starts
from it.

Manufacturable limits hold by construction, for every point of the search space:

- **smallest feature** ``min_feature`` (D): every edge of the profile spans at least that
  much of the width (x), so no tooth is narrower;
- **steepest wall** ``max_wall_deg``: no edge of the profile is steeper than that from the
  base line (the side walls of the part, at ``x = +-D/2``, are the part's own and vertical);
- **height bound** H: every vertex between ``r_p D`` and ``r_p D + H``.

A point of the search space is a vector in the unit box ``[0, 1]^(2 K + 1)`` (K =
``vertices``): K numbers place the free vertices in x (sorted, then spread so that every
span is at least ``min_feature``) and K + 1 numbers their heights, from ``r_p D`` (0) to
``r_p D + H`` (1), for the vertex at ``x = -D/2`` and the K free ones. The profile is built
from the centre outwards, each vertex moved as little as needed to keep its edge within
the steepest wall (which keeps it inside the height bound too): every point of the box is
a face that can be made.

The optimiser is CMA-ES (``cma``, N. Hansen's reference implementation): the objective (M
and the other criteria of :mod:`.search`) is a black box, piecewise constant in the
geometry (a count of grid cells), in 5 to 25 dimensions, evaluated in batches: CMA-ES asks
for a generation of candidates at a time (evaluated in parallel on the study executors),
ranks them (it uses only their order, so plateaus and scale do not upset it), and is the
established method for this size of problem. When it stops before the budget (it has
converged, or the objective is flat around it) it starts again from the best face found
with twice the population (IPOP-CMA-ES), until the budget of evaluations is spent.

Every evaluation is a row of a study table (:mod:`.table`, ``evaluations.parquet``), keyed
by the face's geometry digest: an interrupted search run again replays the optimiser (its
random numbers come from the seed, and its steps depend only on the scores), finds the
evaluations already made in the table, and goes on where it stopped; the result is the
same, bit for bit, as that of a search never interrupted, and the same whatever the number
of workers.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from xface_core.errors import XfaceValueError, is_integer_in, is_positive_up_to
from xface_core.geometry import FaceDesign, custom_face, x_face
from xface_core.maps.grids import ThetaGridKind
from xface_core.physics import DEFAULT_SETTINGS, Physics, SolverSettings
from xface_core.runner import process_count

from .executors import ClientLike, LocalPool, execute
from .noise import PoseNoise
from .run import DesignJob, check_study_grid, evaluate_design, load_engine_before_fork
from .search import CRITERIA, Criterion
from .space import DesignPoint, face_digest
from .table import StudyFile, study_settings

__all__ = [
    "EVALUATIONS_FILE",
    "FaceSearch",
    "ProfileFamily",
    "SearchProgress",
    "optimize_face",
]

FloatArray = npt.NDArray[np.float64]

#: The study table of a search's evaluations, in its output folder.
EVALUATIONS_FILE = "evaluations.parquet"

#: Most free vertices per half profile (41 dimensions: beyond this CMA-ES needs more
#: evaluations than a search of minutes can give, and the features shrink below use).
MAX_VERTICES = 20

#: Most evaluations of one search (each is a whole acceptance map).
MAX_BUDGET = 1_000_000

#: Steepest wall accepted (deg): a vertical inner wall has no slope to turn the faces.
MAX_WALL_DEG = 89.0

#: Below this cross product (D^2) three profile vertices are one straight edge, and the
#: middle one is dropped: a straight profile is then the X-Face's own polygon, vertex for
#: vertex (an extra vertex in the middle of an edge would only cost contact pairs).
COLLINEAR = 1e-12


@dataclass(frozen=True)
class ProfileFamily:
    """Genderless profiles between ``r_p D`` and ``r_p D + H``, point-symmetric about the
    face's centre, with ``vertices`` free vertices per half (see the module).

    Attributes
    ----------
    h_over_d : float
        Height bound H / D.
    r_p : float
        Pivot to the profile's base line, in D.
    vertices : int
        Free vertices of the left half profile (K); the search has 2 K + 1 dimensions.
    layers : int
        2: the second layer is the first's mirror image (the X-Face's arrangement); 1: one
        layer (a point-symmetric profile alone, as the S-Face).
    min_feature : float
        Smallest span of an edge across the width, in D.
    max_wall_deg : float
        Steepest edge of the profile from the base line, in degrees.

    Examples
    --------
    >>> family = ProfileFamily(0.25, 1.0, vertices=3)
    >>> family.dimension
    7
    >>> start = family.design(family.x_face_point())
    >>> [p.tolist() for p in start.base_layers] == [
    ...     p.tolist() for p in x_face(0.25, 1.0).base_layers
    ... ]
    True
    """

    h_over_d: float
    r_p: float
    vertices: int = 3
    layers: int = 2
    min_feature: float = 0.05
    max_wall_deg: float = 75.0

    def __post_init__(self) -> None:
        start = x_face(self.h_over_d, self.r_p)  # checks both as every face does
        object.__setattr__(self, "h_over_d", start.h_over_d)
        object.__setattr__(self, "r_p", start.r_p)
        if not is_integer_in(self.vertices, 1, MAX_VERTICES):
            raise XfaceValueError(
                f"vertices must be an integer in [1, {MAX_VERTICES}], got {self.vertices!r}"
            )
        if self.layers not in (1, 2) or isinstance(self.layers, bool):
            raise XfaceValueError(f"layers must be 1 or 2, got {self.layers!r}")
        spans = self.vertices + 1
        top = 0.5 / spans
        if not is_positive_up_to(self.min_feature, top) or self.min_feature == top:
            raise XfaceValueError(
                f"min_feature must be in (0, {top:.4g}) D with {self.vertices} vertices "
                f"({spans} edges share the half width D/2), got {self.min_feature!r}"
            )
        if not is_positive_up_to(self.max_wall_deg, MAX_WALL_DEG):
            raise XfaceValueError(
                f"max_wall_deg must be in (0, {MAX_WALL_DEG:g}], got {self.max_wall_deg!r}"
            )
        ramp_deg = math.degrees(math.atan(self.h_over_d))
        if ramp_deg >= self.max_wall_deg:
            raise XfaceValueError(
                f"the X-Face's ramp at H/D {self.h_over_d:g} rises at {ramp_deg:.4g} deg, not "
                f"below max_wall_deg {self.max_wall_deg:g}: the family would not contain the "
                "X-Face the search starts from; allow steeper walls or a lower H/D"
            )
        object.__setattr__(self, "min_feature", float(self.min_feature))
        object.__setattr__(self, "max_wall_deg", float(self.max_wall_deg))

    @property
    def dimension(self) -> int:
        """Numbers per point of the search space: K x positions and K + 1 heights."""
        return 2 * self.vertices + 1

    @property
    def _max_slope(self) -> float:
        return math.tan(math.radians(self.max_wall_deg))

    def _vertex_x(self, sorted_u: FloatArray) -> FloatArray:
        """The free vertices' x (D) for their sorted numbers in [0, 1]: every edge spans at
        least ``min_feature``, the rest of the half width is shared out by the numbers."""
        k, g = self.vertices, self.min_feature
        free = 0.5 - (k + 1) * g  # the half width left once every edge has its minimum span
        return -0.5 + g * np.arange(1, k + 1) + free * sorted_u

    def profile(self, point: npt.ArrayLike) -> FloatArray:
        """The first layer's profile (D, body frame, left to right) at a point of the unit
        box (clipped to it), straight runs merged into one edge."""
        u = np.clip(np.asarray(point, dtype=np.float64), 0.0, 1.0)
        if u.shape != (self.dimension,):
            raise XfaceValueError(
                f"a point of this family has {self.dimension} numbers, got {u.shape}"
            )
        k = self.vertices
        xs = np.concatenate(([-0.5], self._vertex_x(np.sort(u[:k])), [0.0]))
        wanted = self.r_p + self.h_over_d * u[k:]  # heights within the bound
        steepest = self._max_slope
        mid = self.r_p + 0.5 * self.h_over_d
        ys = np.empty(k + 2)
        ys[-1] = mid
        for i in range(k, -1, -1):  # from the centre outwards: each edge no steeper than allowed
            rise = steepest * (xs[i + 1] - xs[i])
            ys[i] = min(ys[i + 1] + rise, max(ys[i + 1] - rise, wanted[i]))
        left = np.column_stack((xs[:-1], ys[:-1]))
        # The right half: the left half turned 180 degrees about the centre (0, mid).
        right = np.column_stack((-left[::-1, 0], 2.0 * mid - left[::-1, 1]))
        return _merged(np.vstack((left, right)))

    def design(self, point: npt.ArrayLike, *, name: str | None = None) -> FaceDesign:
        """The face at ``point`` (units of D; built and checked by
        :func:`~xface_core.geometry.custom_face`)."""
        profile = self.profile(point)
        layers = [_part(profile)]
        if self.layers == 2:
            layers.append(_part(profile[::-1] * (-1.0, 1.0)))
        design = custom_face(
            layers,
            layers,
            mated_distance=2.0 * self.r_p + self.h_over_d,
            mirror_symmetric=self.layers == 2,
        )
        return design if name is None else _named(design, name)

    def x_face_point(self) -> FloatArray:
        """The point of the unit box whose face is the X-Face (evenly spread vertices on its
        ramp; with ``layers=1``, one ramp layer alone)."""
        spread = np.arange(1, self.vertices + 1) / (self.vertices + 1)
        x = self._vertex_x(spread)
        return np.concatenate((spread, [0.0], x + 0.5))  # heights on the ramp, in H

    def as_dict(self) -> dict[str, float | int]:
        """The family's settings (in the search's summary)."""
        return asdict(self)


def _merged(profile: FloatArray) -> FloatArray:
    """``profile`` without the vertices in the middle of a straight run."""
    keep = [0]
    for i in range(1, len(profile) - 1):
        a, b, c = profile[keep[-1]], profile[i], profile[i + 1]
        cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(cross) > COLLINEAR:
            keep.append(i)
    keep.append(len(profile) - 1)
    return profile[keep]


def _part(profile: FloatArray) -> FloatArray:
    """The part's polygon under a profile (left to right): down the right side wall to one
    width below the pivot, across, and up the left wall (counter-clockwise, as
    :func:`~xface_core.geometry.x_face` builds its own)."""
    return np.vstack(([0.5, -1.0], profile[::-1], [-0.5, -1.0]))


def _named(design: FaceDesign, name: str) -> FaceDesign:
    return replace(design, name=name)


class SearchProgress(NamedTuple):
    """Where a running search is: evaluations asked for so far (of the budget), the best
    score, and the seconds since this run started."""

    evaluations: int
    budget: int
    best: float
    elapsed: float


@dataclass(frozen=True)
class FaceSearch:
    """What :func:`optimize_face` found.

    ``best`` and ``start`` are study rows (:mod:`.run`: M, outcome counts, regions, seat
    probability); ``score`` is the criterion's column of ``best``.
    """

    family: ProfileFamily
    criterion: Criterion
    best_point: FloatArray
    best_design: FaceDesign
    best: dict[str, Any]
    start: dict[str, Any]
    """The row of the family's start point (:meth:`ProfileFamily.x_face_point`)."""
    x_face: dict[str, Any]
    """The row of the X-Face itself: ``start`` when the family holds it (two mirrored
    layers), else the face the gain is measured against all the same."""
    evaluations: int
    """Candidates the optimiser asked for (its budget counts these)."""
    simulated: int
    """Distinct faces simulated by this run (the rest were in the table, or repeated)."""
    restarts: int
    stop_reasons: tuple[str, ...]
    history: tuple[tuple[int, float], ...]
    """(evaluations so far, best score so far) after each generation."""
    seconds: float
    evaluation_seconds: float
    """Wall time spent simulating the faces this run (the evaluations per second's base)."""
    path: str

    @property
    def score(self) -> float:
        return float(self.best[CRITERIA[self.criterion]])

    @property
    def start_score(self) -> float:
        return float(self.start[CRITERIA[self.criterion]])

    @property
    def x_face_score(self) -> float:
        return float(self.x_face[CRITERIA[self.criterion]])


def _same_polygons(a: FaceDesign, b: FaceDesign) -> bool:
    """The same layers, vertex for vertex (a custom copy of a built-in face is not the same
    study row: its digest holds the kind, but it docks the same)."""
    if len(a.base_layers) != len(b.base_layers) or len(a.moving_layers) != len(b.moving_layers):
        return False
    pairs = [
        *zip(a.base_layers, b.base_layers, strict=True),
        *zip(a.moving_layers, b.moving_layers, strict=True),
    ]
    return all(np.array_equal(p, q) for p, q in pairs)


def _score(row: dict[str, Any], criterion: Criterion) -> float:
    value = row[CRITERIA[criterion]]
    return -math.inf if value is None else float(value)


@contextmanager
def _own_random_state(state: list[Any]) -> Iterator[None]:
    """Run a block with numpy's global generator set to ``state[0]`` and keep what it left
    there: cma draws from the global generator, and a replay after an interruption must see
    the same numbers whatever else in the process drew from it in between."""
    outer = np.random.get_state()  # noqa: NPY002 (cma draws from the legacy global one)
    np.random.set_state(state[0])  # noqa: NPY002
    try:
        yield
    finally:
        state[0] = np.random.get_state()  # noqa: NPY002
        np.random.set_state(outer)  # noqa: NPY002


def optimize_face(
    family: ProfileFamily,
    out: str | os.PathLike[str],
    *,
    criterion: Criterion = "M",
    grid: int = 41,
    theta_kind: ThetaGridKind = "symmetric",
    friction: float = 0.0,
    damping_ratio: float = 1.0,
    settings: SolverSettings = DEFAULT_SETTINGS,
    noise: PoseNoise | None = None,
    budget: int = 1500,
    popsize: int | None = None,
    sigma0: float = 0.15,
    seed: int = 1,
    executor: Executor | ClientLike | None = None,
    workers: int | None = None,
    progress: Callable[[SearchProgress], None] | None = None,
    allow_version_mix: bool = False,
) -> FaceSearch:
    """Search ``family`` for the face with the largest ``criterion`` on the pose grid, by
    CMA-ES from the X-Face, within ``budget`` evaluations (see the module).

    ``out`` is a folder: its ``evaluations.parquet`` holds every face evaluated (a study
    table, :mod:`.table`) and a search run again with the same arguments resumes from it.
    ``sigma0`` is the first step size, in units of the unit box; ``popsize`` the faces per
    generation (default CMA-ES's, 4 + 3 ln(dimension)); ``seed`` the optimiser's random
    numbers. ``executor``/``workers`` as for :func:`~.run.run_study`.

    Raises
    ------
    XfaceValueError
        Bad arguments, ``seat_probability`` without ``noise``, an unwritable ``out``, or an
        ``out`` holding another search's evaluations (another grid, noise or settings).
    """
    import cma  # the optimiser, from the study extra; imported here, where it is used

    _check_search(criterion, grid, theta_kind, noise, budget, popsize, sigma0, seed)
    Physics(damping_ratio=damping_ratio, friction=friction, settings=settings)  # validates
    process_count(workers)  # validates, before the folder is made
    folder = Path(out)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise XfaceValueError(f"cannot write the search to {folder}: {exc.strerror}") from None
    name = _family_name(family)
    start_time = time.monotonic()
    with (
        StudyFile(
            folder / EVALUATIONS_FILE,
            study_settings(grid, theta_kind, settings, noise),
            allow_version_mix=allow_version_mix,
        ) as table,
        _workers(executor, workers) as where,
    ):
        known = {row["face_digest"]: row for row in table.rows() if row["face"] == name}
        clock = _Clock()

        def evaluate(designs: Sequence[FaceDesign]) -> list[dict[str, Any]]:
            return _evaluate(designs, name, known, table, where, workers, clock, grid,
                             theta_kind, settings, noise, friction, damping_ratio)  # fmt: skip

        x_point = family.x_face_point()
        start_design = family.design(x_point)
        start = evaluate([start_design])[0]
        # The gain is against the X-Face, which a family of one layer does not hold.
        reference = x_face(family.h_over_d, family.r_p)
        x_face_row = start if _same_polygons(reference, start_design) else evaluate([reference])[0]
        best = (_score(start, criterion), x_point, start)
        history: list[tuple[int, float]] = [(0, best[0])]
        evaluations, restarts, reasons = 0, 0, []
        rng_state = [np.random.RandomState(seed).get_state()]
        size = popsize or (4 + int(3 * math.log(family.dimension)))
        while evaluations < budget:
            with _own_random_state(rng_state):
                es = cma.CMAEvolutionStrategy(
                    best[1],
                    sigma0,
                    {"bounds": [0.0, 1.0], "popsize": size, "seed": math.nan, "verbose": -9},
                )
            while evaluations < budget and not es.stop():
                with _own_random_state(rng_state):
                    points = [np.asarray(p, dtype=np.float64) for p in es.ask()]
                rows = evaluate([family.design(p) for p in points])
                scores = [_score(r, criterion) for r in rows]
                with _own_random_state(rng_state):
                    es.tell(points, [-s for s in scores])  # CMA-ES minimises
                evaluations += len(points)
                for p, s, r in zip(points, scores, rows, strict=True):
                    if s > best[0]:  # ties keep the earlier face
                        best = (s, p, r)
                history.append((evaluations, best[0]))
                if progress is not None:
                    progress(
                        SearchProgress(evaluations, budget, best[0], time.monotonic() - start_time)
                    )
            if evaluations < budget:
                reasons.append(", ".join(f"{k} {v:g}" for k, v in es.stop().items()))
                restarts += 1
                size *= 2
        table.compact()
    return FaceSearch(
        family=family,
        criterion=criterion,
        best_point=best[1],
        best_design=family.design(best[1], name=name),
        best=best[2],
        start=start,
        x_face=x_face_row,
        evaluations=evaluations,
        simulated=clock.simulated,
        restarts=restarts,
        stop_reasons=tuple(reasons),
        history=tuple(history),
        seconds=time.monotonic() - start_time,
        evaluation_seconds=clock.seconds,
        path=str(folder / EVALUATIONS_FILE),
    )


class _Clock:
    """Faces simulated by this run and the wall time it took."""

    def __init__(self) -> None:
        self.simulated = 0
        self.seconds = 0.0


def _evaluate(
    designs: Sequence[FaceDesign],
    name: str,
    known: dict[str, dict[str, Any]],
    table: StudyFile,
    where: Executor | ClientLike | LocalPool | None,
    workers: int | None,
    clock: _Clock,
    grid: int,
    theta_kind: ThetaGridKind,
    settings: SolverSettings,
    noise: PoseNoise | None,
    friction: float,
    damping_ratio: float,
) -> list[dict[str, Any]]:
    """The study row of every design: from the table when it is there, else simulated (each
    distinct face once), written to the table as it finishes."""
    digests = [face_digest(d) for d in designs]
    jobs = {}
    for digest, design in zip(digests, designs, strict=True):
        if digest not in known and digest not in jobs:
            point = DesignPoint(name, None, None, friction, damping_ratio, digest)
            jobs[digest] = DesignJob(point, design, grid, theta_kind, settings, noise)

    def keep(job: DesignJob, row: dict[str, Any]) -> None:
        table.write_row(row)
        known[job.point.face_digest] = row

    started = time.monotonic()
    execute(evaluate_design, list(jobs.values()), keep, executor=where, workers=workers)
    clock.seconds += time.monotonic() - started
    clock.simulated += len(jobs)
    return [known[d] for d in digests]


@contextmanager
def _workers(
    executor: Executor | ClientLike | None, workers: int | None
) -> Iterator[Executor | ClientLike | LocalPool | None]:
    """The caller's executor; else local processes kept for the whole search (forked after
    the engine is loaded here), or this process for one worker."""
    n = process_count(workers)
    if executor is not None or n <= 1:
        yield executor
        return
    load_engine_before_fork()
    with LocalPool(n) as pool:
        yield pool


def _family_name(family: ProfileFamily) -> str:
    """The faces' name in the table and in every output: the family, not the point."""
    layers = "mirrored pair" if family.layers == 2 else "one layer"
    return (
        f"optimized profile (H/D {family.h_over_d:g}, r_p {family.r_p:g}, {family.vertices} "
        f"vertices, {layers})"
    )


def _check_search(
    criterion: str,
    grid: int,
    theta_kind: ThetaGridKind,
    noise: PoseNoise | None,
    budget: int,
    popsize: int | None,
    sigma0: float,
    seed: int,
) -> None:
    if criterion not in CRITERIA:
        raise XfaceValueError(f"criterion must be one of {', '.join(CRITERIA)}; got {criterion!r}")
    if criterion == "seat_probability" and noise is None:
        raise XfaceValueError(
            "the seat_probability criterion needs a pose noise (sigma_x, sigma_theta)"
        )
    check_study_grid(grid, theta_kind)
    if not is_integer_in(budget, 1, MAX_BUDGET):
        raise XfaceValueError(
            f"budget must be an integer in [1, {MAX_BUDGET}] evaluations, got {budget!r}"
        )
    if popsize is not None and not is_integer_in(popsize, 2, 10_000):
        raise XfaceValueError(f"popsize must be an integer in [2, 10000], got {popsize!r}")
    if not is_positive_up_to(sigma0, 1.0):
        raise XfaceValueError(f"sigma0 must be in (0, 1] (units of the unit box), got {sigma0!r}")
    if not is_integer_in(seed, 0, 2**32 - 1):
        raise XfaceValueError(f"seed must be an integer in [0, 2**32 - 1], got {seed!r}")
