"""Events along a smooth segment: their functions, where they happen, which comes first.

Like scipy's ``solve_ivp`` events in three parts: each event has a signed function (positive
before, <= 0 once it has happened, :func:`event_value`); :func:`locate` brackets its zero
within an accepted trial step; :func:`earlier` keeps the first of several. The engine's
stage :func:`~xface_core._engine.simulate.find_event` scans one trial step with them.

Everything that stays fixed along a segment (the active contacts, their friction states and
the run's constants) travels as one :class:`Segment`, the trial step as one :class:`Step`
(Box2D's step context).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from .bracket import HI, LO, closing_probe, move_bracket, next_probe, start_bracket
from .integrate import dense_angles, pinned_step, pins_path, rk_step
from .motion import slip_margin, velocity
from .pairs import clipped_gap, eval_pair, pair_at
from .records import (
    E_BELOW_SEAT,
    E_CONTACT,
    E_NONE,
    E_OFF_EDGE,
    E_RELEASE,
    E_SLIP,
    FLAT_GAP,
    PUSH_SLACK,
    SLIP_PROBE,
    U_TOL,
    FloatArray,
    Segment,
    Step,
    Trig,
    njit_inline,
    njit_no_refcount,
)


class Event(NamedTuple):
    """The earliest event found so far in a step: its kind, pair (-1: none) and position."""

    kind: int
    pair: int
    h: float
    """Descent from the step's start to the event (D)."""


NO_EVENT = Event(E_NONE, -1, 0.0)

#: How closely (a fraction of the step) the root on the step's Hermite interpolant is
#: bracketed (:func:`_hermite_guess`).
HERMITE_TOL = 1e-13
#: How far (in event tolerances) past and short of its Newton estimate an event's bracket
#: is probed (:func:`locate`): under a half, so that the two ends are within a tolerance,
#: round-off included.
CLOSING = 0.45


@njit_no_refcount
def earlier(candidate: Event, best: Event) -> Event:
    """The earlier of two events (a candidate wins when nothing was found yet; no event
    never wins)."""
    if candidate.kind == E_NONE:
        return best
    if best.kind == E_NONE or candidate.h < best.h:
        return candidate
    return best


@njit_no_refcount
def clear_step_memo(memo: FloatArray) -> None:
    """Forget every remembered step (a new segment: other contacts, another rate)."""
    memo[0, 0] = 0.0  # slots filled
    memo[0, 1] = 0.0  # the slot written next
    memo[0, START_RATE + 7] = 0.0  # no rates remembered
    memo[0, END_RATE + 7] = 0.0
    for k in range(QUARTER_SLOTS):
        memo[0, QUARTER_STATE + QUARTER_WIDTH * k + 9] = 0.0


@njit_no_refcount
def keep_trial_dense(seg: Segment, step: Step) -> None:
    """Keep the dense output of the trial step just integrated (the last step computed) for
    the event scan of that step, or none if the last step computed was another one."""
    d = seg.dense
    if (
        d[0, 4] != 0.0
        and d[0, 0] == step.phi_b
        and d[0, 1] == step.phi_m
        and d[0, 2] == step.y_m
        and d[0, 3] == step.h
    ):
        for c in range(d.shape[1]):
            d[1, c] = d[0, c]
    else:
        d[1, 4] = 0.0


@njit_inline
def has_dense(seg: Segment, step: Step) -> bool:
    """Does the kept dense output cover ``step`` (the trial step, or a head of it)?"""
    d = seg.dense
    return bool(
        d[1, 4] != 0.0
        and d[1, 0] == step.phi_b
        and d[1, 1] == step.phi_m
        and d[1, 2] == step.y_m
        and step.h <= d[1, 3]
    )


@njit_inline
def angles_at(seg: Segment, step: Step, t: float) -> tuple[float, float]:
    """(phi_B, phi_M) a descent ``t`` (D) into ``step``: on the trial step's dense output
    when it covers the step (a few multiplications; as accurate as the step itself), else
    by an integration step (:func:`step_to`). For where the exact state is not needed:
    finding which sample or which candidate to look at, never an event's state."""
    if has_dense(seg, step):
        return dense_angles(seg.dense, 1, t)
    nb, nm, _, _, _ = step_to(seg, step, t)
    return nb, nm


@njit_inline
def step_to(seg: Segment, step: Step, t: float) -> tuple[float, float, float, float, bool]:
    """One step of length ``t`` from the trial step's start (:func:`solve_or_integrate`):
    ``(phi_b, phi_m, err_b, err_m, ok)``.

    Within a segment the step is a pure function of its start state and ``t``, and the event
    scan asks for the same one many times (the trial step's end again in every root search,
    a located event's state in the contact checks and in the advance to it): the last
    ``STEP_MEMO_SLOTS`` are remembered in ``seg.step_memo`` (row 0: slots filled, next slot,
    the rates at the last start and end, :data:`START_RATE`; rows 1..: t, start phi_B,
    phi_M, y_M, then the result) and returned bit for bit. The rate at
    the start, the first stage of every step from it, is computed once per start
    (:func:`start_velocity`).

    Inlined into every caller (numba's ``inline="always"``), and so are the other memo
    look-ups here (:func:`quarter_state`, :func:`start_velocity`, :func:`end_velocity`,
    :func:`angles_at`): a kernel call passes every field of its arguments by value, and a
    :class:`Segment` is about fifty machine words; copied for every look-up that found its
    answer in the memo, that was most of a gap bound's time. Only a miss calls
    (:func:`_step_to_new`). Maps took 0.86-0.95 and predictions 0.85-0.98 of their time
    (docs/notes/2026-11-29-side-by-side-memo-look-ups-inlined.md).
    """
    memo = seg.step_memo
    for k in range(1, int(memo[0, 0]) + 1):
        if (
            memo[k, 0] == t
            and memo[k, 1] == step.phi_b
            and memo[k, 2] == step.phi_m
            and memo[k, 3] == step.y_m
        ):
            return memo[k, 4], memo[k, 5], memo[k, 6], memo[k, 7], memo[k, 8] != 0.0
    return _step_to_new(seg, step, t)


@njit_no_refcount
def _step_to_new(seg: Segment, step: Step, t: float) -> tuple[float, float, float, float, bool]:
    """:func:`step_to` for a step not remembered: integrated (or solved) and remembered."""
    memo = seg.step_memo
    slots = memo.shape[0] - 1
    k1b, k1m, _, _ = start_velocity(seg, step)
    nb, nm, eb, em, ok = solve_or_integrate(seg, step, t, k1b, k1m)
    k = int(memo[0, 1]) + 1
    memo[k, 0], memo[k, 1], memo[k, 2], memo[k, 3] = t, step.phi_b, step.phi_m, step.y_m
    memo[k, 4], memo[k, 5], memo[k, 6], memo[k, 7] = nb, nm, eb, em
    memo[k, 8] = 1.0 if ok else 0.0
    memo[0, 0] = min(memo[0, 0] + 1.0, float(slots))
    memo[0, 1] = float(k % slots)
    return nb, nm, eb, em, ok


@njit_no_refcount
def solve_or_integrate(
    seg: Segment, step: Step, t: float, k1b: float, k1m: float
) -> tuple[float, float, float, float, bool]:
    """One step of length ``t`` from the trial step's start, whose rate is ``(k1b, k1m)``:
    solved on the contacts where they pin the path (:func:`~.integrate.pinned_step`, error
    0), else, or where that declines, integrated (:func:`~.integrate.rk_step`). Its dense
    output goes to row 0 of ``seg.dense``."""
    one = Step(step.phi_b, step.phi_m, step.y_m, t)
    if pins_path(seg.held.n_active, seg.held.winv_b, seg.held.mu):
        nb, nm, ok = pinned_step(seg, one, k1b, k1m)
        if ok:
            return nb, nm, 0.0, 0.0, True
    return rk_step(seg, one, k1b, k1m)


#: Row 0 of the step memo: slots filled and the next slot (columns 0, 1), then one
#: remembered rate each for the last step start and the last step end: at these columns,
#: the state (phi_B, phi_M, y_M), the rate and forces (4), and whether they are set.
START_RATE = 2
END_RATE = 10
#: Then the states at 1/4, 2/4 and 3/4 of the last trial step whose gap bounds were taken
#: from its quarters (:func:`quarter_state`): at these columns, each state (phi_B, phi_M,
#: y_M), its rate (2), cos and sin of phi_B and phi_M (4), and whether it is set.
QUARTER_STATE = 18
QUARTER_WIDTH = 10
QUARTER_SLOTS = 3


@njit_inline
def _remembers(memo: FloatArray, col: int, flag: int, pb: float, pm: float, ym: float) -> bool:
    """Does row 0 of the step memo hold the state ``(pb, pm, ym)`` at ``col`` (set, by the
    value at ``flag``)?"""
    return bool(
        memo[0, flag] != 0.0
        and memo[0, col] == pb
        and memo[0, col + 1] == pm
        and memo[0, col + 2] == ym
    )


@njit_inline
def quarter_state(
    seg: Segment, k: int, pb: float, pm: float, ym: float
) -> tuple[float, float, float, float, float, float]:
    """cos and sin of phi_B and phi_M and the rate (rad/D) at the ``k``-th quarter state of a
    trial step (``k`` in 1..QUARTER_SLOTS), remembered for the last state asked there: the
    gap bounds of every pair screened in the step (:func:`~.scan._gap_bounds`) ask for the
    same three states, and each took a motion solve and two ``sincos`` per pair."""
    memo = seg.step_memo
    col = QUARTER_STATE + QUARTER_WIDTH * (k - 1)
    if not _remembers(memo, col, col + 9, pb, pm, ym):
        _remember_quarter(seg, col, pb, pm, ym)
    return (
        memo[0, col + 5], memo[0, col + 6], memo[0, col + 7], memo[0, col + 8],
        memo[0, col + 3], memo[0, col + 4],
    )  # fmt: skip


@njit_no_refcount
def _remember_quarter(seg: Segment, col: int, pb: float, pm: float, ym: float) -> None:
    """Compute and remember a quarter state (:func:`quarter_state`) at ``col``."""
    memo = seg.step_memo
    vb, vm, _, _ = velocity(seg.held, pb, pm, ym)
    memo[0, col], memo[0, col + 1], memo[0, col + 2] = pb, pm, ym
    memo[0, col + 3], memo[0, col + 4] = vb, vm
    memo[0, col + 5], memo[0, col + 6] = math.cos(pb), math.sin(pb)
    memo[0, col + 7], memo[0, col + 8] = math.cos(pm), math.sin(pm)
    memo[0, col + 9] = 1.0


@njit_inline
def _remembered_velocity(
    seg: Segment, col: int, pb: float, pm: float, ym: float
) -> tuple[float, float, float, float]:
    """:func:`~.motion.velocity` at a state, remembered at ``col`` of the step memo's row 0
    for the last state asked there."""
    memo = seg.step_memo
    if not _remembers(memo, col, col + 7, pb, pm, ym):
        _remember_velocity(seg, col, pb, pm, ym)
    return memo[0, col + 3], memo[0, col + 4], memo[0, col + 5], memo[0, col + 6]


@njit_no_refcount
def _remember_velocity(seg: Segment, col: int, pb: float, pm: float, ym: float) -> None:
    """Compute and remember the rate at a state (:func:`_remembered_velocity`) at ``col``."""
    memo = seg.step_memo
    vb, vm, l1, l2 = velocity(seg.held, pb, pm, ym)
    memo[0, col], memo[0, col + 1], memo[0, col + 2] = pb, pm, ym
    memo[0, col + 3], memo[0, col + 4], memo[0, col + 5], memo[0, col + 6] = vb, vm, l1, l2
    memo[0, col + 7] = 1.0


@njit_inline
def start_velocity(seg: Segment, step: Step) -> tuple[float, float, float, float]:
    """:func:`~.motion.velocity` at the step's start, computed once per start: every step
    from it begins with it, and the event searches and screens of the step ask for it
    again."""
    return _remembered_velocity(seg, START_RATE, step.phi_b, step.phi_m, step.y_m)


@njit_inline
def end_velocity(
    seg: Segment, pb: float, pm: float, ym: float
) -> tuple[float, float, float, float]:
    """:func:`~.motion.velocity` at a step's end state, remembered for the last such state:
    the release check, the turn-rate bound and the Hermite predictor of every search over
    the whole step all ask for it."""
    return _remembered_velocity(seg, END_RATE, pb, pm, ym)


@njit_inline
def contact_value(row: FloatArray, thr: float, trig: Trig, x0: float, ym: float) -> float:
    """The contact event function of a pair (its gap with the edge's convex corners clipped
    on, less the threshold ``thr``, D) at a state given by ``trig``, the cos and sin of
    phi_B and phi_M (for callers that check many pairs at one state)."""
    cb, sb, cm, sm = trig
    g, _, _, _, _, _, _, _, _ = eval_pair(row, cb, sb, cm, sm, x0, ym)
    if g > thr:
        return g - thr
    return clipped_gap(row, g, cb, sb, cm, sm, x0, ym) - thr


@njit_no_refcount
def event_value(
    seg: Segment, kind: int, idx: int, slot: int, thr: float, pb: float, pm: float, ym: float
) -> float:
    """Signed event function: positive before the event, <= 0 once it has happened.

    ``idx`` is the event's pair, ``slot`` its place in the active set, ``thr`` the gap at
    which a new contact counts (D).
    """
    if kind == E_CONTACT:
        cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
        return contact_value(seg.held.pairs[idx], thr, (cb, sb, cm, sm), seg.held.x0, ym)
    if kind == E_RELEASE:
        _, _, l1, l2 = velocity(seg.held, pb, pm, ym)
        lam = l1 if slot == 0 else l2
        if seg.held.mu > 0.0 and seg.held.n_active == 2:
            # The slack with which interval._both_push holds two frictional contacts.
            return lam + PUSH_SLACK * max(abs(l1), abs(l2))
        return lam
    if kind == E_OFF_EDGE:
        _, u, _, _, _, _, _, _, _ = pair_at(seg.held.pairs, idx, pb, pm, seg.held.x0, ym)
        # A vertex trapped in a corner sits at u = 0 or 1 up to round-off: not an event.
        return min(u + U_TOL, 1.0 + U_TOL - u)
    if kind == E_BELOW_SEAT:
        return ym - seg.y_floor
    if kind == E_SLIP:
        return slip_margin(seg.held, slot, pb, pm, ym)
    # E_SPUN
    return math.pi - max(abs(pb), abs(pm))


@njit_no_refcount
def event_after(
    seg: Segment, step: Step, kind: int, idx: int, slot: int, thr: float, t: float
) -> float:
    """The event function on the state one integration step of length ``t`` from the start."""
    nb, nm, _, _, _ = step_to(seg, step, t)
    return event_value(seg, kind, idx, slot, thr, nb, nm, step.y_m - t)


@njit_no_refcount
def _hermite_guess(
    seg: Segment,
    step: Step,
    kind: int,
    idx: int,
    slot: int,
    thr: float,
    nb: float,
    nm: float,
    f_lo: float,
    f_hi: float,
) -> float:
    """Root of the event along the cubic Hermite interpolant of the step (no integration);
    NaN when the rates at the step's ends are not finite."""
    hi = step.h
    pb, pm, ym = step.phi_b, step.phi_m, step.y_m
    v0b, v0m, _, _ = start_velocity(seg, step)
    v1b, v1m, _, _ = end_velocity(seg, nb, nm, ym - hi)
    if not math.isfinite(v0b + v0m + v1b + v1m):
        return math.nan
    # Illinois regula falsi on the step's fraction tau, each estimate moved half a tolerance
    # towards the end that stayed (bracket.closing_probe): an estimate that is the root lands
    # across it and closes the bracket. Plain regula falsi took 30 to 60 event functions (two
    # sincos each) to close it, for what its first estimates had found: the end opposite a
    # converged one moved only by bisection. Now about ten, to the same HERMITE_TOL.
    a_lo, a_hi, fa_lo, fa_hi = 0.0, 1.0, f_lo, f_hi
    side = 0
    for _ in range(60):
        if a_hi - a_lo <= HERMITE_TOL:
            break
        tau = a_hi - fa_hi * (a_hi - a_lo) / (fa_hi - fa_lo)
        if not (a_lo < tau < a_hi):
            tau = 0.5 * (a_lo + a_hi)
        tau = closing_probe(tau, a_lo, a_hi, side, HERMITE_TOL)
        t2 = tau * tau
        t3 = t2 * tau
        h00 = 2 * t3 - 3 * t2 + 1
        h10 = t3 - 2 * t2 + tau
        h01 = -2 * t3 + 3 * t2
        h11 = t3 - t2
        ib = h00 * pb + h10 * hi * v0b + h01 * nb + h11 * hi * v1b
        im = h00 * pm + h10 * hi * v0m + h01 * nm + h11 * hi * v1m
        fa = event_value(seg, kind, idx, slot, thr, ib, im, ym - tau * hi)
        if not math.isfinite(fa):
            break
        if fa > 0.0:
            if side == 1:
                fa_hi *= 0.5  # Illinois: the end that stayed twice counts half
            a_lo, fa_lo, side = tau, fa, 1
        else:
            if side == -1:
                fa_lo *= 0.5
            a_hi, fa_hi, side = tau, fa, -1
    return 0.5 * (a_lo + a_hi) * hi


@njit_inline
def _state_and_rate(seg: Segment, step: Step, t: float) -> tuple[float, float, float, float, float]:
    """The integrated state a descent ``t`` (D) into the step and the rate there:
    ``(phi_B, phi_M, y_M, v_B, v_M)`` (rad, D, rad per D), for event functions taken a
    short move along the rate from it (:func:`_path_slope`, :func:`_value_back`)."""
    pb, pm, _, _, _ = step_to(seg, step, t)
    ym = step.y_m - t
    vb, vm, _, _ = velocity(seg.held, pb, pm, ym)
    return pb, pm, ym, vb, vm


@njit_no_refcount
def _path_slope(
    seg: Segment, step: Step, kind: int, idx: int, slot: int, thr: float, t: float
) -> float:
    """How fast the event function changes (per D of descent) on the integrated path a
    descent ``t`` into the step: a central difference along the rate there
    (:func:`~.motion.velocity`), a millionth of the step either side. Its error: the
    difference's, about that squared, and round-off, about 1e-10 of the slope; the
    integrated path's own slope differs from the rate by its error per step, about 1e-8
    of it. (The step's interpolant was tried: its slope, off by 1e-5 to 0.25 of it, threw
    the estimate outside the tolerance in half the searches.)"""
    pb, pm, ym, vb, vm = _state_and_rate(seg, step, t)
    eta = 1e-6 * step.h
    f_before = event_value(seg, kind, idx, slot, thr, pb - eta * vb, pm - eta * vm, ym + eta)
    f_after = event_value(seg, kind, idx, slot, thr, pb + eta * vb, pm + eta * vm, ym - eta)
    return (f_after - f_before) / (2.0 * eta)


@njit_no_refcount
def _value_back(
    seg: Segment, step: Step, kind: int, idx: int, slot: int, thr: float, t: float,
    back: float,
) -> float:  # fmt: skip
    """The event function a descent ``back`` (D, within a tolerance) before the state a
    descent ``t`` into the step, moved back along the rate there: a bracket's end before
    an event next to its end after it without another integration. Off the integrated
    path by about ``back`` times the step's error per length, 1e-20 D at a tolerance."""
    pb, pm, ym, vb, vm = _state_and_rate(seg, step, t)
    return event_value(seg, kind, idx, slot, thr, pb - back * vb, pm - back * vm, ym + back)


@njit_no_refcount
def locate(
    seg: Segment, step: Step, event_tol: float, kind: int, idx: int, slot: int, thr: float
) -> tuple[float, float]:
    """Step lengths ``(lo, hi)`` bracketing the zero of an event function to ``event_tol``:
    before the event and just after it. The bracket's probes are those of
    :func:`~.bracket.next_probe`: regula falsi with Anderson and Bjorck's scaling of the
    stale end, or once one end moved three times in a row the zero of a power law fitted
    through its values, each moved so that the bracket closes. A contact function that is
    zero to round-off (``FLAT_GAP``) at both ends is located at the start.

    The event function is evaluated on the state after one integration step of the trial
    length from the same start, so the located point (``hi``) lies on the integrated path;
    ``lo`` may be that state moved back along its rate (:func:`_value_back`). An event
    that has already happened at the step's start (its function is not positive there) is
    located at the start: ``(0.0, 0.0)``.
    """
    lo = 0.0
    f_lo = event_value(seg, kind, idx, slot, thr, step.phi_b, step.phi_m, step.y_m)
    hi = step.h
    nb, nm, _, _, _ = step_to(seg, step, hi)
    f_hi = event_value(seg, kind, idx, slot, thr, nb, nm, step.y_m - hi)
    if not f_lo > 0.0 and kind == E_SLIP and hi > SLIP_PROBE:
        # A friction state is chosen a short move ahead (motion.friction_modes): one that is
        # marginal at the start (a stuck contact on the edge of its cone) but holds there
        # has not changed yet. Located from the start it would fire at once, over and over.
        f_probe = event_after(seg, step, kind, idx, slot, thr, SLIP_PROBE)
        if f_probe > 0.0:
            lo, f_lo = SLIP_PROBE, f_probe
    if not f_lo > 0.0:
        return 0.0, 0.0
    if kind == E_CONTACT and f_lo <= FLAT_GAP and abs(f_hi) <= FLAT_GAP:
        # The gap is zero to round-off at both ends: the vertex runs along the line (held on
        # it through a neighbouring edge's contact), and the sign of its function is the
        # round-off's. No crossing can be bracketed; it is at the start as well as anywhere.
        return 0.0, 0.0
    # Predictor: the root on the step's Hermite interpolant, checked with one real step
    # there and moved by Newton's method (the slope along the rate there). The bracket's
    # end after the zero is probed just under half a tolerance past that estimate, and the
    # end before it just under half a tolerance short of it, on the state after the zero
    # moved back along its rate (:func:`_value_back`; off the integrated path by about
    # 1e-20 D): two integrations close a smooth event's bracket. A probe on the wrong
    # side (a bend the interpolant missed, a kink) only narrows the bracket, and the search
    # goes on below with real steps.
    bracket = start_bracket(lo, f_lo, hi, f_hi)
    if math.isfinite(f_hi) and f_hi <= 0.0:
        guess = _hermite_guess(seg, step, kind, idx, slot, thr, nb, nm, f_lo, f_hi)
        if lo < guess < hi:  # false for NaN
            f_guess = event_after(seg, step, kind, idx, slot, thr, guess)
            bracket = move_bracket(bracket, guess, f_guess)
            slope = _path_slope(seg, step, kind, idx, slot, thr, guess)
            if math.isfinite(f_guess) and slope < 0.0:
                estimate = guess - f_guess / slope
                t_after, t_before = estimate + CLOSING * event_tol, estimate - CLOSING * event_tol
                if bracket[LO] < t_after < bracket[HI]:
                    f_after = event_after(seg, step, kind, idx, slot, thr, t_after)
                    bracket = move_bracket(bracket, t_after, f_after)
                    if (
                        f_after <= 0.0
                        and bracket[HI] - bracket[LO] > event_tol
                        and bracket[LO] < t_before
                    ):
                        back = t_after - t_before
                        f_before = _value_back(seg, step, kind, idx, slot, thr, t_after, back)
                        bracket = move_bracket(bracket, t_before, f_before)
    for _ in range(100):
        if bracket[HI] - bracket[LO] <= event_tol:
            break
        mid = next_probe(bracket, event_tol)
        f_mid = event_after(seg, step, kind, idx, slot, thr, mid)
        bracket = move_bracket(bracket, mid, f_mid)
    return bracket[LO], bracket[HI]
