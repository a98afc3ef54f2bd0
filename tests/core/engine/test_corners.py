"""pairs.py's corner geometry: the clipped gap, whether a crossing meets the part, the
distance to an edge's corner, the vertex-on-vertex wedge test and two corners crossing like
an X (docs/contact.md)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core._engine.pairs import (
    COL_CORNER_TESTED,
    COL_EDGE_LENGTH,
    _side_of_all,
    clipped_gap,
    corner_distance,
    corner_motion_admissible,
    corners_can_cross,
    meets_part,
    pair_at,
    wedges_cross,
)
from xface_core.contact import MOVING_VERTEX, pair_table

# Two unit squares (a base block with its top edge at y = 0, the same block as the moving
# part): every corner convex, the top edge from (0.5, 0) to (-0.5, 0).
SQUARE = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.0), (-0.5, 0.0)]
DESIGN = xf.custom_face([SQUARE], [SQUARE], mated_distance=2.0)
TABLE = pair_table(DESIGN).data


def _pair(kind: int, vertex: tuple[float, float], e0: tuple[float, float]) -> int:
    for i, row in enumerate(TABLE):
        if row[0] == kind and tuple(row[1:3]) == vertex and tuple(row[3:5]) == e0:
            return i
    raise AssertionError("no such pair")


# The moving part's corner (-0.5, 0) (in the world at (x0 + 0.5, y_M) with phi_M = 0)
# against the base's top edge.
TOP = _pair(MOVING_VERTEX, (-0.5, 0.0), (0.5, 0.0))


def _at(world_x: float, world_y: float) -> tuple[float, float, float, float, float]:
    """(g, u, x0, y_M, clipped gap) with the moving corner at (world_x, world_y)."""
    x0, ym = world_x - 0.5, world_y
    g, u, *_ = pair_at(TABLE, TOP, 0.0, 0.0, x0, ym)
    return g, u, x0, ym, clipped_gap(TABLE[TOP], g, 1.0, 0.0, 1.0, 0.0, x0, ym)


def test_a_vertex_behind_the_line_but_beside_the_corner_is_outside() -> None:
    # Past the right end of the top edge and below its line: the right wall's line says the
    # vertex is 0.1 D outside the block.
    g, _, x0, ym, c = _at(0.6, -0.1)
    assert g == pytest.approx(-0.1)
    assert c == pytest.approx(0.1)
    assert not meets_part(TABLE[TOP], 1.1, 1.0, 0.0, 1.0, 0.0, x0, ym, 1e-9)


def test_a_vertex_behind_both_lines_of_a_convex_corner_is_inside() -> None:
    _, u, x0, ym, c = _at(0.45, -0.1)
    assert c == pytest.approx(-0.05)  # the wall is the nearer line
    assert meets_part(TABLE[TOP], u, 1.0, 0.0, 1.0, 0.0, x0, ym, 1e-9)


def test_the_clipped_gap_is_the_gap_inside_the_span() -> None:
    g, _, _, _, c = _at(0.0, -0.01)
    assert c == g


def test_the_corner_distance_is_measured_to_the_nearer_end() -> None:
    row = TABLE[TOP]  # a unit edge
    assert corner_distance(row, 0.0, 0.25) == pytest.approx(0.25)
    assert corner_distance(row, 0.0, 0.9) == pytest.approx(0.1)
    assert corner_distance(row, 3e-9, 1.0 + 4e-9) == pytest.approx(5e-9)


# S H/D 0.5, r_p 1 at x0 = -D/2: the base corner (-0.5, 1.25) meets the moving corner
# (0.5, 1.25), both convex (pairs 40 and 46: the base vertex on the two moving edges at that
# corner), at this state.
S_TABLE = pair_table(xf.s_face(0.5, 1.0)).data
S_STATE = (-0.13110005993332843, 0.5053927452637994, 2.6404418354398747)
S_X0 = -0.5


def _admissible(pair: int, vb: float, vm: float) -> bool:
    """The wedge test for a short move along the rate (v_b, v_m) per unit descent."""
    pb, pm, ym = S_STATE
    trial = (pb + 1e-7 * vb, pm + 1e-7 * vm, ym - 1e-7)
    _, u, *_ = pair_at(S_TABLE, pair, pb, pm, S_X0, ym)
    return corner_motion_admissible(S_TABLE[pair], u > 0.5, S_STATE, trial, S_X0, np.empty((4, 2)))


def test_the_corners_slip_past_each_other_along_one_edge() -> None:
    # The rate that keeps only pair 46 (the base corner sliding along the moving edge away
    # from the corner) keeps the corners apart, judged from either pair of the meeting.
    assert _admissible(40, -0.1774, -0.1935)
    assert _admissible(46, -0.1774, -0.1935)


def test_the_corners_do_not_slip_the_way_that_cuts_in() -> None:
    # The rate that keeps only pair 40 takes the base corner into the moving part.
    assert not _admissible(40, 0.1935, 0.1857)
    assert not _admissible(46, 0.1935, 0.1857)


def test_pure_descent_drives_the_corners_into_each_other() -> None:
    assert not _admissible(40, 0.0, 0.0)


# Two corners crossing like an X: the base's top-right corner K = (0.5, 0) and the moving
# square's corner V (body (-0.5, 0), its edges at 90 and 180 degrees when phi_M = 0), V put
# 0.1 D right of the base's wall and 0.05 D below its top. Turned by phi_M its edges point
# at 90 + phi_M and 180 + phi_M degrees.
V_AT = (0.6, -0.05)
MOVING_V = _pair(MOVING_VERTEX, (-0.5, 0.0), (0.5, 0.0))  # V on the top edge, K its start
BASE_K = _pair(1 - MOVING_VERTEX, (0.5, 0.0), (-0.5, 0.0))  # K on V's edge, V its start


def _judging(row: np.ndarray) -> np.ndarray:
    """The pair's row marked as the one that judges its meeting (either pair of a meeting
    asks the same question; the table lets one of them ask it)."""
    judging = row.copy()
    judging[COL_CORNER_TESTED] = 1.0
    return judging


def _wedges_cross(row: np.ndarray, phi_m_deg: float) -> bool:
    """:func:`wedges_cross` of ``row`` with V at V_AT, the moving part turned by phi_M."""
    phi_m = np.radians(phi_m_deg)
    x0 = V_AT[0] - 0.5 * np.cos(phi_m)
    y_m = V_AT[1] - 0.5 * np.sin(phi_m)
    cm, sm = float(np.cos(phi_m)), float(np.sin(phi_m))
    return wedges_cross(row, 1.0, 0.0, cm, sm, x0, y_m, 1e-9, np.empty((4, 2)))


def _crossing(pair: int, phi_m_deg: float) -> bool:
    return _wedges_cross(_judging(TABLE[pair]), phi_m_deg)


def test_only_one_pair_of_a_meeting_judges_it() -> None:
    # Both edges are 1 D long: the moving vertex's pair judges, its partner answers False
    # even where the corners cross.
    assert TABLE[MOVING_V][COL_CORNER_TESTED] == 1.0
    assert TABLE[BASE_K][COL_CORNER_TESTED] == 0.0
    assert not _wedges_cross(TABLE[BASE_K], 70.0)
    assert _crossing(BASE_K, 70.0)


# The S-Face 0.5/1 pairs whose vertex and edge start are both convex, each with its partner.
_S_MEETINGS = [
    (i, int(j))
    for i, row in enumerate(S_TABLE)
    if corners_can_cross(row) and row[COL_CORNER_TESTED] == 1.0
    for j in np.flatnonzero(
        (S_TABLE[:, 0] != row[0])
        & np.all(S_TABLE[:, 1:3] == row[3:5], axis=1)
        & np.all(S_TABLE[:, 3:5] == row[1:3], axis=1)
    )
]


@settings(max_examples=300, deadline=None)
@given(
    meeting=st.sampled_from(_S_MEETINGS),
    phi_b=st.floats(-1.2, 1.2),
    phi_m=st.floats(-1.2, 1.2),
    offset=st.tuples(st.floats(-0.4, 0.4), st.floats(-0.4, 0.4)),
)
def test_both_pairs_of_a_meeting_ask_the_same_question(
    meeting: tuple[int, int], phi_b: float, phi_m: float, offset: tuple[float, float]
) -> None:
    """The property the table's choice rests on: within both pairs' reach (half the shorter
    edge), the pair that judges and its partner answer alike."""
    i, j = meeting
    row, partner = S_TABLE[i], S_TABLE[j]
    cb, sb, cm, sm = np.cos(phi_b), np.sin(phi_b), np.cos(phi_m), np.sin(phi_m)
    reach = 0.5 * min(row[COL_EDGE_LENGTH], partner[COL_EDGE_LENGTH])
    dx, dy = offset
    assume(1e-3 < np.hypot(dx, dy) < 0.99 * reach)

    # Put the vertex V of row i at its edge's start corner K plus ``offset`` in the world,
    # by the moving pivot: a base point is R(phi_B) r, a moving one P_M - R(phi_M) r.
    def turned(c: float, s: float, x: float, y: float) -> np.ndarray:
        return np.array([c * x - s * y, s * x + c * y])

    v_body, k_body = (row[1], row[2]), (row[3], row[4])
    if row[0] == MOVING_VERTEX:  # V on the moving part, K on the base
        pivot = turned(cb, sb, *k_body) + np.array([dx, dy]) + turned(cm, sm, *v_body)
    else:  # V on the base, K on the moving part
        pivot = turned(cb, sb, *v_body) - np.array([dx, dy]) + turned(cm, sm, *k_body)
    x0, y_m = float(pivot[0]), float(pivot[1])
    rays = np.empty((4, 2))
    here = (float(cb), float(sb), float(cm), float(sm), x0, y_m, 1e-9, rays)
    assert wedges_cross(_judging(row), *here) == wedges_cross(_judging(partner), *here)


@pytest.mark.parametrize("pair", [MOVING_V, BASE_K])
def test_two_corners_crossing_like_an_x_overlap(pair: int) -> None:
    # V's wedge spans 160..250 degrees: K (at 153 degrees from V) is outside it and V is
    # outside the base, yet V's edge at 160 degrees enters the base through its wall.
    assert _crossing(pair, 70.0)


@pytest.mark.parametrize("pair", [MOVING_V, BASE_K])
def test_corners_turned_away_from_each_other_do_not_overlap(pair: int) -> None:
    # V's wedge spans 0..90 degrees, away from the base.
    assert not _crossing(pair, -90.0)


@pytest.mark.parametrize("misaligned", [1.04e-12, -1.04e-12, 5e-10, -5e-10])
def test_rays_on_a_line_to_round_off_count_as_on_it(misaligned: float) -> None:
    # Two flush corners: each wedge has a ray along the shared line, opposite each other,
    # one turned by the angles' error. A line along them has every ray on one side either
    # way round (1.04e-12 rad, just past the old floor of 1e-12 on the dot product, made one
    # run of a mirror pair jam where the other slid flush).
    c, s = np.cos(misaligned), np.sin(misaligned)
    rays = np.array([(1.0, 0.0), (0.0, -1.0), (-c, -s), (0.0, -1.0)])
    assert _side_of_all(0.0, -1.0, rays)


def test_rays_turned_across_a_line_by_more_than_round_off_are_not_on_it() -> None:
    rays = np.array([(1.0, 0.0), (0.0, -1.0), (-np.cos(1e-6), np.sin(1e-6)), (0.0, -1.0)])
    assert not _side_of_all(0.0, -1.0, rays)
