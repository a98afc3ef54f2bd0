"""segment.py: the start of a smooth segment, the trial step and the accepted step."""

from __future__ import annotations

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.pairs import COL_EDGE_LENGTH, COL_REACH
from xface_core._engine.records import (
    E_CONTACT,
    MAX_TURN,
    P_ALIGN,
    RUN_DTYPE,
    STEP_CAP_FLOOR,
    UNDECIDED,
    Model,
    Step,
    make_options,
    new_work,
)
from xface_core._engine.scan import asleep, find_event, reach_budget
from xface_core._engine.segment import (
    LOOP_EVENT,
    _shrink,
    accept_step,
    begin_segment,
    next_length,
    step_cap,
    steps_to_event,
    trial_step,
)
from xface_core.physics import Physics
from xface_core.runner import engine_model

OPTS = make_options(Physics(damping_ratio=np.inf))  # the incline's base is held


def _model(incline) -> Model:
    no_edges = np.zeros((0, 5))
    return Model(incline.table, no_edges, no_edges, 2.5)


def _run(incline, pm: float, ym: float) -> np.ndarray:
    runs = np.zeros(1, dtype=RUN_DTYPE)
    r = runs[0]
    r["phi_m"], r["y_m"], r["x0"], r["n_active"], r["h"] = pm, ym, incline.x0, 1, 0.01
    r["y_floor"] = -np.inf
    return runs


def _begin(incline, pm: float, ym: float):
    model = _model(incline)
    runs = _run(incline, pm, ym)
    work = new_work(model, OPTS)
    work.act[0] = 0
    path, pairs = np.zeros((4, 4)), np.zeros((4, 4), dtype=np.int64)
    seg = begin_segment(model, OPTS, runs[0], work, path, pairs)
    return seg, runs, work, path, pairs


def test_begin_segment_starts_exactly_on_the_contact(incline) -> None:
    # Off the constraint by ~1e-9 (an event's leftover): projected back onto it.
    seg, runs, _, path, _ = _begin(incline, incline.phi_m0 + 1e-9, incline.y0)
    r = runs[0]
    assert abs(incline.gap(0, r["phi_m"], r["y_m"])) <= 1e-15
    assert (seg.held.n_active, seg.held.act[0], seg.held.x0) == (1, 0, incline.x0)
    assert path[0].tolist() == [r["y_m"], 0.0, r["phi_m"], P_ALIGN]


def test_begin_segment_sets_the_thresholds_of_new_contacts(incline) -> None:
    # At s_touch pair 1 touches too (gap ~ 0): it counts as new only once it closes past
    # the touching tolerance; pair 0's threshold likewise; clear pairs count at zero.
    ym = incline.y0 - incline.s_touch
    _, _, work, _, _ = _begin(incline, incline.phi_m_at(incline.s_touch), ym)
    tt = OPTS.touch_tol
    for i in range(2):
        assert abs(work.g_prev[i]) <= tt
        assert work.thr[i] == min(work.g_prev[i], 0.0) - tt
    _, _, work, _, _ = _begin(incline, incline.phi_m0, incline.y0)
    assert work.g_prev[1] > tt
    assert work.thr[1] == 0.0


def test_begin_segment_gives_every_pair_its_reach_budget(incline) -> None:
    # Every pair was evaluated at the segment's start: each sleeps by its own budget from
    # there (a pair clear of its edge need not be evaluated in the first step), and none is
    # stale or marked asleep before a step is scanned.
    _, _, work, _, _ = _begin(incline, incline.phi_m0, incline.y0)
    for i in range(len(incline.table)):
        budget = reach_budget(incline.table[i], work.g_prev[i], work.u_prev[i])
        assert work.sleep[i].tolist() == [budget, -1.0, 0.0]
    assert work.sleep[1, 0] > 0.0  # the incline's second pair starts clear of its edge


def _begin_after_an_event(incline, budget: float):
    # Off the constraint by 1e-9 (an event's leftover): the projection turns the part by that.
    model = _model(incline)
    runs = _run(incline, incline.phi_m0 + 1e-9, incline.y0)
    work = new_work(model, OPTS)
    work.act[0] = 0
    work.sleep[1] = (budget, 0.01, 0.0)  # pair 1 asleep through the event's step
    work.g_prev[1] = 123.0  # its value then, kept while it sleeps
    work.sleep_holds[0] = 1
    path, pairs = np.zeros((4, 4)), np.zeros((4, 4), dtype=np.int64)
    begin_segment(model, OPTS, runs[0], work, path, pairs)
    return work


def test_a_pair_asleep_through_the_events_step_keeps_its_budget(incline) -> None:
    work = _begin_after_an_event(incline, 0.3)
    turn_reach = 1e-9 * incline.table[1, COL_REACH]
    assert work.sleep[1].tolist() == pytest.approx([0.3 - turn_reach, -1.0, 1.0], abs=1e-15)
    assert work.g_prev[1] == 123.0  # not evaluated: stale until it wakes
    assert work.thr[1] == 0.0
    assert work.sleep_holds[0] == 0


def test_a_pair_whose_budget_the_projection_spends_is_evaluated(incline) -> None:
    work = _begin_after_an_event(incline, 1e-12)
    assert work.sleep[1, 2] == 0.0
    assert work.g_prev[1] != 123.0
    assert work.sleep[1, 0] == reach_budget(incline.table[1], work.g_prev[1], work.u_prev[1])


def test_a_pair_clear_of_its_edge_sleeps_through_the_first_step(incline) -> None:
    seg, runs, work, _, _ = _begin(incline, incline.phi_m0, incline.y0)
    budget = work.sleep[1, 0]
    r = runs[0]
    r["h"] = 1e-4  # a step far shorter than pair 1's distance from its edge
    step = Step(r["phi_b"], r["phi_m"], r["y_m"], r["h"])
    nb, nm, _, _, ok = trial_step(OPTS, seg, step)
    assert ok
    find_event(OPTS, seg, step, work, nb, nm)
    assert asleep(work, 1)
    assert 0.0 < work.sleep[1, 0] < budget  # its budget spent by the step's travel


def test_a_short_trial_step_is_accepted_with_its_turn(incline) -> None:
    seg, *_ = _begin(incline, incline.phi_m0, incline.y0)
    nb, nm, err, turn, ok = trial_step(OPTS, seg, incline.step(0.005))
    assert ok
    assert err <= 1.0
    assert nb == 0.0
    assert nm == pytest.approx(incline.phi_m_at(0.005), abs=1e-14)
    assert turn == abs(nm - incline.phi_m0)


def test_a_trial_step_turning_more_than_the_cap_is_rejected(incline) -> None:
    # dphi_M/ds ~ -1.3 here: 0.05 D of descent would turn the part by ~0.06 rad.
    seg, *_ = _begin(incline, incline.phi_m0, incline.y0)
    _, _, err, turn, ok = trial_step(OPTS, seg, incline.step(0.05))
    assert turn > MAX_TURN
    assert (err, ok) == (np.inf, False)


def test_accept_step_moves_the_run_and_sets_the_next_length(incline) -> None:
    seg, runs, work, path, pairs = _begin(incline, incline.phi_m0, incline.y0)
    r = runs[0]
    h = r["h"]
    nb, nm, _, _, ok = trial_step(OPTS, seg, incline.step(h))
    assert ok
    work.g_next[:] = [0.5, 0.25]
    accept_step(r, work, nb, nm, 0.0123, path, pairs)
    assert (r["phi_b"], r["phi_m"], r["y_m"], r["steps"]) == (nb, nm, incline.y0 - h, 1)
    assert work.g_prev.tolist() == [0.5, 0.25]
    assert r["h"] == 0.0123


def test_next_length_grows_by_the_error_within_the_turn_cap() -> None:
    h, turn = 1e-3, 1e-4
    assert next_length(h, 0.01, turn, 0.0, 0.0, False) == pytest.approx(h * 0.9 * 0.01**-0.2)
    assert next_length(h, 0.0, turn, 0.0, 0.0, False) == pytest.approx(5.0 * h)
    assert next_length(h, 0.0, 0.5 * MAX_TURN, 0.0, 0.0, False) == pytest.approx(1.8 * h)


def test_next_length_follows_a_shrinking_trend() -> None:
    # The last two accepted steps shrank by 0.7 at the same error: the predictive controller
    # shrinks again where the elementary one (0.9 * 0.2**-0.2 = 1.25) would grow.
    h = 1e-4
    assert next_length(h, 0.2, 1e-4, h / 0.7, 0.2, False) == pytest.approx(
        h * 0.9 * 0.2**-0.2 * 0.7
    )


def test_next_length_right_after_a_rejection_is_not_longer() -> None:
    assert next_length(1e-3, 0.01, 1e-4, 0.0, 0.0, True) == 1e-3


def test_shrink_after_the_turn_cap_aims_just_under_the_cap() -> None:
    h = 1e-2
    assert _shrink(OPTS, h, np.inf, 1.01 * MAX_TURN, False) == pytest.approx(h * 0.9 / 1.01)
    assert _shrink(OPTS, h, np.inf, 10.0 * MAX_TURN, False) == h * 0.25  # at least a quarter


def test_shrink_after_a_failed_step_is_a_quarter() -> None:
    assert _shrink(OPTS, 1e-2, np.inf, 0.0, False) == 1e-2 * 0.25


def test_shrink_by_the_error_estimate() -> None:
    assert _shrink(OPTS, 1e-2, 32.0, 1e-3, True) == pytest.approx(1e-2 * 0.9 / 2.0)
    assert _shrink(OPTS, 1e-2, 1e9, 1e-3, True) == pytest.approx(1e-2 * 0.2)


def test_the_step_loop_stops_at_the_first_event_with_the_steps_before_it_taken(incline) -> None:
    # The incline's second vertex touches the flat edge at the descent s_touch: the loop
    # accepts the steps before it and hands back the trial step that holds it.
    seg, runs, work, path, pairs = _begin(incline, incline.phi_m0, incline.y0)
    r = runs[0]
    r["outcome"] = UNDECIDED
    stop, step, ev = steps_to_event(OPTS, seg, r, work, path, pairs)
    assert (stop, ev.kind, ev.pair) == (LOOP_EVENT, E_CONTACT, 1)
    assert r["steps"] >= 1
    assert step.y_m == r["y_m"]  # the run stands at the trial step's start
    touch = incline.y0 - step.y_m + ev.h
    assert touch == pytest.approx(incline.s_touch, abs=2 * OPTS.event_tol)


def test_a_frictional_release_at_a_fold_chooses_again_and_both_mirror_runs_seat() -> None:
    # X H/D 2.1225, r_p 0.0721, damping ratio 1.29e-3, mu 0.42 from x0 = D, theta0 = -pi/6:
    # the sliding contact's force changes sign within 1.9e-9 D of a fold of its path, which the
    # step to the release cannot cross. Ended there as a turning point it was BAD_MATE, while
    # the mirror run, 3e-9 D apart, reached the fold by a slip event, chose again and seated;
    # Chipmunk2D seats from both (steps 1e-3 to 6.25e-5 D, phi -0.4569 rad at y_M 2.034 D).
    design = xf.x_face(2.122466788111405, 0.07211328716946366)
    physics = Physics(damping_ratio=0.0012909326288174934, friction=0.42177297426967)
    runs = [xf.predict(design, s, -s * np.pi / 6, physics=physics, margins=False) for s in (1, -1)]
    assert [p.outcome for p in runs] == [xf.Outcome.SEATED, xf.Outcome.SEATED]
    assert runs[0].phi_m == pytest.approx(-runs[1].phi_m, abs=1e-6)
    assert runs[0].phi_m == pytest.approx(-0.4569, abs=1e-3)


#: S H/D 0.5, r_p 1 from x0 = 0.9 D, theta0 = -7 pi / 40: a second contact arrives just past
#: a fold of the two-contact path (the constraints' determinant 1.6e-4, growing along the
#: descent), which goes on at about 1e4 rad per D and slows.
PAST_A_FOLD = (xf.s_face(0.5, 1.0), 0.9, -7 * np.pi / 40)


@pytest.mark.parametrize("rtol", [1e-11, 1e-12])
def test_a_path_just_past_a_fold_goes_on_at_tight_tolerances(rtol: float) -> None:
    # There the solved angles are known only to about 1e-11 rad: at rtol 1e-11 and below every
    # trial length failed, and the run ended as a jam at (-0.0971, -0.6196) where the path
    # goes on, as it does at the default tolerances and in Chipmunk2D at 1/100 and 1/1000 of
    # the default stall speed (below the seat height at phi 0.136, -0.969 rad).
    design, x0, theta0 = PAST_A_FOLD
    default = xf.predict(design, x0, theta0, margins=False)
    settings = xf.SolverSettings(rtol=rtol, atol=rtol * 1e-2, event_tol=1e-15)
    tight = xf.predict(design, x0, theta0, settings=settings, margins=False)
    assert default.reason == xf.Reason.BELOW_SEAT.text
    assert tight.reason == default.reason
    assert (tight.phi_b, tight.phi_m) == pytest.approx((default.phi_b, default.phi_m), abs=1e-6)


def test_a_fold_ahead_still_ends_as_a_jam_at_tight_tolerances() -> None:
    # S H/D 1, r_p 0 from x0 = -D, theta0 = -pi/4: the two contacts turn towards a fold, where
    # the rate grows without bound; the trial lengths collapse there and the run is jammed.
    settings = xf.SolverSettings(rtol=1e-12, atol=1e-14, event_tol=1e-15)
    design = xf.s_face(1.0, 0.0)
    p = xf.predict(design, -design.width, -np.pi / 4, settings=settings, margins=False)
    assert p.outcome is xf.Outcome.BAD_MATE
    assert p.reason == xf.Reason.SINGULAR.text


#: V H/D 0.98, r_p 0, mu 0.46 from x0 = -0.494 D, theta0 = 0.706 (issue 37's probe, run 9): a
#: single contact whose force sits on its friction cone while a very light base turns fast.
LIGHT_BASE = xf.v_face(0.9822283062413161, 0.0, width=12.800598349870178)
LIGHT_BASE_POSE = (-0.4943404346891451 * 12.800598349870178, 0.7059746373216553)
LIGHT_BASE_MU = 0.4589249111199053


def test_a_light_base_sticks_where_its_slide_slips_backwards_at_once() -> None:
    # At damping ratio 1e-3 the slide chosen a short move ahead slipped backwards on the
    # segment's path at once; choosing it again, the run stood still until the event budget
    # (UNRESOLVED). Sticking there is consistent (two_contact_coulomb.py's enumeration), and
    # Chipmunk2D seats at phi 0.5274 rad at steps 1e-4, 5e-5 and 2.5e-5 D.
    physics = Physics(damping_ratio=1e-3, friction=LIGHT_BASE_MU)
    p = xf.predict(LIGHT_BASE, *LIGHT_BASE_POSE, physics=physics, margins=False)
    assert p.outcome is xf.Outcome.SEATED
    assert p.phi_m == pytest.approx(0.5274, abs=1e-3)


def test_a_lone_slide_whose_rate_runs_away_chooses_again_and_both_mirror_runs_seat() -> None:
    # At damping ratio 1e-4 the slide's slip turns over so fast that one run's trial length
    # collapsed before its slip event was bracketed (ended BAD_MATE as a turning point) while
    # its mirror run bracketed it, chose to stick and seated. Both now seat, mirrored.
    physics = Physics(damping_ratio=1e-4, friction=LIGHT_BASE_MU)
    x0, theta0 = LIGHT_BASE_POSE
    runs = [
        xf.predict(LIGHT_BASE, s * x0, s * theta0, physics=physics, margins=False) for s in (1, -1)
    ]
    assert [p.outcome for p in runs] == [xf.Outcome.SEATED, xf.Outcome.SEATED]
    assert runs[0].phi_m == pytest.approx(-runs[1].phi_m, abs=1e-6)


def _pairs_with_shortest_edge(length: float) -> np.ndarray:
    pairs = engine_model(xf.x_face(1.0, 1.0)).pairs.copy()
    pairs[:, COL_EDGE_LENGTH] = np.maximum(pairs[:, COL_EDGE_LENGTH], length)
    pairs[3, COL_EDGE_LENGTH] = length
    return pairs


@pytest.mark.parametrize(("shortest", "max_step", "cap"), [
    (0.3, 0.25, 0.15),  # half the shortest edge
    (1.0, 0.25, 0.25),  # the settings' bound
    (0.04, 0.25, STEP_CAP_FLOOR),  # finer features: never below the floor ...
    (0.04, 0.01, 0.01),  # ... unless the settings ask for less
])  # fmt: skip
def test_the_step_cap_is_half_the_shortest_edge_within_its_bounds(
    shortest: float, max_step: float, cap: float
) -> None:
    assert step_cap(_pairs_with_shortest_edge(shortest), max_step) == pytest.approx(cap)


def test_no_step_of_a_run_descends_further_than_the_cap() -> None:
    # S 0.5/1: shortest edge 0.4167 D, so no step in contact is longer than 0.208 D; this
    # pose's slide takes steps longer than the floor (0.13 D).
    design = xf.s_face(0.5, 1.0)
    cap = step_cap(engine_model(design).pairs, Physics().settings.max_step)
    assert cap == pytest.approx(0.5 * 0.4167, abs=1e-4)
    path = xf.predict(design, -1.0 * design.width, 0.1 * np.pi).path
    assert path is not None
    in_contact = path.phase[1:] > 0  # the approach before is exact, not stepped
    steps = np.diff(path.descent)[in_contact] / design.width
    assert steps.max() <= cap * (1 + 1e-12)
    assert steps.max() > STEP_CAP_FLOOR
