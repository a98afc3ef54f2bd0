"""Interpenetration of the two parts (the start pose's check), layer by layer."""

from __future__ import annotations

import math

from .records import FloatArray, njit_no_refcount


@njit_no_refcount
def segments_cross(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float
) -> bool:
    d1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    d3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    return d1 * d2 < 0.0 and d3 * d4 < 0.0


@njit_no_refcount
def inside(px: float, py: float, edges: FloatArray, layer: float, rot: FloatArray) -> bool:
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


@njit_no_refcount
def fill_world_edges(
    edges: FloatArray, moving: bool, pb: float, pm: float, x0: float, ym: float, out: FloatArray
) -> None:
    """The part's edges (rows ``x1, y1, x2, y2, layer`` in its body frame) in the world, into
    ``out`` (n, 4)."""
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


@njit_no_refcount
def _box(world: FloatArray) -> tuple[float, float, float, float]:
    """(min x, max x, min y, max y) of world edges' end points (D)."""
    lo_x, hi_x, lo_y, hi_y = math.inf, -math.inf, math.inf, -math.inf
    for i in range(world.shape[0]):
        for j in range(2):
            lo_x, hi_x = min(lo_x, world[i, 2 * j]), max(hi_x, world[i, 2 * j])
            lo_y, hi_y = min(lo_y, world[i, 2 * j + 1]), max(hi_y, world[i, 2 * j + 1])
    return lo_x, hi_x, lo_y, hi_y


@njit_no_refcount
def _apart(wb: FloatArray, wm: FloatArray) -> bool:
    """Are the parts' bounding boxes (of their world edges) apart? Then no edges cross and
    no vertex is inside the other part: the usual start, clear above the base, is decided
    without the pairwise tests."""
    b_lo_x, b_hi_x, b_lo_y, b_hi_y = _box(wb)
    m_lo_x, m_hi_x, m_lo_y, m_hi_y = _box(wm)
    return m_lo_y > b_hi_y or b_lo_y > m_hi_y or m_lo_x > b_hi_x or b_lo_x > m_hi_x


@njit_no_refcount
def overlapping(
    base_edges: FloatArray,
    moving_edges: FloatArray,
    pb: float,
    pm: float,
    x0: float,
    ym: float,
    wb: FloatArray,
    wm: FloatArray,
) -> bool:
    """True when the parts interpenetrate in some layer (edges cross or a vertex is inside);
    ``wb``, ``wm`` (n, 4) receive the parts' world edges (:class:`~.records.Work`'s
    ``world_b`` and ``world_m``)."""
    fill_world_edges(base_edges, False, pb, pm, x0, ym, wb)
    fill_world_edges(moving_edges, True, pb, pm, x0, ym, wm)
    if _apart(wb, wm):
        return False
    for i in range(wb.shape[0]):
        for j in range(wm.shape[0]):
            if base_edges[i, 4] != moving_edges[j, 4]:
                continue
            if segments_cross(
                wb[i, 0], wb[i, 1], wb[i, 2], wb[i, 3], wm[j, 0], wm[j, 1], wm[j, 2], wm[j, 3]
            ):
                return True
    for j in range(wm.shape[0]):
        if inside(wm[j, 0], wm[j, 1], base_edges, moving_edges[j, 4], wb):
            return True
    for i in range(wb.shape[0]):
        if inside(wb[i, 0], wb[i, 1], moving_edges, base_edges[i, 4], wm):
            return True
    return False
