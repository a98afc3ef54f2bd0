"""The engine's entry points: one run as a short list of stages, and many runs in a loop.

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
from numba import njit

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
    new_work,
)
from .segment import follow_contacts


@njit(cache=True, nogil=True)
def simulate(
    model: Model,
    opts: Options,
    x0: float,
    theta0: float,
    y_start: float,
    run: Run,
    path: FloatArray,
    path_pairs: IntArray,
) -> None:
    """Simulate one dock from (x0, theta0) with the moving pivot at y_start (D, rad).

    The result is left in ``run`` (a row of ``RUN_DTYPE``); ``path`` (n, 4: y_m, phi_b,
    phi_m, phase) and ``path_pairs`` (n, 4) receive the samples. Pass (1, 4) arrays to skip
    recording (only the final sample is then kept).
    """
    work = new_work(model, opts)
    start_run(model, opts, x0, theta0, y_start, run, work, path, path_pairs)
    while run.outcome == UNDECIDED:
        begin_interval(model, opts, run, work, path, path_pairs)
        if run.outcome != UNDECIDED:
            break
        if run.n_active == 0:
            approach(model, opts, run, work, path, path_pairs)
        else:
            follow_contacts(model, opts, run, work, path, path_pairs)


@njit(cache=True, nogil=True)
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
    simulate(model, opts, x0, theta0, y_start, runs[0], path, path_pairs)


@njit(cache=True, nogil=True)
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
    for k in range(n):
        run = runs[k]
        if not valid[k]:
            run.outcome = O_INVALID
            run.phi_b = math.nan
            run.phi_m = math.nan
            continue
        simulate(model, opts, xs[k], ts[k], ys[k], run, path, pairs)
    return runs


@njit(cache=True, nogil=True)
def lowest_reach(vertices: FloatArray, theta: float) -> float:
    """max over body points v of (sin theta v_x + cos theta v_y): how far the moving part,
    turned by theta, reaches below its pivot (D)."""
    s, c = math.sin(theta), math.cos(theta)
    best = -math.inf
    for k in range(vertices.shape[0]):
        best = max(best, s * vertices[k, 0] + c * vertices[k, 1])
    return best
