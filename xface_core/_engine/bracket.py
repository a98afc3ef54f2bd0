"""Root bracketing for event location: where to probe a bracket next and how it moves.

Pure scalar functions, compiled without reference counting, used by
:func:`~xface_core._engine.events.locate` (whose probes are integration steps, so every
probe saved is a step saved): regula falsi with Anderson and Bjorck's scaling of the stale
end, a probe that closes the bracket (Brent's and SUNDIALS' safeguard), and the zero of a
power law fitted through one end's own values where that end keeps moving.
"""

from __future__ import annotations

import math

from .records import njit_no_refcount

#: A root search's bracket (:func:`start_bracket`): a tuple of floats, indexed by these.
#: Its ends and their values (the stale end's value scaled by :func:`stale_scale`), the
#: end that moved last (+1 lo, -1 hi, 0 none yet), each end's own value unscaled and its
#: two earlier values (NaN until it moved so often), nearest first.
LO, F_LO, HI, F_HI, SIDE = 0, 1, 2, 3, 4
LO_TRUE, LO_B, F_LO_B, LO_C, F_LO_C = 5, 6, 7, 8, 9
HI_TRUE, HI_B, F_HI_B, HI_C, F_HI_C = 10, 11, 12, 13, 14
#: Orders of a zero the power secant fits (:func:`zero_order_probe`): a square root's (1/2)
#: to a fourth power's, with room at both ends (a fit exactly at an end of the range can
#: fall outside it by round-off).
MIN_ORDER = 0.4
MAX_ORDER = 5.0
#: Newton steps of that fit before it gives up (it settles in two or three in a map's
#: searches, in up to seven for orders near the range's ends).
ORDER_ITERATIONS = 12

Bracket = tuple[
    float, float, float, float, float, float, float, float, float, float, float, float,
    float, float, float,
]  # fmt: skip


@njit_no_refcount
def start_bracket(lo: float, f_lo: float, hi: float, f_hi: float) -> Bracket:
    """The bracket ``[lo, hi]`` with values ``f_lo`` > 0 >= ``f_hi`` and no history."""
    nan = math.nan
    return (lo, f_lo, hi, f_hi, 0.0, f_lo, nan, nan, nan, nan, f_hi, nan, nan, nan, nan)


@njit_no_refcount
def move_bracket(b: Bracket, mid: float, f_mid: float) -> Bracket:
    """The bracket after a probe at ``mid`` with value ``f_mid``: the end on its side moves
    there (a value that is not finite counts as past the zero), the other end's value is
    scaled when it stayed twice (Anderson and Bjorck), and the moving end's unscaled values
    are remembered."""
    lo, f_lo, hi, f_hi, side = b[LO], b[F_LO], b[HI], b[F_HI], b[SIDE]
    if math.isfinite(f_mid) and f_mid > 0.0:
        if side == 1.0:
            f_hi *= stale_scale(f_mid, f_lo)
        return (
            mid, f_mid, hi, f_hi, 1.0, f_mid, lo, b[LO_TRUE], b[LO_B], b[F_LO_B],
            b[HI_TRUE], b[HI_B], b[F_HI_B], b[HI_C], b[F_HI_C],
        )  # fmt: skip
    if side == -1.0:
        f_lo *= stale_scale(f_mid, f_hi)
    return (
        lo, f_lo, mid, f_mid, -1.0, b[LO_TRUE], b[LO_B], b[F_LO_B], b[LO_C], b[F_LO_C],
        f_mid, hi, b[HI_TRUE], b[HI_B], b[F_HI_B],
    )  # fmt: skip


@njit_no_refcount
def next_probe(b: Bracket, tol: float) -> float:
    """The next probe of a bracket (:func:`start_bracket`), moved by :func:`closing_probe`.

    Once the end that moved last has two earlier values, the zero of the power law fitted
    through its three (:func:`zero_order_probe`); otherwise, or when no order fits, regula
    falsi (bisection when a value is not finite or the secant leaves the bracket).

    Regula falsi keeps moving one end where its model fails: a zero the function reaches
    tangentially on that side (a vertex arriving along its line, a clipped gap turning
    into a corner's distance: ``f = -c (t - r)^2``), along which it gains a factor of
    about 0.6 a probe (60 probes for a zero bracketed in 1e-2, seen in the V-Face), or a
    kink (a slope that changes at the zero). Each end's own values describe its side.
    """
    lo, f_lo, hi, f_hi, side = b[LO], b[F_LO], b[HI], b[F_HI], b[SIDE]
    mid = math.nan
    if side == 1.0:
        mid = zero_order_probe(b[LO_C], b[F_LO_C], b[LO_B], b[F_LO_B], lo, b[LO_TRUE])
    elif side == -1.0:
        mid = zero_order_probe(b[HI_C], b[F_HI_C], b[HI_B], b[F_HI_B], hi, b[HI_TRUE])
    if not (lo < mid < hi) and math.isfinite(f_hi) and f_hi < 0.0 and f_lo > 0.0:
        mid = hi - f_hi * (hi - lo) / (f_hi - f_lo)
    if not (lo < mid < hi):
        mid = 0.5 * (lo + hi)
    return closing_probe(mid, lo, hi, int(side), tol)


@njit_no_refcount
def zero_order_probe(
    t_c: float, f_c: float, t_b: float, f_b: float, t_a: float, f_a: float
) -> float:
    """The zero of ``|f| = k |t - r|^p`` through three points on one side of it, ``c``
    (furthest), ``b``, ``a`` (nearest): the order ``p`` in [MIN_ORDER, MAX_ORDER] for which
    ``|f|^(1/p)`` lies on a line through the three, then that line's zero through ``b`` and
    ``a``. NaN when the points are not finite, not strictly approaching the zero, or
    Newton's method (:func:`_bend`, from ``p = 1``) does not settle inside the range of
    orders (regula falsi then).

    Powers are taken relative to ``|f_b|`` from logarithms taken once. In the logarithms
    of the two slopes the condition is nearly linear in ``q = 1/p`` (the slopes themselves
    grow like ``exp``, and their difference also vanishes at ``q = 0``): Newton's method
    settles in two or three steps where Illinois on the slopes' ratio took 18 (7 to 39)
    in the seats of an X-Face map, each with two ``exp``, a twentieth of the map's time."""
    u_c, u_b, u_a = abs(f_c), abs(f_b), abs(f_a)
    if not (math.isfinite(t_c + t_b + t_a) and u_c > u_b > u_a > 0.0 and math.isfinite(u_c)):
        return math.nan
    if not ((t_c - t_b) * (t_b - t_a) > 0.0):
        return math.nan
    l_c, l_a = math.log(u_c / u_b), math.log(u_a / u_b)
    if not (l_c > 0.0 > l_a):  # values equal to round-off
        return math.nan
    log_ratio = math.log((t_a - t_b) / (t_b - t_c))  # of the two intervals' lengths
    q, q_min, q_max = 1.0, 1.0 / MAX_ORDER, 1.0 / MIN_ORDER
    for _ in range(ORDER_ITERATIONS):
        bend, slope = _bend(l_c, l_a, log_ratio, q)
        if slope == 0.0:  # numba raises on a division by zero (NaN: given up below)
            return math.nan
        q_next = q - bend / slope
        if not math.isfinite(q_next):
            return math.nan
        # A step out of the range goes halfway to its end instead: a fit near the end is
        # still found, and one beyond it creeps to the end without settling (NaN).
        if q_next < q_min:
            q_next = 0.5 * (q + q_min)
        elif q_next > q_max:
            q_next = 0.5 * (q + q_max)
        settled = abs(q_next - q) <= 1e-9
        q = q_next
        if settled:
            w_a = math.exp(q * l_a)  # |f_a|^q / |f_b|^q
            if not w_a < 1.0:
                return math.nan
            return t_a - w_a * (t_a - t_b) / (w_a - 1.0)
    return math.nan


@njit_no_refcount
def _bend(l_c: float, l_a: float, log_ratio: float, q: float) -> tuple[float, float]:
    """How far ``|f|^q`` bends over three points, and its derivative in ``q``: the logarithm
    of the slope of ``|f|^q`` from b to a over the slope from c to b (0 on a line).
    ``l_c``, ``l_a``: the logarithms of ``|f_c| / |f_b|`` and ``|f_a| / |f_b|``;
    ``log_ratio``: of ``(t_a - t_b) / (t_b - t_c)``. NaN where a power rounds to 1."""
    # 1 - |f_a/f_b|^q and |f_c/f_b|^q - 1, to full precision near q l = 0.
    drop_ba, rise_cb = -math.expm1(q * l_a), math.expm1(q * l_c)
    if not (drop_ba > 0.0 and rise_cb > 0.0):
        return math.nan, math.nan
    bend = math.log(drop_ba) - math.log(rise_cb) - log_ratio
    slope = -l_a * (1.0 - drop_ba) / drop_ba - l_c * (1.0 + rise_cb) / rise_cb
    return bend, slope


@njit_no_refcount
def closing_probe(estimate: float, lo: float, hi: float, side: int, tol: float) -> float:
    """Where to probe a bracket ``[lo, hi]`` wider than ``tol`` given the root finder's
    ``estimate``; ``side``: the end the last probe moved (1 ``lo``, -1 ``hi``, 0 none yet).

    Regula falsi, even Illinois, approaches a zero from one side: the end it moves
    converges, the other one stays, and the bracket shrinks below ``tol`` only when an
    estimate is thrown across the zero, after a dozen or more probes that barely move the
    converged end. The probe therefore goes half a tolerance past the estimate towards the
    end that stayed (an estimate within half a tolerance of the zero lands across it and
    closes the bracket), and never nearer than half a tolerance to either end (a converged
    end is crossed at once): the safeguards of Brent's method and of SUNDIALS' root finding.
    The zero stays bracketed; the located event moves within the tolerance.
    """
    t = estimate + 0.5 * tol * side
    return min(max(t, lo + 0.5 * tol), hi - 0.5 * tol)


@njit_no_refcount
def stale_scale(f_new: float, f_old: float) -> float:
    """Anderson and Bjorck's factor for the end of a regula falsi bracket that stayed while
    the other end moved twice: ``1 - f_new / f_old`` of the moving end (0.5 when that is not
    in (0, 1), which includes a non-finite ``f_new`` or ``f_old``). Illinois' fixed 0.5
    shrinks the stale value too slowly where the event function bends at its zero (a
    clipped gap at a corner: 20 probes for a zero where the slope drops from 1.4 to 0.5,
    seen in the X-Face H/D 1); this follows how much the moving end gained."""
    m = 1.0 - f_new / f_old if f_old != 0.0 else 0.5
    return m if 0.0 < m < 1.0 else 0.5
