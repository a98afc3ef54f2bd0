"""Folds of a two-contact path: where the pinned contacts reach their lowest point.

Integration can only approach a fold like sqrt(distance), so the fold is solved for directly;
a jump there skips contact detection, so it is taken only when no clear pair is cut into.
"""

from __future__ import annotations

import math

from .pairs import eval_pair, pair_at
from .records import CUT_DEPTH, FOLD_REACH, U_CORNER, FloatArray, IntArray, njit_no_refcount


@njit_no_refcount
def det3(
    m00: float, m01: float, m02: float, m10: float, m11: float, m12: float, m20: float,
    m21: float, m22: float,
) -> float:  # fmt: skip
    """Determinant of the 3 x 3 matrix with these entries (row by row)."""
    return float(
        m00 * (m11 * m22 - m12 * m21)
        - m01 * (m10 * m22 - m12 * m20)
        + m02 * (m10 * m21 - m11 * m20)
    )


@njit_no_refcount
def solve3(
    m00: float, m01: float, m02: float, m10: float, m11: float, m12: float, m20: float,
    m21: float, m22: float, b0: float, b1: float, b2: float,
) -> tuple[bool, float, float, float]:  # fmt: skip
    """Cramer's rule for the 3 x 3 system with these entries (row by row) and right side
    (numba's np.linalg would need scipy's LAPACK; scalars: nothing allocated)."""
    det = det3(m00, m01, m02, m10, m11, m12, m20, m21, m22)
    if not abs(det) > 1e-300:
        return False, 0.0, 0.0, 0.0
    x0 = det3(b0, m01, m02, b1, m11, m12, b2, m21, m22) / det
    x1 = det3(m00, b0, m02, m10, b1, m12, m20, b2, m22) / det
    x2 = det3(m00, m01, b0, m10, m11, b1, m20, m21, b2) / det
    return True, x0, x1, x2


@njit_no_refcount
def fold_residual(
    table: FloatArray, act: IntArray, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float]:
    g1, _, ab1, am1, _, _, _, _, _ = pair_at(table, act[0], pb, pm, x0, ym)
    g2, _, ab2, am2, _, _, _, _, _ = pair_at(table, act[1], pb, pm, x0, ym)
    return g1, g2, ab1 * am2 - am1 * ab2


#: Finite-difference step of the fold's Jacobian (rad, rad, D).
_FD_STEP = 1e-7


@njit_no_refcount
def solve_fold(
    table: FloatArray, act: IntArray, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float, bool]:
    """The fold of a two-contact path near (pb, pm, ym): both gaps zero and the constraint
    Jacobian in q singular, i.e. the lowest point the pinned contacts can reach.

    Integration can only approach a fold like sqrt(distance), so the end state is solved for
    directly (Newton, finite-difference Jacobian); returns (pb, pm, ym, converged), where
    converged also requires the fold within FOLD_REACH (D) of the start height. In scalars:
    the engine allocates nothing below its batch entries.
    """
    xb, xm, xy = pb, pm, ym
    for _ in range(30):
        f0, f1, f2 = fold_residual(table, act, xb, xm, x0, xy)
        if abs(f0) < 1e-14 and abs(f1) < 1e-14 and abs(f2) < 1e-12:
            # Converged, but a fold further than FOLD_REACH from the start is not this one.
            return xb, xm, xy, abs(xy - ym) < FOLD_REACH
        h = _FD_STEP
        p0, p1, p2 = fold_residual(table, act, xb + h, xm, x0, xy)
        q0, q1, q2 = fold_residual(table, act, xb, xm + h, x0, xy)
        r0, r1, r2 = fold_residual(table, act, xb, xm, x0, xy + h)
        ok, dx0, dx1, dx2 = solve3(
            (p0 - f0) / h, (q0 - f0) / h, (r0 - f0) / h,
            (p1 - f1) / h, (q1 - f1) / h, (r1 - f1) / h,
            (p2 - f2) / h, (q2 - f2) / h, (r2 - f2) / h,
            -f0, -f1, -f2,
        )  # fmt: skip
        if not ok:
            break
        xb += dx0
        xm += dx1
        xy += dx2
        finite = math.isfinite(xb) and math.isfinite(xm) and math.isfinite(xy)
        if not (finite and abs(xb - pb) < 0.1 and abs(xm - pm) < 0.1):
            break
    f0, f1, _ = fold_residual(table, act, xb, xm, x0, xy)
    ok = abs(f0) < 1e-10 and abs(f1) < 1e-10 and abs(xy - ym) < FOLD_REACH
    return xb, xm, xy, ok


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
