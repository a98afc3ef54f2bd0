"""The typed bridge to the compiled engine: one pose with its path, or many without.

:func:`simulate_pose` runs one pose and returns a :class:`Prediction` (no margins: those
build on this module, in :mod:`xface_core.atlas.margins`); :func:`predict_batch` runs many poses of
one design. Lengths are in the design's unit (``design.width`` is D), angles in radians; the
engine works in units of D, so outcomes do not depend on the unit.
"""

from __future__ import annotations

import contextlib
import importlib.metadata
import math
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TypeVar, cast

import numba
import numpy as np
import numpy.typing as npt

from . import _engine
from ._engine import precompiled
from ._engine._stale import source_digest
from .codes import Outcome, Reason
from .contact import contact_geometry, pair_table
from .errors import InputError, XfaceValueError, is_integer_in
from .geometry import FaceDesign, x_face
from .physics import Physics, SolverSettings
from .result import AlignmentPath, Counters, Prediction

__all__ = [
    "MAX_OFFSET",
    "BatchResult",
    "EngineCalls",
    "EngineState",
    "check_pose",
    "count_engine_calls",
    "engine_digest",
    "engine_is_cached",
    "engine_model",
    "engine_options",
    "engine_state",
    "outcomes_at",
    "predict_batch",
    "run_flat",
    "simulate_pose",
    "start_height",
    "start_heights",
    "warm_up_engine",
    "xface_version",
]

FloatArray = npt.NDArray[np.float64]

#: Smallest batch share worth a thread of its own.
MIN_POSES_PER_THREAD = 64

#: Path samples allocated up front; longer paths trigger one re-run with an exact buffer
#: (inside the compiled entry).
PATH_BUFFER = 256

#: Largest accepted |x0| and |y_start|, in widths D: beyond this the geometry is absurd
#: and double precision cannot resolve the contact.
MAX_OFFSET = 1.0e6

#: Start clearance above the lowest non-overlapping height (D).
START_CLEARANCE = 0.01

#: Threads a batch uses by default (asked once: the answer does not change while we run).
DEFAULT_THREADS = os.cpu_count() or 1


def thread_count(threads: object) -> int:
    """``threads`` checked: an integer >= 1 (a numpy integer too; a bool is refused), or one
    per core for None. Raises :class:`XfaceValueError` naming the value otherwise (a float or
    a string used to end in a TypeError deep in the thread split, 0 and negatives were
    silently taken as 1)."""
    if threads is None:
        return DEFAULT_THREADS
    if is_integer_in(threads, 1):
        return int(cast(int, threads))
    raise XfaceValueError(f"threads must be an integer >= 1, got {threads!r}")


#: Most worker processes one local pool starts (``m_table``, the cross-check, a study): each
#: is a fork of a process that holds the compiled engine, so this bounds what a typo can start,
#: far above any machine's cores.
MAX_LOCAL_WORKERS = 1024


def process_count(workers: object, jobs: int | None = None) -> int:
    """The worker processes a local pool starts for ``jobs`` jobs (None: not known yet):
    ``workers`` (None: one per core), an integer in [1, :data:`MAX_LOCAL_WORKERS`] (a numpy
    integer too; a bool is refused), and never more than the jobs (a worker without a job
    would only be forked and ended: ``xface table --workers 100000`` forked until it was
    killed). Raises :class:`XfaceValueError` naming the value otherwise."""
    if workers is None:
        workers = DEFAULT_THREADS
    elif not is_integer_in(workers, 1, MAX_LOCAL_WORKERS):
        raise XfaceValueError(f"workers must be in [1, {MAX_LOCAL_WORKERS}], got {workers!r}")
    n = int(cast(int, workers))
    return n if jobs is None else max(1, min(n, jobs))


def engine_is_cached() -> bool:
    """False when the next simulation compiles the engine first (:func:`engine_state`: no
    precompiled engine serves this process and numba's cache lacks an entry point), about a
    minute of CPU; True when it loads. Kept for callers that only ask yes or no."""
    return engine_state().ready


@dataclass(frozen=True)
class EngineState:
    """Whether the compiled engine is ready for this process, and from where."""

    ready: bool
    """True: the first simulation loads the compiled engine; nothing compiles."""
    source: str
    """``"precompiled"`` (built with the install), ``"cached"`` (numba's cache, written by a
    compile on this machine) or ``"compiles"`` (the first simulation compiles it)."""
    compile_estimate_s: float
    """CPU seconds the first simulation spends compiling (0.0 when ready)."""
    why_not_precompiled: str | None = None
    """Why the install's precompiled engine does not serve this process (None when it does)."""

    def describe(self) -> str:
        """One line: ``ready (precompiled)``, ``ready (cached)`` or ``compiles on first use
        (about 60 s)``."""
        if self.ready:
            return f"ready ({self.source})"
        return f"compiles on first use (about {self.compile_estimate_s:.0f} s of CPU)"


def xface_version() -> str:
    """The installed ``xface`` distribution's version ("unknown" where it runs from a checkout
    that was never installed): what ``xface --version`` prints and a study table records."""
    try:
        return importlib.metadata.version("xface")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def engine_digest() -> str:
    """SHA-256 (hex) of the engine's sources: the digest the precompiled build's manifest
    records, so two results with the same digest came from the same engine code. A study
    table stores it (:mod:`xface_core.study.table`)."""
    return source_digest()


def engine_state() -> EngineState:
    """Where the engine's entry points would come from on their first call in this process:
    the precompiled engine of the install, numba's cache, or a compile (without simulating;
    a few milliseconds). Compiled already in this process counts as ready."""
    entries = _engine.ENTRY_POINTS
    if getattr(numba.config, "DISABLE_JIT", False):  # plain Python: nothing to compile
        return EngineState(True, "not compiled: NUMBA_DISABLE_JIT", 0.0)
    in_memory = [bool(entry.overloads) for entry in entries]
    shipped = [precompiled.has_compiled(entry, shipped=True) for entry in entries]
    cached = [precompiled.has_compiled(entry, shipped=False) for entry in entries]
    build = precompiled.shipped_build()
    why = build.problem
    if all(m or s for m, s in zip(in_memory, shipped, strict=True)):
        return EngineState(True, "precompiled", 0.0, why)
    if all(m or s or c for m, s, c in zip(in_memory, shipped, cached, strict=True)):
        return EngineState(True, "cached", 0.0, why)
    return EngineState(False, "compiles", precompiled.compile_estimate_s(build.manifest), why)


def _warm_up_steps() -> list[Callable[[], object]]:
    """One call of each entry point with the argument types the library passes, in the
    order a prediction needs them."""
    design = x_face(0.25, 1.0)
    physics = Physics()
    thetas = np.array([0.1, 0.2])
    xs = np.array([0.1, -0.2])

    def contact_points() -> object:
        return contact_geometry(design, np.zeros(1, dtype=np.int64), 0.0, 0.0, 0.0, 2.0)

    return [
        lambda: _engine.pairs.fill_extents(pair_table(design).data.copy()),
        lambda: start_height(design, 0.1),
        lambda: start_heights(design, thetas),
        lambda: simulate_pose(design, 0.1, 0.2, physics, path=False),
        lambda: simulate_pose(design, 0.1, 0.2, physics, path=True),
        lambda: run_flat(design, xs, thetas, physics, threads=1),
        contact_points,
    ]


def warm_up_engine(progress: Callable[[int, int], None] | None = None) -> None:
    """Load, or compile, every entry point of the engine before it is needed, so that the
    first real query answers at full speed; ``progress(done, total)`` after each one.

    Seconds when the engine is precompiled or cached (:func:`engine_state`), else the compile
    (about a minute of CPU). The node runs it on its worker thread while it warms up, the
    install's build runs it to make the precompiled engine."""
    steps = _warm_up_steps()
    for done, step in enumerate(steps, start=1):
        step()
        if progress is not None:
            progress(done, len(steps))


class EngineCalls:
    """What went to the engine while a :func:`count_engine_calls` block ran: ``calls`` (one
    per single pose, one per batch however large) and ``poses``."""

    def __init__(self) -> None:
        self.calls = 0
        self.poses = 0
        self._lock = threading.Lock()

    def add(self, poses: int) -> None:
        with self._lock:  # the node's margins and a batch's threads call from other threads
            self.calls += 1
            self.poses += poses


#: The counters of the :func:`count_engine_calls` blocks now running (usually none).
_COUNTERS: list[EngineCalls] = []


def _count(poses: int) -> None:
    for counter in _COUNTERS:
        counter.add(poses)


@contextlib.contextmanager
def count_engine_calls() -> Iterator[EngineCalls]:
    """Count every simulation that goes to the engine inside the block, from any module and
    thread: every single pose (:func:`simulate_pose`) and every batch (:func:`run_flat`, the
    one way to the engine for many poses: ``predict_batch``, maps, atlases, margins, seat
    probabilities). For benches and tests; outside a block it costs one list check a call.

    Examples
    --------
    >>> design = x_face(0.25, 1.0)
    >>> with count_engine_calls() as calls:
    ...     _ = simulate_pose(design, 0.1, 0.2, Physics(), path=False)
    ...     _ = run_flat(design, np.zeros(5), np.full(5, 0.1), Physics())
    >>> calls.calls, calls.poses
    (2, 6)
    """
    counter = EngineCalls()
    _COUNTERS.append(counter)
    try:
        yield counter
    finally:
        _COUNTERS.remove(counter)


def engine_model(design: FaceDesign) -> _engine.Model:
    """The engine's immutable model of a design (cached with its pair table)."""
    return pair_table(design).model


def start_heights(design: FaceDesign, theta0: npt.ArrayLike) -> FloatArray:
    """Lowest moving-pivot heights (units of D) at which the parts are clear of each other
    for any x0, plus a small clearance: the default start of the approach, per angle
    (vectorised; non-finite angles give NaN)."""
    th = np.asarray(theta0, dtype=np.float64)
    table = pair_table(design)
    flat = np.ascontiguousarray(th).reshape(-1)
    heights = _engine.start_heights_of(table.moving_vertices, table.base_top, START_CLEARANCE, flat)
    return np.asarray(heights.reshape(th.shape), dtype=np.float64)


def clear_start_height(design: FaceDesign) -> float:
    """The moving-pivot height (units of D) above which the parts are clear of each other at
    every angle and offset: from there the approach is a pure translation to the first
    contact, so a run's outcome does not depend on how much higher it starts."""
    table = pair_table(design)
    radius = float(np.hypot(table.moving_vertices[:, 0], table.moving_vertices[:, 1]).max())
    return float(table.base_top + radius + START_CLEARANCE)


def start_height(design: FaceDesign, theta0: float) -> float:
    """:func:`start_heights` for one angle (compiled: no numpy overhead per call)."""
    table = pair_table(design)
    reach = _engine.lowest_reach(table.moving_vertices, float(theta0))
    return table.base_top + reach + START_CLEARANCE


def check_pose(design: FaceDesign, x0: float, theta0: float, y_start: float | None) -> None:
    """Raise :class:`InputError` for a pose the engine cannot take (non-finite, absurd)."""
    w = design.width
    limit = MAX_OFFSET * w
    # The usual, valid pose in one expression (0.07 against 0.19 us: once per prediction);
    # anything else goes through the checks below, which name what is wrong.
    if (
        math.isfinite(x0)
        and abs(x0) <= limit
        and math.isfinite(theta0)
        and abs(theta0) <= 2.0 * math.pi
        and (y_start is None or (math.isfinite(y_start) and abs(y_start) <= limit))
    ):
        return
    for name, value in (("x0", x0), ("theta0", theta0), ("y_start", y_start)):
        if value is not None and not math.isfinite(value):
            raise InputError(f"{name} must be finite, got {value!r}")
    if abs(x0) > limit or (y_start is not None and abs(y_start) > limit):
        raise InputError(f"|x0| and |y_start| must be <= {MAX_OFFSET:g} widths")
    if abs(theta0) > 2.0 * math.pi:
        raise InputError(f"|theta0| must be <= 2 pi, got {theta0!r}")


def simulate_pose(
    design: FaceDesign,
    x0: float,
    theta0: float,
    physics: Physics,
    *,
    y_start: float | None = None,
    path: bool = True,
) -> Prediction:
    """One validated pose through the engine (see :func:`xface_core.predict`)."""
    check_pose(design, x0, theta0, y_start)
    if _COUNTERS:
        _count(1)
    w = design.width
    table = pair_table(design)
    m = table.model
    # NaN asks the engine for the default start (check_pose let no NaN through): computed
    # there, it costs no second compiled call.
    y0_given = math.nan if y_start is None else y_start / w
    x0_f = float(x0)  # also for the path: a float, so that an int x0 compiles nothing new
    # The arguments both single-pose entries share, in their order (_engine.simulate).
    pose = (
        m.pairs,
        m.base_edges,
        m.moving_edges,
        m.mated_distance,
        engine_options(physics),
        table.moving_vertices,
        table.base_top,
        START_CLEARANCE,
        x0 / w,
        float(theta0),
        y0_given,
    )
    if path:
        final, arrays = _engine.simulate_path(*pose, x0_f, w, PATH_BUFFER)
        track: AlignmentPath | None = _alignment_path(*arrays)
    else:
        final, track = _engine.simulate_final(*pose), None
    y0_d, outcome, reason, phi_b, phi_m, y_m, steps, events, changes, rejected = final
    if y_start is not None:
        y0_d = y0_given  # as given (its own type), not as the engine's float
    counters = _frozen(
        Counters, steps=steps, events=events, contact_changes=changes, rejected_steps=rejected
    )
    return _frozen(
        Prediction,
        design=design,
        x0=x0_f,
        theta0=float(theta0),
        y_start=y0_d * w,
        outcome=_OUTCOMES[outcome],
        reason=_REASON_TEXTS[reason],
        phi_b=phi_b,
        phi_m=phi_m,
        pivot_m=(x0_f, y_m * w),
        counters=counters,
        path=track,
        margins=None,
    )


def _alignment_path(
    descent: FloatArray,
    phi_b: FloatArray,
    phi_m: FloatArray,
    pivot_m: FloatArray,
    phase: npt.NDArray[np.int64],
    contact_pairs: npt.NDArray[np.int64],
) -> AlignmentPath:
    """The path from the arrays ``_engine.simulate_path`` made for it."""
    return _frozen(
        AlignmentPath,
        descent=descent,
        phi_b=phi_b,
        phi_m=phi_m,
        pivot_m=pivot_m,
        phase=phase,
        contact_pairs=contact_pairs,
    )


_T = TypeVar("_T")


def _frozen(cls: type[_T], **fields: object) -> _T:
    """An instance of the frozen dataclass ``cls`` from the values of all its fields, set
    the way unpickling and ``copy`` set them (straight into the instance's ``__dict__``):
    the generated ``__init__`` sets each field through ``object.__setattr__``, 1.2 us for
    a Prediction against 0.45 us. Only for the result types, which have no
    ``__post_init__`` and no slots (tests/core/test_simulate_pose.py checks both, and every
    field against the old constructor-built Prediction)."""
    obj = _object_new(cls)
    _object_setattr(obj, "__dict__", fields)  # the kwargs dict is ours: no copy
    return obj


_object_new = object.__new__
_object_setattr = object.__setattr__


#: Outcome members and reason texts by their engine codes (looked up, not constructed: an
#: enum call costs about 0.25 us).
_OUTCOMES: dict[int, Outcome] = {int(o): o for o in Outcome}
_REASON_TEXTS: dict[int, str] = {int(r): r.text for r in Reason}

#: Engine options of recently used physics, by identity: ``make_options`` is cached by
#: value, which hashes the Physics and its SolverSettings on every call (0.3 us for the
#: default physics, more for a new but equal one). The entry holds its Physics, so no other
#: object can have its id while the entry exists; the table is emptied when it is full.
_OPTIONS_BY_ID: dict[int, tuple[Physics, FloatArray]] = {}
_OPTIONS_BY_ID_SIZE = 32


def engine_options(physics: Physics) -> FloatArray:
    """The engine's options for ``physics`` as the single-pose entries take them: a
    read-only float64 array (:func:`xface_core._engine.option_values`)."""
    hit = _OPTIONS_BY_ID.get(id(physics))
    if hit is not None and hit[0] is physics:
        return hit[1]
    values = _engine.option_values(_engine.make_options(physics))
    if len(_OPTIONS_BY_ID) >= _OPTIONS_BY_ID_SIZE:
        _OPTIONS_BY_ID.clear()
    _OPTIONS_BY_ID[id(physics)] = (physics, values)
    return values


@dataclass(frozen=True)
class BatchResult:
    """Outcomes and final states of many poses of one design (arrays of the input's shape)."""

    outcome: npt.NDArray[np.int8]
    """Outcome codes (values of :class:`Outcome`)."""
    phi_b: FloatArray
    phi_m: FloatArray
    steps: npt.NDArray[np.int64]
    events: npt.NDArray[np.int64]


def predict_batch(
    design: FaceDesign,
    x0: npt.ArrayLike,
    theta0: npt.ArrayLike,
    *,
    physics: Physics | None = None,
    damping_ratio: float | None = None,
    friction: float | None = None,
    settings: SolverSettings | None = None,
    threads: int | None = None,
    y_start: npt.ArrayLike | None = None,
) -> BatchResult:
    """Predict many poses of one design (broadcast like numpy; no paths).

    ``y_start`` (length, broadcast with the poses) starts every pose at that height of the
    moving pivot instead of the default one just clear of the base for its angle (as
    :func:`xface_core.predict` does); a non-finite or absurd entry gives ``INVALID_INPUT``.

    ``physics`` (or, equivalently, the loose ``damping_ratio``, ``friction`` and
    ``settings``) as for :func:`xface_core.predict`. ``threads`` (an integer >= 1, else
    :class:`XfaceValueError`) splits a large batch over threads (default: one per core); the
    compiled engine releases the GIL, so they run in parallel, and every pose's result is the
    same bit for bit whatever the split.

    Non-finite or absurd entries give ``INVALID_INPUT`` in their cell instead of raising,
    like shapely's vectorised functions return NaN for missing input.

    Examples
    --------
    >>> from xface_core import v_face
    >>> r = predict_batch(v_face(0.5, 1.0), [0.0, 0.2, float("nan")], 0.1)
    >>> [Outcome(c).name for c in r.outcome]
    ['SEATED', 'SEATED', 'INVALID_INPUT']
    """
    phys = Physics.resolve(
        physics, damping_ratio=damping_ratio, friction=friction, settings=settings
    )
    shape, xs, ts, ys = _flat_poses(x0, theta0, y_start)
    w = design.width
    runs = run_flat(design, xs / w, ts, phys, threads, None if ys is None else ys / w)
    return BatchResult(
        outcome=runs["outcome"].astype(np.int8).reshape(shape),
        phi_b=runs["phi_b"].reshape(shape),
        phi_m=runs["phi_m"].reshape(shape),
        steps=runs["steps"].reshape(shape),
        events=runs["events"].reshape(shape),
    )


def outcomes_at(
    design: FaceDesign,
    x0: npt.ArrayLike,
    theta0: npt.ArrayLike,
    physics: Physics,
    *,
    threads: int | None = None,
    y_start: npt.ArrayLike | None = None,
) -> npt.NDArray[np.int8]:
    """Outcome codes of poses given in units of D: the one way the questions asked around a
    pose, of a grid or of many designs ask the engine (no path, no final state).

    ``x0`` (D) and ``theta0`` (rad), and ``y_start`` (D; None: just clear of the base for each
    angle), broadcast like numpy; the result has their shape. ``threads`` as for
    :func:`predict_batch`. Non-finite or absurd entries give ``INVALID_INPUT``. Unlike
    :func:`predict_batch` nothing is scaled by the width: a pose in D is simulated at exactly
    that pose, and a call costs no result arrays (about 25 us less, as much as a few
    simulations of a miss).

    Examples
    --------
    >>> from xface_core import Physics, v_face
    >>> codes = outcomes_at(v_face(0.5, 1.0, width=2.0), [0.0, 0.1], 0.1, Physics())
    >>> [Outcome(c).name for c in codes]
    ['SEATED', 'SEATED']
    """
    shape, xs, ts, ys = _flat_poses(x0, theta0, y_start)
    return run_flat(design, xs, ts, physics, threads, ys)["outcome"].astype(np.int8).reshape(shape)


def _flat_poses(
    x0: npt.ArrayLike, theta0: npt.ArrayLike, y_start: npt.ArrayLike | None
) -> tuple[tuple[int, ...], FloatArray, FloatArray, FloatArray | None]:
    """The broadcast shape of the poses and their flat float arrays (None: no start height)."""
    arrays = [np.asarray(a, dtype=np.float64) for a in (x0, theta0, y_start) if a is not None]
    shape = np.broadcast_shapes(*(a.shape for a in arrays))
    flat = [np.broadcast_to(a, shape).ravel() for a in arrays]
    return shape, flat[0], flat[1], flat[2] if len(flat) == 3 else None


def run_flat(
    design: FaceDesign,
    xs: FloatArray,
    ts: FloatArray,
    physics: Physics,
    threads: int | None = None,
    ys: FloatArray | None = None,
) -> npt.NDArray[np.void]:
    """The engine over flat arrays of x0 (units of D) and theta0: one ``RUN_DTYPE`` row each,
    started at the heights ``ys`` (units of D; default: just clear of the base per angle)."""
    if _COUNTERS:
        _count(len(xs))
    # The one argument type the engine is compiled for (and shipped with): C-contiguous and
    # writeable (numba types a read-only array, e.g. a broadcast view, as another type).
    xs, ts = (np.require(a, np.float64, ["C_CONTIGUOUS", "WRITEABLE"]) for a in (xs, ts))
    valid = (
        np.isfinite(xs) & np.isfinite(ts) & (np.abs(xs) <= MAX_OFFSET) & (np.abs(ts) <= 2 * np.pi)
    )
    if ys is None:
        heights = start_heights(design, ts)  # NaN for an invalid angle: any height then
        ys = np.where(np.isnan(heights), 0.0, heights)
    else:
        valid &= np.isfinite(ys) & (np.abs(ys) <= MAX_OFFSET)
        ys = np.where(valid, ys, 0.0)
    model = engine_model(design)
    opts = _engine.make_options(physics)
    n_threads = min(thread_count(threads), max(1, len(xs) // MIN_POSES_PER_THREAD))
    if n_threads == 1:
        return _engine.simulate_many(model, opts, xs, ts, ys, valid)
    # Interleaved chunks balance the load: hard poses cluster in parts of a map. Each is
    # copied into contiguous arrays: a strided view is another argument type, for which
    # numba would compile (and the install would have to ship) a second simulate_many.
    parts = [slice(k, None, n_threads) for k in range(n_threads)]
    chunks = [tuple(np.ascontiguousarray(a[p]) for a in (xs, ts, ys, valid)) for p in parts]
    with ThreadPoolExecutor(n_threads) as pool:
        results = list(pool.map(lambda c: _engine.simulate_many(model, opts, *c), chunks))
    out = np.empty(len(xs), dtype=_engine.RUN_DTYPE)
    for part, res in zip(parts, results, strict=True):
        out[part] = res
    return out
