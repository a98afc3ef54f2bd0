"""motion.py: the least-dissipation QP, the rate with friction, slip states, corners.

``ev`` rows are (gap, u, dg/dphi_B, dg/dphi_M, beta, du/dd); the QP works in the scaled
variables of W^(-1/2) = diag(sqb, sqm), so a rate is v = W^-1 (sum lambda_i a_i).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core._engine.motion import (
    LOOKAHEAD_CUT,
    _tie_goes_to_trial,
    choose_motion,
    friction_modes,
    solve_qp,
    tangent,
    velocity,
)
from xface_core._engine.pairs import (
    COL_EDGE_LENGTH,
    PAIR_COLUMNS,
    eval_all_pairs,
    fill_extents,
    pair_at,
)
from xface_core._engine.records import (
    FREE,
    SLIDE_NEGATIVE,
    SLIDE_POSITIVE,
    STICK,
)
from xface_core.contact import pair_table

TOL = 1e-9


def _ev(*constraints: tuple[float, float, float]) -> np.ndarray:
    """ev rows of touching contacts inside their edges from (a_b, a_m, beta)."""
    ev = np.zeros((len(constraints), 6))
    for k, (a_b, a_m, beta) in enumerate(constraints):
        ev[k] = (0.0, 0.5, a_b, a_m, beta, 0.0)
    return ev


def _qp(ev: np.ndarray, sqb: float = 1.0, sqm: float = 1.0) -> tuple[tuple, np.ndarray]:
    act = np.full(4, -1, dtype=np.int64)
    cand = np.arange(len(ev), dtype=np.int64)
    return solve_qp(ev, cand, len(ev), sqb, sqm, TOL, act), act


def _fresh_slip(state: int = FREE) -> np.ndarray:
    return np.array([state, FREE], dtype=np.int64)


# ---- solve_qp ---------------------------------------------------------------------------


def test_one_constraint_moves_along_its_weighted_gradient() -> None:
    # a = (1, 2), beta = 1, W^-1 = diag(1/4, 1): |a|^2 in W^-1 is 1/4 + 4 = 17/4, so
    # lambda = 4/17 and v = lambda (a_b / 4, a_m) = (1/17, 8/17).
    (status, n, vb, vm), act = _qp(_ev((1.0, 2.0, 1.0)), sqb=0.5)
    assert (status, n, act[0]) == (0, 1, 0)
    assert (vb, vm) == pytest.approx((1.0 / 17.0, 8.0 / 17.0), rel=1e-15)


def test_a_held_base_does_not_turn() -> None:
    (status, n, vb, vm), _ = _qp(_ev((1.0, 2.0, 1.0)), sqb=0.0)
    assert (status, n) == (0, 1)
    assert (vb, vm) == (0.0, 0.5)  # a_m v_m = beta


def test_two_constraints_whose_single_solutions_fail_are_held_together() -> None:
    # Alone, a1 = (1, 1/2) gives v = (0.8, 0.4) with a2 . v = 0.8 < 1, and the mirror image;
    # both held: (1, 1/2) v = 1 and (1/2, 1) v = 1, v = (2/3, 2/3), multipliers (4/9, 4/9).
    (status, n, vb, vm), act = _qp(_ev((1.0, 0.5, 1.0), (0.5, 1.0, 1.0)))
    assert (status, n, sorted(act[:2])) == (0, 2, [0, 1])
    assert (vb, vm) == pytest.approx((2.0 / 3.0, 2.0 / 3.0), rel=1e-15)


def test_a_loose_constraint_does_not_change_the_single_solution() -> None:
    (status, n, vb, vm), act = _qp(_ev((1.0, 0.0, 1.0), (0.0, 1.0, -3.0)))
    assert (status, n, act[0], vb, vm) == (0, 1, 0, 1.0, 0.0)


def test_a_second_contact_held_with_zero_slack_is_kept_active() -> None:
    # v = (1, 0) from the first meets the second (1, 1) . v >= 1 with equality.
    (status, n, vb, vm), act = _qp(_ev((1.0, 0.0, 1.0), (1.0, 1.0, 1.0)))
    assert (status, n, act[0], act[1]) == (0, 2, 0, 1)
    assert (vb, vm) == (1.0, 0.0)


def test_infeasible_constraints_block() -> None:
    # v_b >= 1, v_m >= 1 and v_b + v_m <= -1 cannot all hold.
    result, _ = _qp(_ev((1.0, 0.0, 1.0), (0.0, 1.0, 1.0), (-1.0, -1.0, 1.0)))
    assert result == (1, 0, 0.0, 0.0)


def test_no_constraint_needing_motion_gives_rest() -> None:
    result, act = _qp(_ev((1.0, 2.0, 0.0), (0.5, -1.0, -2.0), (1.0, 1.0, 0.5 * TOL)))
    assert result == (0, 0, 0.0, 0.0)
    assert act.tolist() == [-1, -1, -1, -1]


def _choose_among(ev: np.ndarray, order: list[int]) -> tuple[int, int, float, float, list[int]]:
    """choose_motion over contacts inside unit edges (none a corner pair), the candidates in
    ``order``: (status, n_active, v_b, v_m, the held pairs)."""
    table = np.zeros((len(ev), PAIR_COLUMNS))
    table[:, COL_EDGE_LENGTH] = 1.0
    act = np.full(4, -1, dtype=np.int64)
    scratch = np.zeros((3, len(ev) + 2), dtype=np.int64)
    cand = np.array(order, dtype=np.int64)
    status, n, vb, vm = choose_motion(
        table, ev, cand, len(ev), 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, act, scratch,
        np.full(4, -1, dtype=np.int64), np.zeros((4, 2)),
    )  # fmt: skip
    return status, n, vb, vm, act[:n].tolist()


def _flush(*offsets: float) -> np.ndarray:
    """Contacts along one flush line, offset s from its middle: a = (1/2 + s, 1/2 - s),
    beta 1. Every one holds the rate (1, 1) with zero slack, the outermost two push it."""
    return _ev(*((0.5 + s, 0.5 - s, 1.0) for s in offsets))


@pytest.mark.parametrize("order", [[0, 1, 2, 3, 4], [2, 1, 3, 0, 4], [4, 3, 2, 1, 0]])
def test_a_flush_line_of_contacts_holds_its_outermost_two_in_any_order(order: list[int]) -> None:
    # Any two of them give the rate (1, 1); only the outermost pair (offsets -0.3 and 0.3,
    # the largest |det|) can carry a force anywhere on the line. The candidates' order
    # (pair indices, which a mirror image reverses) used to choose.
    status, n, vb, vm, held = _choose_among(_flush(-0.3, -0.1, 0.05, 0.2, 0.3), order)
    assert (status, n, sorted(held)) == (0, 2, [0, 4])
    assert (vb, vm) == pytest.approx((1.0, 1.0), rel=1e-12)


@pytest.mark.parametrize("order", [[0, 1, 2], [2, 1, 0], [1, 2, 0]])
def test_of_the_tight_pairs_the_widest_whose_forces_push_is_held(order: list[int]) -> None:
    # All three hold the rate (1, 1) with zero slack. Pairs (0, 2) (|det| 17.6) would need a
    # pulling force on 0 (multipliers -0.045, 0.102); (1, 2) (|det| 2.4; multipliers 0.33,
    # 0.083) is the widest that pushes, and (0, 1) (|det| 1) the narrower one.
    ev = _ev((1.4, -0.4, 1.0), (0.4, 0.6, 1.0), (10.4, 9.6, 20.0))
    status, n, vb, vm, held = _choose_among(ev, order)
    assert (status, n, sorted(held)) == (0, 2, [1, 2])
    assert (vb, vm) == pytest.approx((1.0, 1.0), rel=1e-12)


# Gradients on a grid of quarters: near-parallel gradients would make the multipliers, not
# the QP, ill-conditioned (the check below recovers them by least squares).
quarters = st.integers(-12, 12).map(lambda k: k / 4.0)


@settings(max_examples=200)
@given(
    rows=st.lists(st.tuples(quarters, quarters, quarters), min_size=1, max_size=4),
    sqb=st.sampled_from([0.0, 0.5, 1.0, 2.0]),
)
def test_a_solution_is_feasible_and_optimal_on_its_active_set(
    rows: list[tuple[float, float, float]], sqb: float
) -> None:
    ev = _ev(*rows)
    (status, n, vb, vm), act = _qp(ev, sqb=sqb)
    if status != 0 or n == 0:
        return
    a = ev[:, 2:4]
    assert np.all(a @ [vb, vm] >= ev[:, 4] - 1e-6 * (1 + np.abs(ev[:, 4])))
    assert a[act[:n]] @ [vb, vm] == pytest.approx(ev[act[:n], 4], abs=1e-6)  # held: tight
    # KKT: the scaled rate is a nonnegative combination of the active scaled gradients.
    scaled = a[act[:n]] * [sqb, 1.0]
    u = np.array([vb / sqb if sqb else 0.0, vm])
    lam, *_ = np.linalg.lstsq(scaled.T, u, rcond=None)
    assert scaled.T @ lam == pytest.approx(u, rel=1e-8, abs=1e-9 * (1.0 + np.linalg.norm(u)))
    assert np.all(lam >= -1e-9 * max(1.0, np.abs(lam).max()))


# ---- velocity and slip (the incline of conftest, base free unless said) -------------------


def _act(n: int) -> np.ndarray:
    return np.array([0, 1, -1, -1][:n] + [-1] * (4 - n), dtype=np.int64)


def _state(incline, pb: float = 0.05) -> tuple[float, float, float, float]:
    """A state with pair 0 touching, the base turned a little."""
    g_ref = incline.gap(0, incline.phi_m0, 3.0, pb)
    beta = pair_at(incline.table, 0, pb, incline.phi_m0, incline.x0, 3.0)[4]
    return pb, incline.phi_m0, incline.x0, 3.0 - g_ref / beta


def _rate(
    incline, n: int, state: tuple[float, float, float, float], *, sqb: float = 1.0,
    mu: float = 0.0, slip: np.ndarray | None = None,
) -> tuple[float, float, float, float]:  # fmt: skip
    """:func:`velocity` at ``state`` with the first ``n`` pairs held (W^-1 = diag(sqb^2, 1))."""
    pb, pm, _, ym = state
    seg = incline.segment(n_active=n, winv_b=sqb * sqb, mu=mu, slip=slip)
    return velocity(seg.held, pb, pm, ym)


def _abc(incline, i: int, state: tuple[float, float, float, float]):
    """(a, beta, c, gamma) of pair i, unscaled."""
    _, _, a_b, a_m, beta, *_ = pair_at(incline.table, i, *state)
    c_b, c_m, gam = tangent(incline.table, i, *state)
    return np.array([a_b, a_m]), beta, np.array([c_b, c_m]), gam


@pytest.mark.parametrize("sqb", [0.0, 0.5, 1.0])
def test_frictionless_rate_is_the_least_dissipation_rate(incline, sqb: float) -> None:
    state = _state(incline)
    vb, vm, lam, x = _rate(incline, 1, state, sqb=sqb)
    ev = np.zeros((2, 6))
    eval_all_pairs(incline.table, *state, ev)
    (status, n, qb, qm), _ = _qp(ev[:1], sqb=sqb)
    assert (status, n) == (0, 1)
    assert (vb, vm) == pytest.approx((qb, qm), rel=1e-14)
    a, beta, _, _ = _abc(incline, 0, state)
    assert lam == pytest.approx(beta / (a[0] ** 2 * sqb**2 + a[1] ** 2), rel=1e-14)
    assert x == 0.0


def test_two_frictionless_contacts_fix_the_rate(incline) -> None:
    state = _state(incline)
    vb, vm, l1, l2 = _rate(incline, 2, state)
    a1, b1, _, _ = _abc(incline, 0, state)
    a2, b2, _, _ = _abc(incline, 1, state)
    assert (a1 @ [vb, vm], a2 @ [vb, vm]) == pytest.approx((b1, b2), rel=1e-12)
    assert l1 * a1 + l2 * a2 == pytest.approx([vb, vm], rel=1e-12)


def test_a_stuck_contact_does_not_slip(incline) -> None:
    state = _state(incline)
    slip = _fresh_slip(STICK)
    vb, vm, lam, tau = _rate(incline, 1, state, mu=0.9, slip=slip)
    a, beta, c, gam = _abc(incline, 0, state)
    assert c @ [vb, vm] + gam == pytest.approx(0.0, abs=1e-12)
    assert a @ [vb, vm] == pytest.approx(beta, rel=1e-12)
    # The force is a normal part lambda plus a tangential part tau (W = I here).
    assert lam * a + tau * c == pytest.approx([vb, vm], rel=1e-12)


@pytest.mark.parametrize("mode", [SLIDE_POSITIVE, SLIDE_NEGATIVE])
def test_a_sliding_contact_pushes_along_a_minus_mu_s_c(incline, mode: int) -> None:
    state, mu, sqb = _state(incline), 0.3, 0.5
    slip = _fresh_slip(mode)
    vb, vm, lam, x = _rate(incline, 1, state, sqb=sqb, mu=mu, slip=slip)
    a, beta, c, _ = _abc(incline, 0, state)
    force = a - mu * mode * c
    assert lam >= 0.0
    assert (vb, vm) == pytest.approx((lam * force[0] * sqb**2, lam * force[1]), rel=1e-12)
    assert a @ [vb, vm] == pytest.approx(beta, rel=1e-12)
    assert x == 0.0


def test_friction_shares_the_load_of_two_contacts_without_changing_the_rate(incline) -> None:
    state, mu = _state(incline), 0.4
    slip = np.array([SLIDE_POSITIVE, SLIDE_NEGATIVE], dtype=np.int64)
    free = _rate(incline, 2, state)
    vb, vm, l1, l2 = _rate(incline, 2, state, mu=mu, slip=slip)
    assert (vb, vm) == pytest.approx(free[:2], rel=1e-14)
    a1, _, c1, _ = _abc(incline, 0, state)
    a2, _, c2, _ = _abc(incline, 1, state)
    assert l1 * (a1 - mu * c1) + l2 * (a2 + mu * c2) == pytest.approx([vb, vm], rel=1e-12)


X_TABLE = pair_table(xf.x_face(0.5, 1.0)).data


@settings(max_examples=100)
@given(
    i=st.integers(0, len(X_TABLE) - 1),
    pb=st.floats(-1.0, 1.0),
    pm=st.floats(-1.0, 1.0),
    x0=st.floats(-1.0, 1.0),
    ym=st.floats(1.5, 3.5),
)
def test_slip_rate_is_the_rate_of_the_vertex_along_the_edge(
    i: int, pb: float, pm: float, x0: float, ym: float
) -> None:
    # c . dq/ds + gamma is d/ds of the vertex's distance along the edge from its start,
    # u |e|, whichever part carries the vertex.
    row = X_TABLE[i]
    length = math.hypot(row[5] - row[3], row[6] - row[4])

    def w(b: float, m: float, y: float) -> float:
        return float(pair_at(X_TABLE, i, b, m, x0, y)[1]) * length

    c_b, c_m, gam = tangent(X_TABLE, i, pb, pm, x0, ym)
    h = 1e-6
    assert c_b == pytest.approx((w(pb + h, pm, ym) - w(pb - h, pm, ym)) / (2 * h), abs=1e-7)
    assert c_m == pytest.approx((w(pb, pm + h, ym) - w(pb, pm - h, ym)) / (2 * h), abs=1e-7)
    assert gam == pytest.approx((w(pb, pm, ym - h) - w(pb, pm, ym + h)) / (2 * h), abs=1e-7)


# ---- friction_modes --------------------------------------------------------------------


def _modes(incline, mu: float, sqb: float = 1.0) -> tuple[bool, int]:
    state = _state(incline)
    v0b, v0m, _, _ = _rate(incline, 1, state, sqb=sqb)
    slip = _fresh_slip()
    seg = incline.segment(winv_b=sqb * sqb, mu=mu, slip=slip)
    ok = friction_modes(seg.held, state[0], state[1], state[3], v0b, v0m)
    return ok, int(slip[0])


def _stuck_ratio(incline) -> float:
    """|tau| / lambda of the stuck contact: the least mu that can hold it."""
    _, _, lam, tau = _rate(incline, 1, _state(incline), mu=1.0, slip=_fresh_slip(STICK))
    assert lam > 0.0
    return abs(tau) / lam


def test_friction_modes_slide_the_way_the_frictionless_motion_slips(incline) -> None:
    state = _state(incline)
    v0b, v0m, _, _ = _rate(incline, 1, state)
    _, _, c, gam = _abc(incline, 0, state)
    frictionless_slip = c @ [v0b, v0m] + gam
    assert abs(frictionless_slip) > 0.1
    expected = SLIDE_POSITIVE if frictionless_slip > 0.0 else SLIDE_NEGATIVE
    assert _modes(incline, 0.3) == (True, expected)


def test_friction_modes_stick_once_mu_can_hold_the_contact(incline) -> None:
    # Sliding and sticking meet where mu equals the stuck contact's |tau| / lambda: below it
    # the contact slides, above it it sticks.
    mu_star = _stuck_ratio(incline)
    assert _modes(incline, 0.99 * mu_star) == (True, SLIDE_POSITIVE)
    assert _modes(incline, 1.01 * mu_star) == (True, STICK)


def test_friction_modes_of_a_held_base_on_a_steep_wedge_lock(incline) -> None:
    # Base held: one degree of freedom, the contact cannot stick (it would fix phi_M and the
    # descent together), and with mu far above the incline's slope neither slip direction
    # is consistent.
    assert _modes(incline, 5.0, sqb=0.0) == (False, FREE)


def test_friction_modes_of_two_contacts_follow_the_fixed_rate(incline) -> None:
    state = _state(incline)
    v0b, v0m, _, _ = _rate(incline, 2, state)
    slip = _fresh_slip()
    seg = incline.segment(n_active=2, winv_b=1.0, mu=0.4, slip=slip)
    assert friction_modes(seg.held, state[0], state[1], state[3], v0b, v0m)
    for k in range(2):
        _, _, c, gam = _abc(incline, k, state)
        rate = c @ [v0b, v0m] + gam
        assert slip[k] == (SLIDE_POSITIVE if rate > 0.0 else SLIDE_NEGATIVE)


# ---- choose_motion: corners as alternatives ----------------------------------------------


def _with_corner(incline, direction: float, u_end: float = 1.0):
    """The incline's pair 0 plus a corner pair: the moving pivot itself as a vertex (turning
    the moving part does not move it) on a horizontal base edge that ends at the pivot's
    position (u = ``u_end``, g = 0). ``direction`` +1: the edge runs to the right, so its
    outside faces down and the descending pivot leaves it (opening); -1: it runs to the
    left, its outside faces up, and the pivot would cut into it (closing)."""
    pb, _, x0, ym = state = _state(incline)
    end = np.array([x0, ym])
    start = end - np.array([direction * u_end * 0.5, 0.0])
    tip = start + (end - start) / u_end
    body = np.array([[math.cos(pb), math.sin(pb)], [-math.sin(pb), math.cos(pb)]])  # R(-pb)
    normal = np.array([0.0, -direction])
    corner = np.zeros(incline.table.shape[1])
    corner[:9] = [0.0, 0.0, 0.0, *(body @ start), *(body @ tip), *(body @ normal)]
    table = np.vstack((incline.table[:1], corner))
    fill_extents(table)  # the derived columns of the new row
    return table, state


def _choose(table: np.ndarray, state) -> tuple[tuple, np.ndarray, np.ndarray]:
    ev = np.zeros((2, 6))
    eval_all_pairs(table, *state, ev)
    act = np.full(4, -1, dtype=np.int64)
    cand = np.array([0, 1], dtype=np.int64)
    scratch = np.empty((3, 4), dtype=np.int64)
    trial, rays = np.empty(4, dtype=np.int64), np.empty((4, 2))
    chosen = choose_motion(table, ev, cand, 2, *state, 0.0, 1.0, act, scratch, trial, rays)
    return chosen, act, ev


def test_an_opening_corner_leaves_the_motion_of_the_edge_contact(incline) -> None:
    table, state = _with_corner(incline, +1.0)
    (status, n, vb, vm), act, ev = _choose(table, state)
    assert (ev[1, 0], ev[1, 1]) == pytest.approx((0.0, 1.0), abs=1e-12)
    (_, _, qb, qm), _ = _qp(ev[:1], sqb=0.0)
    assert (status, n, act[0], vb, vm) == (0, 1, 0, qb, qm)


def test_a_closing_corner_blocks_a_held_base(incline) -> None:
    table, state = _with_corner(incline, -1.0)
    (status, n, _, _), _, ev = _choose(table, state)
    assert (ev[1, 0], ev[1, 1]) == pytest.approx((0.0, 1.0), abs=1e-12)
    assert (status, n) == (1, 0)


def test_a_vertex_just_beyond_the_edge_end_is_no_corner(incline) -> None:
    # u = 1.001: the pivot descends past the edge's line beside the edge, not into it.
    table, state = _with_corner(incline, -1.0, u_end=1.001)
    (status, n, vb, vm), act, ev = _choose(table, state)
    assert ev[1, 1] == pytest.approx(1.001, abs=1e-12)
    (_, _, qb, qm), _ = _qp(ev[:1], sqb=0.0)
    assert (status, n, act[0], vb, vm) == (0, 1, 0, qb, qm)


# ---- ties of the motion choice ---------------------------------------------------------------


@pytest.mark.parametrize(("trial_cut", "cost", "wins"), [(0.0, 0.9, True), (0.0, 1.0, False),
                                                          (1e-6, 0.9, False)])  # fmt: skip
def test_against_a_sound_best_only_a_sound_trial_of_less_dissipation_wins_a_tie(
    trial_cut: float, cost: float, wins: bool
) -> None:
    assert _tie_goes_to_trial(0.0, trial_cut, 1.0, cost) is wins


@pytest.mark.parametrize(("trial_cut", "wins"), [(1e-7, True), (1e-6 - 0.5 * LOOKAHEAD_CUT, False)])
def test_against_a_best_that_cuts_in_a_trial_must_cut_in_clearly_less(
    trial_cut: float, wins: bool
) -> None:
    assert _tie_goes_to_trial(1e-6, trial_cut, 1.0, 2.0) is wins
