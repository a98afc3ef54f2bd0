"""Motion with the contacts held: the least-dissipation rate, corners, Coulomb friction.

With q = (phi_B, phi_M) and descent s, each active contact i has a gap g_i, a gradient
a_i = dg_i/dq and beta_i = dg_i/dy_M. Overdamped frictionless motion is the rate
``v = dq/ds`` minimising ``v' W v`` subject to ``a_i . v >= beta_i`` (a 2-variable QP solved
exactly by enumerating its active sets). Corner contacts are alternatives (the admissible set
near two convex corners is a union), friction turns the rate along ``a - mu s c``.
"""

from __future__ import annotations

import math

from .pairs import (
    COL_EDGE_LENGTH,
    clipped_gap,
    corner_distance,
    corner_motion_admissible,
    eval_pair,
    pair_at,
)
from .records import (
    CORNER_REACH,
    FREE,
    SLIDE_NEGATIVE,
    SLIDE_POSITIVE,
    SLIP_FLOOR,
    SLIP_PROBE,
    STICK,
    STICK_SLACK,
    TINY,
    U_CORNER,
    U_TOL,
    Contacts,
    FloatArray,
    IntArray,
    frictionless,
    njit_no_refcount,
)


@njit_no_refcount
def feasible(ev: FloatArray, cand: IntArray, nc: int, vb: float, vm: float, tol: float) -> bool:
    for k in range(nc):
        j = cand[k]
        if ev[j, 2] * vb + ev[j, 3] * vm < ev[j, 4] - tol * (1.0 + abs(ev[j, 4])):
            return False
    return True


@njit_no_refcount
def _tight(ev: FloatArray, j: int, vb: float, vm: float, tol: float) -> bool:
    """Does candidate j hold the rate ``(vb, vm)`` with zero slack (``a . v = beta`` to
    ``tol`` relative to 1 + |beta|)?"""
    return not abs(ev[j, 2] * vb + ev[j, 3] * vm - ev[j, 4]) > tol * (1.0 + abs(ev[j, 4]))


@njit_no_refcount
def widest_pair(
    ev: FloatArray, cand: IntArray, nc: int, sqb: float, sqm: float, tol: float, vb: float,
    vm: float, act: IntArray, nact: int,
) -> int:  # fmt: skip
    """The two contacts to hold for the least-dissipation rate ``(vb, vm)`` (rad per D) when
    more than two candidates hold it with zero slack: of the pairs whose forces push
    (multipliers >= 0) for that rate, the one whose gap gradients are furthest from parallel
    (largest |det| in the metric); ``act[:2]`` is replaced by it. Returns the number held.

    With two edges lying flush the contacts are every vertex of either part on the other's
    edge, and any two give the same rate; the order of the candidates (pair indices) chose,
    and a mirror-symmetric face chose differently from its mirror run (one slid, the other
    locked by friction). The furthest apart of them is the one set whose forces can sit
    anywhere on the flush overlap, as a distributed contact's can, which the friction
    check then needs (:func:`~.interval._with_friction` tries the held set first).

    For contacts inside their edges' spans only (:func:`choose_motion`'s hard constraints):
    corner pairs are alternatives, and two of one corner meeting held together pin a point,
    whichever two they are (docs/contact.md, sections 2 and 6).
    """
    zero = 0
    for k in range(nc):
        if _tight(ev, cand[k], vb, vm, tol):
            zero += 1
    if zero <= 2:
        return nact
    ub, um = vb / sqb if sqb > 0.0 else 0.0, vm / sqm
    best_det = -1.0
    first, second = act[0], act[1]
    for k in range(nc):
        i = cand[k]
        if not _tight(ev, i, vb, vm, tol):
            continue
        ab1, am1 = ev[i, 2] * sqb, ev[i, 3] * sqm
        for m in range(k + 1, nc):
            j = cand[m]
            if not _tight(ev, j, vb, vm, tol):
                continue
            ab2, am2 = ev[j, 2] * sqb, ev[j, 3] * sqm
            det = ab1 * am2 - am1 * ab2
            scale = math.sqrt((ab1 * ab1 + am1 * am1) * (ab2 * ab2 + am2 * am2))
            if abs(det) <= 1e-9 * scale or abs(det) <= best_det:
                continue
            # The forces: u = l1 a1 + l2 a2 in the scaled variables.
            l1 = (ub * am2 - ab2 * um) / det
            l2 = (ab1 * um - am1 * ub) / det
            floor = -tol * (abs(l1) + abs(l2))
            if l1 < floor or l2 < floor:
                continue
            best_det = abs(det)
            first, second = i, j
    act[0], act[1] = first, second
    return nact


@njit_no_refcount
def solve_qp(
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
        if feasible(ev, cand, nc, vb, vm, tol):
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
                if not _tight(ev, j, vb, vm, tol):
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
            if feasible(ev, cand, nc, vb, vm, tol):
                act[0] = i
                act[1] = j
                return 0, 2, vb, vm
    return 1, 0, 0.0, 0.0


@njit_no_refcount
def tangent(
    table: FloatArray, i: int, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float]:
    """Slip of pair i: the vertex's rate along the edge's unit tangent t, relative to the edge,
    is ``c . dq/ds + gamma``.  Returns ``(c_b, c_m, gamma)``; ``c`` is also the generalised
    force of a unit force along t at the contact (on the vertex body; minus it on the other)."""
    row = table[i]
    _, _, _, _, _, px, py, nx, ny = pair_at(table, i, pb, pm, x0, ym)
    # The outward normal is the tangent turned clockwise: t = (-n_y, n_x).
    tx, ty = -ny, nx
    if row[0] == 0.0:
        c_b = -(px * ty - py * tx)
        c_m = (px - x0) * ty - (py - ym) * tx
        return c_b, c_m, -ty
    c_b = px * ty - py * tx
    c_m = -((px - x0) * ty - (py - ym) * tx)
    return c_b, c_m, ty


@njit_no_refcount
def velocity(held: Contacts, pb: float, pm: float, ym: float) -> tuple[float, float, float, float]:
    """Rate dq/ds (rad per D) at the state ``(pb, pm, ym)`` with the active set ``held``
    fixed; returns (v_b, v_m, lambda_0, x) where x is lambda_1 for two contacts and,
    for one stuck contact, its tangential force tau.

    Frictionless, the rate is the least-dissipation one.  With Coulomb friction mu =
    ``held.mu``, a sliding contact pushes along ``a - mu s c`` (s: the slip's sign,
    ``held.slip[k]``), a stuck one (``slip[0] == STICK``) adds the slip constraint
    ``c . v = -gamma``.  Non-finite rates signal a singular configuration (a contact normal
    through both pivots) or a friction lock.
    """
    table, act, nact = held.pairs, held.act, held.n_active
    mu, slip, x0, sqb, sqm = held.mu, held.slip, held.x0, held.sqrt_winv_b, held.sqrt_winv_m
    cb0, sb0, cm0, sm0 = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    _, _, ab1, am1, b1, _, _, _, _ = eval_pair(table[act[0]], cb0, sb0, cm0, sm0, x0, ym)
    ab1 *= sqb
    am1 *= sqm
    if nact == 1:
        if mu > 0.0 and slip[0] != FREE:
            cb, cm, gam = tangent(table, act[0], pb, pm, x0, ym)
            cb *= sqb
            cm *= sqm
            if slip[0] == STICK:
                a11 = ab1 * ab1 + am1 * am1
                a12 = ab1 * cb + am1 * cm
                a22 = cb * cb + cm * cm
                det = a11 * a22 - a12 * a12
                if det <= 1e-24 * max(a11 * a22, TINY):
                    return math.nan, math.nan, math.nan, math.nan
                lam = (b1 * a22 + a12 * gam) / det
                tau = (-a11 * gam - a12 * b1) / det
                return (lam * ab1 + tau * cb) * sqb, (lam * am1 + tau * cm) * sqm, lam, tau
            db = ab1 - mu * slip[0] * cb
            dm = am1 - mu * slip[0] * cm
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
        c1b, c1m, _ = tangent(table, act[0], pb, pm, x0, ym)
        c2b, c2m, _ = tangent(table, act[1], pb, pm, x0, ym)
        d1b -= mu * slip[0] * c1b * sqb
        d1m -= mu * slip[0] * c1m * sqm
        d2b -= mu * slip[1] * c2b * sqb
        d2m -= mu * slip[1] * c2m * sqm
    det2 = d1b * d2m - d1m * d2b
    if det2 == 0.0:
        return math.nan, math.nan, math.nan, math.nan
    l1 = (ub * d2m - d2b * um) / det2
    l2 = (d1b * um - d1m * ub) / det2
    return ub * sqb, um * sqm, l1, l2


@njit_no_refcount
def slip_margin(held: Contacts, k: int, pb: float, pm: float, ym: float) -> float:
    """Positive while contact k keeps its friction state: a sliding contact keeps its slip
    direction, a stuck one keeps its tangential force inside the cone |tau| <= mu lambda."""
    vb, vm, lam, x = velocity(held, pb, pm, ym)
    if held.slip[k] == STICK:
        return float(held.mu * lam * (1.0 + STICK_SLACK) - abs(x))
    cb, cm, gam = tangent(held.pairs, held.act[k], pb, pm, held.x0, ym)
    return float(held.slip[k] * (cb * vb + cm * vm + gam))


@njit_no_refcount
def corner_holds(
    table: FloatArray,
    i: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    vb: float,
    vm: float,
    rays: FloatArray,
) -> bool:
    """True when a short trial move along the rate keeps corner pair i (a vertex at the end
    of an edge: two corners meeting) apart, by the exact wedge test of
    :func:`~.pairs.corner_motion_admissible`."""
    dd = 1e-7
    g0, u0, _, _, _, _, _, _, _ = pair_at(table, i, pb, pm, x0, ym)
    if (u0 < -U_CORNER or u0 > 1.0 + U_CORNER) and corner_distance(table[i], g0, u0) > CORNER_REACH:
        return True  # past the edge's end, away from its corner: no corner contact
    start = (pb, pm, ym)
    trial = (pb + dd * vb, pm + dd * vm, ym - dd)
    return corner_motion_admissible(table[i], u0 > 0.5, start, trial, x0, rays)


@njit_no_refcount
def corners_hold(
    table: FloatArray,
    corner: IntArray,
    n_corner: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    vb: float,
    vm: float,
    rays: FloatArray,
) -> bool:
    """:func:`corner_holds` for each of the first ``n_corner`` pairs of ``corner``."""
    for k in range(n_corner):
        if not corner_holds(table, corner[k], pb, pm, x0, ym, vb, vm, rays):
            return False
    return True


@njit_no_refcount
def is_corner_pair(table: FloatArray, ev: FloatArray, i: int) -> bool:
    """Does pair i meet its edge at an end corner (vertex on vertex, or just past the end)
    rather than inside the span? Corner pairs are alternatives, never held on their own."""
    u = ev[i, 1]
    return not (U_TOL < u < 1.0 - U_TOL and corner_distance(table[i], ev[i, 0], u) > CORNER_REACH)


@njit_no_refcount
def rate_keeps_contacts(
    table: FloatArray,
    ev: FloatArray,
    cand: IntArray,
    nc: int,
    act: IntArray,
    nact: int,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    vb: float,
    vm: float,
    rays: FloatArray,
) -> bool:
    """Does the rate (v_b, v_m per unit descent) cut into no touching pair outside the
    active set? Pairs inside an edge's span by their gap rate, corner pairs by the wedge
    test (:func:`corners_hold`)."""
    for k in range(nc):
        j = cand[k]
        held = False
        for a in range(nact):
            if act[a] == j:
                held = True
        if held:
            continue
        if is_corner_pair(table, ev, j):
            if not corner_holds(table, j, pb, pm, x0, ym, vb, vm, rays):
                return False
        else:
            # dg/ds = a_b v_b + a_m v_m - beta: negative cuts in.
            short = ev[j, 4] - (ev[j, 2] * vb + ev[j, 3] * vm)
            if short > 1e-9 * (1.0 + abs(ev[j, 4])):
                return False
    return True


@njit_no_refcount
def project_gaps(
    table: FloatArray, act: IntArray, nact: int, x0: float, winv_b: float, winv_m: float,
    pb: float, pm: float, ym: float, iterations: int,
) -> tuple[float, float]:  # fmt: skip
    """Newton-project (phi_B, phi_M) onto the gaps of the pairs ``act[:nact]`` (one or two)
    of ``table`` at fixed y_M, along the metric whose inverse is ``(winv_b, winv_m)``, in at
    most ``iterations`` steps: :func:`~.integrate.project` for the held contacts, and the
    motion choice's look-ahead (:func:`cut_ahead`), which has no :class:`Contacts`."""
    for _ in range(iterations):
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


#: Alternatives of the motion choice whose dissipation differs by less than this (relative)
#: give the same rate: a tie, settled by :func:`cut_ahead`.
TIE_COST = 1e-9
#: D of descent: the short move along a tied alternative (its sets differ at second order,
#: here about LOOKAHEAD**2 = 1e-8 D, far above round-off).
LOOKAHEAD = 1e-4
#: D: a cut ahead no deeper than this is round-off (coordinates of up to 50 D carry 1e-14).
LOOKAHEAD_CUT = 1e-12


@njit_no_refcount
def cut_ahead(
    table: FloatArray, cand: IntArray, nc: int, act: IntArray, nact: int, pb: float, pm: float,
    x0: float, ym: float, vb: float, vm: float, sqb: float, sqm: float,
) -> float:  # fmt: skip
    """How far (D) the motion holding ``act[:nact]`` at the rate ``(vb, vm)`` goes wrong a
    short move (``LOOKAHEAD``) ahead: the largest of how far a held vertex has left its
    edge's span and how deep the other touching pairs' vertices are inside (clipped gap).

    Several contact sets can give the same rate: where two corners meet, the contact there
    is held by any of the vertex-edge pairs that meet at it, and they agree to first order
    only. At second order one set slides a vertex off its edge, or into the other part, and
    another does not. Mirror images choose mirror images, where the order of the candidates
    (pair indices) chose differently (a mirror-symmetric face jammed 4.3e-3 rad apart from
    its mirror run). The move is the rate's (first order), then Newton onto the held gaps
    at the new height, along the least-dissipation metric (``sqb``, ``sqm``: W^1/2).
    """
    qb, qm, yy = pb + LOOKAHEAD * vb, pm + LOOKAHEAD * vm, ym - LOOKAHEAD
    if nact > 0:
        qb, qm = project_gaps(table, act, nact, x0, sqb * sqb, sqm * sqm, qb, qm, yy, 6)
    cb, sb, cm, sm = math.cos(qb), math.sin(qb), math.cos(qm), math.sin(qm)
    cut = 0.0
    for k in range(nc):
        i = cand[k]
        row = table[i]
        g, u, _, _, _, _, _, _, _ = eval_pair(row, cb, sb, cm, sm, x0, yy)
        held = (nact > 0 and act[0] == i) or (nact > 1 and act[1] == i)
        if held:
            cut = max(cut, -u * row[COL_EDGE_LENGTH], (u - 1.0) * row[COL_EDGE_LENGTH])
        else:
            cut = max(cut, -clipped_gap(row, g, cb, sb, cm, sm, x0, yy))
    if not math.isfinite(cut):
        return math.inf
    return cut


@njit_no_refcount
def _tie_goes_to_trial(best_cut: float, trial_cut: float, best: float, cost: float) -> bool:
    """Of two alternatives with the same rate (dissipations ``best`` and ``cost`` within
    TIE_COST), does the trial one win? ``best_cut``, ``trial_cut``: how deep a short move
    along each cuts into a pair (:func:`cut_ahead`, D). While the best is sound ahead, only
    a trial also sound and of smaller dissipation wins (as two ways of pinning one corner
    meeting, settled as before ties were looked at); else the trial must cut in clearly
    less."""
    if best_cut <= LOOKAHEAD_CUT:
        return trial_cut <= LOOKAHEAD_CUT and cost < best
    return trial_cut < best_cut - LOOKAHEAD_CUT


@njit_no_refcount
def choose_motion(
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
    scratch: IntArray,
    trial: IntArray,
    rays: FloatArray,
) -> tuple[int, int, float, float]:
    """Least-dissipation rate with corner contacts treated as alternatives.

    A vertex touching an edge inside its span is a hard constraint.  A vertex touching at an
    edge's end (two corners meeting) is only one of several ways to stay apart: the
    admissible motions form a union, so each alternative is tried on top of the hard
    constraints and the admissible one of least dissipation wins.

    ``scratch`` (3, >= nc + 2), ``trial`` (4,) and ``rays`` (4, 2) are working space
    (:class:`~.records.Work`'s ``choice``, ``trial`` and ``rays``): nothing is allocated.
    """
    hard = scratch[0]
    corner = scratch[1]
    nh = 0
    n_corner = 0
    for k in range(nc):
        i = cand[k]
        if not is_corner_pair(table, ev, i):
            hard[nh] = i
            nh += 1
        else:
            # Pairs just beyond an edge's end are only checked for penetration; they are
            # never held (holding them would slide them off at once).
            corner[n_corner] = i
            n_corner += 1
    n_alt = 0
    alt = scratch[2]
    for k in range(n_corner):
        u = ev[corner[k], 1]
        if -U_TOL <= u <= 1.0 + U_TOL:
            alt[n_alt] = corner[k]
            n_alt += 1
    status, nact, vb, vm = solve_qp(ev, hard, nh, sqb, sqm, 1e-9, act)
    if status == 0 and nact == 2:
        nact = widest_pair(ev, hard, nh, sqb, sqm, 1e-9, vb, vm, act, nact)
    if n_corner == 0:
        return status, nact, vb, vm
    trial[:] = -1
    best = math.inf
    best_n = 0
    best_vb = 0.0
    best_vm = 0.0
    best_cut = -1.0  # cut_ahead of the best alternative, once a tie needs it
    found = False
    if status == 0 and corners_hold(table, corner, n_corner, pb, pm, x0, ym, vb, vm, rays):
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
                st, na, tb, tm = solve_qp(ev, hard, nh + extra, sqb, sqm, 1e-9, trial)
                if st != 0 or not corners_hold(
                    table, corner, n_corner, pb, pm, x0, ym, tb, tm, rays
                ):
                    continue
                cost = (tb * tb if sqb > 0.0 else 0.0) / max(sqb * sqb, TINY) + tm * tm / (
                    sqm * sqm
                )
                if found and cost >= best * (1.0 - TIE_COST):
                    if cost > best * (1.0 + TIE_COST):
                        continue
                    # The same rate (as where two corners meet at two places, each contact
                    # held by one of several vertex-edge pairs): the sets differ at second
                    # order only, so they are told apart by a short move along each.
                    if best_cut < 0.0:
                        best_cut = cut_ahead(table, cand, nc, act, best_n, pb, pm, x0, ym,
                                             best_vb, best_vm, sqb, sqm)  # fmt: skip
                    cut = cut_ahead(table, cand, nc, trial, na, pb, pm, x0, ym, tb, tm, sqb, sqm)
                    if not _tie_goes_to_trial(best_cut, cut, best, cost):
                        continue
                    best_cut = cut
                else:
                    best_cut = -1.0  # not computed yet
                found = True
                best = cost
                best_n, best_vb, best_vm = na, tb, tm
                for k in range(4):
                    act[k] = trial[k]
    if not found:
        return 1, 0, 0.0, 0.0
    return 0, best_n, best_vb, best_vm


@njit_no_refcount
def _slips_back(
    table: FloatArray, i: int, x0: float, mode: int, pb: float, pm: float, ym: float,
    vb: float, vm: float,
) -> bool:  # fmt: skip
    """Does pair i, sliding in direction ``mode`` at the rate ``(vb, vm)`` (rad per D), slip
    against that direction at the state itself, by more than SLIP_FLOOR times the size of
    its slip rate's terms?

    Ahead it slips the right way (:func:`friction_modes` judged it there), but an explicit
    move ahead can overshoot: with a very light base the slide's rate relaxes within about
    1e-5 D onto a path that still slips backwards (the base's rate is its moment over a tiny
    damping). The segment then fired its slip event at once, the same slide was chosen again,
    and the run stood still until the event budget: V H/D 0.98, r_p 0, damping ratio 1e-4,
    mu 0.46 (400 events at one state), where sticking, with the force on the cone, is
    consistent (scripts/evidence/two_contact_coulomb.py's enumeration agrees).
    """
    slip, floor = _slip_and_floor(table, i, x0, mode, pb, pm, ym, vb, vm)
    return bool(slip < -floor)


@njit_no_refcount
def _slip_and_floor(
    table: FloatArray, i: int, x0: float, mode: int, pb: float, pm: float, ym: float,
    vb: float, vm: float,
) -> tuple[float, float]:  # fmt: skip
    """Pair i's slip rate (D per D of descent) at the state ``(pb, pm, ym)`` and the rate
    ``(vb, vm)``, signed so that sliding in direction ``mode`` is positive, and the
    round-off floor below which its sign means nothing: SLIP_FLOOR times the size of its
    terms."""
    cb, cm, gam = tangent(table, i, pb, pm, x0, ym)
    floor = SLIP_FLOOR * (abs(cb * vb) + abs(cm * vm) + abs(gam))
    return mode * (cb * vb + cm * vm + gam), floor


@njit_no_refcount
def friction_modes(held: Contacts, pb: float, pm: float, ym: float, v0b: float, v0m: float) -> bool:
    """Choose each active contact's friction state (``held.slip[k]``) at the state
    ``(pb, pm, ym)`` where the frictionless rate is ``(v0b, v0m)`` (rad per D); False for a
    friction lock.

    The active set is the frictionless one (least dissipation); friction then sets the motion
    within it. One contact: slide in the direction the frictionless motion slips, else the
    other way, else stick; each must be consistent (lambda >= 0, the slip keeps its sign, a
    stuck contact's force inside the cone), and a slide that slips backwards at the state
    itself (:func:`_slips_back`) is taken only when nothing else is. Quasi-static Coulomb
    problems can admit several consistent states; this order picks one deterministically.
    Two contacts fix the rate, so each slips the way that rate makes it slip.
    """
    table, act, nact = held.pairs, held.act, held.n_active
    mu, slip, x0 = held.mu, held.slip, held.x0
    slip[0] = FREE
    slip[1] = FREE
    dd = SLIP_PROBE
    if nact == 2:
        # Judged a short move ahead along the (fixed) rate: at a slip reversal the rate at
        # the point itself is zero to round-off, and the old sign would fire the event again.
        qb, qm, yy = pb + dd * v0b, pm + dd * v0m, ym - dd
        wb, wm, _, _ = velocity(frictionless(held), qb, qm, yy)
        if not (math.isfinite(wb) and math.isfinite(wm)):
            qb, qm, yy, wb, wm = pb, pm, ym, v0b, v0m
        for k in range(2):
            cb, cm, gam = tangent(table, act[k], qb, qm, x0, yy)
            rate = cb * wb + cm * wm + gam
            if abs(rate) < 1e-12:
                slip[k] = FREE
            else:
                slip[k] = SLIDE_POSITIVE if rate > 0.0 else SLIDE_NEGATIVE
        return True
    cb, cm, gam = tangent(table, act[0], pb, pm, x0, ym)
    slip0 = cb * v0b + cm * v0m + gam
    first = SLIDE_POSITIVE if slip0 >= 0.0 else SLIDE_NEGATIVE
    deferred = FREE  # a slide that slips backwards at the state itself (_slips_back)
    for mode in (first, -first, STICK):
        slip[0] = mode
        vb, vm, lam, _ = velocity(held, pb, pm, ym)
        if not (math.isfinite(vb) and math.isfinite(vm) and lam >= 0.0):
            continue
        # Judge the state a short move ahead: at a stick-slip transition the state at the
        # point itself is marginal, and the wrong choice would fire its event at once.
        qb, qm, yy = pb + dd * vb, pm + dd * vm, ym - dd
        wb, wm, lam2, x2 = velocity(held, qb, qm, yy)
        if not (math.isfinite(wb) and math.isfinite(wm) and lam2 >= 0.0):
            continue
        if mode == STICK:
            if abs(x2) <= mu * lam2 * (1.0 + STICK_SLACK):
                return True
        else:
            slip_ahead, floor = _slip_and_floor(table, act[0], x0, mode, qb, qm, yy, wb, wm)
            if slip_ahead > floor:
                if not _slips_back(table, act[0], x0, mode, pb, pm, ym, vb, vm):
                    return True
                if deferred == FREE:
                    deferred = mode
    # Chosen only when neither stick nor the other slide is consistent.
    slip[0] = deferred
    return deferred != FREE
