"""How a run records its path and ends: one sample writer, one way to end, one seat test."""

from __future__ import annotations

import math
from typing import Any

from .records import O_BAD_MATE, O_SEATED, P_END, R_SEATED, FloatArray, IntArray, njit_no_refcount

#: One row of :data:`~.records.RUN_DTYPE` (a numba record; fields by attribute).
Run = Any


@njit_no_refcount
def is_seated(pb: float, pm: float, x0: float, ym: float, L: float, tol: float) -> bool:
    """True at the mated pose: equal angles and the moving pivot where the seat puts it,
    each to ``tol`` (rad, and D per D of L)."""
    phi = 0.5 * (pb + pm)
    return (
        abs(pb - pm) <= tol
        and abs(x0 + L * math.sin(phi)) <= tol * max(1.0, L)
        and abs(ym - L * math.cos(phi)) <= tol * max(1.0, L)
    )


@njit_no_refcount
def record(
    run: Run, path: FloatArray, path_pairs: IntArray, phase: int, act: IntArray, n_act: int
) -> None:
    """Append the run's current state as a path sample, with its first ``n_act`` contacts.

    Past the end of the buffer the last row is overwritten (so it always holds the final
    state) while the count keeps growing: the caller sees the overflow and can re-run.
    """
    row = min(run.n_samples, path.shape[0] - 1)
    path[row, 0] = run.y_m
    path[row, 1] = run.phi_b
    path[row, 2] = run.phi_m
    path[row, 3] = phase
    for k in range(4):
        path_pairs[row, k] = act[k] if k < n_act else -1
    run.n_samples += 1


@njit_no_refcount
def end_run(
    run: Run,
    path: FloatArray,
    path_pairs: IntArray,
    act: IntArray,
    outcome: int,
    reason: int,
    keep_contacts: bool,
) -> None:
    """Record the final sample (with the active contacts if ``keep_contacts``) and end."""
    record(run, path, path_pairs, P_END, act, run.n_active if keep_contacts else 0)
    run.outcome = outcome
    run.reason = reason


@njit_no_refcount
def end_at_rest(
    run: Run,
    path: FloatArray,
    path_pairs: IntArray,
    act: IntArray,
    L: float,
    seat_tol: float,
    reason: int,
    keep_contacts: bool,
) -> None:
    """End where the parts came to rest: SEATED if that is the mated pose, else BAD_MATE
    for ``reason`` (jammed, friction lock, fold, below the seat)."""
    seated = is_seated(run.phi_b, run.phi_m, run.x0, run.y_m, L, seat_tol)
    if seated:
        end_run(run, path, path_pairs, act, O_SEATED, R_SEATED, keep_contacts)
    else:
        end_run(run, path, path_pairs, act, O_BAD_MATE, reason, keep_contacts)
