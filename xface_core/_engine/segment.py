"""A smooth segment: the active set held fixed, integrated step by step to its first event.

``follow_contacts`` is the stage loop of one segment: begin it on the contacts, try a step,
look for events in it, accept it or advance to the event and act on it.
"""

from __future__ import annotations

import math

from numba import njit

from .ends import Run, end_at_rest, end_run, record
from .events import (
    NO_EVENT,
    Event,
    clear_step_memo,
    end_velocity,
    has_dense,
    keep_trial_dense,
    start_velocity,
    step_to,
)
from .folds import cuts_in, solve_fold
from .integrate import pins_path, project
from .pairs import COL_EDGE_LENGTH, COL_REACH, eval_pair
from .records import (
    ALIGN_TOL,
    E_BELOW_SEAT,
    E_CONTACT,
    E_NONE,
    E_OFF_EDGE,
    E_RELEASE,
    E_SLIP,
    E_SPUN,
    E_TURN,
    FOLD_RISE,
    FREE,
    MAX_TURN,
    O_BAD_MATE,
    O_UNRESOLVED,
    P_ALIGN,
    P_SLIDE,
    PINNED_ROUNDOFF,
    R_BELOW_SEAT,
    R_SINGULAR,
    R_SPUN,
    R_STEP_LIMIT,
    STEP_CAP_FLOOR,
    STICK,
    TINY,
    UNDECIDED,
    FloatArray,
    IntArray,
    Model,
    Options,
    Segment,
    Step,
    Work,
    held_contacts,
    njit_cached,
    njit_inline,
    njit_no_refcount,
    touch_depth,
)
from .scan import asleep, find_event, reach_budget, wake


@njit_no_refcount
def _phase(run: Run) -> int:
    return P_SLIDE if abs(run.phi_b - run.phi_m) <= ALIGN_TOL else P_ALIGN


@njit(inline="always")
def _segment(model: Model, opts: Options, run: Run, work: Work) -> Segment:
    """What stays fixed along the segment just started. Inlined, so the tuple of arrays is
    built under the caller's reference counting (none in the engine, numba's for a caller
    in Python)."""
    held = held_contacts(model, opts, work, run.n_active, opts.friction, run.x0)
    return Segment(held, run.y_floor, work.step_memo, work.dense)


@njit_no_refcount
def start_segment(
    model: Model, opts: Options, run: Run, work: Work, path: FloatArray, path_pairs: IntArray
) -> None:
    """Start exactly on the active constraints and note every pair's gap and threshold.

    Events leave gaps of up to the touching tolerance; projecting first makes the step
    error measure only the step's own drift. A pair touching now counts as a new contact
    only once it closes past its current gap (less the touching tolerance).
    """
    act, n = work.act, run.n_active
    held = held_contacts(model, opts, work, n, opts.friction, run.x0)
    qb, qm = project(held, run.phi_b, run.phi_m, run.y_m)
    turn = 0.0  # how far the projection turned the parts
    if max(abs(qb - run.phi_b), abs(qm - run.phi_m)) < 1e-6:
        turn = abs(qb - run.phi_b) + abs(qm - run.phi_m)
        run.phi_b, run.phi_m = qb, qm
    tt = opts.touch_tol
    thr, g_prev, u_prev = work.thr, work.g_prev, work.u_prev
    sleep, pairs = work.sleep, model.pairs
    holds = work.sleep_holds[0] == 1
    work.sleep_holds[0] = 0
    cb, sb = math.cos(run.phi_b), math.sin(run.phi_b)
    cm, sm = math.cos(run.phi_m), math.sin(run.phi_m)
    for i in range(pairs.shape[0]):
        row = pairs[i]
        spent = turn * row[COL_REACH]  # how far the projection moved its vertex, at most
        if holds and asleep(work, i) and sleep[i, 0] > spent:
            # Out of reach through the event's step (the event's state included) and still
            # after the projection's turn: it keeps what is left of its budget, and its
            # values wait, stale, until it wakes (scan._refresh_start).
            thr[i] = 0.0
            sleep[i, 0], sleep[i, 1], sleep[i, 2] = sleep[i, 0] - spent, -1.0, 1.0
            continue
        g, u, _, _, _, _, _, _, _ = eval_pair(row, cb, sb, cm, sm, run.x0, run.y_m)
        thr[i] = min(g, 0.0) - tt if -touch_depth(tt) <= g <= tt else 0.0
        g_prev[i] = g
        u_prev[i] = u
        # Looked at here: out of reach by its budget from now on, so the segment's first
        # step need not evaluate a pair far from its edge.
        sleep[i, 0], sleep[i, 1], sleep[i, 2] = reach_budget(row, g, u), -1.0, 0.0
    record(run, path, path_pairs, _phase(run), act, n)
    clear_step_memo(work.step_memo)
    work.dense[1, 4] = 0.0  # no trial step's dense output yet


@njit_cached  # returns arrays (in the Segment) to Python: needs NRT
def begin_segment(
    model: Model, opts: Options, run: Run, work: Work, path: FloatArray, path_pairs: IntArray
) -> Segment:
    """:func:`start_segment`, and the :class:`Segment` it starts (for callers in Python:
    the engine's :func:`follow_contacts` builds it in place)."""
    start_segment(model, opts, run, work, path, path_pairs)
    return _segment(model, opts, run, work)


@njit_inline
def _error_scales(opts: Options, step: Step, nb: float, nm: float) -> tuple[float, float]:
    """The error allowed on phi_B and phi_M (rad) in the trial step from ``step``'s start to
    ``(nb, nm)``: atol plus rtol times the larger magnitude of the angle's two ends."""
    return (
        opts.atol + opts.rtol * max(abs(step.phi_b), abs(nb)),
        opts.atol + opts.rtol * max(abs(step.phi_m), abs(nm)),
    )


@njit_inline
def trial_step(opts: Options, seg: Segment, step: Step) -> tuple[float, float, float, float, bool]:
    """Integrate the trial step: ``(phi_b, phi_m, err, turn, ok)`` with the error relative
    to the tolerances (accept at <= 1) and the largest rotation in the step (rad)."""
    nb, nm, eb, em, ok = step_to(seg, step, step.h)
    keep_trial_dense(seg, step)
    if not ok:
        return nb, nm, math.inf, 0.0, False
    sc_b, sc_m = _error_scales(opts, step, nb, nm)
    err = max(abs(eb) / sc_b, abs(em) / sc_m)
    turn = max(abs(nb - step.phi_b), abs(nm - step.phi_m))
    # Cap the rotation per step: near a turning point of the contact path the rate grows
    # without bound and a long step could jump across thin features.
    if turn > MAX_TURN or turn > opts.jam_speed * step.h:
        return nb, nm, math.inf, turn, False
    return nb, nm, err, turn, ok


@njit_no_refcount
def error_at_roundoff(
    opts: Options, seg: Segment, step: Step, nb: float, nm: float, turn: float, err: float
) -> float:
    """The error (relative, accept at <= 1) of a trial step that failed with ``err``, judged
    again no closer than the solve's round-off where the contacts pin the path and the step
    leaves a fold of it behind; else ``err``.

    There a state is the contacts' solution, known only to the gaps' round-off over the
    constraints' smallest singular value, which falls as the rate grows: PINNED_ROUNDOFF
    times the step's mean rate (``turn`` over its length). Judged closer (rtol 1e-11 just
    past a fold), every trial length failed and the run ended as a jam where the path goes
    on (S 0.5/1 at x0 = 0.9 D, theta0 = -7 pi / 40; docs/model.md, Folds). Towards a fold the
    rate grows: the trial lengths still collapse there, and the fold is a jam. Asked only
    for a failed step (``steps_to_event``): in ``trial_step`` the test made the maps 2-5 %
    slower.
    """
    if not (pins_path(seg.held.n_active, seg.held.winv_b, seg.held.mu) and has_dense(seg, step)):
        return err
    floor = PINNED_ROUNDOFF * max(1.0, turn / step.h)
    sc_b, sc_m = _error_scales(opts, step, nb, nm)
    if floor <= min(sc_b, sc_m):
        return err
    v0b, v0m, _, _ = start_velocity(seg, step)
    v1b, v1m, _, _ = end_velocity(seg, nb, nm, step.y_m - step.h)
    rate_end = max(abs(v1b), abs(v1m))
    if not (math.isfinite(rate_end) and rate_end < max(abs(v0b), abs(v0m))):
        return err  # not leaving a fold behind
    # The kept dense output holds the step's error estimates (integrate.rk_step).
    eb, em = seg.dense[1, 13], seg.dense[1, 14]
    return float(max(eb / max(sc_b, floor), em / max(sc_m, floor)))


@njit_no_refcount
def jump_to_fold(model: Model, run: Run, work: Work, located: bool, start: Step) -> None:
    """Move a two-contact run onto the fold of its path (where the pinned contacts reach
    their lowest point), if the fold is near and the jump cuts into no pair that was clear
    at the ``start`` of the trial step.

    Near means: after a *located* turn, within FOLD_RISE of the turn's height either side
    (the fold is where the turn was found, to the locate's accuracy); after the step size
    collapsed (the rate diverges ahead), anywhere below the current height (the run only
    descends, and solve_fold itself accepts folds within 1e-3 D).
    """
    if run.n_active != 2:
        return
    fb, fm, fy, conv = solve_fold(model.pairs, work.act, run.phi_b, run.phi_m, run.x0, run.y_m)
    near = abs(fy - run.y_m) < FOLD_RISE if located else fy <= run.y_m
    if conv and near:
        wake(model.pairs, work, start.phi_b, start.phi_m, run.x0, start.y_m)
    if conv and near and not cuts_in(model.pairs, work.g_prev, work.thr, fb, fm, run.x0, fy):
        run.phi_b, run.phi_m, run.y_m = fb, fm, fy


@njit_no_refcount
def _error_factor(err: float) -> float:
    """The step-length factor an error ``err`` (relative, accept at <= 1) asks for: 0.9
    err^-1/5 (safety 0.9, the order 4 of the error estimate plus one)."""
    factor: float = 0.9 * err**-0.2
    return factor


@njit_no_refcount
def next_length(
    h: float, err: float, turn: float, h_prev: float, err_prev: float, after_reject: bool
) -> float:
    """The trial length after an accepted step of length ``h`` (D) with error ``err``
    (relative, accept at <= 1) that turned the parts by ``turn`` (rad).

    The elementary controller (0.9 err^-1/5, between 0.2 and 5), no larger than Gustafsson's
    predictive one when the segment's previous accepted step (``h_prev``, ``err_prev``;
    0 for none) is known, and not longer than ``h`` right ``after_reject`` (Hairer, Norsett
    and Wanner's rules, DOPRI5's and RADAU5's codes). Near a fold of the contact path the
    error constant grows step by step (rates about 100 rad/D): the elementary controller
    grew every accepted step and had the next one rejected, every other trial step; the
    predictive one follows the trend. The next step also keeps under the turn cap.
    """
    fac = 5.0 if err == 0.0 else min(5.0, max(0.2, _error_factor(err)))
    if h_prev > 0.0 and err > 0.0 and err_prev > 0.0:
        fac = min(fac, max(0.2, _error_factor(err) * (h / h_prev) * (err_prev / err) ** 0.2))
    if after_reject:
        fac = min(fac, 1.0)
    return min(h * fac, 0.9 * MAX_TURN * h / max(turn, TINY))


@njit_no_refcount
def accept_step(
    run: Run, work: Work, nb: float, nm: float, h_next: float,
    path: FloatArray, path_pairs: IntArray,
) -> None:  # fmt: skip
    """No event in the step: take it; the next trial length is ``h_next``
    (:func:`next_length`)."""
    h = run.h
    run.n_excluded = 0
    g_prev, u_prev, g_next, u_next = work.g_prev, work.u_prev, work.g_next, work.u_next
    for i in range(g_prev.shape[0]):
        g_prev[i] = g_next[i]
        u_prev[i] = u_next[i]
    run.steps += 1
    run.phi_b, run.phi_m, run.y_m = nb, nm, run.y_m - h
    record(run, path, path_pairs, _phase(run), work.act, run.n_active)
    run.h = h_next


@njit_no_refcount
def _shrink(opts: Options, h: float, err: float, turn: float, ok: bool) -> float:
    """The next trial length after a rejected step of length ``h``: by the error estimate;
    after a step that turned further than ``MAX_TURN`` (``ok`` false, ``turn`` > 0) to
    the length that would have turned 0.9 of the cap at the step's mean rate (at least a
    quarter: the rate may still grow); after a failed step (``turn`` 0) a quarter."""
    if ok:
        return max(h * max(0.2, _error_factor(err)), 0.5 * opts.event_tol)
    if turn > MAX_TURN:
        return h * min(0.9, max(0.25, 0.9 * MAX_TURN / turn))
    return h * 0.25


@njit_no_refcount
def advance_to_event(
    model: Model, opts: Options, run: Run, work: Work, seg: Segment, step: Step, ev: Event
) -> int:
    """Move the run to the event; returns its kind (a step to it that crosses a fold of the
    path becomes a TURN, stopped at the last good state)."""
    kind = ev.kind
    if kind == E_TURN:
        # The rate diverges at a fold of the contact path: integrating up to it is
        # ill-conditioned, so solve the active constraints there directly (Newton from the
        # last good state); the state is then exact to about sqrt(event_tol).
        y_ev = step.y_m - ev.h
        tb, tm = run.phi_b, run.phi_m
        for _ in range(20):
            tb, tm = project(seg.held, tb, tm, y_ev)
        # The turn lies within this step, which turns the parts by at most MAX_TURN: a
        # projection further away converged to another solution of the contacts (seen: 0.49
        # rad away, the parts 1.5 D^2 inside each other at a pivot on the seat line).
        near = max(abs(tb - run.phi_b), abs(tm - run.phi_m)) <= MAX_TURN
        if near:
            wake(model.pairs, work, step.phi_b, step.phi_m, run.x0, step.y_m)
        if near and not cuts_in(model.pairs, work.g_prev, work.thr, tb, tm, run.x0, y_ev):
            run.phi_b, run.phi_m, run.y_m = tb, tm, y_ev
        jump_to_fold(model, run, work, True, step)
        run.steps += 1
    elif ev.h > 0.0:
        eb, em, _, _, ok = step_to(seg, step, ev.h)
        if ok and max(abs(eb - run.phi_b), abs(em - run.phi_m)) <= MAX_TURN:
            run.phi_b, run.phi_m, run.y_m = eb, em, step.y_m - ev.h
            run.steps += 1
        elif kind == E_RELEASE and seg.held.mu > 0.0:
            # With friction a sliding contact's force can change sign at a fold of its path,
            # which the step to it cannot cross (the rate blows up on the way): this slip
            # state cannot carry the parts on, but the parts may move on without the contact
            # (its force gone, the descent along its edge). The release stands at the last
            # good state, to choose again there as after any release; a fold the choice
            # cannot leave ends there (a jam, or the turning point of the next segment).
            # X 2.12/0.072, damping ratio 1.3e-3, mu 0.42 at x0 = D, theta0 = -pi/6 ended
            # here as a turning point (BAD_MATE) where its mirror run, reaching the same fold
            # 3e-9 D apart by a slip event, chose again and seated, as the independent engine
            # does from both.
            return kind
        else:
            # The step to the event crosses a fold of the path (the rate blows up on the
            # way): stop at the last good state as at a turning point.
            kind = E_TURN
            jump_to_fold(model, run, work, True, step)
    return kind


@njit_no_refcount
def handle_event(
    model: Model, opts: Options, run: Run, work: Work, seg: Segment, step: Step, ev: Event,
    path: FloatArray, path_pairs: IntArray,
) -> None:  # fmt: skip
    """Advance to the event and act on it: end the run, or update the excluded pairs."""
    kind = advance_to_event(model, opts, run, work, seg, step, ev)
    run.events += 1
    record(run, path, path_pairs, _phase(run), work.act, run.n_active)
    L, tol = model.mated_distance, opts.seat_tol
    if kind == E_BELOW_SEAT:
        end_at_rest(run, path, path_pairs, work.act, L, tol, R_BELOW_SEAT, False)
        return
    if kind == E_TURN:
        end_at_rest(run, path, path_pairs, work.act, L, tol, R_SINGULAR, False)
        return
    if kind == E_SPUN:
        end_run(run, path, path_pairs, work.act, O_BAD_MATE, R_SPUN, False)
        return
    if ev.h > 1e-7:
        run.n_excluded = 0
    exclude, n_ex = work.exclude, run.n_excluded
    if kind == E_RELEASE or kind == E_OFF_EDGE:  # noqa: SIM109 (numba)
        if n_ex < exclude.shape[0]:
            exclude[n_ex] = ev.pair
            run.n_excluded = n_ex + 1
    elif kind == E_CONTACT:
        for k in range(n_ex):
            if exclude[k] == ev.pair:
                exclude[k] = exclude[n_ex - 1]
                run.n_excluded = n_ex - 1
                break
    run.h = max(run.h, 1e3 * opts.event_tol)
    # The run stands inside the step just scanned: the pairs out of reach all through it are
    # still out of reach here (begin_interval, start_segment).
    work.sleep_holds[0] = 1


@njit_no_refcount
def _slides_alone(seg: Segment) -> bool:
    """Is the segment held by one contact that slides with friction?"""
    held = seg.held
    sliding = held.slip[0] != FREE and held.slip[0] != STICK
    return bool(held.n_active == 1 and held.mu > 0.0 and sliding)


@njit_no_refcount
def step_cap(pairs: FloatArray, max_step: float) -> float:
    """The longest descent step of a segment (D): ``max_step`` (the settings' bound), and
    within half the design's shortest edge, but not below ``STEP_CAP_FLOOR``.

    The samples and the corner-crossing test that find a vertex gone in past a corner and
    out again inside a step (:func:`~.scan.find_event`) look within half an edge of the
    corner; a step that translates the parts no farther keeps the dip within their reach.
    On the paper's faces (shortest edge 0.33-1 D) the cap is 0.17-0.25 D; the 363 maps of
    its tables take 0.79 of the time they took at 0.05 D, with no outcome changed
    (docs/notes/2026-11-29-step-cap-by-design.md)."""
    shortest = math.inf
    for i in range(pairs.shape[0]):
        shortest = min(shortest, pairs[i, COL_EDGE_LENGTH])
    return min(max_step, max(STEP_CAP_FLOOR, 0.5 * shortest))


#: How the step loop of a segment stopped (:func:`steps_to_event`).
LOOP_EVENT = 0  # an event inside the last trial step: handle it
LOOP_DIVERGED = 1  # the trial length collapsed: the rate diverges ahead (a turning point)
LOOP_ENDED = 2  # the run ended in the loop (out of steps)


@njit_no_refcount
def steps_to_event(
    opts: Options, seg: Segment, run: Run, work: Work, path: FloatArray, path_pairs: IntArray
) -> tuple[int, Step, Event]:
    """Try steps with the active set fixed, accepting each until one holds an event:
    ``(how it stopped, the last trial step, its event)``.

    The loop of :func:`follow_contacts`, which handles what ends it (an event, or a turning
    point where the trial length collapsed: the fold's jump and the run's end).
    """
    after_reject = False
    h_prev, err_prev = 0.0, 0.0  # the segment's last accepted step (0: none yet)
    step = Step(run.phi_b, run.phi_m, run.y_m, run.h)
    h_cap = step_cap(seg.held.pairs, opts.max_step)
    while run.outcome == UNDECIDED:
        if run.steps >= opts.max_steps:
            end_run(run, path, path_pairs, work.act, O_UNRESOLVED, R_STEP_LIMIT, True)
            return LOOP_ENDED, step, NO_EVENT
        run.h = min(run.h, h_cap)
        step = Step(run.phi_b, run.phi_m, run.y_m, run.h)
        nb, nm, err, turn, ok = trial_step(opts, seg, step)
        if err > 1.0 and ok:
            err = error_at_roundoff(opts, seg, step, nb, nm, turn, err)
        if err > 1.0:
            run.rejected_steps += 1
            if step.h <= opts.event_tol:
                # The rate diverges: the contacts reach a turning point (a contact normal
                # through both pivots). The seat itself is such a point.
                return LOOP_DIVERGED, step, NO_EVENT
            run.h = _shrink(opts, step.h, err, turn, ok)
            after_reject = True
            continue
        ev = find_event(opts, seg, step, work, nb, nm)
        if ev.kind == E_NONE:
            h_next = next_length(step.h, err, turn, h_prev, err_prev, after_reject)
            accept_step(run, work, nb, nm, h_next, path, path_pairs)
            h_prev, err_prev, after_reject = step.h, err, False
            continue
        return LOOP_EVENT, step, ev
    return LOOP_ENDED, step, NO_EVENT


@njit_no_refcount
def follow_contacts(
    model: Model, opts: Options, run: Run, work: Work, path: FloatArray, path_pairs: IntArray
) -> None:
    """Integrate with the active set fixed until the next event, and handle it."""
    start_segment(model, opts, run, work, path, path_pairs)
    seg = _segment(model, opts, run, work)
    y_begun = run.y_m
    stop, step, ev = steps_to_event(opts, seg, run, work, path, path_pairs)
    if stop == LOOP_DIVERGED and run.y_m < y_begun and _slides_alone(seg):
        # A lone sliding contact whose rate runs away: with a very light base the slide's
        # slip can turn over so fast that the trial length collapses before the slip event
        # is bracketed (the mirror run of V H/D 0.98, r_p 0, damping ratio 1e-4, mu 0.46
        # bracketed it 1e-11 D earlier, chose to stick and seated; this one ended as a
        # turning point). Choose again from the last good state, as after a slip event; a
        # segment that diverges without moving still ends as a turning point below.
        ev = Event(E_SLIP, seg.held.act[0], 0.0)
        stop = LOOP_EVENT
    if stop == LOOP_EVENT:
        handle_event(model, opts, run, work, seg, step, ev, path, path_pairs)
    elif stop == LOOP_DIVERGED:
        jump_to_fold(model, run, work, False, step)
        end_at_rest(
            run, path, path_pairs, work.act, model.mated_distance, opts.seat_tol, R_SINGULAR,
            True,
        )  # fmt: skip
