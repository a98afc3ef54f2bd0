"""events.py: event functions, locating an event's zero in a step, the earlier of two."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xface_core._engine.events import (
    HERMITE_TOL,
    NO_EVENT,
    QUARTER_SLOTS,
    QUARTER_STATE,
    START_RATE,
    Event,
    _hermite_guess,
    _path_slope,
    angles_at,
    clear_step_memo,
    earlier,
    event_value,
    has_dense,
    keep_trial_dense,
    locate,
    quarter_state,
    solve_or_integrate,
    step_to,
)
from xface_core._engine.motion import velocity
from xface_core._engine.pairs import pair_at
from xface_core._engine.records import (
    DENSE_WIDTH,
    E_BELOW_SEAT,
    E_CONTACT,
    E_OFF_EDGE,
    E_RELEASE,
    E_SPUN,
    FLAT_GAP,
    STEP_MEMO_SLOTS,
    U_TOL,
)

EVENT_TOL = 1e-12


def _assert_brackets(lo: float, hi: float, root: float) -> None:
    assert 0.0 < lo <= hi
    assert hi - lo <= EVENT_TOL
    # The root to round-off of the event function (a few ulps of y_M ~ 2.5).
    assert lo - 4e-15 <= root <= hi + 4e-15


def test_below_seat_is_located_at_the_floor(incline) -> None:
    step = incline.step(0.05)
    seg = incline.segment(y_floor=step.y_m - 0.0123)
    lo, hi = locate(seg, step, EVENT_TOL, E_BELOW_SEAT, -1, 0, 0.0)
    _assert_brackets(lo, hi, step.y_m - seg.y_floor)


def test_a_new_contact_is_located_where_the_closed_form_path_meets_it(incline) -> None:
    # Pair 1's edge is placed where the exact path puts its vertex at s_touch.
    step, seg = incline.step(0.05), incline.segment()
    lo, hi = locate(seg, step, EVENT_TOL, E_CONTACT, 1, 0, 0.0)
    _assert_brackets(lo, hi, incline.s_touch)
    # Before and after on the integrated path: clear, then touching.
    assert event_value(seg, E_CONTACT, 1, 0, 0.0, *step_to(seg, step, lo)[:2], step.y_m - lo) > 0
    assert event_value(seg, E_CONTACT, 1, 0, 0.0, *step_to(seg, step, hi)[:2], step.y_m - hi) <= 0


def test_a_contact_threshold_moves_the_event(incline) -> None:
    # Counting as touching 1e-4 D before the gap closes brings the event forward.
    step, seg = incline.step(0.05), incline.segment()
    thr = 1e-4
    root = _root(lambda s: incline.gap(1, incline.phi_m_at(s), step.y_m - s) - thr, 0.0, 0.05)
    lo, hi = locate(seg, step, EVENT_TOL, E_CONTACT, 1, 0, thr)
    assert root < incline.s_touch
    _assert_brackets(lo, hi, root)


def _root(f, lo: float, hi: float) -> float:
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def test_an_event_already_past_at_the_start_is_located_there(incline) -> None:
    step = incline.step(0.05)
    seg = incline.segment(y_floor=step.y_m)  # exactly at the floor: f = 0 at the start
    assert locate(seg, step, EVENT_TOL, E_BELOW_SEAT, -1, 0, 0.0) == (0.0, 0.0)
    seg = incline.segment(y_floor=step.y_m + 1.0)
    assert locate(seg, step, EVENT_TOL, E_BELOW_SEAT, -1, 0, 0.0) == (0.0, 0.0)


def test_off_edge_function_is_the_distance_inside_the_span(incline) -> None:
    seg = incline.segment()
    pm, ym = incline.phi_m0, incline.y0
    u = pair_at(incline.table, 0, 0.0, pm, incline.x0, ym)[1]
    assert 0.0 < u < 1.0
    value = event_value(seg, E_OFF_EDGE, 0, 0, 0.0, 0.0, pm, ym)
    assert value == min(u + U_TOL, 1.0 + U_TOL - u)


def test_release_function_is_the_contact_force(incline) -> None:
    seg = incline.segment(n_active=2, winv_b=1.0)
    ym = incline.y0 - incline.s_touch
    pm = incline.phi_m_at(incline.s_touch)
    _, _, l1, l2 = velocity(seg.held, 0.0, pm, ym)
    assert event_value(seg, E_RELEASE, 0, 0, 0.0, 0.0, pm, ym) == l1
    assert event_value(seg, E_RELEASE, 1, 1, 0.0, 0.0, pm, ym) == l2


def test_spun_function_is_the_margin_to_half_a_turn(incline) -> None:
    seg = incline.segment()
    assert event_value(seg, E_SPUN, -1, 0, 0.0, 0.5, -3.0, 1.0) == pytest.approx(math.pi - 3.0)


def test_earlier_prefers_any_event_to_none() -> None:
    late = Event(E_CONTACT, 3, 0.2)
    assert earlier(late, NO_EVENT) == late


def test_earlier_keeps_the_smaller_descent() -> None:
    a, b = Event(E_CONTACT, 3, 0.2), Event(E_RELEASE, 1, 0.1)
    assert earlier(a, b) == b
    assert earlier(b, a) == b


def test_earlier_keeps_the_first_found_on_a_tie() -> None:
    first, second = Event(E_RELEASE, 1, 0.1), Event(E_CONTACT, 3, 0.1)
    assert earlier(second, first) == first


def _fresh_step(seg, step, t: float) -> tuple[float, float, float, float, bool]:
    """The step without the memo: solved or integrated afresh from the start."""
    k1b, k1m, _, _ = velocity(seg.held, step.phi_b, step.phi_m, step.y_m)
    return solve_or_integrate(seg._replace(dense=np.zeros((2, DENSE_WIDTH))), step, t, k1b, k1m)


def test_remembered_steps_are_the_steps_bit_for_bit(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    # More lengths than slots, asked twice each, the second round out of order: every
    # answer (remembered, or computed again after the ring wrapped) is the plain step's.
    lengths = [0.02 * (k + 1) / 23 for k in range(23)]
    for t in [*lengths, *reversed(lengths), *lengths[::3]]:
        assert step_to(seg, step, t) == _fresh_step(seg, step, t)
    assert seg.step_memo[0, 0] == STEP_MEMO_SLOTS  # full


def test_a_new_start_or_segment_is_not_answered_from_the_memo(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    first = step_to(seg, step, 0.01)
    moved = step._replace(phi_m=step.phi_m + 1e-3, y_m=step.y_m - 1e-3)
    assert step_to(seg, moved, 0.01) == _fresh_step(seg, moved, 0.01) != first
    clear_step_memo(seg.step_memo)
    assert seg.step_memo[0, 0] == 0.0
    assert seg.step_memo[0, START_RATE + 7] == 0.0  # the start's rate is forgotten too
    assert step_to(seg, step, 0.01) == first


def _fresh_quarter(seg, pb: float, pm: float, ym: float) -> tuple[float, ...]:
    vb, vm, _, _ = velocity(seg.held, pb, pm, ym)
    return (math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm), vb, vm)


def test_a_quarter_state_is_the_state_computed_afresh_bit_for_bit(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    for _round in range(2):  # the second round is answered from the memo
        for k in range(1, QUARTER_SLOTS + 1):
            pb, pm = angles_at(seg, step, 0.005 * k)
            ym = step.y_m - 0.005 * k
            assert quarter_state(seg, k, pb, pm, ym) == _fresh_quarter(seg, pb, pm, ym)
    # Another state at a slot replaces the one remembered there.
    pb, pm = step.phi_b + 1e-3, step.phi_m - 2e-3
    assert quarter_state(seg, 2, pb, pm, step.y_m) == _fresh_quarter(seg, pb, pm, step.y_m)


def test_a_new_segment_forgets_the_quarter_states(incline) -> None:
    # The rate depends on the segment's contacts: a state remembered in one segment must
    # not answer in the next, even at the same angles and height.
    seg = incline.segment()
    step = incline.step(0.02)
    pb, pm = angles_at(seg, step, 0.005)
    ym = step.y_m - 0.005
    quarter_state(seg, 1, pb, pm, ym)
    # Scribble over the remembered rate: only a state computed afresh gives it back.
    seg.step_memo[0, QUARTER_STATE + 3] = 123.0
    assert quarter_state(seg, 1, pb, pm, ym)[4] == 123.0  # answered from the memo
    clear_step_memo(seg.step_memo)
    assert quarter_state(seg, 1, pb, pm, ym) == _fresh_quarter(seg, pb, pm, ym)


def test_a_gap_zero_to_round_off_at_both_ends_is_located_at_the_start(incline) -> None:
    # Pair 0's vertex is held on its line: its gap is zero to round-off all through the
    # step, and a threshold a few round-offs below it leaves a function whose sign is noise.
    seg, step = incline.segment(), incline.step(0.005)
    thr = incline.gap(0, incline.phi_m0, incline.y0) - 0.5 * FLAT_GAP
    assert locate(seg, step, EVENT_TOL, E_CONTACT, 0, 0, thr) == (0.0, 0.0)


def test_a_gap_clear_of_round_off_is_still_searched(incline) -> None:
    # The same pair with its threshold ten round-off widths below: the gap stays above it
    # (no crossing in the step), and the search ends at the step's end, not at its start.
    seg, step = incline.segment(), incline.step(0.005)
    thr = incline.gap(0, incline.phi_m0, incline.y0) - 10.0 * FLAT_GAP
    _lo, hi = locate(seg, step, EVENT_TOL, E_CONTACT, 0, 0, thr)
    assert hi == pytest.approx(0.005, abs=EVENT_TOL)


def test_the_trial_steps_dense_output_is_kept_for_its_scan(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    step_to(seg, step, step.h)
    keep_trial_dense(seg, step)
    assert has_dense(seg, step)
    head = step._replace(h=0.01)  # a head of the step: covered
    assert has_dense(seg, head)
    assert not has_dense(seg, step._replace(h=0.03))  # longer: not covered


def test_no_dense_output_is_kept_when_the_last_step_was_another(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    step_to(seg, step, step.h)
    step_to(seg, step, 0.01)  # a probe inside: the last step computed is not the trial
    keep_trial_dense(seg, step)
    assert not has_dense(seg, step)


def test_states_inside_the_step_come_from_the_dense_output_within_its_error(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    step_to(seg, step, step.h)
    keep_trial_dense(seg, step)
    pb, pm = angles_at(seg, step, 0.013)
    assert pb == 0.0
    # Within the error the dense output carries for the scan's bounds (columns 13, 14: the
    # step's own error estimate, or for a step solved on the contacts, as this held one,
    # its predictor's distance from the solution).
    assert 0.0 < seg.dense[1, 14] < 1e-5
    assert abs(pm - incline.phi_m_at(0.013)) <= seg.dense[1, 14]
    assert seg.step_memo[0, 0] == 1.0  # no integration step was taken for it


def test_states_fall_back_to_an_integration_step_without_a_dense_output(incline) -> None:
    seg = incline.segment()
    step = incline.step(0.02)
    pb, pm = angles_at(seg, step, 0.013)
    assert (pb, pm) == step_to(seg, step, 0.013)[:2]


def _hermite_root(incline, seg, step, kind: int, idx: int) -> float:
    """The zero of an event function along the step's cubic Hermite interpolant, by
    bisection in Python to round-off (D)."""
    nb, nm, _, _, _ = step_to(seg, step, step.h)
    v0b, v0m, _, _ = velocity(seg.held, step.phi_b, step.phi_m, step.y_m)
    v1b, v1m, _, _ = velocity(seg.held, nb, nm, step.y_m - step.h)

    def f(tau: float) -> float:
        t2, t3 = tau * tau, tau**3
        h00, h10, h01, h11 = 2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + tau, -2 * t3 + 3 * t2, t3 - t2
        pb = h00 * step.phi_b + h10 * step.h * v0b + h01 * nb + h11 * step.h * v1b
        pm = h00 * step.phi_m + h10 * step.h * v0m + h01 * nm + h11 * step.h * v1m
        return event_value(seg, kind, idx, 0, 0.0, pb, pm, step.y_m - tau * step.h)

    lo, hi = 0.0, 1.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) > 0.0 else (lo, mid)
    return 0.5 * (lo + hi) * step.h


@pytest.mark.parametrize("h", [0.02, 0.05])
def test_the_hermite_guess_is_the_interpolants_root_to_its_tolerance(incline, h) -> None:
    step, seg = incline.step(h), incline.segment()
    nb, nm, _, _, _ = step_to(seg, step, h)
    f_lo = event_value(seg, E_CONTACT, 1, 0, 0.0, step.phi_b, step.phi_m, step.y_m)
    f_hi = event_value(seg, E_CONTACT, 1, 0, 0.0, nb, nm, step.y_m - h)
    assert f_lo > 0.0 >= f_hi
    guess = _hermite_guess(seg, step, E_CONTACT, 1, 0, 0.0, nb, nm, f_lo, f_hi)
    assert abs(guess - _hermite_root(incline, seg, step, E_CONTACT, 1)) <= HERMITE_TOL * h
    # The interpolant is off the exact path by its error (3e-7 D at h = 0.05 D): locate()
    # checks the guess with a real step and moves it by Newton's method.
    assert guess == pytest.approx(incline.s_touch, abs=1e-6)


def test_the_hermite_guess_of_a_linear_event_is_its_zero(incline) -> None:
    # y_M falls linearly with the descent: the first estimate is the zero, and the probe half
    # a tolerance past it closes the bracket.
    step = incline.step(0.05)
    seg = incline.segment(y_floor=step.y_m - 0.0123)
    nb, nm, _, _, _ = step_to(seg, step, step.h)
    f_hi = step.y_m - step.h - seg.y_floor
    guess = _hermite_guess(seg, step, E_BELOW_SEAT, -1, 0, 0.0, nb, nm, 0.0123, f_hi)
    assert guess == pytest.approx(0.0123, abs=HERMITE_TOL * step.h)


@pytest.mark.parametrize("h", [0.02, 0.05])
def test_a_smooth_event_is_bracketed_with_two_integrations(incline, h) -> None:
    # One at the interpolant's root, one just past the Newton estimate from there (the end
    # before it is that state moved back along its rate); the step's end is the third
    # remembered step.
    step, seg = incline.step(h), incline.segment()
    clear_step_memo(seg.step_memo)
    lo, hi = locate(seg, step, EVENT_TOL, E_CONTACT, 1, 0, 0.0)
    _assert_brackets(lo, hi, incline.s_touch)
    assert seg.step_memo[0, 0] == 3
    # The end before the event is before it on the integrated path too.
    assert event_value(seg, E_CONTACT, 1, 0, 0.0, *step_to(seg, step, lo)[:2], step.y_m - lo) > 0


def test_the_path_slope_is_the_closed_form_paths(incline) -> None:
    step, seg = incline.step(0.05), incline.segment()
    t, d = 0.01, 1e-4

    def gap(s: float) -> float:
        pm = incline.phi_m_at(s)
        return event_value(seg, E_CONTACT, 1, 0, 0.0, 0.0, pm, step.y_m - s)

    exact = (gap(t + d) - gap(t - d)) / (2.0 * d)  # a smooth closed form: O(d^2)
    slope = _path_slope(seg, step, E_CONTACT, 1, 0, 0.0, t)
    assert slope == pytest.approx(exact, rel=1e-6)
