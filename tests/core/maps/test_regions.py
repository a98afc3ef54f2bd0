"""Largest all-True rectangles, checked against brute force."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from xface_core.maps.regions import largest_centred_rectangle, largest_rectangle


def _brute_area(grid: np.ndarray) -> int:
    n, m = grid.shape
    best = 0
    for r0 in range(n):
        for r1 in range(r0 + 1, n + 1):
            for c0 in range(m):
                for c1 in range(c0 + 1, m + 1):
                    if grid[r0:r1, c0:c1].all():
                        best = max(best, (r1 - r0) * (c1 - c0))
    return best


@given(arrays(bool, st.tuples(st.integers(1, 7), st.integers(1, 7))))
def test_largest_rectangle_matches_brute_force(grid: np.ndarray) -> None:
    rect = largest_rectangle(grid)
    area = 0 if rect is None else len(rect[0]) * len(rect[1])
    assert area == _brute_area(grid)
    if rect is not None:
        assert grid[rect[0].start : rect[0].stop, rect[1].start : rect[1].stop].all()


@given(
    arrays(bool, st.tuples(st.integers(1, 7), st.integers(1, 7))),
    st.tuples(*[st.integers(0, 3)] * 4),
)
def test_false_margins_shift_the_rectangle_found(grid: np.ndarray, pad: tuple[int, ...]) -> None:
    # The search runs on the True cells' bounding box: margins of False cells around a grid
    # move the rectangle found (the same one, ties included) and change nothing else.
    top, bottom, left, right = pad
    padded = np.pad(grid, ((top, bottom), (left, right)))
    rect, moved = largest_rectangle(grid), largest_rectangle(padded)
    if rect is None:
        assert moved is None
        return
    assert moved is not None
    assert (moved[0].start - top, moved[0].stop - top) == (rect[0].start, rect[0].stop)
    assert (moved[1].start - left, moved[1].stop - left) == (rect[1].start, rect[1].stop)


@given(arrays(bool, st.tuples(st.sampled_from([1, 3, 5, 7]), st.sampled_from([1, 3, 5]))))
def test_centred_rectangle_is_centred_and_all_true(grid: np.ndarray) -> None:
    rect = largest_centred_rectangle(grid)
    if rect is None:
        assert not grid[grid.shape[0] // 2, grid.shape[1] // 2]
        return
    rows, cols = rect
    assert rows.start + rows.stop - 1 == grid.shape[0] - 1
    assert cols.start + cols.stop - 1 == grid.shape[1] - 1
    assert grid[rows.start : rows.stop, cols.start : cols.stop].all()
