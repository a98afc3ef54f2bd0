"""The engine's entry points: one run as a short list of stages, many runs in a loop, and
one run for a prediction (``simulate_final``, ``simulate_path``: plain values in and out).

A run, in units of D (MuJoCo's ``mj_forwardSkip`` is the model: stage calls over an
immutable model and mutable data):

1. ``start_run``: the start pose, or an immediate end (non-finite, out of reach, overlap).
2. Per interval, ``begin_interval``: which contacts act and how the parts move, or an end
   (event budget, seated, blocked, friction lock).
3. With nothing touching, ``approach``: exact translation to the next contact, or an end.
4. Otherwise ``follow_contacts``: a smooth segment integrated to its first event, which is
   handled (and may end the run).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from .ends import Run
from .interval import approach, begin_interval, start_run
from .records import (
    O_INVALID,
    RUN_DTYPE,
    UNDECIDED,
    FloatArray,
    IntArray,
    Model,
    Options,
    Work,
    new_work,
    njit_cached,
    njit_no_refcount,
    njit_wrapper,
    reset_work,
)
from .segment import follow_contacts


@njit_no_refcount
def simulate(
    model: Model,
    opts: Options,
    x0: float,
    theta0: float,
    y_start: float,
    run: Run,
    path: FloatArray,
    path_pairs: IntArray,
    work: Work,
) -> None:
    """Simulate one dock from (x0, theta0) with the moving pivot at y_start (D, rad), in the
    scratch arrays ``work`` (fresh from :func:`new_work`, or put back by :func:`reset_work`).

    The result is left in ``run`` (a row of ``RUN_DTYPE``); ``path`` (n, 4: y_m, phi_b,
    phi_m, phase) and ``path_pairs`` (n, 4) receive the samples. Pass (1, 4) arrays to skip
    recording (only the final sample is then kept). Allocates nothing and counts no
    references (:func:`~.records.njit_no_refcount`): the entries below make the arrays.
    """
    start_run(model, opts, x0, theta0, y_start, run, work, path, path_pairs)
    while run.outcome == UNDECIDED:
        begin_interval(model, opts, run, work, path, path_pairs)
        if run.outcome != UNDECIDED:
            break
        if run.n_active == 0:
            approach(model, opts, run, work, path, path_pairs)
        else:
            follow_contacts(model, opts, run, work, path, path_pairs)


@njit_cached
def simulate_one(
    model: Model,
    opts: Options,
    x0: float,
    theta0: float,
    y_start: float,
    runs: npt.NDArray[np.void],
    path: FloatArray,
    path_pairs: IntArray,
) -> None:
    """:func:`simulate` into ``runs[0]`` (a one-row ``RUN_DTYPE`` array made in Python)."""
    simulate(model, opts, x0, theta0, y_start, runs[0], path, path_pairs, new_work(model, opts))


@njit_cached
def simulate_many(
    model: Model,
    opts: Options,
    xs: FloatArray,
    ts: FloatArray,
    ys: FloatArray,
    valid: npt.NDArray[np.bool_],
) -> npt.NDArray[np.void]:
    """:func:`simulate` over flat arrays of poses without paths; one ``RUN_DTYPE`` row per
    pose. Invalid entries end INVALID_INPUT without running (angles NaN)."""
    n = xs.shape[0]
    runs = np.zeros(n, dtype=RUN_DTYPE)
    path = np.zeros((1, 4))
    pairs = np.full((1, 4), -1, dtype=np.int64)
    work = new_work(model, opts)
    for k in range(n):
        run = runs[k]
        if not valid[k]:
            run.outcome = O_INVALID
            run.phi_b = math.nan
            run.phi_m = math.nan
            continue
        reset_work(work)
        simulate(model, opts, xs[k], ts[k], ys[k], run, path, pairs, work)
    return runs


@njit_cached
def lowest_reach(vertices: FloatArray, theta: float) -> float:
    """max over body points v of (sin theta v_x + cos theta v_y): how far the moving part,
    turned by theta, reaches below its pivot (D)."""
    s, c = math.sin(theta), math.cos(theta)
    best = -math.inf
    for k in range(vertices.shape[0]):
        best = max(best, s * vertices[k, 0] + c * vertices[k, 1])
    return best


@njit_cached
def start_heights_of(
    vertices: FloatArray, base_top: float, clearance: float, thetas: FloatArray
) -> FloatArray:
    """Per angle the lowest clear height plus ``clearance`` (D; ``runner.start_heights``,
    in the same order of operations as ``runner.start_height``); NaN for a non-finite
    angle. Compiled: a confirmation batch of eight angles cost 7.7 us in numpy."""
    out = np.empty(thetas.shape[0])
    for k in range(thetas.shape[0]):
        th = thetas[k]
        if math.isfinite(th):
            out[k] = base_top + lowest_reach(vertices, th) + clearance
        else:
            out[k] = math.nan
    return out


# ---- one pose for the typed API (xface_core.runner.simulate_pose) ------------------------
# Called once per prediction, so the Python around the kernel matters as much as the kernel
# for short runs (about 10 us). These entries take plain arrays and floats, which numba's
# dispatcher types in C (a NamedTuple argument is typed field by field in Python: about
# 1.5 us a call, 0.15 us still for a plain tuple of the 15 options), and hand back plain
# scalars and the path already in its final arrays (numpy's slicing and copying of it in
# Python cost about 4 us).


def option_values(opts: Options) -> FloatArray:
    """``opts`` as a read-only float64 array in the order of its fields, as the single-pose
    entries take it (:func:`_options` reads it back). The two integer budgets are exact as
    floats up to 2**53 steps or events, far beyond what a run can spend."""
    values = np.array(opts, dtype=np.float64)
    values.flags.writeable = False
    return values


@njit_wrapper
def _options(v: FloatArray) -> Options:
    """:class:`Options` from :func:`option_values` (of the same numba type as the NamedTuple
    made in Python, so the same compiled ``simulate`` runs)."""
    return Options(
        v[0], v[1], v[2], v[3], v[4], v[5], v[6], int(v[7]), int(v[8]),
        v[9], v[10], v[11], v[12], v[13], v[14],
    )  # fmt: skip


#: A run's end as plain values (:func:`_final_values`).
FinalValues = tuple[float, int, int, float, float, float, int, int, int, int]

#: A path as the fields of ``AlignmentPath`` (:func:`path_arrays`).
PathArrays = tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray, IntArray]


@njit_wrapper
def _start(
    vertices: FloatArray, base_top: float, clearance: float, theta0: float, y_start: float
) -> float:
    """``y_start`` (D), or if it is NaN the lowest clear height for ``theta0`` plus
    ``clearance`` (``runner.start_height``, in the same order of operations)."""
    if math.isnan(y_start):
        return base_top + lowest_reach(vertices, theta0) + clearance
    return y_start


@njit_wrapper
def _run_recorded(
    model: Model, opts: Options, x0: float, theta0: float, y_start: float, n_buf: int
) -> tuple[npt.NDArray[np.void], FloatArray, IntArray]:
    """:func:`simulate` into a new one-row ``RUN_DTYPE`` array with a path buffer of
    ``n_buf`` rows (1: no path, only the final sample). A path longer than a buffer of
    more than one row runs again with room for all of it (the engine is deterministic, so
    it is the same run). The buffer cannot grow during the run instead: the engine's
    sample writer keeps to the arrays it is given (it runs without reference counting, so
    it must not allocate), and longer paths are rare (none in 4000 random poses of each
    built-in face at the default physics; some at extreme damping ratios)."""
    runs = np.zeros(1, dtype=RUN_DTYPE)
    while True:
        path = np.empty((n_buf, 4))
        pairs = np.empty((n_buf, 4), dtype=np.int64)
        simulate(model, opts, x0, theta0, y_start, runs[0], path, pairs, new_work(model, opts))
        if n_buf == 1 or runs[0].n_samples <= n_buf:
            return runs, path, pairs
        n_buf = runs[0].n_samples


@njit_wrapper
def _run_pose(
    pairs: FloatArray, base_edges: FloatArray, moving_edges: FloatArray,
    mated_distance: float, options: FloatArray, vertices: FloatArray, base_top: float,
    clearance: float, x0: float, theta0: float, y_start: float, n_buf: int,
) -> tuple[npt.NDArray[np.void], FloatArray, IntArray, float]:  # fmt: skip
    """The single-pose entries' run: the model and options from their plain arguments, the
    start height (:func:`_start`), :func:`_run_recorded`; returns its arrays and the start
    height (D)."""
    model = Model(pairs, base_edges, moving_edges, mated_distance)
    y0 = _start(vertices, base_top, clearance, theta0, y_start)
    runs, path, path_pairs = _run_recorded(model, _options(options), x0, theta0, y0, n_buf)
    return runs, path, path_pairs, y0


@njit_wrapper
def _final_values(run: Run, y_start: float) -> FinalValues:
    """The run's end as plain values: start height and final height (D), outcome and reason
    codes, final angles (rad), counters."""
    return (
        y_start,
        run.outcome,
        run.reason,
        run.phi_b,
        run.phi_m,
        run.y_m,
        run.steps,
        run.events,
        run.contact_changes,
        run.rejected_steps,
    )


@njit_cached
def simulate_final(
    pairs: FloatArray,
    base_edges: FloatArray,
    moving_edges: FloatArray,
    mated_distance: float,
    options: FloatArray,
    vertices: FloatArray,
    base_top: float,
    clearance: float,
    x0: float,
    theta0: float,
    y_start: float,
) -> FinalValues:
    """One pose without its path: :func:`_final_values` of the run from (x0, theta0) at
    height ``y_start`` (D, rad; NaN: ``clearance`` above the lowest clear height, see
    :func:`_start`). The model's arrays as in :class:`Model`, the options from
    :func:`option_values`; ``vertices`` and ``base_top`` those of the pair table."""
    runs, _, _, y0 = _run_pose(
        pairs, base_edges, moving_edges, mated_distance, options, vertices, base_top,
        clearance, x0, theta0, y_start, 1,
    )  # fmt: skip
    return _final_values(runs[0], y0)


@njit_cached
def path_arrays(
    path: FloatArray, pairs: IntArray, n: int, x0: float, y_start: float, scale: float
) -> PathArrays:
    """The first ``n`` samples as the fields of ``AlignmentPath``: descent from ``y_start``,
    phi_B, phi_M, the moving pivot (n, 2) at offset ``x0``, phase and contact pairs.
    ``x0`` is in the caller's length unit, ``y_start`` and the path in D; lengths come out
    multiplied by ``scale`` (D in the caller's unit), as numpy computed them before."""
    descent, phi_b, phi_m = np.empty(n), np.empty(n), np.empty(n)
    pivot = np.empty((n, 2))
    phase = np.empty(n, dtype=np.int64)
    contact = np.empty((n, 4), dtype=np.int64)
    for k in range(n):
        descent[k] = (y_start - path[k, 0]) * scale
        phi_b[k] = path[k, 1]
        phi_m[k] = path[k, 2]
        pivot[k, 0] = x0
        pivot[k, 1] = path[k, 0] * scale
        phase[k] = np.int64(path[k, 3])  # as astype(int64): truncation
        for j in range(4):
            contact[k, j] = pairs[k, j]
    return descent, phi_b, phi_m, pivot, phase, contact


@njit_cached
def simulate_path(
    pairs: FloatArray,
    base_edges: FloatArray,
    moving_edges: FloatArray,
    mated_distance: float,
    options: FloatArray,
    vertices: FloatArray,
    base_top: float,
    clearance: float,
    x0: float,
    theta0: float,
    y_start: float,
    x0_length: float,
    scale: float,
    n_buf: int,
) -> tuple[FinalValues, PathArrays]:
    """:func:`simulate_final` with the path: its values and :func:`path_arrays` (``x0_length``
    is x0 in the caller's unit, ``scale`` D in it), recorded into ``n_buf`` rows first."""
    runs, path, path_pairs, y0 = _run_pose(
        pairs, base_edges, moving_edges, mated_distance, options, vertices, base_top,
        clearance, x0, theta0, y_start, n_buf,
    )  # fmt: skip
    n = min(runs[0].n_samples, path.shape[0])
    arrays = path_arrays(path, path_pairs, n, x0_length, y0, scale)
    return _final_values(runs[0], y0), arrays
