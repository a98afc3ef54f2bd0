"""scan.py: the earliest event of a trial step over every source."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.events import NO_EVENT, step_to
from xface_core._engine.motion import slip_margin
from xface_core._engine.pairs import (
    COL_CORNER_TESTED,
    COL_LENGTH_AFTER,
    PAIR_COLUMNS,
    clipped_gap,
    eval_all_pairs,
    eval_pair,
    fill_extents,
    pair_at,
)
from xface_core._engine.records import (
    CORNER_REACH,
    DENSE_WIDTH,
    E_BELOW_SEAT,
    E_CONTACT,
    E_NONE,
    E_SLIP,
    FINE_SAMPLES,
    FREE,
    RUN_DTYPE,
    STEP_MEMO_SLOTS,
    STEP_MEMO_WIDTH,
    Contacts,
    Segment,
    Step,
    Work,
    make_options,
    new_work,
)
from xface_core._engine.scan import (
    _contact_events,
    _crossing,
    _far_behind,
    _far_outside_or_behind,
    _gap_bounds,
    _inside_thin_corner,
    _segment_distance,
    _travel,
    _trig,
    _turn_rates,
    find_event,
    reach_budget,
)
from xface_core._engine.segment import begin_segment
from xface_core.physics import Physics
from xface_core.runner import engine_model

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
        np.zeros((4, 2)), np.zeros((FINE_SAMPLES, 6)),
        np.zeros((STEP_MEMO_SLOTS + 1, STEP_MEMO_WIDTH)),
        np.column_stack([np.zeros(n), np.full(n, -1.0), np.zeros(n)]), np.zeros((2, DENSE_WIDTH)),
        np.empty((3, n + 2), dtype=np.int64), np.full(4, -1, dtype=np.int64),
        np.empty((0, 4)), np.empty((0, 4)), np.empty(n, dtype=np.int64),
        np.zeros(1, dtype=np.int64), np.full((n, 4), np.nan),
    )  # fmt: skip


def _scan(incline, h: float, y_floor: float = -np.inf, table: np.ndarray | None = None):
    table = incline.table if table is None else table
    seg = incline.segment(y_floor=y_floor)
    seg = seg._replace(held=seg.held._replace(pairs=table))
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


def _segments_of_a_dock(design, x0: float, theta0: float):
    """(segment, step start) at every path sample of a dock with contacts held."""
    p = xf.predict(design, x0 * design.width, theta0)
    model = engine_model(design)
    opts = make_options(Physics())
    y0 = p.y_start / design.width
    for k in range(len(p.path.descent)):
        act = np.full(4, -1, dtype=np.int64)
        held = [int(j) for j in p.path.contact_pairs[k] if j >= 0]
        if not held:
            continue
        act[: len(held)] = held
        contacts = Contacts(
            model.pairs, act, len(held), 0.0, np.full(2, FREE, dtype=np.int64), x0,
            opts.sqrt_winv_b, opts.sqrt_winv_m, opts.winv_b, opts.winv_m,
        )  # fmt: skip
        seg = Segment(
            contacts, -np.inf, np.zeros((STEP_MEMO_SLOTS + 1, STEP_MEMO_WIDTH)),
            np.zeros((2, DENSE_WIDTH)),
        )  # fmt: skip
        y = y0 - p.path.descent[k] / design.width
        yield seg, Step(float(p.path.phi_b[k]), float(p.path.phi_m[k]), float(y), 0.0)


def _screened_steps(design, x0: float, theta0: float):
    """(segment, trial step, turn-rate bound, cos and sin at both ends) for steps of 0.002,
    0.01 and 0.05 D from every path sample of a dock with contacts held."""
    for seg, start in _segments_of_a_dock(design, x0, theta0):
        for h in (0.002, 0.01, 0.05):
            step = start._replace(h=h)
            nb, nm, _, _, ok = step_to(seg, step, h)
            if not ok:
                continue
            ends = (
                (np.cos(step.phi_b), np.sin(step.phi_b), np.cos(step.phi_m), np.sin(step.phi_m)),
                (np.cos(nb), np.sin(nb), np.cos(nm), np.sin(nm)),
            )
            yield seg, step, _turn_rates(seg, step, nb, nm), ends


def _pair_inside_step(seg, step: Step, i: int, states: int) -> list[tuple[float, float]]:
    """Pair i's gap and edge parameter at ``states`` evenly spaced states of the step, its
    ends included (each one integration step from the step's start)."""
    values = []
    for t in np.linspace(0.0, step.h, states):
        pb, pm, _, _, _ = step_to(seg, step, t)
        g, u = pair_at(seg.held.pairs, i, pb, pm, seg.held.x0, step.y_m - t)[:2]
        values.append((float(g), float(u)))
    return values


@pytest.mark.parametrize(
    ("design", "x0", "theta0"),
    [
        (xf.x_face(0.25, 2.0), 0.3, 0.2),
        (xf.s_face(0.5, 1.0), 0.1, -0.2),
        (xf.v_face(0.5, 1.0), 0.2, 0.3),
    ],
)
def test_the_gap_never_rises_above_its_ceiling_in_a_step(design, x0, theta0) -> None:
    # The far-behind screen skips a pair's contact search only below this ceiling: on real
    # segments (every held set of three docks, steps up to the longest the engine takes),
    # the plain gap at 64 states inside the step stays under it, from the ends and from
    # the quarters alike.
    checked = 0
    for seg, step, rates, ends in _screened_steps(design, x0, theta0):
        for i in range(seg.held.pairs.shape[0]):
            gaps = [g for g, _ in _pair_inside_step(seg, step, i, 64)]
            top, low = max(gaps), min(gaps)
            for pieces in (1, 4):
                floor, ceiling, _, _ = _gap_bounds(seg, step, i, rates, pieces, *ends)
                assert floor <= low
                assert top <= ceiling
            if _far_behind(seg, step, i, 0.0, rates, *ends):
                assert top < -CORNER_REACH
            if _far_outside_or_behind(seg, step, i, 0.0, rates, *ends):
                assert low > 0.0 or top < -CORNER_REACH
            checked += 1
    assert checked > 100


@pytest.mark.parametrize(
    ("design", "x0", "theta0"),
    [
        (xf.x_face(0.25, 2.0), 0.3, 0.2),
        (xf.s_face(0.5, 1.0), 0.1, -0.2),
        (xf.v_face(0.5, 1.0), 0.2, 0.3),
    ],
)
def test_the_reach_budget_changes_less_than_the_travel_in_a_step(design, x0, theta0) -> None:
    # A pair sleeps while its reach budget exceeds the travel the steps spend
    # (_contact_events: the descent plus twice the turn between a step's ends times the
    # pair's reach). On real segments the budget, taken at 17 states inside each step,
    # never moves by more than that travel (0.77 of it at most when measured).
    checked = 0
    for seg, step, _, _ in _screened_steps(design, x0, theta0):
        nb, nm, _, _, _ = step_to(seg, step, step.h)
        turn = abs(nb - step.phi_b) + abs(nm - step.phi_m)
        for i in range(seg.held.pairs.shape[0]):
            row = seg.held.pairs[i]
            budgets = [reach_budget(row, g, u) for g, u in _pair_inside_step(seg, step, i, 17)]
            assert max(budgets) - min(budgets) <= _travel(row, step.h, 2.0 * turn)
            checked += 1
    assert checked > 100


@pytest.mark.parametrize(
    ("design", "x0", "theta0"),
    [(xf.s_face(0.5, 1.0), 0.1, -0.2), (xf.x_face(0.25, 2.0), 0.3, 0.2)],
)
def test_the_pairs_near_their_edge_are_listed_for_the_dip_search(design, x0, theta0) -> None:
    # _contact_events lists the pairs _contacts_inside_step samples: every inactive pair
    # whose vertex comes within the step's travel of its edge at either end, and no other.
    listed = 0
    for seg, step, _, ends in _screened_steps(design, x0, theta0):
        nb, nm, _, _, _ = step_to(seg, step, step.h)
        work = _work(seg.held.pairs, step.phi_b, step.phi_m, seg.held.x0, step.y_m)
        _, _, n_near = _contact_events(OPTS, seg, step, work, nb, nm, *ends, NO_EVENT)
        turn = abs(nb - step.phi_b) + abs(nm - step.phi_m)
        expected = []
        for i in range(seg.held.pairs.shape[0]):
            if i in seg.held.act[: seg.held.n_active]:
                continue
            row, bound = seg.held.pairs[i], _travel(seg.held.pairs[i], step.h, turn)
            g0, u0, g1, u1 = work.g_prev[i], work.u_prev[i], work.g_next[i], work.u_next[i]
            if min(_segment_distance(row, g0, u0), _segment_distance(row, g1, u1)) <= bound:
                expected.append(i)
        assert sorted(work.near[:n_near]) == expected
        listed += n_near
    assert listed > 0


@pytest.mark.parametrize(
    ("design", "x0", "theta0"),
    [(xf.s_face(0.5, 1.0), 0.1, -0.2), (xf.v_face(0.5, 1.0), 0.2, 0.3)],
)
def test_the_shared_screen_decides_as_the_two_screens_do(design, x0, theta0) -> None:
    # _contacts_inside_step takes one bound over the step's ends for both screens; it must
    # skip exactly the pairs that one of the two would skip, at thresholds either side.
    decided = set()
    for seg, step, rates, ends in _screened_steps(design, x0, theta0):
        for i in range(seg.held.pairs.shape[0]):
            for thr in (-0.1, -1e-9, 0.0, 0.02):
                # The outside screen: the bound from the step's ends stays above thr.
                outside = _gap_bounds(seg, step, i, rates, 1, *ends)[0] > thr
                behind = _far_behind(seg, step, i, thr, rates, *ends)
                shared = _far_outside_or_behind(seg, step, i, thr, rates, *ends)
                assert shared == (outside or behind)
                decided.add((outside, behind))
    assert {(True, False), (False, True), (False, False)} <= decided


def _budget_row(length: float, crossable: bool, judges: bool = True) -> np.ndarray:
    """A pair row with an edge of ``length``; its start corner K and its vertex V both convex
    (they can cross like an X) or K reflex; a crossable pair that does not ``judge`` leaves
    the meeting to its partner (pairs.tests_corner_crossing)."""
    row = np.zeros(PAIR_COLUMNS)
    row[21] = length  # COL_EDGE_LENGTH
    row[14] = 1.0 if crossable else 0.0  # K convex
    row[16:20] = (1.0, 0.0, 0.0, 1.0)  # V's two edge directions: a convex vertex
    row[COL_CORNER_TESTED] = 1.0 if judges else 0.0
    return row


def _distances(g: float, u: float, length: float) -> tuple[float, float]:
    """Distance from the edge extended by a quarter at each end (where a line crossing is
    searched) and from the start corner's half-edge disc (two corners crossing)."""
    t = np.linspace(-0.25, 1.25, 301)
    to_edge = np.hypot((u - t) * length, g).min()
    to_corner = max(np.hypot(u * length, g) - 0.51 * length, 0.0)
    return to_edge, to_corner


@pytest.mark.parametrize("seed", range(5))
def test_thereach_budget_is_below_every_distance_at_which_a_pair_is_looked_at(seed) -> None:
    # A pair whose corners can cross is looked at near its edge and near its start corner;
    # the budget must be below both distances, so that a pair moving less than its budget
    # cannot get there unseen. One whose corners cannot cross is looked at near its edge.
    rng = np.random.default_rng(seed)
    length = rng.uniform(0.05, 2.0)
    crossable, reflex = _budget_row(length, True), _budget_row(length, False)
    partner = _budget_row(length, True, judges=False)
    for g, u in zip(rng.normal(0.0, 1.0, 200), rng.normal(0.5, 1.5, 200), strict=True):
        to_edge, to_corner = _distances(g, u, length)
        assert reach_budget(crossable, g, u) <= min(to_edge, to_corner) + 1e-12
        assert reach_budget(reflex, g, u) <= to_edge + 1e-12
        assert reach_budget(partner, g, u) <= to_edge + 1e-12


def test_a_reflex_corner_does_not_keep_a_pair_near_it_in_the_scans() -> None:
    # Vertex half an edge beside the edge's line at its start corner: in the corner's disc,
    # but 0.3 edges from the edge itself. Only a pair whose corners can cross is kept there.
    length, g, u = 1.0, 0.3, -0.1
    assert reach_budget(_budget_row(length, True), g, u) < 0.0
    assert reach_budget(_budget_row(length, False), g, u) == pytest.approx(0.3 - 1e-6)


def test_a_pair_that_leaves_its_corners_to_its_partner_is_not_kept_near_them() -> None:
    # As above, with both corners convex: the pair whose partner judges the meeting sleeps
    # by its edge alone.
    length, g, u = 1.0, 0.3, -0.1
    partner = _budget_row(length, True, judges=False)
    assert reach_budget(partner, g, u) == pytest.approx(0.3 - 1e-6)


def test_a_pair_flat_at_the_event_does_not_come_before_it() -> None:
    # V 0.5/1 from x0 0.6 D, theta0 -pi/20: two contacts carry the parts to the seat, where
    # a third closes. A vertex held on a neighbouring edge's line has a contact function
    # zero to round-off there (flat: "located" at the step's start). When its round-off
    # fell below zero at the seat's state, it came first and ended the run 8e-5 rad short
    # of the seat (seen once the two-contact steps were solved instead of integrated).
    design = xf.v_face(0.5, 1.0)
    p = xf.predict(design, 0.6 * design.width, -np.pi / 20.0)
    assert p.outcome == xf.Outcome.SEATED
    assert abs(p.phi_b - p.phi_m) < 1e-9


def _needle_table(incline, tip_x: float) -> np.ndarray:
    """Pair 1 of the incline turned into a thin base needle pointing left at pair 1's contact
    height: its upper flank (the pair's edge, outside up) runs from (tip_x + 3, height + 1e-3)
    to the tip (tip_x, height); the lower flank goes back from the tip 1e-3 below."""
    height = incline.table[1, 4]
    top = (tip_x + 3.0, height + 1e-3)
    tip = (tip_x, height)
    length = math.hypot(3.0, 1e-3)
    up = (-1e-3 / length, 3.0 / length)  # outward normal of the upper flank
    down = (-1e-3 / length, -3.0 / length)  # of the lower flank (tip to (tip_x + 3, height - 1e-3))
    table = incline.table.copy()
    row = np.zeros(PAIR_COLUMNS)
    row[:10] = (0.0, -0.4, 1.3, *top, *tip, *up, 0.0)
    row[12:14] = down
    row[15] = 1.0  # the tip is a convex corner; the flank's other end counts as reflex
    row[COL_LENGTH_AFTER] = length
    table[1] = row
    fill_extents(table)
    return table


def _through_needle(incline, tip_x: float) -> float:
    table = _needle_table(incline, tip_x)
    seg = incline.segment()
    seg = seg._replace(held=seg.held._replace(pairs=table))
    step = incline.step(0.05)
    nb, nm, _, _, ok = step_to(seg, step, step.h)
    assert ok
    ends = ((step.phi_b, step.phi_m, step.y_m), (nb, nm, step.y_m - step.h))
    gaps = tuple(pair_at(table, 1, pb, pm, incline.x0, y)[0] for pb, pm, y in ends)
    beside_end = clipped_gap(table[1], gaps[1], *_trig(nb, nm), incline.x0, ends[1][2])
    start = _trig(step.phi_b, step.phi_m)
    return float(
        _inside_thin_corner(seg, step, table[1], 0.0, OPTS.event_tol, gaps, beside_end, start)
    )


def test_a_vertex_through_a_thin_needle_in_one_step_is_found_inside_it(incline) -> None:
    # The vertex (x ~ 0.73) comes down through the needle, 0.2 D from its tip: behind both
    # flanks' lines between the two crossings, 8.5e-5 D of descent apart.
    t = _through_needle(incline, 0.5)
    assert 0.0 < t < 0.05
    pm = incline.phi_m_at(t)
    row = _needle_table(incline, 0.5)[1]
    y = incline.y0 - t
    assert eval_pair(row, 1.0, 0.0, math.cos(pm), math.sin(pm), incline.x0, y)[0] <= 0.0
    assert clipped_gap(row, -math.inf, 1.0, 0.0, math.cos(pm), math.sin(pm), incline.x0, y) <= 0.0


def test_a_vertex_passing_beside_a_needle_s_tip_is_not_inside_it(incline) -> None:
    # The tip at x = 1.0, right of the vertex's path: it crosses both lines' extensions left
    # of the tip, the lower one first (in front of both in between).
    assert _through_needle(incline, 1.0) == 0.0


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_release_before_a_pole_in_the_same_step_comes_first(sign: float) -> None:
    # X 0.25/1 from (-0.85 D, 0.7069) and its mirror: in one step of the two-contact segment
    # contact 54's force crosses zero (0.3 of the step in), then both forces change sign
    # through a pole, so 54's force is positive again at the step's end. Taking the pole
    # alone, the run ended there as a jam (BAD_MATE); with the release first it seats, as the
    # independent engine does (final angles 0.38739 at its default step and a quarter of it)
    # and as xface does at 1000 times tighter tolerances.
    design = xf.x_face(0.25, 1.0)
    tight = xf.SolverSettings(rtol=1e-11, atol=1e-13, event_tol=1e-15)
    x0, theta0 = sign * -0.85 * design.width, sign * 0.7068583470577035
    p = xf.predict(design, x0, theta0)
    reference = xf.predict(design, x0, theta0, settings=tight)
    assert p.outcome == reference.outcome == xf.Outcome.SEATED
    assert p.phi_b == pytest.approx(sign * 0.3873950, abs=1e-6)


def test_a_slip_before_a_pole_in_the_same_step_comes_first() -> None:
    # X 2.1225/0.0721 at damping ratio 1.29e-3 and mu 0.42, from x0 = D, theta0 = -pi/6: on
    # the slide of contact 38 (slipping backwards), a step of 6.03e-9 D from this state
    # (where a run took it) crosses the slip's zero 1.59e-9 D in and the pole of the force
    # 0.3e-9 D later; past the pole the slip margin is positive again (+3.7), so the step's
    # end does not show it. The slip comes first, not the force's change of sign.
    design = xf.x_face(2.122466788111405, 0.07211328716946366)
    physics = Physics(damping_ratio=0.0012909326288174934, friction=0.42177297426967)
    model, opts = engine_model(design), make_options(physics)
    runs = np.zeros(1, dtype=RUN_DTYPE)
    run = runs[0]
    run["phi_b"], run["phi_m"] = -0.4403023074717209, -0.45575232748550115
    run["y_m"], run["x0"], run["n_active"], run["had_contact"] = 2.3617886553490792, 1.0, 1, True
    work = new_work(model, opts)
    work.act[0], work.slip[0] = 38, -1
    path, pairs = np.zeros((4, 4)), np.full((4, 4), -1, dtype=np.int64)
    seg = begin_segment(model, opts, run, work, path, pairs)
    step = Step(float(run["phi_b"]), float(run["phi_m"]), float(run["y_m"]), 6.030854484182746e-09)
    nb, nm, _, _, ok = step_to(seg, step, step.h)
    assert ok
    assert slip_margin(seg.held, 0, nb, nm, step.y_m - step.h) > 0.0
    ev = find_event(opts, seg, step, work, nb, nm)
    assert ev.kind == E_SLIP
    assert ev.h == pytest.approx(1.59e-9, abs=0.02e-9)


# Two corners crossing like an X (tests/core/engine/test_corners.py): the base block's
# top-right corner K and the moving square's corner V (body (-0.5, 0)), the moving pivot at
# one x0, as in a run. A state: phi_M (degrees) and the height of V (D).
SQUARE = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.0), (-0.5, 0.0)]
SQUARES_MODEL = engine_model(xf.custom_face([SQUARE], [SQUARE], mated_distance=2.0))
V_ON_TOP = next(
    i
    for i, row in enumerate(SQUARES_MODEL.pairs)
    if row[0] == 0 and tuple(row[1:5]) == (-0.5, 0.0, 0.5, 0.0)
)
X0_CORNERS = 0.6 - 0.5 * math.cos(math.radians(70.0))
#: States at which V and K cross (V's edge at 160 degrees through the base's wall) ...
CORNERS_CROSSED = [(70.0, -0.05), (70.0, 0.05), (0.0, -0.05)]
#: ... and at which they do not: the last one too far from K to be tested (|u| > 1/2).
CORNERS_APART = [(0.0, 0.05), (-90.0, 0.05), (150.0, -0.05)]


def _corner_state(state: tuple[float, float]) -> tuple[float, ...]:
    """cos and sin of phi_B and phi_M, y_M, then phi_B and phi_M (rad) at ``state``."""
    phi_m = math.radians(state[0])
    y_m = state[1] - 0.5 * math.sin(phi_m)
    return (1.0, 0.0, math.cos(phi_m), math.sin(phi_m), y_m, 0.0, phi_m)


def _corners_crossed(
    now_state: tuple[float, float], start_state: tuple[float, float], memo: np.ndarray
) -> bool:
    """Scan's corner test of the pair V_ON_TOP with ``memo`` as its row of the memo."""
    now, start = _corner_state(now_state), _corner_state(start_state)
    work = new_work(SQUARES_MODEL, OPTS)
    work.corner_memo[V_ON_TOP] = memo
    row = SQUARES_MODEL.pairs[V_ON_TOP]
    g, u, *_ = eval_pair(row, *now[:4], X0_CORNERS, now[4])
    crossed = _crossing(OPTS, work, V_ON_TOP, row, g, u, X0_CORNERS, now, start)
    memo[:] = work.corner_memo[V_ON_TOP]
    return bool(crossed)


@pytest.mark.parametrize("start_state", CORNERS_CROSSED + CORNERS_APART)
@pytest.mark.parametrize("now_state", CORNERS_CROSSED + CORNERS_APART)
def test_corners_crossing_answer_the_same_with_the_start_remembered(
    now_state: tuple[float, float], start_state: tuple[float, float]
) -> None:
    fresh = _corners_crossed(now_state, start_state, np.full(4, np.nan))
    memo = np.full(4, np.nan)
    _corners_crossed(start_state, (0.0, 1.0), memo)  # the step before ended at this start
    assert _corners_crossed(now_state, start_state, memo) == fresh


@pytest.mark.parametrize("state", CORNERS_CROSSED + CORNERS_APART[:2])
def test_the_corner_memo_holds_the_answer_at_the_state_tested(state: tuple[float, float]) -> None:
    memo = np.full(4, np.nan)
    _corners_crossed(state, (0.0, 1.0), memo)
    _, _, _, _, y_m, pb, pm = _corner_state(state)
    assert memo.tolist() == [1.0 if state in CORNERS_CROSSED else 0.0, pb, pm, y_m]


def test_a_pair_screened_out_leaves_the_corner_memo_alone() -> None:
    memo = np.full(4, np.nan)
    _corners_crossed(CORNERS_APART[2], (0.0, 1.0), memo)
    assert np.isnan(memo).all()


def test_corners_cross_in_a_step_only_from_apart_at_its_start() -> None:
    memo = np.full(4, np.nan)
    assert _corners_crossed(CORNERS_CROSSED[0], CORNERS_APART[0], memo)
    assert not _corners_crossed(CORNERS_CROSSED[1], CORNERS_CROSSED[0], memo)
