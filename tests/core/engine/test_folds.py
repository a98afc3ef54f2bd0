"""folds.py: the 3 x 3 solve, the fold of a two-contact path, cuts into clear pairs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xface_core._engine.folds import cuts_in, det3, fold_residual, solve3, solve_fold
from xface_core._engine.pairs import fill_extents, pair_at
from xface_core._engine.records import CUT_DEPTH


@pytest.mark.parametrize("seed", range(5))
def test_solve3_agrees_with_numpy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(20):
        m = rng.uniform(-1.0, 1.0, (3, 3)) + 3.0 * np.eye(3)  # diagonally dominant
        b = rng.uniform(-1.0, 1.0, 3)
        ok, *x = solve3(*m.ravel(), *b)
        assert ok
        np.testing.assert_allclose(x, np.linalg.solve(m, b), rtol=1e-12, atol=1e-14)
        assert det3(*m.ravel()) == pytest.approx(np.linalg.det(m), rel=1e-12)


def test_solve3_refuses_a_singular_system() -> None:
    m = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]])
    assert solve3(*m.ravel(), 1.0, 2.0, 3.0) == (False, 0.0, 0.0, 0.0)


# ---- a fold in closed form --------------------------------------------------------------
#
# Pair 0: the moving pivot itself as a vertex against a base edge on the line y = 1 (outside
# up), so g0 = n(phi_B) . P_M - 1 with n(phi_B) = (-sin phi_B, cos phi_B): the turned line
# must pass through the pivot, which it can only while |P_M| >= 1. Pair 1: the base pivot as
# a vertex against a moving edge through the moving pivot, g1 = sin(phi_M) x0 - cos(phi_M) y_M.
# Descending at x0 = 0.6, the pinned contacts reach their lowest point where |P_M| = 1:
# y_M = 0.8, n = P_M / |P_M| (phi_B = -asin 0.6), and phi_M = atan2(0.8, 0.6).
X0 = 0.6
FOLD = (-math.asin(0.6), math.atan2(0.8, 0.6), 0.8)
BOTH = np.array([0, 1, -1, -1], dtype=np.int64)


@pytest.fixture(scope="module")
def fold_table(incline) -> np.ndarray:
    table = np.zeros((2, incline.table.shape[1]))  # the engine's row width
    table[0, :9] = [0.0, 0.0, 0.0, 1.0, 1.0, -1.0, 1.0, 0.0, 1.0]
    table[1, :9] = [1.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0, -1.0]
    fill_extents(table)
    return table


def _on_both(y: float) -> tuple[float, float]:
    """The angles with both pairs touching at height y (the branch that reaches the fold)."""
    r = math.hypot(X0, y)
    return math.atan2(-X0, y) + math.acos(1.0 / r), math.atan2(y, X0)


def test_the_closed_form_fold_is_a_fold(fold_table: np.ndarray) -> None:
    pb, pm, y = FOLD
    g0, g1, det = fold_residual(fold_table, BOTH, pb, pm, X0, y)
    assert (g0, g1, det) == pytest.approx((0.0, 0.0, 0.0), abs=1e-15)
    above = _on_both(y + 1e-3)
    assert fold_residual(fold_table, BOTH, *above, X0, y + 1e-3)[:2] == pytest.approx(
        (0.0, 0.0), abs=1e-15
    )


@pytest.mark.parametrize("rise", [1e-6, 1e-4, 5e-4])
def test_solve_fold_finds_where_two_pinned_contacts_turn(
    fold_table: np.ndarray, rise: float
) -> None:
    y = FOLD[2] + rise
    fb, fm, fy, ok = solve_fold(fold_table, BOTH, *_on_both(y), X0, y)
    assert ok
    assert (fb, fm, fy) == pytest.approx(FOLD, abs=1e-9)
    # Both gaps vanish there and so does the determinant of d(g0, g1)/d(phi_B, phi_M),
    # here by central differences of the gaps alone.
    h = 1e-6

    def gaps(b: float, m: float) -> np.ndarray:
        return np.array([pair_at(fold_table, i, b, m, X0, fy)[0] for i in (0, 1)])

    assert gaps(fb, fm) == pytest.approx([0.0, 0.0], abs=1e-12)
    jac = np.column_stack(
        (
            (gaps(fb + h, fm) - gaps(fb - h, fm)) / (2 * h),
            (gaps(fb, fm + h) - gaps(fb, fm - h)) / (2 * h),
        )
    )
    assert abs(np.linalg.det(jac)) <= 1e-8


def test_solve_fold_accepts_a_fold_within_1e_3_below_its_start(fold_table: np.ndarray) -> None:
    y = FOLD[2] + 0.9e-3
    fb, fm, fy, ok = solve_fold(fold_table, BOTH, *_on_both(y), X0, y)
    assert ok
    assert (fb, fm, fy) == pytest.approx(FOLD, abs=1e-9)


def test_solve_fold_refuses_a_fold_more_than_1e_3_below_its_start(fold_table: np.ndarray) -> None:
    # 3e-3 D above the fold the angles are within its reach (phi_B moves by ~0.07 rad,
    # about sqrt(1.6 rise), under the 0.1 rad it allows), but the fold is 3e-3 D below.
    y = FOLD[2] + 3e-3
    start = _on_both(y)
    assert abs(start[0] - FOLD[0]) < 0.1
    assert not solve_fold(fold_table, BOTH, *start, X0, y)[3]


def test_cuts_in_fires_on_a_clear_pair_pushed_behind_its_edge(incline) -> None:
    # Pair 1 of the incline, clear at the start, at a state deeper than CUT_DEPTH behind
    # its edge (its vertex straight below the touching height).
    table, x0 = incline.table, incline.x0
    pm = incline.phi_m_at(incline.s_touch)
    y_touch = incline.y0 - incline.s_touch
    g_start = np.array([0.0, 0.1])
    thr = np.zeros(2)
    assert cuts_in(table, g_start, thr, 0.0, pm, x0, y_touch - 10 * CUT_DEPTH)
    assert not cuts_in(table, g_start, thr, 0.0, pm, x0, y_touch - 0.5 * CUT_DEPTH)


def test_cuts_in_ignores_pairs_that_touched_at_the_start(incline) -> None:
    table, x0 = incline.table, incline.x0
    pm = incline.phi_m_at(incline.s_touch)
    y_deep = incline.y0 - incline.s_touch - 1e-3
    # Pair 1 already at its threshold when the step started: not a skipped contact.
    assert not cuts_in(table, np.array([0.0, 0.0]), np.zeros(2), 0.0, pm, x0, y_deep)
