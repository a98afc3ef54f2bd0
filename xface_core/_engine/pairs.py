"""Vertex-edge pairs in the world: gaps, edge parameters and their derivatives.

A pair is one vertex of one part against one edge of the other (columns of the table:
:mod:`xface_core.contact`). Everything here is evaluated on scalar arguments, the engine's
innermost arithmetic.
"""

from __future__ import annotations

import math

from .records import (
    CORNER_REACH,
    U_CORNER,
    FloatArray,
    IntArray,
    njit_inline,
    njit_no_refcount,
    touch_depth,
)

#: Columns of the pair table the engine fills itself (:func:`fill_extents`): the largest
#: distance (D) of the pair's vertex or edge ends from their pivots, and the edge's length.
COL_REACH = 20
COL_EDGE_LENGTH = 21
#: Columns of the neighbouring edges' lengths (D): the edge before the start corner, and the
#: edge after the end corner (:mod:`xface_core.contact` fills them).
COL_LENGTH_BEFORE = 22
COL_LENGTH_AFTER = 23
#: Column: 1 if this pair tests its vertex against its edge's start corner for two corners
#: crossed like an X (:func:`tests_corner_crossing`), 0 if its partner does (the pair whose
#: vertex is that corner and whose edge starts at this pair's vertex: the same meeting).
COL_CORNER_TESTED = 24
#: Columns of a full pair table (:mod:`xface_core.contact`).
PAIR_COLUMNS = 25


@njit_no_refcount
def fill_extents(table: FloatArray) -> None:
    """Fill the reach and edge-length columns from the geometry columns of every pair: the
    contact search asks for them at every step, and they never change."""
    for i in range(table.shape[0]):
        row = table[i]
        row[COL_REACH] = max(
            math.hypot(row[1], row[2]), math.hypot(row[3], row[4]), math.hypot(row[5], row[6])
        )
        row[COL_EDGE_LENGTH] = math.hypot(row[5] - row[3], row[6] - row[4])


@njit_inline
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


@njit_inline
def vertex_in_edge_frame(
    row: FloatArray, cb: float, sb: float, cm: float, sm: float, x0: float, y_m: float
) -> tuple[float, float]:
    """The pair's vertex in the body frame of its edge's part (D): where the edge, its
    corners and its neighbours are stored, so that each is one dot product away."""
    vx, vy = row[1], row[2]
    if row[0] == 0.0:
        # Moving vertex P = P_M - R(phi_M) v, into the base's frame: R(-phi_B) P.
        px = x0 - (cm * vx - sm * vy)
        py = y_m - (sm * vx + cm * vy)
        return cb * px + sb * py, -sb * px + cb * py
    # Base vertex P = R(phi_B) v, into the moving part's frame: R(-phi_M) (P_M - P).
    dx = x0 - (cb * vx - sb * vy)
    dy = y_m - (sb * vx + cb * vy)
    return cm * dx + sm * dy, -sm * dx + cm * dy


@njit_inline
def adjacent_gap(row: FloatArray, qx: float, qy: float, at_end: bool) -> float:
    """The pair's vertex, at ``(qx, qy)`` in its edge's frame (:func:`vertex_in_edge_frame`),
    against the line of the edge next to one corner of its edge: its signed distance (D)
    from that line along the line's outward normal, for the end corner (``at_end``) or the
    start corner. Near a convex corner a vertex is inside the other part only if it is
    behind both lines (g < 0 and g_adj < 0). (Both parts' body frames keep orientation, so
    distances along body-frame normals are the world's.)

    The neighbour's line bounds the part only near its corner and along the neighbour's
    own span: the result is ``-inf`` (the line says nothing there) where the vertex lies
    alongside this pair's edge nearer its other corner, or alongside it and farther from the
    corner, along the neighbour, than the neighbour is long. At a needle corner (its two
    edges nearly parallel) the line runs on past the needle's base, across the body the edge
    bounds: a vertex entering the body through the edge's middle was beside that line, and
    the contact went unseen (a custom face cut 0.29 D into its partner). On a long thin part
    the line of the corner 4.9 D away crossed the near end of the edge: a vertex passing
    through a needle 0.2 D from its tip was beside it. Past the corner the line still clips,
    however short the neighbour: there the edge's own line is no contact surface either
    (held as one, a vertex 0.5 edge lengths before a corner fired the same contact every
    3e-9 D).
    """
    if at_end:
        rx, ry = qx - row[5], qy - row[6]
        nx, ny, span = row[12], row[13], row[COL_LENGTH_AFTER]
    else:
        rx, ry = qx - row[3], qy - row[4]
        nx, ny, span = row[10], row[11], row[COL_LENGTH_BEFORE]
    # A counter-clockwise outline has its outside on the right of each edge, so an edge with
    # outward normal n runs along (-n_y, n_x): this edge from its start to its end, the
    # neighbour after the end away from the corner, the one before the start towards it.
    into_edge = -row[8] * rx + row[7] * ry
    if at_end:
        into_edge = -into_edge
    if into_edge > 0.5 * row[COL_EDGE_LENGTH]:
        return -math.inf  # nearer the edge's other corner
    along_neighbour = -ny * rx + nx * ry
    if not at_end:
        along_neighbour = -along_neighbour
    if into_edge >= 0.0 and along_neighbour > span:
        return -math.inf
    gap: float = nx * rx + ny * ry
    return gap


@njit_inline
def clipped_gap(
    row: FloatArray, g: float, cb: float, sb: float, cm: float, sm: float, x0: float, y_m: float
) -> float:
    """The pair's gap ``g`` (D) with the edge's convex corners clipped on:
    ``max(g, gap to the neighbour's line at each convex end)``, each line only where it
    bounds the part (:func:`adjacent_gap`).

    Near a convex corner the other part is the intersection of the two edges' inner
    half-planes, so this is negative exactly when the vertex is inside it there. A vertex
    that passes over a corner and into the edge's span is then one crossing of this
    function, where the plain gap crosses twice (out past the corner, back in) and can do so
    inside one integration step unseen.
    """
    # Only a convex end clips: a reflex one's neighbour line is not computed at all.
    start, end = row[14] > 0.5, row[15] > 0.5
    if start or end:
        qx, qy = vertex_in_edge_frame(row, cb, sb, cm, sm, x0, y_m)
        if start:
            g = max(g, adjacent_gap(row, qx, qy, False))
        if end:
            g = max(g, adjacent_gap(row, qx, qy, True))
    return g


@njit_no_refcount
def past_reflex_end(row: FloatArray, u: float) -> bool:
    """Is the pair's vertex past a reflex end of its edge by more than ``U_CORNER`` (where
    the neighbouring edge's own pair takes over)?"""
    return (u < -U_CORNER and row[14] < 0.5) or (u > 1.0 + U_CORNER and row[15] < 0.5)


@njit_no_refcount
def meets_part(
    row: FloatArray,
    u: float,
    cb: float,
    sb: float,
    cm: float,
    sm: float,
    x0: float,
    y_m: float,
    tol: float,
) -> bool:
    """Would the pair's vertex, behind its edge's line at edge parameter ``u``, be inside the
    other part (near this edge)?

    Past a convex end of the edge the neighbouring edge decides: outside its line (to within
    ``tol``, D) the vertex is outside the part, exact at any distance along the line. Past a
    reflex end (a notch) the neighbour's own pair takes over, and this edge counts only
    within ``U_CORNER`` of its end (a tip reaching the bottom of a notch).
    """
    if past_reflex_end(row, u):
        return False
    # The neighbours' lines alone (clipped_gap of a vertex infinitely deep behind this
    # edge's line): outside one of them at a convex end, the vertex is beside the part.
    return clipped_gap(row, -math.inf, cb, sb, cm, sm, x0, y_m) <= -tol


@njit_no_refcount
def corner_distance(row: FloatArray, g: float, u: float) -> float:
    """Distance (D) from the pair's vertex to the nearer end corner of its edge, from the
    gap ``g`` and edge parameter ``u``."""
    along = u if u < 0.5 else 1.0 - u
    return math.hypot(g, along * row[COL_EDGE_LENGTH])


@njit_no_refcount
def _to_world(row: FloatArray, x: float, y: float, moving: bool, c: float, s: float, x0: float,
              y_m: float, point: bool) -> tuple[float, float]:  # fmt: skip
    """A body-frame point (or direction, ``point=False``) of one part in the world."""
    wx, wy = c * x - s * y, s * x + c * y
    if moving:
        # The moving part's frame is turned half a turn: world = P_M - R(phi_M) r.
        return (x0 - wx, y_m - wy) if point else (-wx, -wy)
    return wx, wy


@njit_no_refcount
def _outside(nx: float, ny: float, dx: float, dy: float, tol: float) -> bool:
    """``n . d >= -tol``: the move d does not go behind the line with normal n."""
    return nx * dx + ny * dy >= -tol


#: rad: rays of the corners' wedges (unit vectors) this close to a line count as on it.
#: Flush edges meet at corners whose rays lie on one line to the angles' error: 1.04e-12 rad
#: after an event, just past the old floor of 1e-12 on the dot product, made one run of a
#: mirror pair jam where the other slid flush (the sign of the error decided). Over a slide
#: of 1 D, 1e-9 rad is the touching tolerance.
COLLINEAR = 1e-9


@njit_inline
def _side_of_all(mx: float, my: float, rays: FloatArray) -> bool:
    """Are all four rays (unit vectors) on the non-negative side of the line with unit normal
    m, to within ``COLLINEAR`` of its direction?"""
    for k in range(4):  # noqa: SIM110 (numba compiles no generators)
        if mx * rays[k, 0] + my * rays[k, 1] < -COLLINEAR:
            return False
    return True


@njit_inline
def _cone_admits(
    row: FloatArray,
    at_end: bool,
    cv: float,
    sv: float,
    ck: float,
    sk: float,
    x0: float,
    y_m: float,
    dx: float,
    dy: float,
    tol: float,
    rays: FloatArray,
) -> bool:
    """Is the offset d = (dx, dy) (D) of the pair's vertex V from the corner K of its edge
    (the end corner if ``at_end``) one at which the parts keep apart near V and K, to within
    ``tol`` (D)? (``cv, sv``/``ck, sk``: cos and sin of the angles of V's and K's parts;
    ``rays``: a (4, 2) scratch array.)

    Near K and V the parts are the wedges W_K (the edge owner's interior angle at K) and
    W_V (the vertex owner's at V):
    - both convex: the parts overlap iff d lies inside the cone spanned by W_K and -W_V, so
      d is admissible iff some line through the corner has that cone on one side and d on
      the other (a union of half-planes: the corners may slip past each other either way);
    - K reflex (V in a notch): d must stay in the notch, on the outer side of both edges;
    - V reflex: the same with the roles swapped.
    """
    moving_v = row[0] == 0.0  # kind 0: moving vertex on a base edge
    # The edge owner's wedge at K, from the edge directions in and out of K (a
    # counter-clockwise polygon has its inside on the left): rays t_out and -t_in.
    if at_end:
        tin_x, tin_y = -row[8], row[7]
        tout_x, tout_y = -row[13], row[12]
        k_convex = row[15] > 0.5
    else:
        tin_x, tin_y = -row[11], row[10]
        tout_x, tout_y = -row[8], row[7]
        k_convex = row[14] > 0.5
    ax, ay = _to_world(row, tout_x, tout_y, not moving_v, ck, sk, x0, y_m, False)
    bx, by = _to_world(row, -tin_x, -tin_y, not moving_v, ck, sk, x0, y_m, False)
    # The vertex owner's wedge at V: rays to its next and previous vertices.
    nx_, ny_ = _to_world(row, row[16], row[17], moving_v, cv, sv, x0, y_m, False)
    px_, py_ = _to_world(row, row[18], row[19], moving_v, cv, sv, x0, y_m, False)
    v_convex = (-px_) * ny_ - (-py_) * nx_ > 0.0
    if not k_convex:
        # V sits in a notch of K's part: stay on the outer side of both of its edges (the
        # outward normal of an edge is its direction turned clockwise).
        return _outside(ay, -ax, dx, dy, tol) and _outside(-by, bx, dx, dy, tol)
    if not v_convex:
        # K sits in a notch of V's part: K (at -p relative to V) stays outside both of V's
        # edges, V -> next (direction n_) and previous -> V (direction -p_).
        return _outside(-ny_, nx_, dx, dy, tol) and _outside(py_, -px_, dx, dy, tol)
    rays[0, 0], rays[0, 1] = ax, ay
    rays[1, 0], rays[1, 1] = bx, by
    rays[2, 0], rays[2, 1] = -nx_, -ny_
    rays[3, 0], rays[3, 1] = -px_, -py_
    for k in range(4):
        for sign in (1.0, -1.0):
            mx, my = -sign * rays[k, 1], sign * rays[k, 0]
            if _side_of_all(mx, my, rays) and _outside(-mx, -my, dx, dy, tol):
                return True
    return False


@njit_no_refcount
def _part_angles(row: FloatArray, pb: float, pm: float) -> tuple[float, float, float, float]:
    """``(cv, sv, ck, sk)``: cos and sin of the angle of the vertex's part and of the edge's."""
    if row[0] == 0.0:
        return math.cos(pm), math.sin(pm), math.cos(pb), math.sin(pb)
    return math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)


@njit_no_refcount
def corner_motion_admissible(
    row: FloatArray,
    at_end: bool,
    start: tuple[float, float, float],
    trial: tuple[float, float, float],
    x0: float,
    rays: FloatArray,
) -> bool:
    """Does a short move from ``start`` to ``trial`` (phi_B, phi_M, y_M) keep the pair's
    vertex V and the corner K of its edge (the end corner if ``at_end``) from
    interpenetrating? (``rays``: a (4, 2) scratch array.)

    Exact to first order for vertex-on-vertex contact: the move d of V relative to K is
    judged by :func:`_cone_admits` as if V were at K.
    """
    moving_v = row[0] == 0.0  # kind 0: moving vertex on a base edge
    pb0, pm0, y0 = start
    pb1, pm1, y1 = trial
    cv0, sv0, ck0, sk0 = _part_angles(row, pb0, pm0)
    kx, ky = (row[5], row[6]) if at_end else (row[3], row[4])
    # The move of V relative to K to first order (a finite difference of the positions
    # would carry the move's curvature, about dd^2 |v|^2, into a test of its direction:
    # near a fold, where the parts turn fast, that made straight slides look like cuts).
    # A point r of a part turning by dphi moves by J R r dphi (J: a quarter turn); the
    # moving part's points are P_M - R r, and P_M moves by dy_M vertically.
    d_pb, d_pm, d_y = pb1 - pb0, pm1 - pm0, y1 - y0
    d_v = d_pm if moving_v else d_pb
    d_k = d_pb if moving_v else d_pm
    rvx, rvy = cv0 * row[1] - sv0 * row[2], sv0 * row[1] + cv0 * row[2]
    rkx, rky = ck0 * kx - sk0 * ky, sk0 * kx + ck0 * ky
    sign_v = -1.0 if moving_v else 1.0
    dvx, dvy = sign_v * -rvy * d_v, sign_v * rvx * d_v + (d_y if moving_v else 0.0)
    dkx, dky = -sign_v * -rky * d_k, -sign_v * rkx * d_k + (0.0 if moving_v else d_y)
    # Judged by its direction as if V were at K: V is within CORNER_REACH of K (events
    # leave it a few 1e-9 D off, on either side), and a direction into the corner would
    # reach it within that distance.
    dx, dy = dvx - dkx, dvy - dky
    # Round-off of d is relative to the moves of V and K themselves: a vertex held in a
    # notch moves with it, and d is then zero to 1e-22.
    tol = 1e-6 * (math.hypot(dvx, dvy) + math.hypot(dkx, dky))
    return _cone_admits(row, at_end, cv0, sv0, ck0, sk0, x0, y0, dx, dy, tol, rays)


@njit_no_refcount
def corners_can_cross(row: FloatArray) -> bool:
    """Are the pair's vertex V and the start corner K of its edge both convex? Only then can
    they cross like an X (:func:`wedges_cross`): at a reflex K or V a vertex near it is
    inside by its own gaps."""
    return bool(row[14] >= 0.5 and row[18] * row[17] - row[19] * row[16] < 0.0)


@njit_no_refcount
def tests_corner_crossing(row: FloatArray) -> bool:
    """Does this pair test its vertex V and its edge's start corner K for crossing like an X
    (:func:`wedges_cross`)? Only if both are convex (:func:`corners_can_cross`), and only one
    of the two pairs that meet there does: this one, and its partner (K's part's vertex K
    against V's part's edge that starts at V) with the other, ask the same question of the
    same two wedges (the cone of one wedge and the other turned by pi, the offset's sign and
    the roles swapped). The pair with the longer edge asks it (:mod:`xface_core.contact`
    marks it), as far as half of that edge, which covers the partner's half of its own."""
    return bool(corners_can_cross(row) and row[COL_CORNER_TESTED] > 0.5)


@njit_inline
def wedges_cross(row: FloatArray, cb: float, sb: float, cm: float, sm: float, x0: float,
                 y_m: float, margin: float, rays: FloatArray) -> bool:  # fmt: skip
    """Do the parts overlap near the pair's vertex V and the start corner K of its edge,
    deeper than ``margin`` (D), with both corners convex?

    Two convex corners can cross like an X, neither vertex inside the other part and an
    edge of each cutting through the other; no gap of a vertex shows it. Then V - K lies
    inside the cone of :func:`_cone_admits`. Judged only where V is nearer K than half of
    K's edge (the wedges stand for the parts there). Every (vertex, corner) meeting is two
    pairs' start corner, this pair's and its partner's (:func:`tests_corner_crossing`);
    the one with the longer edge judges it, within half of that edge, which covers the
    other's half of its own: so the pairs that test cover every meeting. False for a pair
    that leaves its meeting to its partner.
    """
    if not tests_corner_crossing(row):
        return False
    moving_v = row[0] == 0.0
    cv, sv, ck, sk = (cm, sm, cb, sb) if moving_v else (cb, sb, cm, sm)
    vx, vy = _to_world(row, row[1], row[2], moving_v, cv, sv, x0, y_m, True)
    wx, wy = _to_world(row, row[3], row[4], not moving_v, ck, sk, x0, y_m, True)
    dx, dy = vx - wx, vy - wy
    dist2 = dx * dx + dy * dy  # squared: no hypot for a test this frequent
    if dist2 <= CORNER_REACH * CORNER_REACH or dist2 > 0.25 * row[COL_EDGE_LENGTH] ** 2:
        return False
    return not _cone_admits(row, False, cv, sv, ck, sk, x0, y_m, dx, dy, margin, rays)


@njit_inline
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
    table: FloatArray,
    ev: FloatArray,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    touch_tol: float,
    exclude: IntArray,
    n_ex: int,
    cand: IntArray,
) -> int:
    """The pairs in contact (their indices into ``cand``; returns how many).

    A pair touches when its gap is within the touching window and its vertex would be inside
    the other part behind the edge's line (:func:`meets_part`) -- or when its vertex is
    within ``CORNER_REACH`` of the edge's end, whatever its gap's sign and whatever the
    neighbouring edge says: there two corners meet, the vertex touches every edge that ends
    at the corner, and every way of staying apart is an alternative for the motion choice.
    Excluded pairs (released or slid off at this point of the path) are left out.
    """
    cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    reach = max(touch_tol, CORNER_REACH)
    nc = 0
    for i in range(ev.shape[0]):
        # Events stop a crossing just past its threshold (-touch_tol for pairs already
        # touching), so the window reaches below -touch_tol.
        g = ev[i, 0]
        u = ev[i, 1]
        if g > reach or g < -touch_depth(touch_tol) or u < -0.25 or u > 1.25:
            continue
        row = table[i]
        # A vertex within CORNER_REACH of an edge's end is at that corner, so it touches
        # every edge that ends there, whatever its gap to each line (up to CORNER_REACH).
        # At a corner meeting a corner, the gaps of the edges that do not carry the
        # contact are the state's error (about 1e-9 D), and dropping one dropped a way of
        # moving on: the parts jammed where they slip on (docs/contact.md).
        at_corner = corner_distance(row, g, u) <= CORNER_REACH
        if g > touch_tol and not at_corner:
            continue
        skip = False
        for k in range(n_ex):
            if exclude[k] == i:
                skip = True
        if skip or nc >= cand.shape[0]:
            continue
        if not at_corner and not meets_part(row, u, cb, sb, cm, sm, x0, ym, touch_tol):
            continue
        cand[nc] = i
        nc += 1
    return nc
