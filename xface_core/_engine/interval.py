"""Stages between smooth segments: the run's start, the choice of contacts and motion at the
start of an interval, and the exact approach to the next contact when nothing touches."""

from __future__ import annotations

import math

from .ends import Run, end_at_rest, end_run, is_seated, record
from .motion import choose_motion, friction_modes, rate_keeps_contacts, velocity
from .overlap import overlapping
from .pairs import eval_all_pairs, eval_pair, fill_u_rate, next_contact, touching_pairs
from .records import (
    O_BAD_MATE,
    O_INVALID,
    O_NO_CONTACT,
    O_OUT_OF_REACH,
    O_PASSED,
    O_SEATED,
    O_UNRESOLVED,
    P_APPROACH,
    PUSH_SLACK,
    R_BELOW_SEAT,
    R_EVENT_LIMIT,
    R_FRICTION_LOCK,
    R_JAMMED,
    R_NO_CONTACT,
    R_NONFINITE,
    R_OUT_OF_REACH,
    R_OVERLAP,
    R_PASSED,
    R_SEATED,
    UNDECIDED,
    FloatArray,
    IntArray,
    Model,
    Options,
    Work,
    held_contacts,
    njit_no_refcount,
)
from .scan import asleep

#: Status of the motion chosen at an interval's start.
MOVES = 0
BLOCKED = 1

#: Touching tolerances a start is lifted by before it counts as interpenetrating (the
#: touching window of the contact search reaches 4 below a contact).
START_LIFT = 4.0


@njit_no_refcount
def start_run(
    model: Model,
    opts: Options,
    x0: float,
    theta0: float,
    y_start: float,
    run: Run,
    work: Work,
    path: FloatArray,
    path_pairs: IntArray,
) -> None:
    """Reset the run to the start pose and end it at once if the pose cannot dock
    (non-finite, out of reach, interpenetrating)."""
    run.outcome = UNDECIDED
    run.reason = -1
    run.phi_b = 0.0
    run.phi_m = theta0
    run.y_m = y_start
    run.x0 = x0
    run.steps = 0
    run.events = 0
    run.contact_changes = 0
    run.rejected_steps = 0
    run.n_samples = 0
    run.n_active = 0
    run.n_excluded = 0
    run.had_contact = False
    run.h = opts.first_step
    run.y_floor = 0.0
    L = model.mated_distance
    if not (
        math.isfinite(x0) and math.isfinite(theta0) and math.isfinite(y_start) and math.isfinite(L)
    ):
        run.outcome = O_INVALID
        run.reason = R_NONFINITE
    elif abs(x0) > L:
        end_run(run, path, path_pairs, work.act, O_OUT_OF_REACH, R_OUT_OF_REACH, False)
    elif overlapping(
        model.base_edges, model.moving_edges, 0.0, theta0, x0,
        y_start + START_LIFT * opts.touch_tol, work.world_b, work.world_m,
    ):  # fmt: skip
        # Overlapping even when lifted by a few touching tolerances: a real interpenetration,
        # not a start exactly at contact (whose rounding may put a vertex 1e-16 D inside).
        end_run(run, path, path_pairs, work.act, O_INVALID, R_OVERLAP, False)
    else:
        run.y_floor = math.sqrt(L * L - x0 * x0) - opts.seat_tol * max(1.0, L)
        record(run, path, path_pairs, P_APPROACH, work.act, 0)


@njit_no_refcount
def _both_push(l1: float, l2: float) -> bool:
    """Both contact forces compressive, to PUSH_SLACK of the larger one. On a flush edge (two
    contacts, one normal) friction can leave one end's force at about -1e-4 of the other's
    (S H/D 12.4, r_p 0, mu 0.66): released, that end is closed again by the one-contact
    rate within 1e-4 D, over and over (400 events), where holding it is the sliding limit
    the engine shows (it seats)."""
    return min(l1, l2) >= -PUSH_SLACK * max(abs(l1), abs(l2))


@njit_no_refcount
def _with_friction(
    model: Model, opts: Options, run: Run, work: Work, nc: int, n_new: int, v0b: float,
    v0m: float,
) -> tuple[bool, int, float, float]:  # fmt: skip
    """The active set and friction states under Coulomb friction, from the frictionless
    choice (``n_new`` contacts in ``work.act``, rate ``(v0b, v0m)``).

    Friction turns the rate away from the frictionless one, so it must be checked again:
    every active contact pushes (lambda >= 0) and slips the way its state says, and no
    other touching pair (corners by the wedge test) is cut into. One contact: its
    consistent slip state (sliding either way, else stuck), alone if that keeps every
    other pair, else together with each touching pair in turn (two contacts fix the rate).
    Two contacts: the frictionless pair if both push, else each alone. When no set is
    consistent the parts are locked by friction: returns ``(False, ...)``.
    Returns ``(consistent, n_active, v_b, v_m)``.
    """
    pb, pm, x0, ym = run.phi_b, run.phi_m, run.x0, run.y_m
    table, act, ev, cand, rays = model.pairs, work.act, work.ev, work.cand, work.rays
    two = held_contacts(model, opts, work, 2, opts.friction, x0)
    if n_new == 2:
        friction_modes(two, pb, pm, ym, v0b, v0m)
        vb, vm, l1, l2 = velocity(two, pb, pm, ym)
        if math.isfinite(vb + vm) and _both_push(l1, l2):
            return True, 2, v0b, v0m
        # One contact pulls under friction: try each alone.
        first, second = act[0], act[1]
        for keep in (first, second):
            act[0], act[1] = keep, -1
            keeps, fb, fm = _one_consistent(model, opts, run, work, nc, v0b, v0m)
            if keeps:
                return True, 1, fb, fm
        act[0], act[1] = first, second
        return False, 2, v0b, v0m
    ok, fb, fm = _one_contact_rate(model, opts, run, work, v0b, v0m)
    if not ok:
        return False, 1, v0b, v0m
    if rate_keeps_contacts(table, ev, cand, nc, act, 1, pb, pm, x0, ym, fb, fm, rays):
        return True, 1, v0b, v0m
    # The frictional rate cuts into a touching pair: hold one more (the deepest cut first
    # would be a heuristic; any consistent pair is an admissible quasi-static motion, and
    # the candidates come in a fixed order, so the choice is deterministic).
    for k in range(nc):
        j = cand[k]
        if j == act[0]:
            continue
        act[1] = j
        friction_modes(two, pb, pm, ym, fb, fm)
        vb, vm, l1, l2 = velocity(two, pb, pm, ym)
        if not (math.isfinite(vb + vm) and _both_push(l1, l2)):
            continue
        if rate_keeps_contacts(table, ev, cand, nc, act, 2, pb, pm, x0, ym, vb, vm, rays):
            return True, 2, vb, vm
    act[1] = -1
    return False, 1, v0b, v0m


@njit_no_refcount
def _one_contact_rate(
    model: Model, opts: Options, run: Run, work: Work, v0b: float, v0m: float
) -> tuple[bool, float, float]:
    """The slip state of the one contact ``work.act[0]`` (``work.slip``) and its frictional
    rate ``(ok, v_b, v_m)``; ok is False when no slip state is consistent."""
    one = held_contacts(model, opts, work, 1, opts.friction, run.x0)
    if not friction_modes(one, run.phi_b, run.phi_m, run.y_m, v0b, v0m):
        return False, 0.0, 0.0
    fb, fm, _, _ = velocity(one, run.phi_b, run.phi_m, run.y_m)
    return True, fb, fm


@njit_no_refcount
def _one_consistent(
    model: Model, opts: Options, run: Run, work: Work, nc: int, v0b: float, v0m: float
) -> tuple[bool, float, float]:
    """Is the one contact ``work.act[0]`` consistent under friction (a slip state that
    pushes and slips its way, and a rate that cuts into no other touching pair)? Returns
    ``(consistent, v_b, v_m)`` with its frictional rate."""
    ok, fb, fm = _one_contact_rate(model, opts, run, work, v0b, v0m)
    keeps = ok and rate_keeps_contacts(
        model.pairs, work.ev, work.cand, nc, work.act, 1, run.phi_b, run.phi_m, run.x0,
        run.y_m, fb, fm, work.rays,
    )  # fmt: skip
    return keeps, fb, fm


@njit_no_refcount
def _choose(model: Model, opts: Options, run: Run, work: Work) -> tuple[int, int, bool]:
    """The touching pairs, the least-dissipation motion and, with friction, the consistent
    active set: ``(status, n_active, consistent)`` (work.act, work.slip set)."""
    pb, pm, x0, ym = run.phi_b, run.phi_m, run.x0, run.y_m
    nc = touching_pairs(
        model.pairs, work.ev, pb, pm, x0, ym, opts.touch_tol, work.exclude, run.n_excluded,
        work.cand,
    )  # fmt: skip
    sqb, sqm = opts.sqrt_winv_b, opts.sqrt_winv_m
    status, n_new, v0b, v0m = choose_motion(
        model.pairs, work.ev, work.cand, nc, pb, pm, x0, ym, sqb, sqm, work.act, work.choice,
        work.trial, work.rays,
    )  # fmt: skip
    consistent = True
    if status == MOVES and n_new > 0 and opts.friction > 0.0:
        consistent, n_new, _, _ = _with_friction(model, opts, run, work, nc, n_new, v0b, v0m)
    return status, n_new, consistent


@njit_no_refcount
def _keeps_excluded(model: Model, opts: Options, run: Run, work: Work, n_new: int) -> bool:
    """Does the chosen motion (its rate with friction) keep clear of the excluded pairs?"""
    pb, pm, x0, ym = run.phi_b, run.phi_m, run.x0, run.y_m
    vb, vm = 0.0, 0.0
    if n_new > 0:
        held = held_contacts(model, opts, work, n_new, opts.friction, x0)
        vb, vm, _, _ = velocity(held, pb, pm, ym)
    return rate_keeps_contacts(
        model.pairs, work.ev, work.exclude, run.n_excluded, work.act, n_new, pb, pm, x0, ym,
        vb, vm, work.rays,
    )  # fmt: skip


@njit_no_refcount
def _excluded_in_reach(run: Run, work: Work) -> bool:
    """Were the excluded pairs (the motion choice checks the rate against them) evaluated in
    the step the last event was found in?"""
    for k in range(run.n_excluded):  # noqa: SIM110 (numba compiles no generators)
        if asleep(work, work.exclude[k]):
            return False
    return True


@njit_no_refcount
def _eval_pairs_in_reach(
    table: FloatArray, pb: float, pm: float, x0: float, ym: float, work: Work
) -> None:
    """:func:`~.pairs.eval_all_pairs` for the pairs evaluated in the step the last event was
    found in. The others were out of reach all through that step, the event's state
    included (farther than ``SLEEP_SLACK`` from their edge, a thousand times the touching
    window): marked with an infinite gap, they are no contact candidates. About 45 of the
    72 pairs of S 0.5/1 at every event."""
    cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
    ev = work.ev
    for i in range(table.shape[0]):
        if asleep(work, i):
            ev[i, 0], ev[i, 1], ev[i, 2], ev[i, 3], ev[i, 4] = math.inf, 0.5, 0.0, 0.0, 0.0
            continue
        g, u, ab, am, be, _, _, _, _ = eval_pair(table[i], cb, sb, cm, sm, x0, ym)
        ev[i, 0], ev[i, 1], ev[i, 2], ev[i, 3], ev[i, 4] = g, u, ab, am, be


@njit_no_refcount
def begin_interval(
    model: Model, opts: Options, run: Run, work: Work, path: FloatArray, path_pairs: IntArray
) -> None:
    """Which contacts act from here, and how do the parts move? Sets ``run.n_active`` and
    ``work.act`` (and the friction states), or ends the run (budget, seated, blocked)."""
    L = model.mated_distance
    if run.events >= opts.max_events:
        end_run(run, path, path_pairs, work.act, O_UNRESOLVED, R_EVENT_LIMIT, True)
        return
    pb, pm, x0, ym = run.phi_b, run.phi_m, run.x0, run.y_m
    if run.had_contact and is_seated(pb, pm, x0, ym, L, opts.seat_tol):
        # At the mated pose (to the seat tolerance) nothing is left to decide; going on
        # would only follow round-off around the seat's corners.
        end_run(run, path, path_pairs, work.act, O_SEATED, R_SEATED, False)
        return
    if work.sleep_holds[0] == 1 and _excluded_in_reach(run, work):
        _eval_pairs_in_reach(model.pairs, pb, pm, x0, ym, work)
    else:
        eval_all_pairs(model.pairs, pb, pm, x0, ym, work.ev)
        work.sleep_holds[0] = 0
    status, n_new, consistent = _choose(model, opts, run, work)
    if (
        status == MOVES
        and consistent
        and run.n_excluded > 0
        and not _keeps_excluded(model, opts, run, work, n_new)
    ):
        # A pair released or slid off here is kept out so that contacts at a corner cannot
        # cycle; but a motion that cuts into it is no motion: choose again with it.
        run.n_excluded = 0
        status, n_new, consistent = _choose(model, opts, run, work)
    if not consistent:
        # Friction locks the contact: no admissible slip state lets the parts descend.
        end_at_rest(run, path, path_pairs, work.act, L, opts.seat_tol, R_FRICTION_LOCK, False)
        return
    if status == BLOCKED:
        # No descent is possible any more.
        end_at_rest(run, path, path_pairs, work.act, L, opts.seat_tol, R_JAMMED, False)
        return
    if n_new != run.n_active:
        run.contact_changes += 1
    run.n_active = n_new


@njit_no_refcount
def approach(
    model: Model, opts: Options, run: Run, work: Work, path: FloatArray, path_pairs: IntArray
) -> None:
    """Nothing touches: translate along -y, angles frozen, exactly to the next contact (or
    end: passed, never touched, or below the seat).

    Runs right after :func:`begin_interval` found no contact, on the pair values
    (``work.ev`` columns 0-4) it evaluated at this state.
    """
    if work.sleep_holds[0] == 1:
        # Every pair's translation to its contact is needed, and the move may be long.
        eval_all_pairs(model.pairs, run.phi_b, run.phi_m, run.x0, run.y_m, work.ev)
        work.sleep_holds[0] = 0
    fill_u_rate(model.pairs, run.phi_b, run.phi_m, work.ev)
    d, _ = next_contact(work.ev, opts.touch_tol)
    if not math.isfinite(d):
        if run.had_contact:
            end_run(run, path, path_pairs, work.act, O_PASSED, R_PASSED, False)
        else:
            end_run(run, path, path_pairs, work.act, O_NO_CONTACT, R_NO_CONTACT, False)
        return
    if run.y_m - d < run.y_floor:
        # Stop at the seat height, or where the pivot already is if it started below it (a
        # start below the seat height cannot seat: the pivot only descends).
        run.y_m = min(run.y_m, run.y_floor)
        end_run(run, path, path_pairs, work.act, O_BAD_MATE, R_BELOW_SEAT, False)
        return
    run.y_m -= d
    if d > 1e-7:
        run.n_excluded = 0
    run.events += 1
    run.had_contact = True
    record(run, path, path_pairs, P_APPROACH, work.act, 0)
