"""Guaranteed-acceptance regions: ranges of (x0, theta0) that always seat.

The paper (Section IV-A) notes that counting successes is not ideal and asks for "a range of
{x0, theta0} offsets that will always succeed". On a grid map that is an axis-aligned
rectangle of cells that are all SEATED; two are reported: the largest anywhere and the
largest centred on the aligned pose (x0 = 0, theta0 = 0).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["CellRect", "largest_centred_rectangle", "largest_rectangle"]

CellRect = tuple[range, range]
"""(rows, cols) half-open index ranges of a rectangle of grid cells."""


def largest_rectangle(ok: npt.ArrayLike) -> CellRect | None:
    """Largest-area axis-aligned rectangle of True cells (ties: the first found, scanning
    rows top to bottom), or None when no cell is True.

    Uses the classic histogram-stack method: O(rows x cols).

    Examples
    --------
    >>> largest_rectangle([[0, 1, 1], [1, 1, 1], [0, 1, 1]])
    (range(0, 3), range(1, 3))
    >>> largest_rectangle([[0, 0]]) is None
    True
    """
    grid = np.asarray(ok, dtype=bool)
    rows, cols = np.flatnonzero(grid.any(axis=1)), np.flatnonzero(grid.any(axis=0))
    if rows.size == 0:
        return None
    # Only the bounding box of the True cells can hold a rectangle, and a column of False
    # cells left of it closes rectangles as the box's own edge does: the same rectangles are
    # found in the same order. A map's seated cells are mostly a small patch: over the 363
    # maps of the paper's tables the search took 0.11 s, and 0.03 s on the box.
    r0, c0 = int(rows[0]), int(cols[0])
    box = grid[r0 : int(rows[-1]) + 1, c0 : int(cols[-1]) + 1]
    n_cols = box.shape[1]
    best_area = 0
    best: CellRect | None = None
    # Plain lists, with a 0 column closing every row: indexing numpy scalars one by one took
    # about 1 ms of a 41 x 41 map (3 % of the S map's time, all of it in the kernel else).
    heights = [0] * (n_cols + 1)
    for r, row in enumerate(box.tolist(), start=r0):
        for c, inside in enumerate(row):
            heights[c] = heights[c] + 1 if inside else 0
        stack: list[int] = []
        for c in range(n_cols + 1):
            h = heights[c]
            while stack and heights[stack[-1]] >= h:
                top = stack.pop()
                height = heights[top]
                left = stack[-1] + 1 if stack else 0
                area = height * (c - left)
                if area > best_area:
                    best_area = area
                    best = (range(r - height + 1, r + 1), range(c0 + left, c0 + c))
            stack.append(c)
    return best


def largest_centred_rectangle(ok: npt.ArrayLike) -> CellRect | None:
    """Largest-area rectangle of True cells centred on the middle cell of an odd-sized grid
    (the aligned pose), or None when the middle cell is not True. Ties go to the band with
    fewer rows.

    Examples
    --------
    >>> largest_centred_rectangle([[0, 1, 0], [1, 1, 1], [0, 1, 0]])
    (range(1, 2), range(0, 3))
    >>> largest_centred_rectangle([[0, 1, 1, 1, 0], [1, 1, 1, 1, 1], [0, 1, 1, 1, 0]])
    (range(0, 3), range(1, 4))
    """
    grid = np.asarray(ok, dtype=bool)
    n_rows, n_cols = grid.shape
    cr, cc = n_rows // 2, n_cols // 2
    if not grid[cr, cc]:
        return None
    best_area = 0
    best: CellRect | None = None
    max_half_cols = min(cc, n_cols - 1 - cc)
    for half_rows in range(min(cr, n_rows - 1 - cr) + 1):
        rows = grid[cr - half_rows : cr + half_rows + 1]
        half_cols = -1
        for k in range(max_half_cols + 1):
            if rows[:, cc - k : cc + k + 1].all():
                half_cols = k
            else:
                break
        if half_cols < 0:
            break
        max_half_cols = half_cols  # wider row bands can only be narrower
        area = (2 * half_rows + 1) * (2 * half_cols + 1)
        if area > best_area:
            best_area = area
            best = (
                range(cr - half_rows, cr + half_rows + 1),
                range(cc - half_cols, cc + half_cols + 1),
            )
    return best
