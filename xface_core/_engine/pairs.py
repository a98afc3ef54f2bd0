"""Vertex-edge pairs in the world: gaps, edge parameters and their derivatives.

A pair is one vertex of one part against one edge of the other (columns of the table:
:mod:`xface_core.contact`). Everything here is evaluated on scalar arguments, the engine's
innermost arithmetic.
"""

from __future__ import annotations

import math

from .records import U_CORNER, FloatArray, IntArray, njit_no_refcount


@njit_no_refcount
def eval_pair(
    row: FloatArray, cb: float, sb: float, cm: float, sm: float, x0: float, y_m: float
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """Gap and derivatives of one pair in the world.

    Returns ``(g, u, a_b, a_m, beta, px, py, nx, ny)``: gap (D), edge parameter, the gap's
    derivatives with respect to phi_B and phi_M (D/rad), ``beta = dg/dy_M``, the world
    position of the vertex and the world normal of the edge.
    """
    vx, vy = row[1], row[2]
    if row[0] == 0.0:
        # Moving vertex: P = P_M - R(phi_M) v.  Base edge: R(phi_B) e, normal R(phi_B) n.
        px = x0 - (cm * vx - sm * vy)
        py = y_m - (sm * vx + cm * vy)
        e0x = cb * row[3] - sb * row[4]
        e0y = sb * row[3] + cb * row[4]
        e1x = cb * row[5] - sb * row[6]
        e1y = sb * row[5] + cb * row[6]
        nx = cb * row[7] - sb * row[8]
        ny = sb * row[7] + cb * row[8]
        # d/dphi of a point rotating about a pivot c is J (p - c), J = [[0, -1], [1, 0]].
        a_b = -ny * px + nx * py
        a_m = ny * (px - x0) - nx * (py - y_m)
        beta = ny
    else:
        # Base vertex: P = R(phi_B) v.  Moving edge: P_M - R(phi_M) e, normal -R(phi_M) n.
        px = cb * vx - sb * vy
        py = sb * vx + cb * vy
        e0x = x0 - (cm * row[3] - sm * row[4])
        e0y = y_m - (sm * row[3] + cm * row[4])
        e1x = x0 - (cm * row[5] - sm * row[6])
        e1y = y_m - (sm * row[5] + cm * row[6])
        nx = -(cm * row[7] - sm * row[8])
        ny = -(sm * row[7] + cm * row[8])
        a_b = ny * px - nx * py
        a_m = -ny * (px - x0) + nx * (py - y_m)
        beta = -ny
    rx = px - e0x
    ry = py - e0y
    dx = e1x - e0x
    dy = e1y - e0y
    g = nx * rx + ny * ry
    u = (rx * dx + ry * dy) / (dx * dx + dy * dy)
    return g, u, a_b, a_m, beta, px, py, nx, ny


@njit_no_refcount
def pair_at(
    table: FloatArray, i: int, pb: float, pm: float, x0: float, ym: float
) -> tuple[float, float, float, float, float, float, float, float, float]:
    return eval_pair(table[i], math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm), x0, ym)


@njit_no_refcount
def eval_all_pairs(
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


@njit_no_refcount
def next_contact(ev: FloatArray, touch_tol: float) -> tuple[float, int]:
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


@njit_no_refcount
def fill_u_rate(table: FloatArray, pb: float, pm: float, ev: FloatArray) -> None:
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


@njit_no_refcount
def touching_pairs(
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
