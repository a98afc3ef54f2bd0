"""overlap.py: interpenetration of the two parts, layer by layer."""

from __future__ import annotations

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.overlap import (
    _apart,
    fill_world_edges,
    inside,
    overlapping,
    segments_cross,
)
from xface_core.contact import pair_table


def test_crossing_segments_cross() -> None:
    assert segments_cross(0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0)


@pytest.mark.parametrize(
    "other",
    [
        (2.0, 0.0, 3.0, 1.0),  # apart
        (0.5, 0.5, 1.0, 0.0),  # ends on the first: touching, not crossing
        (0.0, 0.5, 1.0, 1.5),  # parallel
    ],
)
def test_touching_or_apart_segments_do_not_cross(other: tuple[float, ...]) -> None:
    assert not segments_cross(0.0, 0.0, 1.0, 1.0, *other)


def test_inside_is_the_even_odd_rule_of_one_layer() -> None:
    # Unit square in layer 0, a far square in layer 1 (ignored for layer 0).
    square = np.array(
        [[0, 0, 1, 0, 0], [1, 0, 1, 1, 0], [1, 1, 0, 1, 0], [0, 1, 0, 0, 0]], dtype=np.float64
    )
    edges = np.vstack((square, square + np.array([5.0, 5.0, 5.0, 5.0, 1.0])))
    world = edges[:, :4].copy()
    assert inside(0.5, 0.5, edges, 0.0, world)
    assert not inside(1.5, 0.5, edges, 0.0, world)
    assert not inside(5.5, 5.5, edges, 0.0, world)
    assert inside(5.5, 5.5, edges, 1.0, world)


def world_edges(
    edges: np.ndarray, moving: bool, pb: float, pm: float, x0: float, ym: float
) -> np.ndarray:
    out = np.full((edges.shape[0], 4), np.nan)
    fill_world_edges(edges, moving, pb, pm, x0, ym, out)
    return out


def _overlapping(base: np.ndarray, moving: np.ndarray, pm: float, x0: float, y: float) -> bool:
    wb, wm = np.empty((base.shape[0], 4)), np.empty((moving.shape[0], 4))
    return bool(overlapping(base, moving, 0.0, pm, x0, y, wb, wm))


def test_world_edges_turn_the_moving_part_about_its_pivot() -> None:
    edges = np.array([[1.0, 0.0, 1.0, 2.0, 0.0]])
    # Moving part at pivot (3, 4) turned by 0: a body point v sits at P_M - v.
    assert world_edges(edges, True, 0.7, 0.0, 3.0, 4.0).tolist() == [[2.0, 4.0, 2.0, 2.0]]
    # Base turned by a quarter turn: (x, y) -> (-y, x).
    out = world_edges(edges, False, np.pi / 2, 0.3, 3.0, 4.0)
    assert out == pytest.approx(np.array([[0.0, 1.0, -2.0, 1.0]]), abs=1e-15)


DESIGN = xf.s_face(0.5, 1.0)
TABLE = pair_table(DESIGN)


def _overlap(x0: float, theta0: float, y: float) -> bool:
    return _overlapping(TABLE.base_edges, TABLE.moving_edges, theta0, x0, y)


def test_parts_apart_do_not_overlap() -> None:
    assert not _overlap(0.2, 0.3, 5.0)


def test_parts_pushed_into_each_other_overlap() -> None:
    assert _overlap(0.0, 0.0, 0.5 * DESIGN.mated_distance)


def test_a_part_deep_inside_the_other_overlaps_without_crossing_edges() -> None:
    # A tiny moving body wholly inside the base: no edges cross, a vertex is inside.
    tiny = np.array(
        [[0.0, 0.0, 0.1, 0.0, 0.0], [0.1, 0.0, 0.0, 0.1, 0.0], [0.0, 0.1, 0.0, 0.0, 0.0]]
    )
    assert _overlapping(TABLE.base_edges, tiny, 0.0, 0.0, 0.5)


def test_parts_whose_boxes_are_apart_are_decided_by_the_boxes() -> None:
    wb = world_edges(TABLE.base_edges, False, 0.0, 0.3, 0.2, 5.0)
    wm = world_edges(TABLE.moving_edges, True, 0.0, 0.3, 0.2, 5.0)
    assert _apart(wb, wm)
    close_b = world_edges(TABLE.base_edges, False, 0.0, 0.0, 0.0, 0.5 * DESIGN.mated_distance)
    close_m = world_edges(TABLE.moving_edges, True, 0.0, 0.0, 0.0, 0.5 * DESIGN.mated_distance)
    assert not _apart(close_b, close_m)


@pytest.mark.parametrize(("x0", "theta0", "y"), [(0.2, 0.3, 5.0), (0.0, 0.0, 0.5), (0.1, 0.2, 1.0)])
def test_the_check_leaves_the_world_edges_in_the_given_arrays(
    x0: float, theta0: float, y: float
) -> None:
    # The engine's form: the caller's scratch arrays (Work.world_b, world_m), no allocation.
    wb = np.full((TABLE.base_edges.shape[0], 4), np.nan)
    wm = np.full((TABLE.moving_edges.shape[0], 4), np.nan)
    overlapping(TABLE.base_edges, TABLE.moving_edges, 0.0, theta0, x0, y, wb, wm)
    assert np.array_equal(wb, world_edges(TABLE.base_edges, False, 0.0, theta0, x0, y))
    assert np.array_equal(wm, world_edges(TABLE.moving_edges, True, 0.0, theta0, x0, y))
