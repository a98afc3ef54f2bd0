"""scan.py: the earliest event of a trial step over every source."""

from __future__ import annotations

import numpy as np
import pytest

from xface_core._engine.events import step_to
from xface_core._engine.pairs import eval_all_pairs
from xface_core._engine.records import (
    E_BELOW_SEAT,
    E_CONTACT,
    E_NONE,
    FINE_SAMPLES,
    STEP_MEMO_SLOTS,
    Work,
    make_options,
)
from xface_core._engine.scan import find_event
from xface_core.physics import Physics

OPTS = make_options(Physics())


def _work(table: np.ndarray, pb: float, pm: float, x0: float, ym: float) -> Work:
    """Work arrays as a segment leaves them at its start: gaps, edge parameters and the
    thresholds of new contacts (pairs clear at the start count at a zero gap)."""
    n = len(table)
    ev = np.zeros((n, 6))
    eval_all_pairs(table, pb, pm, x0, ym, ev)
    tt = OPTS.touch_tol
    thr = np.where((ev[:, 0] >= -4 * tt) & (ev[:, 0] <= tt), np.minimum(ev[:, 0], 0.0) - tt, 0.0)
    return Work(
        ev, ev[:, 0].copy(), ev[:, 1].copy(), np.zeros(n), np.zeros(n), thr,
        np.zeros(16, dtype=np.int64), np.full(8, -1, dtype=np.int64),
        np.array([0, -1, -1, -1], dtype=np.int64), np.zeros(2, dtype=np.int64),
        np.zeros((4, 2)), np.zeros((FINE_SAMPLES, 2)), np.zeros((STEP_MEMO_SLOTS + 1, 9)),
    )  # fmt: skip


def _scan(incline, h: float, y_floor: float = -np.inf, table: np.ndarray | None = None):
    table = incline.table if table is None else table
    seg = incline.segment(y_floor=y_floor)._replace(pairs=table)
    step = incline.step(h)
    work = _work(table, 0.0, step.phi_m, incline.x0, step.y_m)
    nb, nm, _, _, ok = step_to(seg, step, h)
    assert ok
    return find_event(OPTS, seg, step, work, nb, nm), work, (nb, nm)


def test_the_new_contact_in_the_step_is_found(incline) -> None:
    ev, _, _ = _scan(incline, 0.05)
    assert (ev.kind, ev.pair) == (E_CONTACT, 1)
    assert ev.h == pytest.approx(incline.s_touch, abs=2 * OPTS.event_tol)


def test_the_seat_height_before_the_contact_comes_first(incline) -> None:
    y_floor = incline.y0 - 0.005
    ev, _, _ = _scan(incline, 0.05, y_floor=y_floor)
    assert (ev.kind, ev.pair, ev.h) == (E_BELOW_SEAT, -1, incline.y0 - y_floor)


def test_the_contact_before_the_seat_height_comes_first(incline) -> None:
    ev, _, _ = _scan(incline, 0.05, y_floor=incline.y0 - 0.03)
    assert (ev.kind, ev.pair) == (E_CONTACT, 1)


def test_a_step_short_of_every_event_has_none(incline) -> None:
    ev, work, (nb, nm) = _scan(incline, 0.5 * incline.s_touch)
    assert ev.kind == E_NONE
    # The scan leaves every pair's gap at the step's end for the next step.
    end = np.zeros((2, 6))
    eval_all_pairs(incline.table, nb, nm, incline.x0, incline.y0 - 0.5 * incline.s_touch, end)
    assert np.array_equal(work.g_next, end[:, 0])
    assert np.array_equal(work.u_next, end[:, 1])


def test_a_line_crossed_far_beside_its_edge_is_no_contact(incline) -> None:
    # Pair 1's edge cut down to x in [1.0, 1.5]: its vertex (x ~ 0.73) passes beside it.
    table = incline.table.copy()
    table[1, 5] = 1.0
    ev, _, _ = _scan(incline, 0.05, table=table)
    assert ev.kind == E_NONE
