"""Folds of a two-contact path: where the pinned contacts reach their lowest point.

Integration can only approach a fold like sqrt(distance), so the fold is solved for directly;
a jump there skips contact detection, so it is taken only when no clear pair is cut into.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .pairs import eval_pair, pair_at
from .records import CUT_DEPTH, FOLD_REACH, U_CORNER, FloatArray, IntArray, njit_no_refcount


@njit_no_refcount
def det3(m: FloatArray) -> float:
    return float(
        m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
        - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
        + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0])
    )


@njit(cache=True, nogil=True)
def solve3(m: FloatArray, b0: float, b1: float, b2: float) -> tuple[bool, float, float, float]:
    """Cramer's rule for a 3 x 3 system (numba's np.linalg would need scipy's LAPACK)."""
    det = det3(m)
    if not abs(det) > 1e-300:
        return False, 0.0, 0.0, 0.0
    out = np.empty(3)
    for j in range(3):
        c = m.copy()
        c[0, j] = b0
        c[1, j] = b1
        c[2, j] = b2
        out[j] = det3(c) / det
    return True, out[0], out[1], out[2]


@njit_no_refcount
def fold_residual(
    table: FloatArray, act: IntArray, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float]:
    g1, _, ab1, am1, _, _, _, _, _ = pair_at(table, act[0], pb, pm, x0, ym)
    g2, _, ab2, am2, _, _, _, _, _ = pair_at(table, act[1], pb, pm, x0, ym)
    return g1, g2, ab1 * am2 - am1 * ab2


@njit(cache=True, nogil=True)
def solve_fold(
    table: FloatArray, act: IntArray, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float, bool]:
    """The fold of a two-contact path near (pb, pm, ym): both gaps zero and the constraint
    Jacobian in q singular, i.e. the lowest point the pinned contacts can reach.

    Integration can only approach a fold like sqrt(distance), so the end state is solved for
    directly (Newton, finite-difference Jacobian); returns (pb, pm, ym, converged), where
    converged also requires the fold within FOLD_REACH (D) of the start height.
    """
    x = np.array([pb, pm, ym])
    jac = np.empty((3, 3))
    for _ in range(30):
        f0 = np.array(fold_residual(table, act, x[0], x[1], x0, x[2]))
        if abs(f0[0]) < 1e-14 and abs(f0[1]) < 1e-14 and abs(f0[2]) < 1e-12:
            # Converged, but a fold further than FOLD_REACH from the start is not this one.
            return x[0], x[1], x[2], abs(x[2] - ym) < FOLD_REACH
        for j in range(3):
            step = 1e-7
            xp = x.copy()
            xp[j] += step
            fp = np.array(fold_residual(table, act, xp[0], xp[1], x0, xp[2]))
            jac[:, j] = (fp - f0) / step
        ok, dx0, dx1, dx2 = solve3(jac, -f0[0], -f0[1], -f0[2])
        if not ok:
            break
        x[0] += dx0
        x[1] += dx1
        x[2] += dx2
        if not (np.all(np.isfinite(x)) and abs(x[0] - pb) < 0.1 and abs(x[1] - pm) < 0.1):
            break
    f0 = np.array(fold_residual(table, act, x[0], x[1], x0, x[2]))
    ok = abs(f0[0]) < 1e-10 and abs(f0[1]) < 1e-10 and abs(x[2] - ym) < FOLD_REACH
    return x[0], x[1], x[2], ok


@njit_no_refcount
def cuts_in(
    table: FloatArray,
    g_start: FloatArray,
    thr: FloatArray,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
) -> bool:
    """True when, at (pb, pm, ym), some pair that was clear at the step start lies behind its
    edge's line (deeper than CUT_DEPTH) within the edge's span: a jump there (to a fold)
    skipped a contact.  Contacts closing exactly at a seat fold stay far shallower.  Unlike
    :func:`overlapping` this does not fire on corners that merely touch."""
    cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    for i in range(table.shape[0]):
        if g_start[i] <= thr[i]:
            continue
        g, u, _, _, _, _, _, _, _ = eval_pair(table[i], cb, sb, cm, sm, x0, ym)
        if g < thr[i] - CUT_DEPTH and -U_CORNER <= u <= 1.0 + U_CORNER:
            return True
    return False
