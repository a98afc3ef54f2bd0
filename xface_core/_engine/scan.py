"""Which event comes first in an accepted trial step: the scan over every event source.

Sources, in the order they are checked (the earliest wins, ties to the first found): the
active contacts (release, or the path turning back; leaving the edge), their friction states,
new contacts among the other pairs, the seat height and a part spinning past +-pi.
"""

from __future__ import annotations

import math

from .bracket import HI, LO, move_bracket, next_probe, start_bracket
from .events import (
    NO_EVENT,
    QUARTER_SLOTS,
    Event,
    angles_at,
    contact_value,
    earlier,
    end_velocity,
    has_dense,
    locate,
    quarter_state,
    start_velocity,
    step_to,
)
from .motion import slip_margin, velocity
from .pairs import (
    COL_EDGE_LENGTH,
    COL_REACH,
    clipped_gap,
    corner_distance,
    eval_pair,
    pair_at,
    past_reflex_end,
    tests_corner_crossing,
    wedges_cross,
)
from .records import (
    COARSE_SAMPLES,
    CORNER_REACH,
    E_BELOW_SEAT,
    E_CONTACT,
    E_NONE,
    E_OFF_EDGE,
    E_RELEASE,
    E_SLIP,
    E_SPUN,
    E_TURN,
    FINE_SAMPLES,
    FLAT_GAP,
    FREE,
    SLEEP_SLACK,
    U_TOL,
    Contacts,
    FloatArray,
    Options,
    Segment,
    Step,
    Trig,
    Work,
    njit_inline,
    njit_no_refcount,
    touch_depth,
)


@njit_no_refcount
def _trig(pb: float, pm: float) -> Trig:
    """cos and sin of phi_B and phi_M (rad) at one state, for checking many pairs there."""
    return (math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm))


@njit_no_refcount
def _trig_after(seg: Segment, step: Step, t: float) -> Trig:
    """cos and sin of phi_B and phi_M a descent ``t`` (D) into the step, on the integrated
    path (for checking many pairs at one state)."""
    pb, pm, _, _, _ = step_to(seg, step, t)
    return _trig(pb, pm)


@njit_inline
def _active_events(
    opts: Options, seg: Segment, step: Step, nb: float, nm: float, end: Trig, best: Event
) -> Event:
    """An active contact lets go (its force changes sign), the path turns back (the force
    changes sign through a pole), or its vertex leaves the edge."""
    y1 = step.y_m - step.h
    tol = opts.event_tol
    held = seg.held
    _, _, l1, l2 = end_velocity(seg, nb, nm, y1)
    for k in range(held.n_active):
        pair = held.act[k]
        lam = l1 if k == 0 else l2
        if lam < 0.0:
            lo, hk = locate(seg, step, tol, E_RELEASE, pair, k, 0.0)
            kind = E_RELEASE
            pbk, pmk, _, _, _ = step_to(seg, step, lo)
            wb, wm, m1, m2 = velocity(held, pbk, pmk, step.y_m - lo)
            sb, sm, s1, s2 = start_velocity(seg, step)
            pole = abs(m1 if k == 0 else m2) > 1e-6 * max(1.0, abs(s1 if k == 0 else s2))
            # With friction the forces also have a pole where the friction-turned normals
            # line up (the contacts wedge) while the rate stays finite: the path goes on,
            # only this set of slipping contacts cannot carry it; choose again (a release).
            wedge = held.mu > 0.0 and max(abs(wb), abs(wm)) < 1e3 * max(1.0, abs(sb), abs(sm))
            if pole:
                best = _event_before_pole(opts, seg, step, lo, E_SLIP, -1, 4, best)
            if pole and not wedge:
                # lambda changed sign through a pole, not through zero: the contact path
                # turns back here and cannot descend further.
                kind = E_TURN
                hk = lo
                best = _event_before_pole(opts, seg, step, lo, E_RELEASE, k, 3, best)
            best = earlier(Event(kind, pair, hk), best)
        ecb, esb, ecm, esm = end
        _, u, _, _, _, _, _, _, _ = eval_pair(held.pairs[pair], ecb, esb, ecm, esm, held.x0, y1)
        if u < -U_TOL or u > 1.0 + U_TOL:
            _, hk = locate(seg, step, tol, E_OFF_EDGE, pair, k, 0.0)
            best = earlier(Event(E_OFF_EDGE, pair, hk), best)
    return best


@njit_no_refcount
def _value_before_pole(held: Contacts, kind: int, k: int, pb: float, pm: float, y: float) -> float:
    """What :func:`_event_before_pole` samples for held contact ``k`` at the state ``(pb, pm,
    y)``: its force for a release (the raw multiplier, no slack: a pole's search wants its
    sign), its slip margin (:func:`~.motion.slip_margin`) for a change of friction state."""
    if kind == E_SLIP:
        return slip_margin(held, k, pb, pm, y)
    _, _, l1, l2 = velocity(held, pb, pm, y)
    return l1 if k == 0 else l2


@njit_no_refcount
def _event_before_pole(
    opts: Options, seg: Segment, step: Step, t_pole: float, kind: int, pole_slot: int,
    samples: int, best: Event,
) -> Event:  # fmt: skip
    """An event of ``kind`` (E_RELEASE or E_SLIP) of a held contact other than
    ``pole_slot`` that came before the pole of a contact force found a descent ``t_pole``
    (D) into the step (the bracket's end before it), or ``best``: found before the release
    or the turning point there.

    The rates diverge at the pole and every force and slip margin changes sign through it,
    so a value that crossed zero before it can be positive again at the step's end, where
    :func:`_active_events` and :func:`_slip_events` look. It is sampled at ``samples``
    quarters of the way to the pole on the integrated path (three for a release; four for
    a slip, the last just before the pole, where a margin runs to its pole fastest); the
    first negative sample closes the search for its zero.

    - A release: X 0.25/1 at x0 = -0.85 D, theta0 = 0.7069 crossed a release 0.3 of the
      way into its step and ended at the pole as a jam; the independent engine seats it,
      and so did xface with the other first steps tried, 1e-4 to 0.05 D.
    - A slip: X 2.1225/0.0721 at damping ratio 1.29e-3 and mu 0.42 from x0 = D,
      theta0 = -pi/6: the slide's margin fell through zero 1.6e-9 D into its step and ran
      to -2800 at the pole 0.3e-9 D later, and to +3.7 past it. Found as a turning point
      (its stages' cos and sin taken otherwise) the run jammed, and as a release the slip
      was passed over; with the slip it chooses again and seats as its mirror run does
      (docs/notes/2026-11-30-event-brackets.md). A friction state contradicted at the
      step's start already is not this search's: located there, it would be chosen again
      at the same state, over and over.
    """
    held = seg.held
    for k in range(held.n_active):
        if k == pole_slot:
            continue
        if kind == E_SLIP and (
            held.slip[k] == FREE
            or not (slip_margin(held, k, step.phi_b, step.phi_m, step.y_m) > 0.0)
        ):
            continue
        for q in range(1, samples + 1):
            t = 0.25 * q * t_pole
            pb, pm, _, _, ok = step_to(seg, step, t)
            if not ok:
                break
            if _value_before_pole(held, kind, k, pb, pm, step.y_m - t) < 0.0:
                head = Step(step.phi_b, step.phi_m, step.y_m, t)
                _, hk = locate(seg, head, opts.event_tol, kind, held.act[k], k, 0.0)
                return earlier(Event(kind, held.act[k], hk), best)
    return best


@njit_inline
def _slip_events(
    opts: Options, seg: Segment, step: Step, nb: float, nm: float, best: Event
) -> Event:
    """A sliding contact stops or reverses, or a stuck one starts to slide."""
    y1 = step.y_m - step.h
    for k in range(seg.held.n_active):
        if seg.held.slip[k] == FREE:
            continue
        margin = slip_margin(seg.held, k, nb, nm, y1)
        if margin < 0.0:
            _, hk = locate(seg, step, opts.event_tol, E_SLIP, seg.held.act[k], k, 0.0)
            kind = E_SLIP
            if hk == 0.0 and seg.held.n_active == 2:
                # Two contacts fix the rate, and their slip states were read from it a
                # short move ahead (motion.friction_modes); contradicted already at the
                # start, the rate turns over within that move: a fold of the contact path
                # (its normals line up with the pivots), where choosing again would choose
                # the same and fire again, forever (V H/D 0.439, r_p 0, mu 2.44 at
                # x0 = -0.208 D, theta0 = 1.414: the event budget). The path turns here.
                kind = E_TURN
            best = earlier(Event(kind, seg.held.act[k], hk), best)
    return best


@njit_inline
def _contact_events(
    opts: Options, seg: Segment, step: Step, work: Work, nb: float, nm: float, start: Trig,
    end: Trig, best: Event,
) -> tuple[Event, bool, int]:  # fmt: skip
    """New contacts: an inactive pair's gap crosses its threshold inside the edge's span.
    Also fills every pair's gap and edge parameter at the step's end (``work.g_next``), says
    whether two corners cross there that did not at the start (:func:`_crossing`), and lists
    the inactive pairs whose vertex comes within the step's travel of their edge in
    ``work.near`` (how many: the third value), for :func:`_contacts_inside_step`."""
    y1 = step.y_m - step.h
    # Arrays taken out of the records once: numba counts references on every attribute read.
    thr, g_prev, u_prev = work.thr, work.g_prev, work.u_prev
    g_next, u_next, near = work.g_next, work.u_next, work.near
    n_near = 0
    # The turn between the ends, as _contacts_inside_step bounds a vertex's travel with it.
    turn_ends = abs(nb - step.phi_b) + abs(nm - step.phi_m)
    pairs, act, n_act, x0 = seg.held.pairs, seg.held.act, seg.held.n_active, seg.held.x0
    tol = opts.event_tol
    cb1, sb1, cm1, sm1 = end
    # The states at the earliest event so far and two event widths before it, computed once
    # per candidate event and shared by every pair checked against it.
    at_h, at = -1.0, (1.0, 0.0, 1.0, 0.0)  # cos and sin of the angles there
    early_h, early = -1.0, at
    cb0, sb0, cm0, sm0 = start
    crossed = False
    rates = (-1.0, -1.0)  # _turn_rates, once a pair needs them
    sleep = work.sleep
    # Twice the turn between the ends: the bound on the turn inside an accepted step that
    # _turn_rates also takes.
    turn = 2.0 * turn_ends
    for i in range(pairs.shape[0]):
        row = pairs[i]
        travel = _travel(row, step.h, turn)
        if sleep[i, 0] > travel:
            # Out of reach all through the step: no contact, no corners crossing, nothing
            # to evaluate (most pairs of a run, most of the time). Its values are stale
            # until it wakes (_refresh_start; every reader of them wakes it first), so they
            # are not carried on. The budget is spent here, before the step is known to be
            # taken: a step that ends in an event ends the segment, and start_segment wakes
            # every pair.
            sleep[i, 0] -= travel
            sleep[i, 1] = travel
            sleep[i, 2] = 1.0
            continue
        sleep[i, 1] = -1.0
        _refresh_start(row, i, work, (cb0, sb0, cm0, sm0), x0, step.y_m)
        g1, u1, _, _, _, _, _, _, _ = eval_pair(row, cb1, sb1, cm1, sm1, x0, y1)
        g_next[i] = g1
        u_next[i] = u1
        sleep[i, 0] = reach_budget(row, g1, u1)
        if not crossed:
            crossed = _crossing(opts, work, i, row, g1, u1, x0, (cb1, sb1, cm1, sm1, y1, nb, nm),
                                (cb0, sb0, cm0, sm0, step.y_m, step.phi_b, step.phi_m))  # fmt: skip
        if (n_act > 0 and act[0] == i) or (n_act > 1 and act[1] == i):
            continue
        if _within_travel(row, g_prev[i], u_prev[i], g1, u1, _travel(row, step.h, turn_ends)):
            near[n_near] = i
            n_near += 1
        # The event function is the gap with the edge's convex corners clipped on
        # (pairs.clipped_gap): it is never below the plain gap, so a pair whose gap is above
        # its threshold at the step's end has not crossed, and one whose gap was above it at
        # the start was outside then.
        if g1 > thr[i]:
            continue
        # Where along the edge does the vertex cross its line? (Linear estimate; the exact
        # check follows the root finding.) Far outside the span: not a contact.
        crossed_line = g_prev[i] > thr[i]
        if crossed_line:
            u_est = u_prev[i] + (u1 - u_prev[i]) * (g_prev[i] - thr[i]) / (g_prev[i] - g1)
            if u_est < -0.25 or u_est > 1.25:
                continue
        # The step searched for this pair's crossing: the whole trial step, or its head up
        # to where the vertex is inside a thin corner it passed through (below).
        search, through_corner = step, False
        beside_end = clipped_gap(row, g1, cb1, sb1, cm1, sm1, x0, y1)
        if beside_end > thr[i]:
            # Behind the edge's line at the end, beside a neighbour's: past the corner. If
            # it crossed the line in this step, it went around the corner or through it.
            t_in = 0.0
            if crossed_line:
                gaps = (g_prev[i] - thr[i], g1 - thr[i])
                t_in = _inside_thin_corner(seg, step, row, thr[i], tol, gaps, beside_end, start)
            if t_in <= 0.0:
                continue
            search = Step(step.phi_b, step.phi_m, step.y_m, t_in)
            through_corner = True
        elif not crossed_line and (
            clipped_gap(row, g_prev[i], cb0, sb0, cm0, sm0, x0, step.y_m) <= thr[i]
        ):
            continue  # inside at the start already
        if not through_corner:
            if rates[0] < 0.0:
                rates = _turn_rates(seg, step, nb, nm)
            if _far_behind(seg, step, i, thr[i], rates, (cb0, sb0, cm0, sm0), (cb1, sb1, cm1, sm1)):
                continue
        # Not crossed yet at the earliest event found so far: it cannot come first. Crossed
        # within two event widths before it: the same moment (contacts closing together,
        # as at a seat); the next interval's touching scan picks it up without a search of
        # its own. (Several contacts close together at a seat; this spares their searches.)
        # Not for a vertex through a thin corner: its contact function is above the
        # threshold again at the event found (and at the step's end), whatever came first.
        if best.kind != E_NONE and not through_corner:
            if at_h != best.h:
                at = _trig_after(seg, step, best.h)
                at_h = best.h
            if contact_value(row, thr[i], at, x0, step.y_m - at_h) > -FLAT_GAP:
                continue
            t_early = max(best.h - 2.0 * tol, 0.0)
            if early_h != best.h:
                early = _trig_after(seg, step, t_early)
                early_h = best.h
            if contact_value(row, thr[i], early, x0, step.y_m - t_early) > 0.0:
                continue
        _, hk = locate(seg, search, tol, E_CONTACT, i, 0, thr[i])
        if best.kind != E_NONE and hk >= best.h:
            continue
        if _is_contact(opts, seg, step, i, hk, thr[i]):
            best = Event(E_CONTACT, i, hk)
    return best, crossed, n_near


@njit_no_refcount
def _inside_thin_corner(
    seg: Segment, step: Step, row: FloatArray, thr: float, tol: float,
    gaps: tuple[float, float], beside_end: float, start: Trig,
) -> float:  # fmt: skip
    """Where (a descent into the trial step, D) the pair's vertex is inside the other part
    at a convex corner it passed in this step, or 0.0 if it went around the corner outside;
    ``gaps``: its gap less ``thr`` at the step's ends (D, above 0, then not);
    ``beside_end``: its clipped gap at the step's end (D, above ``thr``); ``start``: cos and
    sin of the angles at the step's start. Beside a neighbour's line at the start as well,
    it never was behind both: 0.0 at once.

    The vertex crossed the edge's line (the plain gap fell to ``thr``) but ends beside the
    neighbouring edge's line, so the contact function (:func:`~.pairs.clipped_gap`, behind
    both lines) is above ``thr`` at both ends of the step. Crossing the edge's line first, it
    was behind both lines in between: inside a thin corner, through it in one step (a
    needle 4e-4 D thick crossed in a 0.05 D step, unseen: the parts then overlapped 1.5e-3 D).
    Crossing the neighbour's line first, it was in front of both: around the corner.

    Closes in on the edge line's crossing on the step's dense output (integrating at every
    probe made the maps 1.25 times slower: the probes also pushed the step's other states
    out of the step memo) and stops at the first state that shows which: behind both lines
    (inside) or in front of both (around). An inside state is returned only if the integrated path
    is inside there too (else the window is within the step's error: none)."""
    x0 = seg.held.x0
    cb, sb, cm, sm = start
    beside = (clipped_gap(row, -math.inf, cb, sb, cm, sm, x0, step.y_m) - thr, beside_end - thr)
    if beside[0] > 0.0:
        return 0.0
    # The first probe halfway between where the two lines are crossed on the chords of
    # their distances; then the edge line's crossing is closed in on by the root search's
    # probes (bracket.next_probe): a vertex passing a corner (2000 times in an X 1/1 map,
    # nearly all around it) crosses both lines within a hundredth of the step of each other,
    # and halving took 18 probes a pass to tell which came first.
    t_edge = step.h * gaps[0] / (gaps[0] - gaps[1])
    t_side = step.h * -beside[0] / (beside[1] - beside[0])
    t = 0.5 * (t_edge + t_side)
    b = start_bracket(0.0, gaps[0], step.h, gaps[1])
    while b[HI] - b[LO] > tol:
        cb, sb, cm, sm = _trig(*angles_at(seg, step, t))
        y = step.y_m - t
        g, _, _, _, _, _, _, _, _ = eval_pair(row, cb, sb, cm, sm, x0, y)
        outside = clipped_gap(row, -math.inf, cb, sb, cm, sm, x0, y) > thr
        if g <= thr and not outside:
            pb, pm, _, _, ok = step_to(seg, step, t)
            cb, sb, cm, sm = _trig(pb, pm)
            g, _, _, _, _, _, _, _, _ = eval_pair(row, cb, sb, cm, sm, x0, y)
            if ok and g <= thr and clipped_gap(row, g, cb, sb, cm, sm, x0, y) <= thr:
                return t
            return 0.0
        if g > thr and outside:
            return 0.0
        b = move_bracket(b, t, g - thr)
        t = next_probe(b, tol)
    return 0.0


@njit_no_refcount
def _within_travel(
    row: FloatArray, g0: float, u0: float, g1: float, u1: float, bound: float
) -> bool:
    """Does the pair's vertex come within ``bound`` (D, its travel in the step) of its edge at
    either end of the step (gap and edge parameter ``g0, u0`` at the start, ``g1, u1`` at the
    end)? Only then can it dip in and out inside the step."""
    if abs(g0) > bound and abs(g1) > bound:
        return False  # the segment is no nearer than the line (spares the square roots)
    return min(_segment_distance(row, g0, u0), _segment_distance(row, g1, u1)) <= bound


@njit_no_refcount
def _is_contact(opts: Options, seg: Segment, step: Step, i: int, hk: float, thr: float) -> bool:
    """Is the crossing of pair i's clipped gap located at ``hk`` this edge's contact? Only
    if the vertex crosses this edge's own line (not just a neighbour's, far from this edge's
    corner), and within the span, past a convex end at the corner, or just past a reflex end
    (a tip reaching the bottom of a notch).

    Behind the line by more than the touching window (``TOUCH_WINDOW`` touching tolerances:
    a pair no nearer is no touching pair, :func:`~.pairs.touching_pairs`) and away from both
    corners, the vertex crossed a neighbour's line, whatever the gap's size: where two edges
    are nearly in line a vertex 1.8e-3 D past their corner, held on the next edge, is only
    1e-7 D behind this one's line (a custom face, H/D 0.0011, edges 5.5e-5 rad apart).
    Reported, it was no touching pair at the next choice, its threshold stayed, and the same
    contact fired at the same state until the event budget (the range probe's seed 7, run
    2400: tests/core/range_reproducers.json).
    """
    pbk, pmk, _, _, _ = step_to(seg, step, hk)
    gk, uk, _, _, _, _, _, _, _ = pair_at(seg.held.pairs, i, pbk, pmk, seg.held.x0, step.y_m - hk)
    if gk < thr - CORNER_REACH:
        return False
    row = seg.held.pairs[i]
    if gk < thr - touch_depth(opts.touch_tol) and corner_distance(row, gk, uk) > CORNER_REACH:
        return False
    return not past_reflex_end(row, uk)


@njit_no_refcount
def _turn_rates(seg: Segment, step: Step, nb: float, nm: float) -> tuple[float, float]:
    """Bounds on how fast phi_B and phi_M turn (rad per D of descent) anywhere inside the
    trial step ending at ``(nb, nm)``: twice the largest of the rates at its ends and its
    mean rate. An accepted step's rate changes little (its error is within rtol); infinite
    when a rate is not finite."""
    v0b, v0m, _, _ = start_velocity(seg, step)
    v1b, v1m, _, _ = end_velocity(seg, nb, nm, step.y_m - step.h)
    rate_b = 2.0 * max(abs(v0b), abs(v1b), abs(nb - step.phi_b) / step.h)
    rate_m = 2.0 * max(abs(v0m), abs(v1m), abs(nm - step.phi_m) / step.h)
    if not math.isfinite(rate_b + rate_m):
        return math.inf, math.inf
    return rate_b, rate_m


@njit_no_refcount
def _gap_bounds(
    seg: Segment, step: Step, i: int, rates: tuple[float, float], pieces: int, start: Trig,
    end: Trig,
) -> tuple[float, float, float, float]:  # fmt: skip
    """Bounds (D) on pair i's plain gap anywhere in the trial step, from its values at
    ``pieces + 1`` evenly spaced states (the step's ends, and in between its dense output when
    kept, else ``step_to``; the bounds then widened by the interpolant's error) and
    how fast it can change: ``(floor, ceiling, smallest, largest)``, the last two of the
    gap at those states.

    Between two states ``dt`` apart the gap g is Lipschitz in the descent: |dg/ds| <=
    |dg/dy_M| + |dg/dphi_B| r_B + |dg/dphi_M| r_M, with |dg/dy_M| <= 1, the angle
    derivatives bounded by their larger value at the two states plus how far they can change
    in ``dt`` (the vertex's travel: the descent and its turn about both pivots), and the turn
    rates r bounded by ``rates`` (rad per D, :func:`_turn_rates`) over the whole step, or, in
    a piece of it, like them from the rates at the piece's ends and its mean rate. From both
    ends of a piece, g stays between ``(g_a + g_b -+ Lip dt) / 2`` there (or the end values).
    ``start``, ``end``: cos and sin of phi_B and phi_M at the step's ends (the callers have
    them).
    """
    row, x0 = seg.held.pairs[i], seg.held.x0
    dt = step.h / pieces
    # sqrt of the sum of squares, not hypot: a bound, and glibc's hypot (exact to round-off
    # without overflow, neither needed at a few D) was 5 % of the kernel's samples.
    arm = math.sqrt(row[1] * row[1] + row[2] * row[2])  # the vertex from its own pivot (D)
    g_top, g_low, g_ceiling, g_floor = -math.inf, math.inf, -math.inf, math.inf
    ab_max, am_max = 0.0, 0.0  # the largest |dg/dphi| at the states (D/rad)
    # The previous state: gap, |dg/dphi| (D/rad), the vertex from the edge's pivot (D),
    # angles and rates.
    g_a, ab_a, am_a, lever_a, pb_a, pm_a, vb_a, vm_a = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for k in range(pieces + 1):
        pb, pm = step.phi_b, step.phi_m
        if k == pieces:
            pb, pm, _, _, _ = step_to(seg, step, step.h)
        elif k > 0:
            # Inside the step the dense output serves (its error is covered by ``slack``).
            pb, pm = angles_at(seg, step, k * dt)
        y = step.y_m - (step.h if k == pieces else k * dt)
        cb, sb, cm, sm = start if k == 0 else end
        vb, vm = 0.0, 0.0
        if 0 < k < pieces:
            if k <= QUARTER_SLOTS:
                cb, sb, cm, sm, vb, vm = quarter_state(seg, k, pb, pm, y)
            else:
                cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
                vb, vm, _, _ = velocity(seg.held, pb, pm, y)
        elif pieces > 1:
            if k == 0:
                vb, vm, _, _ = start_velocity(seg, step)
            else:
                vb, vm, _, _ = end_velocity(seg, pb, pm, y)
        g, _, ab, am, _, px, py, _, _ = eval_pair(row, cb, sb, cm, sm, x0, y)
        lx, ly = (px, py) if row[0] == 0.0 else (px - x0, py - y)
        lever = math.sqrt(lx * lx + ly * ly)
        g_top, g_low = max(g_top, g), min(g_low, g)
        if k > 0:
            rate_b, rate_m = rates
            if pieces > 1:
                rate_b = 2.0 * max(abs(vb_a), abs(vb), abs(pb - pb_a) / dt)
                rate_m = 2.0 * max(abs(vm_a), abs(vm), abs(pm - pm_a) / dt)
                if not math.isfinite(rate_b + rate_m):
                    return -math.inf, math.inf, g_low, g_top
            turn = (rate_b + rate_m) * dt
            reach_e = max(lever_a, lever) + dt + arm * turn
            change = dt + (arm + reach_e) * turn  # how far either derivative can move
            lip = 1.0 + (max(ab_a, abs(ab)) + change) * rate_b
            lip += (max(am_a, abs(am)) + change) * rate_m
            g_ceiling = max(g_ceiling, 0.5 * (g_a + g + lip * dt))
            g_floor = min(g_floor, 0.5 * (g_a + g - lip * dt))
        g_a, ab_a, am_a, lever_a = g, abs(ab), abs(am), lever
        ab_max, am_max = max(ab_max, ab_a), max(am_max, am_a)
        pb_a, pm_a, vb_a, vm_a = pb, pm, vb, vm
    if pieces > 1 and has_dense(seg, step):
        # The states inside the step came from its dense output, off the path by about the
        # step's error estimate: widen the bounds by ten times that over the gap's angle
        # derivatives (and a round-off floor).
        d = seg.dense
        slack = 10.0 * (d[1, 13] * ab_max + d[1, 14] * am_max) + 1e-12
        return min(g_low, g_floor) - slack, max(g_top, g_ceiling) + slack, g_low, g_top
    return min(g_low, g_floor), max(g_top, g_ceiling), g_low, g_top


@njit_no_refcount
def _far_behind(
    seg: Segment, step: Step, i: int, thr: float, rates: tuple[float, float], start: Trig,
    end: Trig,
) -> bool:  # fmt: skip
    """Is pair i's vertex behind its edge's line by more than CORNER_REACH below its
    threshold all through the trial step (its parts turning at most at ``rates``)?

    Then no crossing of its contact function located in the step is a contact
    (:func:`_is_contact` wants the plain gap within CORNER_REACH of the threshold), and its
    search can be skipped with the same result. Such pairs are common: a vertex held on one
    edge is behind the line of the neighbouring edge, whose clipped gap is then the held
    gap, zero to round-off, and its root search bisected that noise (some 30 steps each).
    The bound (:func:`_gap_bounds`) is tried from the step's ends, then from its quarters
    (three more states, remembered by ``step_to`` for every pair of the step).
    """
    _, ceiling, _, g_top = _gap_bounds(seg, step, i, rates, 1, start, end)
    return _behind_from_quarters(seg, step, i, thr, rates, start, end, ceiling, g_top)


@njit_no_refcount
def _behind_from_quarters(
    seg: Segment, step: Step, i: int, thr: float, rates: tuple[float, float], start: Trig,
    end: Trig, ceiling: float, g_top: float,
) -> bool:  # fmt: skip
    """:func:`_far_behind` given the bound from the step's ends (its ``ceiling`` and the
    larger gap at the ends, ``g_top``): decided there, or tried again from the quarters."""
    floor = thr - CORNER_REACH
    if ceiling < floor:
        return True
    if g_top >= floor:
        return False
    _, ceiling, _, _ = _gap_bounds(seg, step, i, rates, 4, start, end)
    return ceiling < floor


@njit_no_refcount
def _far_outside_or_behind(
    seg: Segment, step: Step, i: int, thr: float, rates: tuple[float, float], start: Trig,
    end: Trig,
) -> bool:  # fmt: skip
    """Does pair i's plain gap stay above its threshold all through the trial step (its
    parts turning at most at ``rates``), or is it :func:`_far_behind`? Outside, its contact
    function (the clipped gap, never below the plain one) is positive at every state inside
    the step: sampling it there finds nothing, and :func:`_contacts_inside_step` skips it
    with the same result. One bound over the step's ends serves both screens (computed once
    for each: about 20000 bounds, 40000 pair evaluations, per S 0.5/1 map)."""
    floor, ceiling, _, g_top = _gap_bounds(seg, step, i, rates, 1, start, end)
    if floor > thr:
        return True
    return _behind_from_quarters(seg, step, i, thr, rates, start, end, ceiling, g_top)


@njit_inline
def _contacts_before(
    opts: Options, seg: Segment, step: Step, work: Work, start: Trig, best: Event
) -> Event:
    """A contact that came before the event found, though the trial step's end did not show
    it: a vertex that went in past a corner and out again within the step. At the event's
    state no pair that started outside may be inside; one that is gets located before it.
    """
    thr, g_prev = work.thr, work.g_prev
    pairs, act, n_act, x0 = seg.held.pairs, seg.held.act, seg.held.n_active, seg.held.x0
    cb0, sb0, cm0, sm0 = start
    for _ in range(4):
        if best.kind == E_NONE or best.h <= 0.0:
            return best
        head = Step(step.phi_b, step.phi_m, step.y_m, best.h)
        eb, em, _, _, _ = step_to(seg, step, best.h)
        at_event = (math.cos(eb), math.sin(eb), math.cos(em), math.sin(em))
        rates = (-1.0, -1.0)  # _turn_rates of the head, once a pair needs them
        earliest = best
        early_h = -1.0  # the state two event widths before the event, once a pair needs it
        early = at_event
        t_early = max(best.h - 2.0 * opts.event_tol, 0.0)
        for i in range(pairs.shape[0]):
            if (n_act > 0 and act[0] == i) or (n_act > 1 and act[1] == i) or asleep(work, i):
                continue
            if contact_value(pairs[i], thr[i], at_event, x0, step.y_m - best.h) > -FLAT_GAP:
                continue
            row = pairs[i]
            if g_prev[i] <= thr[i] and (
                clipped_gap(row, g_prev[i], cb0, sb0, cm0, sm0, x0, step.y_m) <= thr[i]
            ):
                continue  # inside at the start already: no crossing in this step
            # Crossed within two event widths before the event: the same moment (contacts
            # closing together, as at a seat), as in _contact_events; the next interval's
            # touching scan picks it up without a search of its own.
            if early_h != best.h:
                early = _trig_after(seg, step, t_early)
                early_h = best.h
            if contact_value(row, thr[i], early, x0, step.y_m - t_early) > 0.0:
                continue
            if rates[0] < 0.0:
                rates = _turn_rates(seg, head, eb, em)
            if _far_behind(seg, head, i, thr[i], rates, (cb0, sb0, cm0, sm0), at_event):
                continue
            _, hk = locate(seg, head, opts.event_tol, E_CONTACT, i, 0, thr[i])
            if hk >= earliest.h:
                continue
            if _is_contact(opts, seg, step, i, hk, thr[i]):
                earliest = Event(E_CONTACT, i, hk)
        if earliest.h == best.h:
            return best
        best = earliest
    return best


@njit_no_refcount
def _reach(row: FloatArray) -> float:
    """Largest distance (D) of the pair's vertex or edge ends from their pivots."""
    return float(row[COL_REACH])


@njit_no_refcount
def _travel(row: FloatArray, h: float, turn: float) -> float:
    """How far (D) the pair's vertex can move relative to its edge in a step of descent
    ``h`` (D) that turns the parts by ``turn`` (rad, both parts together)."""
    return h + turn * _reach(row)


@njit_no_refcount
def _segment_distance(row: FloatArray, g: float, u: float) -> float:
    """Distance (D) of the pair's vertex from its edge (the segment, not the line)."""
    if 0.0 <= u <= 1.0:
        return abs(g)
    along = (u if u < 0.0 else u - 1.0) * row[COL_EDGE_LENGTH]
    return math.sqrt(g * g + along * along)  # as in _gap_bounds: no hypot


@njit_no_refcount
def reach_budget(row: FloatArray, g: float, u: float) -> float:
    """How far (D) the pair's vertex can move relative to its edge, from where its gap is
    ``g`` and its edge parameter ``u``, and still be out of reach: farther than SLEEP_SLACK
    from the edge extended by a quarter of its length at both ends (where a crossing of its
    line is still searched, :func:`_contact_events`), and from within half an edge of its
    start corner (where two corners crossing are looked for, :func:`_crossing`, if this
    pair looks for them: a reflex corner cannot cross, and of the two pairs of each meeting
    of convex corners only one looks, :func:`~.pairs.tests_corner_crossing`; on S 0.5/1 the
    corner's reach alone kept such pairs in the scans 26500 times a map)."""
    length = float(row[COL_EDGE_LENGTH])
    along = 0.0
    if u < -0.25:
        along = (-0.25 - u) * length
    elif u > 1.25:
        along = (u - 1.25) * length
    # The larger leg of each distance, not the distance itself: a bound as safe, and a
    # hypot per pair and step was a tenth of the engine's time.
    to_edge = max(abs(g), along)
    if not tests_corner_crossing(row):
        return float(to_edge - SLEEP_SLACK)
    to_corner = max(abs(u) * length, abs(g)) - 0.52 * length
    return float(min(to_edge, to_corner) - SLEEP_SLACK)


@njit_no_refcount
def asleep(work: Work, i: int) -> bool:
    """Was pair i out of reach all through the trial step being scanned
    (:func:`_contact_events` decides it for the step)?"""
    return bool(work.sleep[i, 1] >= 0.0)


@njit_no_refcount
def wake(pairs: FloatArray, work: Work, pb: float, pm: float, x0: float, ym: float) -> None:
    """Bring every pair's values at the step's start ``(pb, pm, ym)`` up to date and wake
    them all: for the checks that read them for every pair (:func:`~.folds.cuts_in`)."""
    sleep = work.sleep
    trig = (math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm))
    for i in range(pairs.shape[0]):
        _refresh_start(pairs[i], i, work, trig, x0, ym)
        sleep[i, 0], sleep[i, 1] = 0.0, -1.0


@njit_no_refcount
def _refresh_start(row: FloatArray, i: int, work: Work, trig: Trig, x0: float, ym: float) -> None:
    """Pair i's gap and edge parameter at the step's start (``trig``: cos and sin of the
    angles there), if they went stale while it was out of reach."""
    if work.sleep[i, 2] != 0.0:
        cb, sb, cm, sm = trig
        g, u, _, _, _, _, _, _, _ = eval_pair(row, cb, sb, cm, sm, x0, ym)
        work.g_prev[i], work.u_prev[i] = g, u
        work.sleep[i, 2] = 0.0


@njit_no_refcount
def _contacts_inside_step(
    opts: Options,
    seg: Segment,
    step: Step,
    work: Work,
    nb: float,
    nm: float,
    start: Trig,
    end: Trig,
    best: Event,
    n_samples: int,
    n_near: int,
) -> Event:
    """A vertex that goes in past a corner and out again within the step (the contact
    function above its threshold at both ends, below it in between: a base tip cutting off
    a corner of the moving part in one 0.025 D step was seen). Pairs whose vertex comes
    within a step's travel of their edge are sampled at ``k / (n_samples + 1)`` of the step
    (up to the earliest event found); a dip is located like any contact. Only the first
    ``n_near`` pairs of ``work.near`` can (:func:`_contact_events` listed them for the whole
    step: the travel up to an earlier event is shorter)."""
    h_end = step.h if best.kind == E_NONE else best.h
    if h_end <= 4.0 * opts.event_tol:
        return best
    thr, g_prev, u_prev, g_next, u_next, samples = (
        work.thr,
        work.g_prev,
        work.u_prev,
        work.g_next,
        work.u_next,
        work.samples,
    )
    pairs, x0 = seg.held.pairs, seg.held.x0
    turn = abs(nb - step.phi_b) + abs(nm - step.phi_m)
    cb0, sb0, cm0, sm0 = start
    y1 = step.y_m - step.h
    cb1, sb1, cm1, sm1 = end
    sampled = False
    rates = (-1.0, -1.0)  # _turn_rates, once a pair needs them
    near = work.near
    for j in range(n_near):
        i = near[j]
        row = pairs[i]
        if not _within_travel(row, g_prev[i], u_prev[i], g_next[i], u_next[i],
                              _travel(row, h_end, turn)):  # fmt: skip
            continue
        # (The clipped gap is never below the plain one: a plain gap above the threshold
        # spares computing it.)
        if (
            g_next[i] <= thr[i]
            and clipped_gap(row, g_next[i], cb1, sb1, cm1, sm1, x0, y1) <= thr[i]
        ):
            continue  # crossed by the step's end: _contact_events' case
        if g_prev[i] <= thr[i] and (
            clipped_gap(row, g_prev[i], cb0, sb0, cm0, sm0, x0, step.y_m) <= thr[i]
        ):
            continue  # inside at the start already
        if not sampled:
            # The states at the samples, computed once and shared by every pair: on the
            # step's dense output, which only has to show where to look (a dip found there
            # is checked on the integrated path before it is searched).
            for k in range(n_samples):
                sb_k, sm_k = angles_at(seg, step, (k + 1) / (n_samples + 1) * h_end)
                samples[k, 0], samples[k, 1] = sb_k, sm_k
                samples[k, 2], samples[k, 3] = math.cos(sb_k), math.sin(sb_k)
                samples[k, 4], samples[k, 5] = math.cos(sm_k), math.sin(sm_k)
            sampled = True
        screened = False
        for k in range(n_samples):
            t = (k + 1) / (n_samples + 1) * h_end
            at_sample = (samples[k, 2], samples[k, 3], samples[k, 4], samples[k, 5])
            if contact_value(row, thr[i], at_sample, x0, step.y_m - t) > 0.0:
                continue
            # The screen only where a sample dips: it never changes what the samples find
            # (a pair it passes has no contact inside the step), and three samples cost
            # less than one bound.
            if not screened:
                if rates[0] < 0.0:
                    rates = _turn_rates(seg, step, nb, nm)
                if _far_outside_or_behind(seg, step, i, thr[i], rates, start, end):
                    break
                screened = True
            pb_k, pm_k, _, _, _ = step_to(seg, step, t)
            at_sample = (math.cos(pb_k), math.sin(pb_k), math.cos(pm_k), math.sin(pm_k))
            if contact_value(row, thr[i], at_sample, x0, step.y_m - t) > 0.0:
                continue  # a dip of the interpolant only, within the step's error
            head = Step(step.phi_b, step.phi_m, step.y_m, t)
            # The search runs over the head of the step up to this sample: far behind there
            # (screened again over that shorter head), its crossing is no contact.
            head_rates = _turn_rates(seg, head, pb_k, pm_k)
            if _far_behind(seg, head, i, thr[i], head_rates, (cb0, sb0, cm0, sm0), at_sample):
                break
            _, hk = locate(seg, head, opts.event_tol, E_CONTACT, i, 0, thr[i])
            if best.kind != E_NONE and hk >= best.h:
                break
            if _is_contact(opts, seg, step, i, hk, thr[i]):
                best = Event(E_CONTACT, i, hk)
            break
    return best


@njit_inline
def _crossing(
    opts: Options,
    work: Work,
    i: int,
    row: FloatArray,
    g: float,
    u: float,
    x0: float,
    now: tuple[float, float, float, float, float, float, float],
    start: tuple[float, float, float, float, float, float, float],
) -> bool:
    """Do pair i's vertex and the start corner of its edge (``row``) cross like an X in the
    state ``now`` (cos and sin of phi_B and phi_M, y_M, then phi_B and phi_M; the pair's
    gap ``g`` and edge parameter ``u`` there), though they did not at the ``start`` of the
    step?

    :func:`~.pairs.wedges_cross`: no vertex is inside the other part then, so no contact
    function shows it; the vertex that went in and out again on the way did, inside the
    step. That test looks within half an edge of the corner, so |u| <= 1/2 and
    |g| <= half the edge's length: both screen the pair first, and so does the vertex's
    distance from the corner, ``hypot(u * length, g)`` (to 2 % of it: its test takes the
    distance from the world positions, equal to round-off).

    The answer at ``now`` is remembered with its state (``Work.corner_memo``); the next
    step starts there, and its start's answer is taken from the memo instead of computed
    again. A pair of corners that stays crossed (the wedges stand for the parts only near
    the corner, and a short neighbouring edge leaves one inside the other's wedge) was
    tested at both ends of every step: about 18 of the 84 tests a cell of X 1/1 made
    (docs/notes/2026-11-30-where-a-cell-spends-its-cycles.md).
    """
    length2 = (row[5] - row[3]) ** 2 + (row[6] - row[4]) ** 2
    if abs(u) > 0.5 or g * g > 0.25 * length2 or u * u * length2 + g * g > 0.26 * length2:
        return False
    margin = touch_depth(opts.touch_tol)
    memo, rays = work.corner_memo[i], work.rays
    cb0, sb0, cm0, sm0, y0, pb0, pm0 = start
    # Read before the answer at ``now`` takes the memo's place.
    start_known = memo[1] == pb0 and memo[2] == pm0 and memo[3] == y0
    start_crossed = memo[0] == 1.0
    cb, sb, cm, sm, y, pb, pm = now
    crossed_now = wedges_cross(row, cb, sb, cm, sm, x0, y, margin, rays)
    memo[0], memo[1], memo[2], memo[3] = 1.0 if crossed_now else 0.0, pb, pm, y
    if not crossed_now:
        return False
    if start_known:
        return not start_crossed
    return not wedges_cross(row, cb0, sb0, cm0, sm0, x0, y0, margin, rays)


@njit_inline
def _crossed_at_event(opts: Options, seg: Segment, step: Step, work: Work, nb: float,
                      nm: float, start: Trig, best: Event) -> bool:  # fmt: skip
    """:func:`_crossing` at the state of the earliest event found (the step's end has it
    from :func:`_contact_events`)."""
    eb, em, _, _, _ = step_to(seg, step, best.h)
    ey = step.y_m - best.h
    pairs, x0, u_prev, u_next = seg.held.pairs, seg.held.x0, work.u_prev, work.u_next
    now = (math.cos(eb), math.sin(eb), math.cos(em), math.sin(em), ey, eb, em)
    at_start = (start[0], start[1], start[2], start[3], step.y_m, step.phi_b, step.phi_m)
    turn = abs(nb - step.phi_b) + abs(nm - step.phi_m)
    for i in range(pairs.shape[0]):
        if asleep(work, i):
            continue
        row = pairs[i]
        # Only a pair with u near the corner at either end of the step can have it there
        # at the event (twice the vertex's travel relative to the edge bounds the change of
        # u times the edge's length).
        travel = 2.0 * _travel(row, best.h, turn)
        if min(abs(u_prev[i]), abs(u_next[i])) - 0.5 > travel / row[COL_EDGE_LENGTH]:
            continue
        g, u, _, _, _, _, _, _, _ = eval_pair(row, now[0], now[1], now[2], now[3], x0, ey)
        if _crossing(opts, work, i, row, g, u, x0, now, at_start):
            return True
    return False


@njit_inline
def find_event(opts: Options, seg: Segment, step: Step, work: Work, nb: float, nm: float) -> Event:
    """The earliest event in the trial step that ends at ``(nb, nm)``, or ``NO_EVENT``."""
    # The trigonometry of the step's two ends, once for every source (each computed it
    # again; libm's sincos is about a sixth of the kernel's time,
    # docs/notes/2026-11-23-pymunk-whole-map.md).
    start, end = _trig(step.phi_b, step.phi_m), _trig(nb, nm)
    best = _active_events(opts, seg, step, nb, nm, end, NO_EVENT)
    if opts.friction > 0.0:
        best = _slip_events(opts, seg, step, nb, nm, best)
    best, crossed, n_near = _contact_events(opts, seg, step, work, nb, nm, start, end, best)
    best = _contacts_inside_step(
        opts, seg, step, work, nb, nm, start, end, best, COARSE_SAMPLES, n_near
    )
    best = _contacts_before(opts, seg, step, work, start, best)
    if best.kind != E_NONE:
        crossed = _crossed_at_event(opts, seg, step, work, nb, nm, start, best)
    if crossed:
        # Two corners cross like an X where the step ends: a vertex went in and out again
        # in a sliver of the step that the coarse samples missed.
        best = _contacts_inside_step(
            opts, seg, step, work, nb, nm, start, end, best, FINE_SAMPLES, n_near
        )
    y1 = step.y_m - step.h
    if y1 < seg.y_floor:
        # y_M falls linearly with the descent: the crossing is known exactly.
        best = earlier(Event(E_BELOW_SEAT, -1, step.y_m - seg.y_floor), best)
    if max(abs(nb), abs(nm)) > math.pi:
        _, hk = locate(seg, step, opts.event_tol, E_SPUN, -1, 0, 0.0)
        best = earlier(Event(E_SPUN, -1, hk), best)
    return best
