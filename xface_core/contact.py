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
10-11 outward unit normal of the edge before the edge's start corner (same frame as 7-8)
12-13 outward unit normal of the edge after the edge's end corner (same frame as 7-8)
14    1 if the edge's start corner is convex (its polygon turns left there), else 0
15    1 if the edge's end corner is convex, else 0
16-17 unit direction from the vertex to the next vertex of its polygon (vertex's frame)
18-19 unit direction from the vertex to the previous vertex of its polygon
20    largest distance of the vertex or the edge's ends from their pivots (filled by
      :func:`~xface_core._engine.pairs.fill_extents`)
21    the edge's length (likewise)
22    length of the edge before the edge's start corner (same frame as 3-6)
23    length of the edge after the edge's end corner
24    1 if this pair tests its vertex and its edge's start corner for crossing like an X, 0
      if its partner does (filled after 21: :func:`_mark_corner_tests`)
====  =================================================================================

The neighbours' normals let the engine tell, near a corner, whether a vertex behind the
edge's line is inside the other part (behind both lines of a convex corner) or only beside
it (behind one line, in front of the other: possible at a corner sharper than 90 degrees).
"""

from __future__ import annotations

import math
import threading
import weakref
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ._engine import Model
from ._engine.pairs import (
    COL_CORNER_TESTED,
    COL_EDGE_LENGTH,
    COL_LENGTH_AFTER,
    COL_LENGTH_BEFORE,
    PAIR_COLUMNS,
    eval_pair,
    fill_extents,
)
from .geometry import FaceDesign

__all__ = ["PairTable", "clear_cache", "contact_geometry", "eval_pair", "pair_table"]

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
    model: Model
    """The engine's immutable model built from these arrays."""


def _edges(poly: FloatArray, layer: int) -> FloatArray:
    nxt = np.roll(poly, -1, axis=0)
    return np.column_stack((poly, nxt, np.full(len(poly), float(layer))))


#: Columns of a pair row (see the module docstring).


def _unit(v: FloatArray) -> FloatArray:
    return np.asarray(v / np.hypot(v[:, 0], v[:, 1])[:, None], dtype=np.float64)


def _pairs(vertices: FloatArray, edges: FloatArray, kind: int) -> FloatArray:
    """Every vertex (of a closed polygon, in order) against every edge of another closed
    polygon's edges (in order)."""
    to_next = _unit(np.roll(vertices, -1, axis=0) - vertices)
    to_prev = _unit(np.roll(vertices, 1, axis=0) - vertices)
    d = edges[:, 2:4] - edges[:, 0:2]
    length = np.hypot(d[:, 0], d[:, 1])
    # A counter-clockwise polygon has its outside on the right of each edge.
    normals = np.column_stack((d[:, 1] / length, -d[:, 0] / length))
    before, after = np.roll(normals, 1, axis=0), np.roll(normals, -1, axis=0)
    # The polygon turns left (a convex corner) where the next normal is the previous one
    # turned counter-clockwise.
    convex_start = before[:, 0] * normals[:, 1] - before[:, 1] * normals[:, 0] > 0.0
    convex_end = normals[:, 0] * after[:, 1] - normals[:, 1] * after[:, 0] > 0.0
    n_e, n_v = len(edges), len(vertices)
    length_before, length_after = np.roll(length, 1), np.roll(length, -1)
    # Row (j, i): edge j against vertex i, edges outer, vertices inner.
    per_edge = np.column_stack(
        (edges[:, 0:4], normals, edges[:, 4], before, after, convex_start, convex_end)
    )
    per_vertex = np.column_stack((vertices, to_next, to_prev))
    out = np.empty((n_e, n_v, PAIR_COLUMNS))
    out[:, :, 0] = float(kind)
    out[:, :, 1:3] = per_vertex[None, :, 0:2]
    out[:, :, 3:16] = per_edge[:, None, :]
    out[:, :, 16:20] = per_vertex[None, :, 2:6]
    out[:, :, COL_LENGTH_BEFORE] = length_before[:, None]
    out[:, :, COL_LENGTH_AFTER] = length_after[:, None]
    return out.reshape(-1, PAIR_COLUMNS)


#: Pair tables kept, least recently used first out (a table is a few kB to a few hundred kB).
CACHE_SIZE = 64

_cache: OrderedDict[tuple[object, ...], PairTable] = OrderedDict()
_cache_lock = threading.Lock()

#: The tables of the designs asked for most recently, by the design object itself (a
#: FaceDesign compares and hashes by identity; the entry goes with the design): found
#: without hashing the geometry key again, which tuples do not remember (0.41 against
#: 0.08 us, once per prediction). Emptied when full, so that it keeps at most CACHE_SIZE
#: tables alive besides those of the cache above.
_by_design: weakref.WeakKeyDictionary[FaceDesign, PairTable] = weakref.WeakKeyDictionary()


def _mark_corner_tests(data: FloatArray, first: int, n_base: int, n_moving: int) -> None:
    """Fill COL_CORNER_TESTED for one layer whose moving-vertex block starts at row ``first``
    (its ``n_base`` base and ``n_moving`` moving vertices, as many edges each).

    Row ``first + e n_moving + v`` is moving vertex v against base edge e, which starts at
    base vertex e; its partner, base vertex e against moving edge v (which starts at moving
    vertex v), is row ``first + n_base n_moving + v n_base + e``. Of the two, the one with
    the longer edge tests their corners for crossing (``_engine.pairs.tests_corner_crossing``),
    the moving vertex's on a tie: both lengths are read from the table, so exactly one does.
    """
    e, v = np.divmod(np.arange(n_base * n_moving), n_moving)
    own = first + e * n_moving + v
    partner = first + n_base * n_moving + v * n_base + e
    own_len, partner_len = data[own, COL_EDGE_LENGTH], data[partner, COL_EDGE_LENGTH]
    moving_tests = own_len >= partner_len
    data[own, COL_CORNER_TESTED] = moving_tests
    data[partner, COL_CORNER_TESTED] = ~moving_tests


def _build(design: FaceDesign) -> PairTable:
    tables, base_edges, moving_edges = [], [], []
    blocks = []  # per layer: the first row of its moving-vertex block, and the counts
    start = 0
    for layer, (base, moving) in enumerate(
        zip(design.base_layers, design.moving_layers, strict=True)
    ):
        be, me = _edges(base, layer), _edges(moving, layer)
        base_edges.append(be)
        moving_edges.append(me)
        tables.append(_pairs(moving, be, MOVING_VERTEX))
        tables.append(_pairs(base, me, BASE_VERTEX))
        blocks.append((start, len(base), len(moving)))
        start += 2 * len(base) * len(moving)
    data = np.ascontiguousarray(np.vstack(tables))
    fill_extents(data)
    for first, n_base, n_moving in blocks:
        _mark_corner_tests(data, first, n_base, n_moving)
    base = np.ascontiguousarray(np.vstack(base_edges))
    moving = np.ascontiguousarray(np.vstack(moving_edges))
    return PairTable(
        data=data,
        base_edges=base,
        moving_edges=moving,
        base_radius=max(float(np.hypot(*p.T).max()) for p in design.base_layers),
        moving_radius=max(float(np.hypot(*p.T).max()) for p in design.moving_layers),
        moving_vertices=np.ascontiguousarray(np.vstack(design.moving_layers)),
        base_top=max(float(p[:, 1].max()) for p in design.base_layers),
        model=Model(data, base, moving, float(design.mated_distance)),
    )


def pair_table(design: FaceDesign) -> PairTable:
    """The pair table of a design, cached by its geometry (equal designs and copies at
    another width share one table; the cache holds no reference to a design)."""
    table = _by_design.get(design)
    if table is None:
        table = _by_geometry(design)
        with _cache_lock:
            if len(_by_design) >= CACHE_SIZE:
                _by_design.clear()
            _by_design[design] = table
    return table


def _by_geometry(design: FaceDesign) -> PairTable:
    """The table of the design's geometry from the cache, built if it is not there."""
    key = design.cache_key
    with _cache_lock:
        table = _cache.get(key)
        if table is not None:
            _cache.move_to_end(key)
            return table
    table = _build(design)
    with _cache_lock:
        _cache[key] = table
        while len(_cache) > CACHE_SIZE:
            _cache.popitem(last=False)
    return table


def clear_cache() -> None:
    """Forget every cached pair table (benchmarks measure the cold build with it)."""
    with _cache_lock:
        _cache.clear()
        _by_design.clear()


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
