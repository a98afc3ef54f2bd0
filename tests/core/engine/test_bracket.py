"""Root bracketing (xface_core._engine.bracket): probes, the bracket's moves, the fitted order.

The engine's searches (events.locate) probe with integration steps; here the same functions
run on plain test functions, counting probes.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from xface_core._engine.bracket import (
    F_HI_B,
    F_HI_C,
    F_LO,
    F_LO_B,
    HI,
    HI_B,
    HI_C,
    HI_TRUE,
    LO,
    LO_B,
    LO_TRUE,
    closing_probe,
    move_bracket,
    next_probe,
    stale_scale,
    start_bracket,
    zero_order_probe,
)

EVENT_TOL = 1e-12


def _illinois_scale(f_new: float, f_old: float) -> float:
    return 0.5


def _illinois(
    f: Callable[[float], float],
    lo: float,
    hi: float,
    tol: float,
    closing: bool,
    scale: Callable[[float, float], float] = _illinois_scale,
) -> tuple[float, float, int]:
    """locate's bracketing loop on a plain function, with or without the closing probe,
    with Illinois' halving of the stale end or another ``scale`` (the engine's is
    ``stale_scale``), without fitting the zero's order: the final bracket and the number
    of evaluations. (The engine's own loop is :func:`_engine_search`.)"""
    f_lo, f_hi, n, side = f(lo), f(hi), 2, 0
    while hi - lo > tol:
        mid = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        if not (lo < mid < hi):
            mid = 0.5 * (lo + hi)
        if closing:
            mid = closing_probe(mid, lo, hi, side, tol)
        f_mid = f(mid)
        n += 1
        if f_mid > 0.0:
            f_hi *= scale(f_mid, f_lo) if side == 1 else 1.0
            lo, f_lo = mid, f_mid
            side = 1
        else:
            f_lo *= scale(f_mid, f_hi) if side == -1 else 1.0
            hi, f_hi = mid, f_mid
            side = -1
    return lo, hi, n


def _engine_search(
    f: Callable[[float], float], lo: float, hi: float, tol: float
) -> tuple[float, float, int]:
    """locate's loop with the engine's own bracket functions on a plain function."""
    bracket, n = start_bracket(lo, f(lo), hi, f(hi)), 2
    while bracket[HI] - bracket[LO] > tol:
        mid = next_probe(bracket, tol)
        bracket = move_bracket(bracket, mid, f(mid))
        n += 1
    return bracket[LO], bracket[HI], n


ROOT = 0.0123456789
TEST_FUNCTIONS: dict[str, Callable[[float], float]] = {
    "linear": lambda t: ROOT - t,
    "convex": lambda t: math.exp(-30.0 * t) - math.exp(-30.0 * ROOT),
    "concave": lambda t: math.log1p(ROOT) - math.log1p(t),
    "cubic": lambda t: (ROOT - t) + 40.0 * (ROOT - t) ** 3,
    "sqrt": lambda t: math.sqrt(0.05 - t) - math.sqrt(0.05 - ROOT),
}


def test_the_closing_probe_keeps_half_a_tolerance_from_either_end() -> None:
    assert closing_probe(0.3, 0.3, 1.0, 0, 0.1) == pytest.approx(0.35)
    assert closing_probe(1.0, 0.3, 1.0, 0, 0.1) == pytest.approx(0.95)
    assert closing_probe(0.6, 0.3, 1.0, 0, 0.1) == 0.6


def test_the_closing_probe_steps_past_the_estimate_towards_the_end_that_stayed() -> None:
    # lo moved last: hi stayed, the probe goes half a tolerance towards it; and back.
    assert closing_probe(0.6, 0.3, 1.0, 1, 0.1) == pytest.approx(0.65)
    assert closing_probe(0.6, 0.3, 1.0, -1, 0.1) == pytest.approx(0.55)


@pytest.mark.parametrize("name", sorted(TEST_FUNCTIONS))
def test_the_closing_root_search_brackets_the_zero_to_the_tolerance(name: str) -> None:
    lo, hi, _ = _illinois(TEST_FUNCTIONS[name], 0.0, 0.05, EVENT_TOL, closing=True)
    assert 0.0 < hi - lo <= EVENT_TOL
    assert lo <= ROOT <= hi


@pytest.mark.parametrize("name", ["linear", "convex", "concave"])
def test_the_closing_probe_ends_the_creep_of_regula_falsi(name: str) -> None:
    # Plain Illinois pins one end on the zero and then creeps with the other (28-38
    # evaluations here); the closing probe crosses the zero at once.
    f = TEST_FUNCTIONS[name]
    *_, n_plain = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=False)
    *_, n_closing = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=True)
    assert n_plain >= 20
    assert n_closing <= n_plain // 2


@pytest.mark.parametrize("name", sorted(TEST_FUNCTIONS))
def test_the_closing_probe_never_costs_evaluations(name: str) -> None:
    *_, n_plain = _illinois(TEST_FUNCTIONS[name], 0.0, 0.05, EVENT_TOL, closing=False)
    *_, n_closing = _illinois(TEST_FUNCTIONS[name], 0.0, 0.05, EVENT_TOL, closing=True)
    assert n_closing <= n_plain


#: Event functions that bend at their zero, as a clipped gap does at a corner: slopes 1.4 and
#: 0.5 either side (seen in the X-Face H/D 1), and a vertex arriving along the line.
BENT_FUNCTIONS: dict[str, Callable[[float], float]] = {
    "kink": lambda t: 1.4 * (ROOT - t) if t < ROOT else 0.5 * (ROOT - t),
    "tangent": lambda t: 2.0 * (ROOT - t) if t < ROOT else -30.0 * (t - ROOT) ** 2,
}


def test_the_stale_scale_follows_the_moving_ends_gain() -> None:
    assert stale_scale(-0.25, -1.0) == pytest.approx(0.75)
    assert stale_scale(0.1, 0.4) == pytest.approx(0.75)


def test_the_stale_scale_halves_when_the_moving_end_did_not_gain() -> None:
    assert stale_scale(-2.0, -1.0) == 0.5  # the new value is further from zero
    assert stale_scale(1.0, -1.0) == 0.5  # signs differ: not the same end
    assert stale_scale(-1.0, 0.0) == 0.5


def test_the_stale_scale_halves_after_a_value_that_is_not_finite() -> None:
    # locate moves the bracket's end to a probe whose function is NaN or infinite (a rate
    # through a pole) and then halves the other end, as Illinois did.
    assert stale_scale(math.nan, -1.0) == 0.5
    assert stale_scale(-math.inf, -1.0) == 0.5
    assert stale_scale(-1.0, math.nan) == 0.5
    assert stale_scale(-1.0, -math.inf) == 0.5


def test_the_stale_scale_brackets_a_kinked_zero_in_a_third_of_the_probes() -> None:
    # 33 probes with Illinois' halving, 11 with the scale. (At the tangential zero it takes
    # more, 52 against 39; over random poses of the built-in faces it saves probes.)
    f = BENT_FUNCTIONS["kink"]
    *_, n_illinois = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=True)
    *_, n_scaled = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=True, scale=stale_scale)
    assert 3 * n_scaled <= n_illinois


@pytest.mark.parametrize("name", sorted(BENT_FUNCTIONS))
def test_the_stale_scale_brackets_a_bent_zero_to_the_tolerance(name: str) -> None:
    f = BENT_FUNCTIONS[name]
    lo, hi, _ = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=True, scale=stale_scale)
    assert lo <= ROOT <= hi
    assert hi - lo <= EVENT_TOL


@pytest.mark.parametrize("name", sorted(TEST_FUNCTIONS))
def test_the_stale_scale_brackets_smooth_zeros_to_the_tolerance(name: str) -> None:
    lo, hi, _ = _illinois(
        TEST_FUNCTIONS[name], 0.0, 0.05, EVENT_TOL, closing=True, scale=stale_scale
    )
    assert lo <= ROOT <= hi
    assert 0.0 < hi - lo <= EVENT_TOL


def test_a_tangential_zero_is_bracketed_in_a_fifth_of_the_probes() -> None:
    # 52 probes with regula falsi and the stale scale alone, far fewer once the zero's
    # order is fitted through each end's own values.
    f = BENT_FUNCTIONS["tangent"]
    *_, n_scaled = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=True, scale=stale_scale)
    *_, n_fitted = _engine_search(f, 0.0, 0.05, EVENT_TOL)
    assert 5 * n_fitted <= n_scaled


@pytest.mark.parametrize("name", sorted(TEST_FUNCTIONS) + sorted(BENT_FUNCTIONS))
def test_the_engines_search_brackets_every_zero_to_the_tolerance(name: str) -> None:
    f = {**TEST_FUNCTIONS, **BENT_FUNCTIONS}[name]
    lo, hi, n = _engine_search(f, 0.0, 0.05, EVENT_TOL)
    assert lo <= ROOT <= hi
    assert hi - lo <= EVENT_TOL
    *_, n_scaled = _illinois(f, 0.0, 0.05, EVENT_TOL, closing=True, scale=stale_scale)
    # The fit approaches a smooth zero from one side (2 probes more on the convex and
    # concave functions, whose regula falsi crosses sooner); it never costs more.
    assert n <= n_scaled + 2


@pytest.mark.parametrize("order", [0.5, 1.0, 2.0, 3.0])
def test_the_zero_order_probe_finds_the_zero_of_a_power(order: float) -> None:
    def f(t: float) -> float:
        return -3.0 * (t - 0.3) ** order

    ts = (0.9, 0.6, 0.4)
    assert zero_order_probe(ts[0], f(ts[0]), ts[1], f(ts[1]), ts[2], f(ts[2])) == (
        pytest.approx(0.3, abs=1e-6)
    )


@pytest.mark.parametrize(("order", "steps"), [(1.0, 1), (0.5, 4), (2.0, 4), (3.0, 5), (4.95, 7)])
def test_the_zero_order_probes_fit_settles_in_a_few_newton_steps(order: float, steps: int) -> None:
    bends = []
    probe = zero_order_probe.py_func
    bend = probe.__globals__["_bend"]

    def counted(*args: float) -> tuple[float, float]:
        bends.append(args)
        result: tuple[float, float] = bend(*args)
        return result

    probe.__globals__["_bend"] = counted
    try:
        ts = (0.9, 0.6, 0.4)
        fs = [-3.0 * (t - 0.3) ** order for t in ts]
        assert probe(ts[0], fs[0], ts[1], fs[1], ts[2], fs[2]) == pytest.approx(0.3, abs=1e-9)
    finally:
        probe.__globals__["_bend"] = bend
    assert len(bends) <= steps


@pytest.mark.parametrize("order", [0.3, 5.5, 8.0])
def test_the_zero_order_probe_gives_up_outside_its_orders(order: float) -> None:
    # No order in [MIN_ORDER, MAX_ORDER] puts the three on a line.
    ts = (0.9, 0.6, 0.4)
    fs = [-((t - 0.3) ** order) for t in ts]
    assert math.isnan(zero_order_probe(ts[0], fs[0], ts[1], fs[1], ts[2], fs[2]))


def test_the_zero_order_probe_needs_points_approaching_the_zero() -> None:
    assert math.isnan(zero_order_probe(0.9, -1.0, 0.6, -2.0, 0.4, -0.5))  # |f| grew
    assert math.isnan(zero_order_probe(0.9, -1.0, 0.95, -0.5, 0.4, -0.2))  # t turned back
    assert math.isnan(zero_order_probe(math.nan, -1.0, 0.6, -0.5, 0.4, -0.2))


def test_a_new_bracket_probes_by_regula_falsi() -> None:
    assert next_probe(start_bracket(0.0, 1.0, 1.0, -1.0), 1e-12) == 0.5


def test_each_end_keeps_its_own_unscaled_values() -> None:
    b = start_bracket(0.0, 1.0, 1.0, -1.0)
    for mid, value in ((0.9, -0.5), (0.8, -0.25)):  # hi moves twice: lo's value is scaled
        b = move_bracket(b, mid, value)
    assert b[F_LO] == pytest.approx(0.5)  # Anderson and Bjorck: 1 - 0.25 / 0.5
    assert (b[LO_TRUE], b[HI_TRUE]) == (1.0, -0.25)
    assert (b[HI_B], b[F_HI_B], b[HI_C], b[F_HI_C]) == (0.9, -0.5, 1.0, -1.0)
    b = move_bracket(b, 0.1, 0.5)  # lo moves: hi keeps its history
    assert (b[LO_B], b[F_LO_B], b[HI_B], b[HI_C]) == (0.0, 1.0, 0.9, 1.0)


def test_the_zero_order_probe_gives_up_on_values_equal_to_round_off() -> None:
    # |f_c| / |f_b| = 1 + 2e-16: its powers round to 1, and the compiled kernel would
    # raise ZeroDivisionError on the slope between them (seen in the golden maps).
    assert math.isnan(zero_order_probe(0.9, -1.0, 0.6, -(1.0 - 2.0**-52), 0.4, -0.5))
