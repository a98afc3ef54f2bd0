"""The compiled quasi-static docking kernel (numba).

One run simulates one initial pose in units of D:

1. **Approach**: translation along -y with frozen angles to the exact first contact
   (closed-form vertex-against-edge distances, no integration).
2. **Alignment and slide**: with q = (phi_B, phi_M) and descent s, each active contact i
   has a gap g_i, a gradient a_i = dg_i/dq and beta_i = dg_i/dy_M.  Overdamped frictionless
   motion is the least-dissipation rate ``v = dq/ds`` minimising ``v' W v`` subject to
   ``a_i . v >= beta_i`` (a 2-variable QP, solved by enumerating its active sets).  Between
   changes of the active set the path is a smooth ODE in s, integrated with Dormand-Prince
   5(4) and error control, projected back onto the active constraints after every step, with
   events (new contact, release, vertex leaving an edge, end conditions) located by Illinois
   root finding on the step length.
3. **End**: descent blocked (seated or jammed), no further contact (passed), or a guard.

Everything here works on plain float arrays so numba can compile it; the Python wrapper
in :mod:`xface_core.predict` turns results into typed objects.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from .contact import eval_pair

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

# ---- settings vector layout (see predict.SolverSettings) --------------------------------
S_RTOL = 0
S_ATOL = 1
S_EVENT_TOL = 2
S_TOUCH_TOL = 3
S_SEAT_TOL = 4
S_MAX_STEP = 5
S_MAX_STEPS = 6
S_MAX_EVENTS = 7
S_WINV_B = 8
S_WINV_M = 9
S_JAM_SPEED = 10
S_FIRST_STEP = 11
S_FRICTION = 12
N_SETTINGS = 13

# ---- outcome codes (values of outcome.Outcome) ------------------------------------------
O_INVALID = 0
O_OUT_OF_REACH = 1
O_NO_CONTACT = 2
O_SEATED = 3
O_BAD_MATE = 4
O_PASSED = 5
O_UNRESOLVED = 6

# ---- reason codes (texts in predict.REASONS) --------------------------------------------
R_SEATED = 0
R_JAMMED = 1
R_BELOW_SEAT = 2
R_PASSED = 3
R_NO_CONTACT = 4
R_SPUN = 5
R_SINGULAR = 6
R_STEP_LIMIT = 7
R_EVENT_LIMIT = 8
R_OVERLAP = 9
R_OUT_OF_REACH = 10
R_NONFINITE = 11
R_FRICTION_LOCK = 12

# ---- phases (values of result.Phase) ----------------------------------------------------
P_APPROACH = 0
P_ALIGN = 1
P_SLIDE = 2
P_END = 3

# ---- event kinds -------------------------------------------------------------------------
E_NONE = 0
E_CONTACT = 1
E_RELEASE = 2
E_OFF_EDGE = 3
E_BELOW_SEAT = 4
E_SPUN = 5
E_TURN = 6
E_SLIP = 7

TINY = 1e-300
# Friction state of an active contact (fric[1 + k]): sliding with the slip rate's sign, or stuck.
STICK = 2.0
ALIGN_TOL = 1e-9
U_TOL = 1e-9
U_CORNER = 1e-6  # edge-parameter slack within which a vertex meets an edge's end corner
CUT_DEPTH = 1e-7  # D: deeper than this, a jump to a fold cut into a contact
MAX_TURN = 0.02  # rad per accepted step
MAX_CAND = 16

# Dormand-Prince 5(4) tableau.
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0,
    -355.0 / 33.0,
    46732.0 / 5247.0,
    49.0 / 176.0,
    -5103.0 / 18656.0,
)
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
)


@njit(cache=True, nogil=True)
def _eval(
    table: FloatArray, i: int, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float, float, float, float, float, float, float]:
    return eval_pair(table[i], math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm), x0, ym)


@njit(cache=True, nogil=True)
def _eval_all(
    table: FloatArray, pb: float, pm: float, x0: float, ym: float, out: FloatArray
) -> None:
    cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    for i in range(table.shape[0]):
        g, u, ab, am, be, _px, _py, _nx, _ny = eval_pair(table[i], cb, sb, cm, sm, x0, ym)
        out[i, 0] = g
        out[i, 1] = u
        out[i, 2] = ab
        out[i, 3] = am
        out[i, 4] = be


@njit(cache=True, nogil=True)
def _feasible(ev: FloatArray, cand: IntArray, nc: int, vb: float, vm: float, tol: float) -> bool:
    for k in range(nc):
        j = cand[k]
        if ev[j, 2] * vb + ev[j, 3] * vm < ev[j, 4] - tol * (1.0 + abs(ev[j, 4])):
            return False
    return True


@njit(cache=True, nogil=True)
def _solve_qp(
    ev: FloatArray, cand: IntArray, nc: int, sqb: float, sqm: float, tol: float, act: IntArray
) -> tuple[int, int, float, float]:
    """Least-dissipation rate over the candidate contacts.

    Returns ``(status, n_active, v_b, v_m)``; status 1 means no descent is possible
    (the constraints are infeasible: the parts are blocked).  The QP is strictly convex in
    the scaled variables u = W^(1/2) v, so the first KKT point found is the optimum.
    """
    needs_motion = False
    for k in range(nc):
        if ev[cand[k], 4] > tol:
            needs_motion = True
    if not needs_motion:
        return 0, 0, 0.0, 0.0
    for k in range(nc):
        i = cand[k]
        b = ev[i, 4]
        if b <= 0.0:
            continue
        ab = ev[i, 2] * sqb
        am = ev[i, 3] * sqm
        nn = ab * ab + am * am
        if nn <= 1e-24:
            continue
        lam = b / nn
        vb = lam * ab * sqb
        vm = lam * am * sqm
        if _feasible(ev, cand, nc, vb, vm, tol):
            act[0] = i
            # A second contact held with zero slack (e.g. two edges lying flush) is only
            # satisfied to first order; hold it too, or the path would cut into it at second
            # order.  Holding it changes v by no more than the feasibility tolerance.
            best_j = -1
            best_det = 0.0
            for m in range(nc):
                j = cand[m]
                if j == i:
                    continue
                slack = ev[j, 2] * vb + ev[j, 3] * vm - ev[j, 4]
                if abs(slack) > tol * (1.0 + abs(ev[j, 4])):
                    continue
                ab2 = ev[j, 2] * sqb
                am2 = ev[j, 3] * sqm
                det = abs(ab * am2 - am * ab2)
                if det > 1e-9 * math.sqrt(nn * (ab2 * ab2 + am2 * am2)) and det > best_det:
                    best_det = det
                    best_j = j
            if best_j >= 0:
                act[1] = best_j
                return 0, 2, vb, vm
            return 0, 1, vb, vm
    for k in range(nc):
        i = cand[k]
        ab1 = ev[i, 2] * sqb
        am1 = ev[i, 3] * sqm
        b1 = ev[i, 4]
        for m in range(k + 1, nc):
            j = cand[m]
            ab2 = ev[j, 2] * sqb
            am2 = ev[j, 3] * sqm
            b2 = ev[j, 4]
            det = ab1 * am2 - am1 * ab2
            scale = math.sqrt((ab1 * ab1 + am1 * am1) * (ab2 * ab2 + am2 * am2))
            if abs(det) <= 1e-12 * scale or scale <= 1e-24:
                continue
            ub = (b1 * am2 - am1 * b2) / det
            um = (ab1 * b2 - b1 * ab2) / det
            l1 = (ub * am2 - ab2 * um) / det
            l2 = (ab1 * um - am1 * ub) / det
            if l1 < 0.0 or l2 < 0.0:
                continue
            vb = ub * sqb
            vm = um * sqm
            if _feasible(ev, cand, nc, vb, vm, tol):
                act[0] = i
                act[1] = j
                return 0, 2, vb, vm
    return 1, 0, 0.0, 0.0


@njit(cache=True, nogil=True)
def _tangent(
    table: FloatArray, i: int, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float]:
    """Slip of pair i: the vertex's rate along the edge's unit tangent t, relative to the edge,
    is ``c . dq/ds + gamma``.  Returns ``(c_b, c_m, gamma)``; ``c`` is also the generalised
    force of a unit force along t at the contact (on the vertex body; minus it on the other)."""
    row = table[i]
    _, _, _, _, _, px, py, nx, ny = _eval(table, i, pb, pm, x0, ym)
    # The outward normal is the tangent turned clockwise: t = (-n_y, n_x).
    tx, ty = -ny, nx
    if row[0] == 0.0:
        c_b = -(px * ty - py * tx)
        c_m = (px - x0) * ty - (py - ym) * tx
        return c_b, c_m, -ty
    c_b = px * ty - py * tx
    c_m = -((px - x0) * ty - (py - ym) * tx)
    return c_b, c_m, ty


@njit(cache=True, nogil=True)
def _velocity(
    table: FloatArray,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    sqb: float,
    sqm: float,
    fric: FloatArray,
) -> tuple[float, float, float, float]:
    """Rate dq/ds with the active set held fixed; returns (v_b, v_m, lambda_0, x) where x is
    lambda_1 for two contacts and, for one stuck contact, its tangential force tau.

    Frictionless, the rate is the least-dissipation one.  With Coulomb friction mu =
    fric[0], a sliding contact pushes along ``a - mu s c`` (s: the slip's sign, fric[1 + k]),
    a stuck one (fric[1] = STICK) adds the slip constraint ``c . v = -gamma``.  Non-finite
    rates signal a singular configuration (a contact normal through both pivots) or a
    friction lock.
    """
    mu = fric[0]
    cb0, sb0, cm0, sm0 = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    _, _, ab1, am1, b1, _, _, _, _ = eval_pair(table[act[0]], cb0, sb0, cm0, sm0, x0, ym)
    ab1 *= sqb
    am1 *= sqm
    if nact == 1:
        if mu > 0.0 and fric[1] != 0.0:
            cb, cm, gam = _tangent(table, act[0], pb, pm, x0, ym)
            cb *= sqb
            cm *= sqm
            if fric[1] == STICK:
                a11 = ab1 * ab1 + am1 * am1
                a12 = ab1 * cb + am1 * cm
                a22 = cb * cb + cm * cm
                det = a11 * a22 - a12 * a12
                if det <= 1e-24 * max(a11 * a22, TINY):
                    return math.nan, math.nan, math.nan, math.nan
                lam = (b1 * a22 + a12 * gam) / det
                tau = (-a11 * gam - a12 * b1) / det
                return (lam * ab1 + tau * cb) * sqb, (lam * am1 + tau * cm) * sqm, lam, tau
            db = ab1 - mu * fric[1] * cb
            dm = am1 - mu * fric[1] * cm
            den = ab1 * db + am1 * dm
            if den <= 1e-24:
                return math.nan, math.nan, math.nan, 0.0
            lam = b1 / den
            return lam * db * sqb, lam * dm * sqm, lam, 0.0
        nn = ab1 * ab1 + am1 * am1
        if nn <= 1e-24:
            return math.nan, math.nan, math.nan, 0.0
        lam = b1 / nn
        return lam * ab1 * sqb, lam * am1 * sqm, lam, 0.0
    _, _, ab2, am2, b2, _, _, _, _ = eval_pair(table[act[1]], cb0, sb0, cm0, sm0, x0, ym)
    ab2 *= sqb
    am2 *= sqm
    det = ab1 * am2 - am1 * ab2
    if det == 0.0:
        return math.nan, math.nan, math.nan, math.nan
    # Two contacts fix the rate; friction only changes how the load is shared.
    ub = (b1 * am2 - am1 * b2) / det
    um = (ab1 * b2 - b1 * ab2) / det
    d1b, d1m, d2b, d2m = ab1, am1, ab2, am2
    if mu > 0.0:
        c1b, c1m, _ = _tangent(table, act[0], pb, pm, x0, ym)
        c2b, c2m, _ = _tangent(table, act[1], pb, pm, x0, ym)
        d1b -= mu * fric[1] * c1b * sqb
        d1m -= mu * fric[1] * c1m * sqm
        d2b -= mu * fric[2] * c2b * sqb
        d2m -= mu * fric[2] * c2m * sqm
    det2 = d1b * d2m - d1m * d2b
    if det2 == 0.0:
        return math.nan, math.nan, math.nan, math.nan
    l1 = (ub * d2m - d2b * um) / det2
    l2 = (d1b * um - d1m * ub) / det2
    return ub * sqb, um * sqm, l1, l2


@njit(cache=True, nogil=True)
def _slip_margin(
    table: FloatArray,
    act: IntArray,
    nact: int,
    k: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    sqb: float,
    sqm: float,
    fric: FloatArray,
) -> float:
    """Positive while contact k keeps its friction state: a sliding contact keeps its slip
    direction, a stuck one keeps its tangential force inside the cone |tau| <= mu lambda."""
    vb, vm, lam, x = _velocity(table, act, nact, pb, pm, x0, ym, sqb, sqm, fric)
    if fric[1 + k] == STICK:
        return float(fric[0] * lam - abs(x))
    cb, cm, gam = _tangent(table, act[k], pb, pm, x0, ym)
    return float(fric[1 + k] * (cb * vb + cm * vm + gam))


@njit(cache=True, nogil=True)
def _project(
    table: FloatArray,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    winv_b: float,
    winv_m: float,
) -> tuple[float, float]:
    """Newton-project (phi_B, phi_M) onto the active constraints g = 0 at fixed y_M,
    along the least-dissipation metric (keeps the constraint violation at round-off)."""
    for _ in range(3):
        cb0, sb0, cm0, sm0 = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
        g1, _, ab1, am1, _, _, _, _, _ = eval_pair(table[act[0]], cb0, sb0, cm0, sm0, x0, ym)
        if nact == 1:
            nn = ab1 * ab1 * winv_b + am1 * am1 * winv_m
            if nn <= 1e-24:
                break
            lam = -g1 / nn
            pb += lam * ab1 * winv_b
            pm += lam * am1 * winv_m
            if abs(g1) < 1e-15:
                break
        else:
            g2, _, ab2, am2, _, _, _, _, _ = eval_pair(table[act[1]], cb0, sb0, cm0, sm0, x0, ym)
            m11 = ab1 * ab1 * winv_b + am1 * am1 * winv_m
            m12 = ab1 * ab2 * winv_b + am1 * am2 * winv_m
            m22 = ab2 * ab2 * winv_b + am2 * am2 * winv_m
            det = m11 * m22 - m12 * m12
            if det <= 1e-24 * (m11 * m22 + TINY):
                break
            l1 = (-g1 * m22 + g2 * m12) / det
            l2 = (-g2 * m11 + g1 * m12) / det
            pb += (l1 * ab1 + l2 * ab2) * winv_b
            pm += (l1 * am1 + l2 * am2) * winv_m
            if abs(g1) < 1e-15 and abs(g2) < 1e-15:
                break
    return pb, pm


@njit(cache=True, nogil=True)
def _rk_step(
    table: FloatArray,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    h: float,
    sqb: float,
    sqm: float,
    winv_b: float,
    winv_m: float,
    fric: FloatArray,
) -> tuple[float, float, float, float, bool]:
    """One Dormand-Prince step of length h in descent; returns (pb, pm, err_b, err_m, ok)."""
    k1b, k1m, _, _ = _velocity(table, act, nact, pb, pm, x0, ym, sqb, sqm, fric)
    k2b, k2m, _, _ = _velocity(
        table, act, nact, pb + h * A21 * k1b, pm + h * A21 * k1m, x0, ym - h / 5.0, sqb, sqm, fric
    )
    k3b, k3m, _, _ = _velocity(
        table,
        act,
        nact,
        pb + h * (A31 * k1b + A32 * k2b),
        pm + h * (A31 * k1m + A32 * k2m),
        x0,
        ym - h * 0.3,
        sqb,
        sqm,
        fric,
    )
    k4b, k4m, _, _ = _velocity(
        table,
        act,
        nact,
        pb + h * (A41 * k1b + A42 * k2b + A43 * k3b),
        pm + h * (A41 * k1m + A42 * k2m + A43 * k3m),
        x0,
        ym - h * 0.8,
        sqb,
        sqm,
        fric,
    )
    k5b, k5m, _, _ = _velocity(
        table,
        act,
        nact,
        pb + h * (A51 * k1b + A52 * k2b + A53 * k3b + A54 * k4b),
        pm + h * (A51 * k1m + A52 * k2m + A53 * k3m + A54 * k4m),
        x0,
        ym - h * (8.0 / 9.0),
        sqb,
        sqm,
        fric,
    )
    k6b, k6m, _, _ = _velocity(
        table,
        act,
        nact,
        pb + h * (A61 * k1b + A62 * k2b + A63 * k3b + A64 * k4b + A65 * k5b),
        pm + h * (A61 * k1m + A62 * k2m + A63 * k3m + A64 * k4m + A65 * k5m),
        x0,
        ym - h,
        sqb,
        sqm,
        fric,
    )
    nb = pb + h * (B1 * k1b + B3 * k3b + B4 * k4b + B5 * k5b + B6 * k6b)
    nm = pm + h * (B1 * k1m + B3 * k3m + B4 * k4m + B5 * k5m + B6 * k6m)
    k7b, k7m, _, _ = _velocity(table, act, nact, nb, nm, x0, ym - h, sqb, sqm, fric)
    eb = h * (E1 * k1b + E3 * k3b + E4 * k4b + E5 * k5b + E6 * k6b + E7 * k7b)
    em = h * (E1 * k1m + E3 * k3m + E4 * k4m + E5 * k5m + E6 * k6m + E7 * k7m)
    ok = math.isfinite(eb) and math.isfinite(em) and math.isfinite(nb) and math.isfinite(nm)
    if ok:
        # The projection's correction is part of the step's error: a large one means the
        # step left the constraint manifold (e.g. near a turning point of the contact path).
        qb, qm = _project(table, act, nact, nb, nm, x0, ym - h, winv_b, winv_m)
        eb = max(abs(eb), abs(qb - nb))
        em = max(abs(em), abs(qm - nm))
        nb, nm = qb, qm
    return nb, nm, eb, em, ok


@njit(cache=True, nogil=True)
def _event_value(
    table: FloatArray,
    kind: int,
    idx: int,
    slot: int,
    thr: float,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    sqb: float,
    sqm: float,
    y_floor: float,
    fric: FloatArray,
) -> float:
    """Signed event function: positive before the event, <= 0 once it has happened."""
    if kind == E_CONTACT:
        g, _, _, _, _, _, _, _, _ = _eval(table, idx, pb, pm, x0, ym)
        return g - thr
    if kind == E_RELEASE:
        _, _, l1, l2 = _velocity(table, act, nact, pb, pm, x0, ym, sqb, sqm, fric)
        return l1 if slot == 0 else l2
    if kind == E_OFF_EDGE:
        _, u, _, _, _, _, _, _, _ = _eval(table, idx, pb, pm, x0, ym)
        # A vertex trapped in a corner sits at u = 0 or 1 up to round-off: not an event.
        return min(u + U_TOL, 1.0 + U_TOL - u)
    if kind == E_BELOW_SEAT:
        return ym - y_floor
    if kind == E_SLIP:
        return _slip_margin(table, act, nact, slot, pb, pm, x0, ym, sqb, sqm, fric)
    # E_SPUN
    return math.pi - max(abs(pb), abs(pm))


@njit(cache=True, nogil=True)
def _is_seated(pb: float, pm: float, x0: float, ym: float, L: float, tol: float) -> bool:
    phi = 0.5 * (pb + pm)
    return (
        abs(pb - pm) <= tol
        and abs(x0 + L * math.sin(phi)) <= tol * max(1.0, L)
        and abs(ym - L * math.cos(phi)) <= tol * max(1.0, L)
    )


@njit(cache=True, nogil=True)
def _segments_cross(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> bool:
    d1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    d3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    return d1 * d2 < 0.0 and d3 * d4 < 0.0


@njit(cache=True, nogil=True)
def _inside(px: float, py: float, edges: FloatArray, layer: float, rot: FloatArray) -> bool:
    """Even-odd point-in-polygon test against the world edges of one layer."""
    inside = False
    for k in range(edges.shape[0]):
        if edges[k, 4] != layer:
            continue
        x1, y1, x2, y2 = rot[k, 0], rot[k, 1], rot[k, 2], rot[k, 3]
        if (y1 > py) != (y2 > py):
            xc = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
            if px < xc:
                inside = not inside
    return inside


@njit(cache=True, nogil=True)
def _world_edges(
    edges: FloatArray, moving: bool, pb: float, pm: float, x0: float, ym: float
) -> FloatArray:
    out = np.empty((edges.shape[0], 4))
    if moving:
        c, s = math.cos(pm), math.sin(pm)
        for k in range(edges.shape[0]):
            for j in range(2):
                x, y = edges[k, 2 * j], edges[k, 2 * j + 1]
                out[k, 2 * j] = x0 - (c * x - s * y)
                out[k, 2 * j + 1] = ym - (s * x + c * y)
    else:
        c, s = math.cos(pb), math.sin(pb)
        for k in range(edges.shape[0]):
            for j in range(2):
                x, y = edges[k, 2 * j], edges[k, 2 * j + 1]
                out[k, 2 * j] = c * x - s * y
                out[k, 2 * j + 1] = s * x + c * y
    return out


@njit(cache=True, nogil=True)
def overlapping(
    base_edges: FloatArray,
    moving_edges: FloatArray,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
) -> bool:
    """True when the parts interpenetrate in some layer (edges cross or a vertex is inside)."""
    wb = _world_edges(base_edges, False, pb, pm, x0, ym)
    wm = _world_edges(moving_edges, True, pb, pm, x0, ym)
    for i in range(wb.shape[0]):
        for j in range(wm.shape[0]):
            if base_edges[i, 4] != moving_edges[j, 4]:
                continue
            if _segments_cross(
                wb[i, 0], wb[i, 1], wb[i, 2], wb[i, 3], wm[j, 0], wm[j, 1], wm[j, 2], wm[j, 3]
            ):
                return True
    for j in range(wm.shape[0]):
        if _inside(wm[j, 0], wm[j, 1], base_edges, moving_edges[j, 4], wb):
            return True
    for i in range(wb.shape[0]):
        if _inside(wb[i, 0], wb[i, 1], moving_edges, base_edges[i, 4], wm):
            return True
    return False


@njit(cache=True, nogil=True)
def _next_contact(ev: FloatArray, touch_tol: float) -> tuple[float, int]:
    """Exact descent to the next contact under pure translation; (inf, -1) when none.

    Along the approach the gap of every pair falls linearly: g(d) = g - beta d.
    """
    best = math.inf
    best_i = -1
    utol = 1e-12
    for i in range(ev.shape[0]):
        g, u, be = ev[i, 0], ev[i, 1], ev[i, 4]
        if be <= 1e-14 or g <= touch_tol:
            continue
        d = g / be
        if d >= best:
            continue
        # The edge parameter moves linearly too; recompute it at the hit.
        # du/dd follows from the vertical motion of the vertex relative to the edge.
        u_hit = u + d * ev[i, 5]
        if -utol <= u_hit <= 1.0 + utol:
            best = d
            best_i = i
    return best, best_i


@njit(cache=True, nogil=True)
def _fill_u_rate(table: FloatArray, pb: float, pm: float, ev: FloatArray) -> None:
    """Column 5 of ev: du/dd of each pair under pure descent (vertex moves -y relative to
    a base edge, +y relative to a moving edge)."""
    cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    for i in range(table.shape[0]):
        row = table[i]
        if row[0] == 0.0:
            dx = cb * (row[5] - row[3]) - sb * (row[6] - row[4])
            dy = sb * (row[5] - row[3]) + cb * (row[6] - row[4])
            sign = -1.0
        else:
            dx = -(cm * (row[5] - row[3]) - sm * (row[6] - row[4]))
            dy = -(sm * (row[5] - row[3]) + cm * (row[6] - row[4]))
            sign = 1.0
        ev[i, 5] = sign * dy / (dx * dx + dy * dy)


@njit(cache=True, nogil=True)
def _record(
    path: FloatArray,
    pairs: IntArray,
    n: int,
    ym: float,
    pb: float,
    pm: float,
    phase: int,
    act: IntArray,
    nact: int,
) -> int:
    # Past the end of the buffer the last row is overwritten (so it always holds the final
    # state) while the count keeps growing: the caller sees the overflow and can re-run.
    row = min(n, path.shape[0] - 1)
    path[row, 0] = ym
    path[row, 1] = pb
    path[row, 2] = pm
    path[row, 3] = phase
    for k in range(4):
        pairs[row, k] = act[k] if k < nact else -1
    return n + 1


@njit(cache=True, nogil=True)
def _touching(
    ev: FloatArray, touch_tol: float, exclude: IntArray, n_ex: int, cand: IntArray
) -> int:
    utol = U_CORNER
    nc = 0
    for i in range(ev.shape[0]):
        # Events stop a crossing just past its threshold (-touch_tol for pairs already
        # touching), so the window reaches a little below -touch_tol.
        g = ev[i, 0]
        if g > touch_tol or g < -4.0 * touch_tol or ev[i, 1] < -utol or ev[i, 1] > 1.0 + utol:
            continue
        skip = False
        for k in range(n_ex):
            if exclude[k] == i:
                skip = True
        if skip or nc >= cand.shape[0]:
            continue
        cand[nc] = i
        nc += 1
    return nc


@njit(cache=True, nogil=True)
def _corners_hold(
    table: FloatArray,
    corner: IntArray,
    n_corner: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    vb: float,
    vm: float,
) -> bool:
    """True when a short trial move along the rate leaves no corner pair penetrating.

    A vertex penetrates an edge only if it lies behind the edge's line *and* within the
    edge's span; near a convex corner this is the exact local non-penetration test.
    """
    dd = 1e-7
    for k in range(n_corner):
        g0, _, _, _, _, _, _, _, _ = _eval(table, corner[k], pb, pm, x0, ym)
        g, u, _, _, _, _, _, _, _ = _eval(table, corner[k], pb + dd * vb, pm + dd * vm, x0, ym - dd)
        # Compare with where the pair starts: events leave gaps of +-event_tol behind, and
        # the trial move's second-order drift is ~dd^2; a real cut shrinks g by ~dd.
        if g < min(g0, 0.0) - 1e-11 and -U_CORNER <= u <= 1.0 + U_CORNER:
            return False
    return True


@njit(cache=True, nogil=True)
def _choose_motion(
    table: FloatArray,
    ev: FloatArray,
    cand: IntArray,
    nc: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    sqb: float,
    sqm: float,
    act: IntArray,
) -> tuple[int, int, float, float]:
    """Least-dissipation rate with corner contacts treated as alternatives.

    A vertex touching an edge inside its span is a hard constraint.  A vertex touching at an
    edge's end (two corners meeting) is only one of several ways to stay apart: the
    admissible motions form a union, so each alternative is tried on top of the hard
    constraints and the admissible one of least dissipation wins.
    """
    hard = np.empty(nc + 2, dtype=np.int64)
    corner = np.empty(nc, dtype=np.int64)
    nh = 0
    n_corner = 0
    for k in range(nc):
        i = cand[k]
        u = ev[i, 1]
        if U_TOL < u < 1.0 - U_TOL:
            hard[nh] = i
            nh += 1
        else:
            # Pairs just beyond an edge's end are only checked for penetration; they are
            # never held (holding them would slide them off at once).
            corner[n_corner] = i
            n_corner += 1
    n_alt = 0
    alt = np.empty(n_corner, dtype=np.int64)
    for k in range(n_corner):
        u = ev[corner[k], 1]
        if -U_TOL <= u <= 1.0 + U_TOL:
            alt[n_alt] = corner[k]
            n_alt += 1
    status, nact, vb, vm = _solve_qp(ev, hard, nh, sqb, sqm, 1e-9, act)
    if n_corner == 0:
        return status, nact, vb, vm
    trial = np.full(4, -1, dtype=np.int64)
    best = math.inf
    best_n = 0
    best_vb = 0.0
    best_vm = 0.0
    found = False
    if status == 0 and _corners_hold(table, corner, n_corner, pb, pm, x0, ym, vb, vm):
        found = True
        best = (vb * vb if sqb > 0.0 else 0.0) / max(sqb * sqb, TINY) + vm * vm / (sqm * sqm)
        best_n, best_vb, best_vm = nact, vb, vm
    for extra in range(1, 3):
        if found:
            break
        for a in range(n_alt):
            for b in range(a, n_alt):
                if (extra == 1 and b != a) or (extra == 2 and b == a):
                    continue
                hard[nh] = alt[a]
                hard[nh + 1] = alt[b]
                st, na, tb, tm = _solve_qp(ev, hard, nh + extra, sqb, sqm, 1e-9, trial)
                if st != 0 or not _corners_hold(table, corner, n_corner, pb, pm, x0, ym, tb, tm):
                    continue
                cost = (tb * tb if sqb > 0.0 else 0.0) / max(sqb * sqb, TINY) + tm * tm / (
                    sqm * sqm
                )
                if cost < best:
                    found = True
                    best = cost
                    best_n, best_vb, best_vm = na, tb, tm
                    for k in range(4):
                        act[k] = trial[k]
    if not found:
        return 1, 0, 0.0, 0.0
    return 0, best_n, best_vb, best_vm


@njit(cache=True, nogil=True)
def _det3(m: FloatArray) -> float:
    return float(
        m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
        - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
        + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0])
    )


@njit(cache=True, nogil=True)
def _solve3(m: FloatArray, b0: float, b1: float, b2: float) -> tuple[bool, float, float, float]:
    """Cramer's rule for a 3 x 3 system (numba's np.linalg would need scipy's LAPACK)."""
    det = _det3(m)
    if not abs(det) > 1e-300:
        return False, 0.0, 0.0, 0.0
    out = np.empty(3)
    for j in range(3):
        c = m.copy()
        c[0, j] = b0
        c[1, j] = b1
        c[2, j] = b2
        out[j] = _det3(c) / det
    return True, out[0], out[1], out[2]


@njit(cache=True, nogil=True)
def _fold_residual(
    table: FloatArray, act: IntArray, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float]:
    g1, _, ab1, am1, _, _, _, _, _ = _eval(table, act[0], pb, pm, x0, ym)
    g2, _, ab2, am2, _, _, _, _, _ = _eval(table, act[1], pb, pm, x0, ym)
    return g1, g2, ab1 * am2 - am1 * ab2


@njit(cache=True, nogil=True)
def _solve_fold(
    table: FloatArray, act: IntArray, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float, bool]:
    """The fold of a two-contact path near (pb, pm, ym): both gaps zero and the constraint
    Jacobian in q singular, i.e. the lowest point the pinned contacts can reach.

    Integration can only approach a fold like sqrt(distance), so the end state is solved for
    directly (Newton, finite-difference Jacobian); returns (pb, pm, ym, converged).
    """
    x = np.array([pb, pm, ym])
    jac = np.empty((3, 3))
    for _ in range(30):
        f0 = np.array(_fold_residual(table, act, x[0], x[1], x0, x[2]))
        if abs(f0[0]) < 1e-14 and abs(f0[1]) < 1e-14 and abs(f0[2]) < 1e-12:
            return x[0], x[1], x[2], True
        for j in range(3):
            step = 1e-7
            xp = x.copy()
            xp[j] += step
            fp = np.array(_fold_residual(table, act, xp[0], xp[1], x0, xp[2]))
            jac[:, j] = (fp - f0) / step
        ok, dx0, dx1, dx2 = _solve3(jac, -f0[0], -f0[1], -f0[2])
        if not ok:
            break
        x[0] += dx0
        x[1] += dx1
        x[2] += dx2
        if not (np.all(np.isfinite(x)) and abs(x[0] - pb) < 0.1 and abs(x[1] - pm) < 0.1):
            break
    f0 = np.array(_fold_residual(table, act, x[0], x[1], x0, x[2]))
    ok = abs(f0[0]) < 1e-10 and abs(f0[1]) < 1e-10 and abs(x[2] - ym) < 1e-3
    return x[0], x[1], x[2], ok


@njit(cache=True, nogil=True)
def _friction_modes(
    table: FloatArray,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    sqb: float,
    sqm: float,
    fric: FloatArray,
    v0b: float,
    v0m: float,
) -> bool:
    """Choose each active contact's friction state (fric[1 + k]); False for a friction lock.

    The active set is the frictionless one (least dissipation); friction then sets the motion
    within it. One contact: slide in the direction the frictionless motion slips, else the
    other way, else stick; each must be consistent (lambda >= 0, the slip keeps its sign, a
    stuck contact's force inside the cone). Quasi-static Coulomb problems can admit several
    consistent states; this order picks one deterministically. Two contacts fix the rate, so
    each slips the way that rate makes it slip.
    """
    fric[1] = 0.0
    fric[2] = 0.0
    if nact == 2:
        for k in range(2):
            cb, cm, gam = _tangent(table, act[k], pb, pm, x0, ym)
            slip = cb * v0b + cm * v0m + gam
            fric[1 + k] = 0.0 if abs(slip) < 1e-12 else math.copysign(1.0, slip)
        return True
    cb, cm, gam = _tangent(table, act[0], pb, pm, x0, ym)
    slip0 = cb * v0b + cm * v0m + gam
    first = 1.0 if slip0 >= 0.0 else -1.0
    dd = 1e-7
    for mode in (first, -first, STICK):
        fric[1] = mode
        vb, vm, lam, _ = _velocity(table, act, nact, pb, pm, x0, ym, sqb, sqm, fric)
        if not (math.isfinite(vb) and math.isfinite(vm) and lam >= 0.0):
            continue
        # Judge the state a short move ahead: at a stick-slip transition the state at the
        # point itself is marginal, and the wrong choice would fire its event at once.
        qb, qm, yy = pb + dd * vb, pm + dd * vm, ym - dd
        wb, wm, lam2, x2 = _velocity(table, act, nact, qb, qm, x0, yy, sqb, sqm, fric)
        if not (math.isfinite(wb) and math.isfinite(wm) and lam2 >= 0.0):
            continue
        if mode == STICK:
            if abs(x2) <= fric[0] * lam2:
                return True
        else:
            tb, tm, tg = _tangent(table, act[0], qb, qm, x0, yy)
            if mode * (tb * wb + tm * wm + tg) >= 0.0:
                return True
    fric[1] = 0.0
    return False


@njit(cache=True, nogil=True)
def _cuts_in(
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


@njit(cache=True, nogil=True)
def simulate(
    table: FloatArray,
    base_edges: FloatArray,
    moving_edges: FloatArray,
    L: float,
    x0: float,
    theta0: float,
    y_start: float,
    settings: FloatArray,
    path: FloatArray,
    path_pairs: IntArray,
) -> tuple[int, int, float, float, float, int, int, int, int, int]:
    """Simulate one dock in units of D.

    Returns ``(outcome, reason, phi_b, phi_m, y_m, steps, events, contact_changes,
    rejected_steps, n_samples)``.  ``path`` (n, 4: y_m, phi_b, phi_m, phase) and
    ``path_pairs`` (n, 4) receive the samples; pass (1, 4) arrays to skip recording
    (only the final sample is then kept).
    """
    rtol = settings[S_RTOL]
    atol = settings[S_ATOL]
    event_tol = settings[S_EVENT_TOL]
    touch_tol = settings[S_TOUCH_TOL]
    seat_tol = settings[S_SEAT_TOL]
    max_step = settings[S_MAX_STEP]
    max_steps = int(settings[S_MAX_STEPS])
    max_events = int(settings[S_MAX_EVENTS])
    winv_b = settings[S_WINV_B]
    winv_m = settings[S_WINV_M]
    jam_speed = settings[S_JAM_SPEED]
    sqb = math.sqrt(winv_b)
    sqm = math.sqrt(winv_m)
    # fric[0]: Coulomb coefficient; fric[1 + k]: friction state of active contact k.
    fric = np.zeros(3)
    fric[0] = settings[S_FRICTION]
    # The trial step's start and the solver constants, for event searches.
    step = np.zeros(11)

    pb = 0.0
    pm = theta0
    ym = y_start
    steps = 0
    events = 0
    changes = 0
    rejected = 0
    n = 0
    act = np.full(4, -1, dtype=np.int64)
    nact = 0
    no_act = np.full(4, -1, dtype=np.int64)

    if not (
        math.isfinite(x0) and math.isfinite(theta0) and math.isfinite(y_start) and math.isfinite(L)
    ):
        return O_INVALID, R_NONFINITE, pb, pm, ym, 0, 0, 0, 0, 0
    if abs(x0) > L:
        n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
        return O_OUT_OF_REACH, R_OUT_OF_REACH, pb, pm, ym, 0, 0, 0, 0, n
    if overlapping(base_edges, moving_edges, pb, pm, x0, ym):
        n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
        return O_INVALID, R_OVERLAP, pb, pm, ym, 0, 0, 0, 0, n

    npairs = table.shape[0]
    ev = np.empty((npairs, 6))
    # Gap and edge parameter of every pair at the start and at the end of the trial step.
    g_prev = np.empty(npairs)
    u_prev = np.empty(npairs)
    g_next = np.empty(npairs)
    u_next = np.empty(npairs)
    thr = np.zeros(npairs)
    cand = np.empty(MAX_CAND, dtype=np.int64)
    # Pairs released or slid off at the current point; kept out of the touching set until
    # the path makes progress, so a corner touching several features cannot cycle.
    exclude = np.full(8, -1, dtype=np.int64)
    n_ex = 0
    y_floor = math.sqrt(L * L - x0 * x0) - seat_tol * max(1.0, L)
    step[2] = x0
    step[5] = sqb
    step[6] = sqm
    step[7] = winv_b
    step[8] = winv_m
    step[9] = y_floor
    step[10] = event_tol
    had_contact = False
    n = _record(path, path_pairs, n, ym, pb, pm, P_APPROACH, act, 0)
    h = settings[S_FIRST_STEP]

    while True:
        if events >= max_events:
            n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, nact)
            return O_UNRESOLVED, R_EVENT_LIMIT, pb, pm, ym, steps, events, changes, rejected, n
        # ---- start of an interval: which contacts act, and how do the parts move? ----------
        if had_contact and _is_seated(pb, pm, x0, ym, L, seat_tol):
            # At the mated pose (to the seat tolerance) nothing is left to decide; going on
            # would only follow round-off around the seat's corners.
            n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
            return O_SEATED, R_SEATED, pb, pm, ym, steps, events, changes, rejected, n
        _eval_all(table, pb, pm, x0, ym, ev)
        nc = _touching(ev, touch_tol, exclude, n_ex, cand)
        status, new_nact, v0b, v0m = _choose_motion(
            table, ev, cand, nc, pb, pm, x0, ym, sqb, sqm, act
        )
        if status == 0 and new_nact == 1 and fric[0] > 0.0:
            # Friction turns the rate away from the frictionless one: a touching contact that
            # the frictionless rate cleared may now be cut into.  Hold it as well.
            if _friction_modes(table, act, 1, pb, pm, x0, ym, sqb, sqm, fric, v0b, v0m):
                fb, fm, _, _ = _velocity(table, act, 1, pb, pm, x0, ym, sqb, sqm, fric)
                worst = 0.0
                for k in range(nc):
                    j = cand[k]
                    if j == act[0]:
                        continue
                    short = ev[j, 4] - (ev[j, 2] * fb + ev[j, 3] * fm)
                    if short > 1e-9 * (1.0 + abs(ev[j, 4])) and short > worst:
                        worst = short
                        act[1] = j
                if worst > 0.0:
                    new_nact = 2
                    # Two contacts fix the rate; the frictionless one is the same rate.
                    v0b, v0m, _, _ = _velocity(table, act, 2, pb, pm, x0, ym, sqb, sqm, fric)
        if status == 0 and new_nact > 0 and fric[0] > 0.0:
            if not _friction_modes(table, act, new_nact, pb, pm, x0, ym, sqb, sqm, fric, v0b, v0m):
                # Friction locks the contact: no admissible slip state lets the parts descend.
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
                if _is_seated(pb, pm, x0, ym, L, seat_tol):
                    return O_SEATED, R_SEATED, pb, pm, ym, steps, events, changes, rejected, n
                return O_BAD_MATE, R_FRICTION_LOCK, pb, pm, ym, steps, events, changes, rejected, n
        if status == 1:
            # Blocked: no descent is possible any more.
            n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
            if _is_seated(pb, pm, x0, ym, L, seat_tol):
                return O_SEATED, R_SEATED, pb, pm, ym, steps, events, changes, rejected, n
            return O_BAD_MATE, R_JAMMED, pb, pm, ym, steps, events, changes, rejected, n
        if new_nact != nact:
            changes += 1
        nact = new_nact
        if nact == 0:
            # Free descent: translate exactly to the next contact.
            _fill_u_rate(table, pb, pm, ev)
            d, _ = _next_contact(ev, touch_tol)
            if not math.isfinite(d):
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
                if had_contact:
                    return O_PASSED, R_PASSED, pb, pm, ym, steps, events, changes, rejected, n
                return O_NO_CONTACT, R_NO_CONTACT, pb, pm, ym, steps, events, changes, rejected, n
            if ym - d < y_floor:
                ym = y_floor
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, 0)
                return O_BAD_MATE, R_BELOW_SEAT, pb, pm, ym, steps, events, changes, rejected, n
            ym -= d
            if d > 1e-7:
                n_ex = 0
            events += 1
            had_contact = True
            n = _record(path, path_pairs, n, ym, pb, pm, P_APPROACH, act, 0)
            continue
        # ---- integrate with the active set fixed until the next event ----------------------
        # Start exactly on the active constraints (events leave gaps of up to the touching
        # tolerance); the step error then measures only the step's own drift.
        qb, qm = _project(table, act, nact, pb, pm, x0, ym, winv_b, winv_m)
        if max(abs(qb - pb), abs(qm - pm)) < 1e-6:
            pb, pm = qb, qm
        _eval_all(table, pb, pm, x0, ym, ev)
        for i in range(npairs):
            g = ev[i, 0]
            thr[i] = min(g, 0.0) - touch_tol if -4.0 * touch_tol <= g <= touch_tol else 0.0
            g_prev[i] = g
            u_prev[i] = ev[i, 1]
        phase = P_SLIDE if abs(pb - pm) <= ALIGN_TOL else P_ALIGN
        n = _record(path, path_pairs, n, ym, pb, pm, phase, act, nact)
        while True:
            if steps >= max_steps:
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, nact)
                return O_UNRESOLVED, R_STEP_LIMIT, pb, pm, ym, steps, events, changes, rejected, n
            h = min(h, max_step)
            nb, nm, eb, em, ok = _rk_step(
                table, act, nact, pb, pm, x0, ym, h, sqb, sqm, winv_b, winv_m, fric
            )
            if ok:
                sc_b = atol + rtol * max(abs(pb), abs(nb))
                sc_m = atol + rtol * max(abs(pm), abs(nm))
                err = max(abs(eb) / sc_b, abs(em) / sc_m)
                turn = max(abs(nb - pb), abs(nm - pm))
                # Cap the rotation per step: near a turning point of the contact path the rate
                # grows without bound and a long step could jump across thin features.
                if turn > MAX_TURN or turn > jam_speed * h:
                    ok = False
                    err = math.inf
            else:
                err = math.inf
            if err > 1.0:
                rejected += 1
                if h <= event_tol:
                    # The rate diverges: the contacts reach a turning point (a contact normal
                    # through both pivots).  The seat itself is such a point.
                    if nact == 2:
                        fb, fm, fy, conv = _solve_fold(table, act, pb, pm, x0, ym)
                        # The jump to the fold skips contact detection: take it only when
                        # the parts are still apart there.
                        if conv and fy <= ym and not _cuts_in(table, g_prev, thr, fb, fm, x0, fy):
                            pb, pm, ym = fb, fm, fy
                    n = _record(path, path_pairs, n, ym, pb, pm, P_END, act, nact)
                    if _is_seated(pb, pm, x0, ym, L, seat_tol):
                        return O_SEATED, R_SEATED, pb, pm, ym, steps, events, changes, rejected, n
                    return O_BAD_MATE, R_SINGULAR, pb, pm, ym, steps, events, changes, rejected, n
                h = max(h * max(0.2, 0.9 * err**-0.2), 0.5 * event_tol) if ok else h * 0.25
                continue
            # ---- events in this step? ------------------------------------------------------
            ev_kind = E_NONE
            ev_idx = -1
            ev_h = h
            ym1 = ym - h
            step[0] = pb
            step[1] = pm
            step[3] = ym
            step[4] = h
            # active contacts: release (lambda < 0) and leaving the edge
            _, _, l1, l2 = _velocity(table, act, nact, nb, nm, x0, ym1, sqb, sqm, fric)
            for k in range(nact):
                lam = l1 if k == 0 else l2
                if lam < 0.0:
                    lo, hk = _locate_in_step(
                        table, E_RELEASE, act[k], k, 0.0, act, nact, step, fric
                    )
                    kind = E_RELEASE
                    pbk, pmk, _, _, _ = _rk_step(
                        table, act, nact, pb, pm, x0, ym, lo, sqb, sqm, winv_b, winv_m, fric
                    )
                    _, _, m1, m2 = _velocity(
                        table, act, nact, pbk, pmk, x0, ym - lo, sqb, sqm, fric
                    )
                    _, _, s1, s2 = _velocity(table, act, nact, pb, pm, x0, ym, sqb, sqm, fric)
                    if abs(m1 if k == 0 else m2) > 1e-6 * max(1.0, abs(s1 if k == 0 else s2)):
                        # lambda changed sign through a pole, not through zero: the contact
                        # path turns back here and cannot descend further.
                        kind = E_TURN
                        hk = lo
                    if hk < ev_h or ev_kind == E_NONE:
                        ev_kind, ev_idx, ev_h = kind, act[k], hk
                _, u, _, _, _, _, _, _, _ = _eval(table, act[k], nb, nm, x0, ym1)
                if u < -U_TOL or u > 1.0 + U_TOL:
                    _, hk = _locate_in_step(
                        table, E_OFF_EDGE, act[k], k, 0.0, act, nact, step, fric
                    )
                    if hk < ev_h or ev_kind == E_NONE:
                        ev_kind, ev_idx, ev_h = E_OFF_EDGE, act[k], hk
            # friction: a sliding contact stops or reverses, a stuck one starts to slide
            if fric[0] > 0.0:
                for k in range(nact):
                    if fric[1 + k] == 0.0:
                        continue
                    if _slip_margin(table, act, nact, k, nb, nm, x0, ym1, sqb, sqm, fric) < 0.0:
                        _, hk = _locate_in_step(
                            table, E_SLIP, act[k], k, 0.0, act, nact, step, fric
                        )
                        if hk < ev_h or ev_kind == E_NONE:
                            ev_kind, ev_idx, ev_h = E_SLIP, act[k], hk
            # inactive pairs: new contacts (the gap crosses its threshold inside the edge)
            cache_h = -1.0
            cache_b = pb
            cache_m = pm
            early_h = -1.0
            early_b = pb
            early_m = pm
            cb1, sb1, cm1, sm1 = math.cos(nb), math.sin(nb), math.cos(nm), math.sin(nm)
            for i in range(npairs):
                g1, u1, _, _, _, _, _, _, _ = eval_pair(table[i], cb1, sb1, cm1, sm1, x0, ym1)
                g_next[i] = g1
                u_next[i] = u1
                if (nact > 0 and act[0] == i) or (nact > 1 and act[1] == i):
                    continue
                if g1 > thr[i] or g_prev[i] <= thr[i]:
                    continue
                # Where along the edge does the vertex cross its line?  (Linear estimate; the
                # exact check follows the root finding.)  Far outside the span: not a contact.
                u_est = u_prev[i] + (u1 - u_prev[i]) * (g_prev[i] - thr[i]) / (g_prev[i] - g1)
                if u_est < -0.25 or u_est > 1.25:
                    continue
                if ev_kind != E_NONE:
                    # Not crossed yet at the earliest event found so far: it cannot come first.
                    # (Several contacts close together at a seat; this spares their searches.)
                    if cache_h != ev_h:
                        cache_b, cache_m, _, _, _ = _rk_step(
                            table, act, nact, pb, pm, x0, ym, ev_h, sqb, sqm, winv_b, winv_m, fric
                        )
                        cache_h = ev_h
                    gk, _, _, _, _, _, _, _, _ = _eval(table, i, cache_b, cache_m, x0, ym - ev_h)
                    if gk > thr[i]:
                        continue
                    # Crossed within two event widths before it: the same moment (contacts
                    # closing together, as at a seat); the next interval's touching scan picks
                    # it up without a search of its own.
                    if early_h != ev_h:
                        early_b, early_m, _, _, _ = _rk_step(
                            table,
                            act,
                            nact,
                            pb,
                            pm,
                            x0,
                            ym,
                            max(ev_h - 2.0 * event_tol, 0.0),
                            sqb,
                            sqm,
                            winv_b,
                            winv_m,
                            fric,
                        )
                        early_h = ev_h
                    ge, _, _, _, _, _, _, _, _ = _eval(
                        table, i, early_b, early_m, x0, ym - max(ev_h - 2.0 * event_tol, 0.0)
                    )
                    if ge > thr[i]:
                        continue
                _, hk = _locate_in_step(table, E_CONTACT, i, 0, thr[i], act, nact, step, fric)
                if ev_kind != E_NONE and hk >= ev_h:
                    continue
                pbk, pmk, _, _, _ = _rk_step(
                    table, act, nact, pb, pm, x0, ym, hk, sqb, sqm, winv_b, winv_m, fric
                )
                _, uk, _, _, _, _, _, _, _ = _eval(table, i, pbk, pmk, x0, ym - hk)
                # A vertex crossing a line just beyond the edge's end is meeting the corner
                # there (e.g. a tip reaching the bottom of a notch): that is a contact too.
                if -U_CORNER <= uk <= 1.0 + U_CORNER:
                    ev_kind, ev_idx, ev_h = E_CONTACT, i, hk
            if ym1 < y_floor:
                # y_M falls linearly with the descent: the crossing is known exactly.
                hk = ym - y_floor
                if hk < ev_h or ev_kind == E_NONE:
                    ev_kind, ev_idx, ev_h = E_BELOW_SEAT, -1, hk
            if max(abs(nb), abs(nm)) > math.pi:
                _, hk = _locate_in_step(table, E_SPUN, -1, 0, 0.0, act, nact, step, fric)
                if hk < ev_h or ev_kind == E_NONE:
                    ev_kind, ev_idx, ev_h = E_SPUN, -1, hk
            if ev_kind == E_NONE:
                n_ex = 0
                g_prev[:] = g_next
                u_prev[:] = u_next
                steps += 1
                pb, pm, ym = nb, nm, ym1
                phase = P_SLIDE if abs(pb - pm) <= ALIGN_TOL else P_ALIGN
                n = _record(path, path_pairs, n, ym, pb, pm, phase, act, nact)
                fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err**-0.2))
                # Keep the next step inside the per-step turn cap instead of having it rejected.
                h = min(h * fac, 0.9 * MAX_TURN * h / max(turn, TINY))
                continue
            # ---- advance to the event and act on it ------------------------------------------
            if ev_kind == E_TURN:
                # The rate diverges at a fold of the contact path: integrating up to it is
                # ill-conditioned, so solve the active constraints there directly (Newton from
                # the last good state); the state is then exact to about sqrt(event_tol).
                tb, tm = pb, pm
                for _ in range(20):
                    tb, tm = _project(table, act, nact, tb, tm, x0, ym - ev_h, winv_b, winv_m)
                if not _cuts_in(table, g_prev, thr, tb, tm, x0, ym - ev_h):
                    pb, pm = tb, tm
                    ym = ym - ev_h
                if nact == 2:
                    fb, fm, fy, conv = _solve_fold(table, act, pb, pm, x0, ym)
                    if (
                        conv
                        and abs(fy - ym) < 1e-6
                        and not _cuts_in(table, g_prev, thr, fb, fm, x0, fy)
                    ):
                        pb, pm, ym = fb, fm, fy
                steps += 1
            elif ev_h > 0.0:
                eb, em, _, _, e_ok = _rk_step(
                    table, act, nact, pb, pm, x0, ym, ev_h, sqb, sqm, winv_b, winv_m, fric
                )
                if e_ok and max(abs(eb - pb), abs(em - pm)) <= MAX_TURN:
                    pb, pm = eb, em
                    ym = ym - ev_h
                    steps += 1
                else:
                    # The step to the event crosses a fold of the path (the rate blows up
                    # on the way): stop at the last good state as at a turning point.
                    ev_kind = E_TURN
                    if nact == 2:
                        fb, fm, fy, conv = _solve_fold(table, act, pb, pm, x0, ym)
                        if (
                            conv
                            and abs(fy - ym) < 1e-6
                            and not _cuts_in(table, g_prev, thr, fb, fm, x0, fy)
                        ):
                            pb, pm, ym = fb, fm, fy
            events += 1
            phase = P_SLIDE if abs(pb - pm) <= ALIGN_TOL else P_ALIGN
            n = _record(path, path_pairs, n, ym, pb, pm, phase, act, nact)
            if ev_kind == E_BELOW_SEAT:
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, no_act, 0)
                if _is_seated(pb, pm, x0, ym, L, seat_tol):
                    return O_SEATED, R_SEATED, pb, pm, ym, steps, events, changes, rejected, n
                return O_BAD_MATE, R_BELOW_SEAT, pb, pm, ym, steps, events, changes, rejected, n
            if ev_kind == E_TURN:
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, no_act, 0)
                if _is_seated(pb, pm, x0, ym, L, seat_tol):
                    return O_SEATED, R_SEATED, pb, pm, ym, steps, events, changes, rejected, n
                return O_BAD_MATE, R_SINGULAR, pb, pm, ym, steps, events, changes, rejected, n
            if ev_kind == E_SPUN:
                n = _record(path, path_pairs, n, ym, pb, pm, P_END, no_act, 0)
                return O_BAD_MATE, R_SPUN, pb, pm, ym, steps, events, changes, rejected, n
            if ev_h > 1e-7:
                n_ex = 0
            if ev_kind == E_RELEASE or ev_kind == E_OFF_EDGE:  # noqa: SIM109 (numba)
                if n_ex < exclude.shape[0]:
                    exclude[n_ex] = ev_idx
                    n_ex += 1
            elif ev_kind == E_CONTACT:
                for k in range(n_ex):
                    if exclude[k] == ev_idx:
                        exclude[k] = exclude[n_ex - 1]
                        n_ex -= 1
                        break
            h = max(h, 1e3 * event_tol)
            break


@njit(cache=True, nogil=True)
def _event_after(
    table: FloatArray,
    kind: int,
    idx: int,
    slot: int,
    thr: float,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    t: float,
    sqb: float,
    sqm: float,
    winv_b: float,
    winv_m: float,
    y_floor: float,
    fric: FloatArray,
) -> float:
    """The event function on the state one integration step of length ``t`` from the start."""
    nb, nm, _, _, _ = _rk_step(table, act, nact, pb, pm, x0, ym, t, sqb, sqm, winv_b, winv_m, fric)
    return _event_value(
        table, kind, idx, slot, thr, act, nact, nb, nm, x0, ym - t, sqb, sqm, y_floor, fric
    )


@njit(cache=True, nogil=True)
def _locate(
    table: FloatArray,
    kind: int,
    idx: int,
    slot: int,
    thr: float,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    h: float,
    sqb: float,
    sqm: float,
    winv_b: float,
    winv_m: float,
    y_floor: float,
    event_tol: float,
    fric: FloatArray,
) -> tuple[float, float]:
    """Step lengths bracketing the zero of an event function (Illinois method).

    The event function is evaluated on the state after one integration step of the trial
    length from the same start, so the located point lies on the integrated path.  The
    returned pair ``(lo, hi)`` brackets the event to ``event_tol``: before it and just after.
    """
    lo = 0.0
    f_lo = _event_value(
        table, kind, idx, slot, thr, act, nact, pb, pm, x0, ym, sqb, sqm, y_floor, fric
    )
    hi = h
    nb, nm, _, _, _ = _rk_step(table, act, nact, pb, pm, x0, ym, hi, sqb, sqm, winv_b, winv_m, fric)
    f_hi = _event_value(
        table, kind, idx, slot, thr, act, nact, nb, nm, x0, ym - hi, sqb, sqm, y_floor, fric
    )
    if not f_lo > 0.0:
        return 0.0, 0.0
    # Predictor: root of the event along the cubic Hermite interpolant of the step (no extra
    # integration), then a tight bracket around it checked with real steps.  Most events are
    # then pinned with three or four integrations instead of a dozen.
    if math.isfinite(f_hi) and f_hi <= 0.0:
        v0b, v0m, _, _ = _velocity(table, act, nact, pb, pm, x0, ym, sqb, sqm, fric)
        v1b, v1m, _, _ = _velocity(table, act, nact, nb, nm, x0, ym - hi, sqb, sqm, fric)
        if math.isfinite(v0b + v0m + v1b + v1m):
            a_lo, a_hi, fa_lo, fa_hi = 0.0, 1.0, f_lo, f_hi
            for _ in range(60):
                if a_hi - a_lo <= 1e-13:
                    break
                tau = a_hi - fa_hi * (a_hi - a_lo) / (fa_hi - fa_lo)
                if not (a_lo < tau < a_hi):
                    tau = 0.5 * (a_lo + a_hi)
                t2 = tau * tau
                t3 = t2 * tau
                h00 = 2 * t3 - 3 * t2 + 1
                h10 = t3 - 2 * t2 + tau
                h01 = -2 * t3 + 3 * t2
                h11 = t3 - t2
                ib = h00 * pb + h10 * hi * v0b + h01 * nb + h11 * hi * v1b
                im = h00 * pm + h10 * hi * v0m + h01 * nm + h11 * hi * v1m
                fa = _event_value(
                    table,
                    kind,
                    idx,
                    slot,
                    thr,
                    act,
                    nact,
                    ib,
                    im,
                    x0,
                    ym - tau * hi,
                    sqb,
                    sqm,
                    y_floor,
                    fric,
                )
                if not math.isfinite(fa):
                    break
                if fa > 0.0:
                    if a_lo == tau:
                        break
                    a_lo, fa_lo = tau, fa
                else:
                    a_hi, fa_hi = tau, fa
            guess = 0.5 * (a_lo + a_hi) * hi
            delta = max(2e-5 * hi, 4.0 * event_tol)
            t_lo, t_hi = guess - delta, guess + delta
            if t_lo > 0.0 and t_hi < hi:
                g_lo = _event_after(
                    table,
                    kind,
                    idx,
                    slot,
                    thr,
                    act,
                    nact,
                    pb,
                    pm,
                    x0,
                    ym,
                    t_lo,
                    sqb,
                    sqm,
                    winv_b,
                    winv_m,
                    y_floor,
                    fric,
                )
                g_hi = _event_after(
                    table,
                    kind,
                    idx,
                    slot,
                    thr,
                    act,
                    nact,
                    pb,
                    pm,
                    x0,
                    ym,
                    t_hi,
                    sqb,
                    sqm,
                    winv_b,
                    winv_m,
                    y_floor,
                    fric,
                )
                if g_lo > 0.0 and math.isfinite(g_hi) and g_hi <= 0.0:
                    lo, f_lo, hi, f_hi = t_lo, g_lo, t_hi, g_hi
    side = 0
    for _ in range(100):
        if hi - lo <= event_tol:
            break
        if math.isfinite(f_hi) and f_hi < 0.0 and f_lo > 0.0:
            mid = hi - f_hi * (hi - lo) / (f_hi - f_lo)
            if not (lo < mid < hi):
                mid = 0.5 * (lo + hi)
        else:
            mid = 0.5 * (lo + hi)
        f_mid = _event_after(
            table,
            kind,
            idx,
            slot,
            thr,
            act,
            nact,
            pb,
            pm,
            x0,
            ym,
            mid,
            sqb,
            sqm,
            winv_b,
            winv_m,
            y_floor,
            fric,
        )
        if math.isfinite(f_mid) and f_mid > 0.0:
            lo, f_lo = mid, f_mid
            if side == 1:
                f_hi *= 0.5
            side = 1
        else:
            hi, f_hi = mid, f_mid
            if side == -1:
                f_lo *= 0.5
            side = -1
    return lo, hi


@njit(cache=True, nogil=True)
def _locate_in_step(
    table: FloatArray,
    kind: int,
    idx: int,
    slot: int,
    thr: float,
    act: IntArray,
    nact: int,
    step: FloatArray,
    fric: FloatArray,
) -> tuple[float, float]:
    """:func:`_locate` for the current trial step, whose start state and solver constants
    are packed in ``step``: (pb, pm, x0, ym, h, sqb, sqm, winv_b, winv_m, y_floor,
    event_tol)."""
    return _locate(
        table,
        kind,
        idx,
        slot,
        thr,
        act,
        nact,
        step[0],
        step[1],
        step[2],
        step[3],
        step[4],
        step[5],
        step[6],
        step[7],
        step[8],
        step[9],
        step[10],
        fric,
    )


@njit(cache=True, nogil=True)
def lowest_reach(vertices: FloatArray, theta: float) -> float:
    """max over body points v of (sin theta v_x + cos theta v_y): how far the moving part,
    turned by theta, reaches below its pivot (D)."""
    s, c = math.sin(theta), math.cos(theta)
    best = -math.inf
    for k in range(vertices.shape[0]):
        best = max(best, s * vertices[k, 0] + c * vertices[k, 1])
    return best


@njit(cache=True, nogil=True)
def simulate_many(
    table: FloatArray,
    base_edges: FloatArray,
    moving_edges: FloatArray,
    L: float,
    xs: FloatArray,
    ts: FloatArray,
    ys: FloatArray,
    valid: npt.NDArray[np.bool_],
    settings: FloatArray,
) -> tuple[npt.NDArray[np.int8], FloatArray, FloatArray, IntArray, IntArray]:
    """:func:`simulate` over flat arrays of poses without paths; invalid entries give
    INVALID_INPUT without running."""
    n = xs.shape[0]
    code = np.empty(n, dtype=np.int8)
    pbs = np.full(n, math.nan)
    pms = np.full(n, math.nan)
    steps = np.zeros(n, dtype=np.int64)
    events = np.zeros(n, dtype=np.int64)
    path = np.zeros((1, 4))
    pairs = np.full((1, 4), -1, dtype=np.int64)
    for k in range(n):
        if not valid[k]:
            code[k] = O_INVALID
            continue
        out = simulate(
            table, base_edges, moving_edges, L, xs[k], ts[k], ys[k], settings, path, pairs
        )
        code[k] = out[0]
        pbs[k] = out[2]
        pms[k] = out[3]
        steps[k] = out[5]
        events[k] = out[6]
    return code, pbs, pms, steps, events
