"""pairs.py: a vertex-edge pair's gap, edge parameter and derivatives; the approach."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core._engine.overlap import overlapping
from xface_core._engine.pairs import (
    COL_EDGE_LENGTH,
    COL_LENGTH_AFTER,
    COL_LENGTH_BEFORE,
    COL_REACH,
    PAIR_COLUMNS,
    clipped_gap,
    eval_all_pairs,
    eval_pair,
    fill_extents,
    fill_u_rate,
    next_contact,
    pair_at,
    touching_pairs,
)
from xface_core._engine.records import TOUCH_WINDOW
from xface_core.contact import BASE_VERTEX, MOVING_VERTEX, _pairs, pair_table
from xface_core.runner import start_height


def pair_row(
    kind: int, vertex: tuple[float, float], e0: tuple[float, float], e1: tuple[float, float]
) -> np.ndarray:
    """A pair-table row (layer 0) with the outward normal on the right of the edge's
    direction, as for a counter-clockwise body."""
    dx, dy = e1[0] - e0[0], e1[1] - e0[1]
    length = math.hypot(dx, dy)
    return np.array([kind, *vertex, *e0, *e1, dy / length, -dx / length, 0.0])


coord = st.floats(-1.0, 1.0)
angle = st.floats(-math.pi, math.pi)


@st.composite
def rows(draw: st.DrawFn) -> np.ndarray:
    """A pair of either kind with an edge at least 0.1 D long."""
    kind = draw(st.sampled_from([MOVING_VERTEX, BASE_VERTEX]))
    e0 = (draw(coord), draw(coord))
    e1 = (draw(coord), draw(coord))
    if math.hypot(e1[0] - e0[0], e1[1] - e0[1]) < 0.1:
        e1 = (e0[0] + 0.1, e0[1])
    return pair_row(kind, (draw(coord), draw(coord)), e0, e1)


def _rot(phi: float) -> np.ndarray:
    return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])


def _world(row: np.ndarray, pb: float, pm: float, x0: float, ym: float) -> tuple[np.ndarray, ...]:
    """Vertex and edge ends in the world: base points at R(pb) v, moving ones at
    P_M - R(pm) v."""
    pivot = np.array([x0, ym])
    base, moving = (lambda p: _rot(pb) @ p), (lambda p: pivot - _rot(pm) @ p)
    vertex_to, edge_to = (moving, base) if row[0] == MOVING_VERTEX else (base, moving)
    return vertex_to(row[1:3]), edge_to(row[3:5]), edge_to(row[5:7])


def _outside_sign(row: np.ndarray) -> float:
    """+1 when the body-frame normal is on the right of the edge (kept so in the world:
    the moving part is turned by 180 degrees, which keeps orientation)."""
    d, n = row[5:7] - row[3:5], row[7:9]
    return float(np.sign(d[1] * n[0] - d[0] * n[1]))


def test_moving_vertex_against_a_turned_base_edge() -> None:
    # The base edge y = 1 (outside up) turned by 90 degrees lies on x = -1, outside -x; the
    # moving vertex (0.1, 0.2) turned by 90 degrees sits at P_M + (0.2, -0.1) = (-3, 0.2).
    row = pair_row(MOVING_VERTEX, (0.1, 0.2), (0.5, 1.0), (-0.5, 1.0))
    out = pair_at(row[None, :], 0, math.pi / 2, math.pi / 2, -3.2, 0.3)
    # g = 2 beyond the line, u = 0.3 along it; turning the base by +dphi moves the line by
    # -0.2 dphi at the vertex, turning the moving part moves the vertex by (0.1, 0.2) dphi;
    # lifting the moving pivot slides the vertex along the line (beta = 0).
    expected = (2.0, 0.3, -0.2, -0.1, 0.0, -3.0, 0.2, -1.0, 0.0)
    assert out == pytest.approx(expected, abs=1e-15)


def test_base_vertex_against_a_moving_edge() -> None:
    # The moving edge (0.5, 1) -> (-0.5, 1) of the unturned moving part lies at y = y_M - 1,
    # its outside facing down (-y): the base vertex (0.1, 0.2) is 1.8 below it.
    row = pair_row(BASE_VERTEX, (0.1, 0.2), (0.5, 1.0), (-0.5, 1.0))
    out = eval_pair(row, 1.0, 0.0, 1.0, 0.0, 0.2, 3.0)
    # u = 0.4 from (x0 - 0.5) towards (x0 + 0.5); lifting the moving part opens the gap.
    expected = (1.8, 0.4, -0.1, -0.1, 1.0, 0.1, 0.2, 0.0, -1.0)
    assert out == pytest.approx(expected, abs=1e-15)


@settings(max_examples=200)
@given(row=rows(), pb=angle, pm=angle, x0=st.floats(-2.0, 2.0), ym=st.floats(0.0, 4.0))
def test_gap_is_the_signed_distance_from_the_edge_line(
    row: np.ndarray, pb: float, pm: float, x0: float, ym: float
) -> None:
    g, u, _, _, _, px, py, nx, ny = pair_at(row[None, :], 0, pb, pm, x0, ym)
    p, e0, e1 = _world(row, pb, pm, x0, ym)
    d, r = e1 - e0, p - e0
    length = math.hypot(*d)
    # Right of the edge's direction is outside: distance = (d x r) / |d| with a minus sign.
    assert g == pytest.approx(-_outside_sign(row) * (d[0] * r[1] - d[1] * r[0]) / length, abs=1e-12)
    assert u == pytest.approx(float(r @ d) / length**2, abs=1e-12)
    assert (px, py) == pytest.approx(tuple(p), abs=1e-12)
    assert math.hypot(nx, ny) == pytest.approx(1.0, abs=1e-12)
    assert nx * d[0] + ny * d[1] == pytest.approx(0.0, abs=1e-12)


@settings(max_examples=200)
@given(row=rows(), pb=angle, pm=angle, x0=st.floats(-2.0, 2.0), ym=st.floats(0.0, 4.0))
def test_derivatives_match_central_differences_of_the_gap(
    row: np.ndarray, pb: float, pm: float, x0: float, ym: float
) -> None:
    table = row[None, :]
    _, _, a_b, a_m, beta, _, _, _, _ = pair_at(table, 0, pb, pm, x0, ym)
    h = 1e-6

    def g(b: float, m: float, y: float) -> float:
        return float(pair_at(table, 0, b, m, x0, y)[0])

    assert a_b == pytest.approx((g(pb + h, pm, ym) - g(pb - h, pm, ym)) / (2 * h), abs=1e-7)
    assert a_m == pytest.approx((g(pb, pm + h, ym) - g(pb, pm - h, ym)) / (2 * h), abs=1e-7)
    assert beta == pytest.approx((g(pb, pm, ym + h) - g(pb, pm, ym - h)) / (2 * h), abs=1e-7)


X_TABLE = pair_table(xf.x_face(0.5, 1.0)).data


@settings(max_examples=50)
@given(pb=st.floats(-0.5, 0.5), pm=st.floats(-0.5, 0.5), x0=st.floats(-1.0, 1.0))
def test_all_pairs_are_the_single_pair_values(pb: float, pm: float, x0: float) -> None:
    ev = np.full((len(X_TABLE), 6), 7.0)
    eval_all_pairs(X_TABLE, pb, pm, x0, 2.7, ev)
    expected = [pair_at(X_TABLE, i, pb, pm, x0, 2.7)[:5] for i in range(len(X_TABLE))]
    assert np.array_equal(ev[:, :5], np.array(expected))
    assert np.all(ev[:, 5] == 7.0)  # the approach's column is left alone


@settings(max_examples=50)
@given(pb=st.floats(-0.5, 0.5), pm=st.floats(-0.5, 0.5), x0=st.floats(-1.0, 1.0))
def test_u_rate_is_the_edge_parameter_rate_of_a_pure_descent(
    pb: float, pm: float, x0: float
) -> None:
    ev = np.zeros((len(X_TABLE), 6))
    fill_u_rate(X_TABLE, pb, pm, ev)
    h = 1e-6
    for i in range(len(X_TABLE)):
        u_up = pair_at(X_TABLE, i, pb, pm, x0, 2.7 + h)[1]
        u_down = pair_at(X_TABLE, i, pb, pm, x0, 2.7 - h)[1]
        assert ev[i, 5] == pytest.approx((u_down - u_up) / (2 * h), abs=1e-6)


@pytest.mark.parametrize(("x0", "theta0"), [(0.3, 0.2), (-0.6, -0.4), (0.0, 0.0), (0.9, 1.0)])
def test_next_contact_is_the_first_touch_of_a_pure_descent(x0: float, theta0: float) -> None:
    design = xf.x_face(0.5, 1.0)
    table = pair_table(design)
    y = start_height(design, theta0)
    ev = np.zeros((len(X_TABLE), 6))
    eval_all_pairs(X_TABLE, 0.0, theta0, x0, y, ev)
    fill_u_rate(X_TABLE, 0.0, theta0, ev)
    d, i = next_contact(ev, 1e-9)
    assert i >= 0
    g, u, *_ = pair_at(X_TABLE, i, 0.0, theta0, x0, y - d)
    assert g == pytest.approx(0.0, abs=1e-12)
    assert -1e-12 <= u <= 1.0 + 1e-12

    wb, wm = np.empty((len(table.base_edges), 4)), np.empty((len(table.moving_edges), 4))

    def overlap(s: float) -> bool:
        b, m = table.base_edges, table.moving_edges
        return bool(overlapping(b, m, 0.0, theta0, x0, y - s, wb, wm))

    # Clear of each other all the way down to d, cutting in just beyond it.
    assert not any(overlap(s) for s in np.linspace(0.0, d, 50)[:-1])
    assert overlap(d + 1e-3)


def test_next_contact_without_approaching_pairs_is_none() -> None:
    ev = np.zeros((3, 6))
    ev[:, 0] = [1.0, 0.5, 2.0]  # gaps
    ev[:, 1] = 0.5
    ev[:, 4] = [-1.0, 0.0, -0.5]  # beta <= 0: descending opens these gaps or keeps them
    assert next_contact(ev, 1e-9) == (math.inf, -1)


def test_next_contact_skips_pairs_that_meet_the_line_beyond_the_edge() -> None:
    ev = np.zeros((2, 6))
    ev[0] = [0.1, 0.5, 0.0, 0.0, 1.0, 20.0]  # touches at d = 0.1 but with u = 2.5
    ev[1] = [0.3, 0.5, 0.0, 0.0, 1.0, 1.0]  # touches at d = 0.3 with u = 0.8
    assert next_contact(ev, 1e-9) == (pytest.approx(0.3), 1)


def test_touching_pairs_window_and_exclusions() -> None:
    tol = 1e-9
    ev = np.zeros((6, 6))
    ev[:, 0] = [0.5 * tol, -3.9 * tol, 2 * tol, -(TOUCH_WINDOW + 1) * tol, 0.0, 0.0]
    ev[:, 1] = [0.5, 1.0 + 0.5e-6, 0.5, 0.5, -2e-6, 0.2]
    cand = np.full(16, -1, dtype=np.int64)
    exclude = np.array([5, -1], dtype=np.int64)
    # Unit edges with reflex (unflagged) ends: no neighbour masks a pair.
    table = np.zeros((6, PAIR_COLUMNS))
    table[:, 3:7] = [0.0, 0.0, 1.0, 0.0]
    fill_extents(table)
    n = touching_pairs(table, ev, 0.0, 0.0, 0.0, 2.0, tol, exclude, 1, cand)
    # 2: too far, 3: too deep, 4: beyond the edge's start, 5: excluded.
    assert cand[:n].tolist() == [0, 1]


def test_a_vertex_at_a_corner_touches_the_edges_that_end_there_whatever_its_gap() -> None:
    # After a slide off an edge's end the vertex sits at the corner, and its gaps to the
    # lines of the edges that end there are the state's error (1e-9 D), either sign.
    tol = 1e-9
    ev = np.zeros((5, 6))
    ev[:, 0] = [2.0 * tol, -2.0 * tol, 2.0 * tol, 2.0 * tol, 2e-7]
    ev[:, 1] = [1.0, 1e-9, 0.5, 1.0 - 1e-6, 1.0]
    cand = np.full(16, -1, dtype=np.int64)
    table = np.zeros((5, PAIR_COLUMNS))
    table[:, 3:7] = [0.0, 0.0, 1.0, 0.0]
    fill_extents(table)
    n = touching_pairs(table, ev, 0.0, 0.0, 0.0, 2.0, tol, cand[:0], 0, cand)
    # 2: off the line inside the span; 3: 1e-6 D from the corner; 4: 2e-7 D off the line.
    assert cand[:n].tolist() == [0, 1]


def test_the_extents_are_the_pairs_reach_and_edge_length() -> None:
    table = pair_table(xf.x_face(0.5, 1.0)).data
    for row in table:
        reach = max(math.hypot(row[1], row[2]), math.hypot(row[3], row[4]),
                    math.hypot(row[5], row[6]))  # fmt: skip
        assert row[COL_REACH] == pytest.approx(reach, rel=1e-15)
        assert row[COL_EDGE_LENGTH] == pytest.approx(
            math.hypot(row[5] - row[3], row[6] - row[4]), rel=1e-15
        )


#: A base body with a needle on its top-left corner (counter-clockwise): the left wall runs
#: from the needle's tip (-1, 1) down to (-1, -1); the needle's other flank, 1 D long, is
#: almost parallel to it (0.001 D apart at the needle's base, y = 0).
NEEDLE_BODY = np.array([(-1.0, -1.0), (1.0, -1.0), (1.0, 0.0), (-0.999, 0.0), (-1.0, 1.0)])


def _needle_wall_row() -> np.ndarray:
    """A moving vertex at its pivot (so at (x0, y_M) in the world with phi_M 0) against the
    needle body's left wall (edge 4: tip to bottom corner)."""
    edges = np.column_stack((NEEDLE_BODY, np.roll(NEEDLE_BODY, -1, axis=0), np.zeros(5)))
    vertices = np.array([(0.0, 0.0), (0.1, 0.0), (0.0, 0.1)])
    table = _pairs(vertices, edges, MOVING_VERTEX)
    fill_extents(table)
    return table[4 * len(vertices)]


def _clipped_at(row: np.ndarray, x: float, y: float) -> float:
    g = eval_pair(row, 1.0, 0.0, 1.0, 0.0, x, y)[0]
    return float(clipped_gap(row, g, 1.0, 0.0, 1.0, 0.0, x, y))


def test_the_neighbour_lengths_are_the_edges_before_and_after_the_corners() -> None:
    row = _needle_wall_row()
    assert row[COL_LENGTH_BEFORE] == pytest.approx(math.hypot(0.001, 1.0), rel=1e-15)
    assert row[COL_LENGTH_AFTER] == pytest.approx(2.0, rel=1e-15)


def test_a_vertex_in_the_body_past_a_needle_s_base_is_inside_through_the_wall() -> None:
    # Behind the wall's line, beside the needle flank's line, but farther along the flank
    # than the flank is long: inside the body (the flank's line says nothing there).
    row = _needle_wall_row()
    assert shapely.Polygon(NEEDLE_BODY).contains(shapely.Point(-0.5, -0.5))
    assert _clipped_at(row, -0.5, -0.5) == pytest.approx(-0.5, abs=1e-15)


def test_a_vertex_beside_a_needle_within_its_span_is_outside() -> None:
    # In the notch between the needle and the body's top: behind the wall's line, in front
    # of the flank's, within the flank's span.
    row = _needle_wall_row()
    assert not shapely.Polygon(NEEDLE_BODY).contains(shapely.Point(-0.9, 0.5))
    assert _clipped_at(row, -0.9, 0.5) > 0.0
