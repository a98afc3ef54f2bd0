"""Contact features: vertex-against-edge pairs, their gaps and gradients.

A *pair* is one vertex of one part against one edge of the other part, in the same layer.
Its gap is the signed distance of the vertex from the edge's line along the edge's outward
normal; the pair is geometrically meaningful while the vertex projects inside the edge
(edge parameter ``u`` in [0, 1]).

Every pair is stored in its owners' body frames (units of D) in one flat float table, so the
compiled kernel can loop over plain arrays. Columns of :data:`PairTable.data`:

====  =================================================================================
col   meaning
====  =================================================================================
0     kind: 0 = moving vertex on a base edge, 1 = base vertex on a moving edge
1-2   vertex (body frame of its part)
3-6   edge start and end (body frame of the edge's part)
7-8   outward unit normal of the edge (body frame of the edge's part)
9     layer index
====  =================================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt
from numba import njit

from .geometry import FaceDesign

__all__ = ["PairTable", "contact_geometry", "pair_table"]

FloatArray = npt.NDArray[np.float64]

MOVING_VERTEX = 0
BASE_VERTEX = 1


@dataclass(frozen=True, eq=False)
class PairTable:
    """All vertex-edge pairs of a design plus its edges, ready for the kernel."""

    data: FloatArray
    """(n_pairs, 10) pair table, see the module docstring."""
    base_edges: FloatArray
    """(n, 5) base edges: x0, y0, x1, y1, layer (body frame)."""
    moving_edges: FloatArray
    """(n, 5) moving edges: x0, y0, x1, y1, layer (body frame)."""
    base_radius: float
    """Largest distance of a base vertex from the base pivot (D)."""
    moving_radius: float
    """Largest distance of a moving vertex from the moving pivot (D)."""
    moving_vertices: FloatArray
    """(n, 2) all vertices of the moving part, every layer (body frame, D)."""
    base_top: float
    """Highest point of the base part in its body frame (D)."""


def _edges(poly: FloatArray, layer: int) -> FloatArray:
    nxt = np.roll(poly, -1, axis=0)
    return np.column_stack((poly, nxt, np.full(len(poly), float(layer))))


def _pairs(vertices: FloatArray, edges: FloatArray, kind: int) -> FloatArray:
    rows = []
    for x0, y0, x1, y1, layer in edges:
        dx, dy = x1 - x0, y1 - y0
        length = math.hypot(dx, dy)
        # A counter-clockwise polygon has its outside on the right of each edge.
        nx, ny = dy / length, -dx / length
        for vx, vy in vertices:
            rows.append((kind, vx, vy, x0, y0, x1, y1, nx, ny, layer))
    return np.asarray(rows, dtype=np.float64).reshape(-1, 10)


@lru_cache(maxsize=256)
def _pair_table_cached(key: tuple[object, ...], design: FaceDesign) -> PairTable:
    del key  # only the cache key
    tables, base_edges, moving_edges = [], [], []
    for layer, (base, moving) in enumerate(
        zip(design.base_layers, design.moving_layers, strict=True)
    ):
        be, me = _edges(base, layer), _edges(moving, layer)
        base_edges.append(be)
        moving_edges.append(me)
        tables.append(_pairs(moving, be, MOVING_VERTEX))
        tables.append(_pairs(base, me, BASE_VERTEX))
    return PairTable(
        data=np.ascontiguousarray(np.vstack(tables)),
        base_edges=np.ascontiguousarray(np.vstack(base_edges)),
        moving_edges=np.ascontiguousarray(np.vstack(moving_edges)),
        base_radius=max(float(np.hypot(*p.T).max()) for p in design.base_layers),
        moving_radius=max(float(np.hypot(*p.T).max()) for p in design.moving_layers),
        moving_vertices=np.ascontiguousarray(np.vstack(design.moving_layers)),
        base_top=max(float(p[:, 1].max()) for p in design.base_layers),
    )


def pair_table(design: FaceDesign) -> PairTable:
    """The (cached) pair table of a design; the width does not enter it."""
    return _pair_table_cached(design.cache_key, design)


@njit(cache=True, nogil=True)
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


def contact_geometry(
    design: FaceDesign,
    pairs: npt.NDArray[np.int64],
    phi_b: float,
    phi_m: float,
    x0: float,
    y_m: float,
    *,
    scale: float = 1.0,
) -> tuple[FloatArray, FloatArray]:
    """World contact points and unit normals of the given pairs.

    ``x0`` and ``y_m`` are in units of D; points are returned multiplied by ``scale``.
    Normals point from the base part into the moving part (the direction of the force the
    base exerts on the moving part).
    """
    table = pair_table(design).data
    cb, sb, cm, sm = math.cos(phi_b), math.sin(phi_b), math.cos(phi_m), math.sin(phi_m)
    points = np.zeros((len(pairs), 2))
    normals = np.zeros((len(pairs), 2))
    for k, p in enumerate(pairs):
        row = table[int(p)]
        _, _, _, _, _, px, py, nx, ny = eval_pair(row, cb, sb, cm, sm, x0, y_m)
        sign = 1.0 if row[0] == 0.0 else -1.0
        points[k] = (px * scale, py * scale)
        normals[k] = (sign * nx, sign * ny)
    return points, normals
