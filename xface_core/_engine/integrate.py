"""One step along the path with the active set fixed: solved on the contacts where they pin
the path (two contacts, or one with the base held: :func:`pinned_step`, exact to round-off),
else a Dormand-Prince 5(4) step (:func:`rk_step`) projected back onto the active contacts
(the projection's correction counts as step error)."""

from __future__ import annotations

import math

from .motion import project_gaps, velocity
from .pairs import eval_pair
from .records import Contacts, FloatArray, Segment, Step, njit_no_refcount

# Dormand-Prince 5(4) tableau.
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (
    9017.0 / 3168.0,
    -355.0 / 33.0,
    46732.0 / 5247.0,
    49.0 / 176.0,
    -5103.0 / 18656.0,
)
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
#: Dense output (Hairer, Norsett & Wanner's DOPRI5, CONTD5): a continuous extension of order
#: 4 over the step from the stages it has already evaluated.
D1, D3, D4, D5, D6, D7 = (
    -12715105075.0 / 11282082432.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
)
E1, E3, E4, E5, E6, E7 = (
    71.0 / 57600.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
)


@njit_no_refcount
def project(held: Contacts, pb: float, pm: float, ym: float) -> tuple[float, float]:
    """Newton-project (phi_B, phi_M) onto the active constraints ``held`` (g = 0) at fixed
    y_M, along the least-dissipation metric (keeps the constraint violation at round-off)."""
    return project_gaps(
        held.pairs, held.act, held.n_active, held.x0, held.winv_b, held.winv_m, pb, pm, ym, 3
    )


@njit_no_refcount
def rk_step(
    seg: Segment, step: Step, k1b: float, k1m: float
) -> tuple[float, float, float, float, bool]:
    """One Dormand-Prince step ``step`` (its length h in descent, D) from the start rate
    ``(k1b, k1m)`` (rad per D: :func:`~.motion.velocity` there, which every step from one
    start shares, and the event searches take many); returns (pb, pm, err_b, err_m, ok).

    The step's dense output goes to row 0 of ``seg.dense`` (``DENSE_WIDTH`` values, see
    :func:`dense_angles`); the interpolant ends on the projected end state."""
    pb, pm, ym, h = step
    held = seg.held
    k2b, k2m, _, _ = velocity(held, pb + h * A21 * k1b, pm + h * A21 * k1m, ym - h / 5.0)
    k3b, k3m, _, _ = velocity(
        held, pb + h * (A31 * k1b + A32 * k2b), pm + h * (A31 * k1m + A32 * k2m), ym - h * 0.3
    )
    k4b, k4m, _, _ = velocity(
        held,
        pb + h * (A41 * k1b + A42 * k2b + A43 * k3b),
        pm + h * (A41 * k1m + A42 * k2m + A43 * k3m),
        ym - h * 0.8,
    )
    k5b, k5m, _, _ = velocity(
        held,
        pb + h * (A51 * k1b + A52 * k2b + A53 * k3b + A54 * k4b),
        pm + h * (A51 * k1m + A52 * k2m + A53 * k3m + A54 * k4m),
        ym - h * (8.0 / 9.0),
    )
    k6b, k6m, _, _ = velocity(
        held,
        pb + h * (A61 * k1b + A62 * k2b + A63 * k3b + A64 * k4b + A65 * k5b),
        pm + h * (A61 * k1m + A62 * k2m + A63 * k3m + A64 * k4m + A65 * k5m),
        ym - h,
    )
    nb = pb + h * (B1 * k1b + B3 * k3b + B4 * k4b + B5 * k5b + B6 * k6b)
    nm = pm + h * (B1 * k1m + B3 * k3m + B4 * k4m + B5 * k5m + B6 * k6m)
    k7b, k7m, _, _ = velocity(held, nb, nm, ym - h)
    eb = h * (E1 * k1b + E3 * k3b + E4 * k4b + E5 * k5b + E6 * k6b + E7 * k7b)
    em = h * (E1 * k1m + E3 * k3m + E4 * k4m + E5 * k5m + E6 * k6m + E7 * k7m)
    ok = math.isfinite(eb) and math.isfinite(em) and math.isfinite(nb) and math.isfinite(nm)
    if ok:
        # The projection's correction is part of the step's error: a large one means the
        # step left the constraint manifold (e.g. near a turning point of the contact path).
        qb, qm = project(held, nb, nm, ym - h)
        eb = max(abs(eb), abs(qb - nb))
        em = max(abs(em), abs(qm - nm))
        nb, nm = qb, qm
    dense = seg.dense
    dense[0, 0], dense[0, 1], dense[0, 2], dense[0, 3] = pb, pm, ym, h
    dense[0, 4] = 1.0 if ok else 0.0
    dense[0, 13], dense[0, 14] = abs(eb), abs(em)
    _dense_coefficients(dense, 5, pb, nb, h, k1b, k3b, k4b, k5b, k6b, k7b)
    _dense_coefficients(dense, 9, pm, nm, h, k1m, k3m, k4m, k5m, k6m, k7m)
    return nb, nm, eb, em, ok


@njit_no_refcount
def pins_path(nact: int, winv_b: float, mu: float) -> bool:
    """Do the active contacts pin the path, so that a step is solved on them
    (:func:`pinned_step`) instead of integrated (:func:`rk_step`)? Two contacts fix both
    angles at every height; one fixes the moving part's while the base is held
    (``winv_b`` 0), unless friction may make it stick."""
    return nact == 2 or (nact == 1 and winv_b == 0.0 and mu == 0.0)


#: A two-contact step is solved, not integrated, only where the contacts' gap gradients
#: (in the angles) are at least this far from parallel: |det| >= PINNED_CONDITION |a1| |a2|
#: (the sine of the angle between them). Below it, a flush pair reaching its edge ends
#: (singular to 1e-4, S-Face 0.5/1), Newton wanders along the nearly free direction.
PINNED_CONDITION = 1e-2
#: Newton iterations of a two-contact solve, and the gap (D) both contacts must reach.
PINNED_ITERATIONS = 6
PINNED_GAP = 1e-14


@njit_no_refcount
def pinned_solve(
    held: Contacts, pb: float, pm: float, ym: float
) -> tuple[float, float, float, float, bool]:
    """Newton's method on both active gaps of ``held`` at the height ``ym`` (D) from ``(pb, pm)``:
    ``(phi_b, phi_m, v_b, v_m, converged)`` with the rate there (rad per D: the gaps held,
    ``J v = beta``, the same for any metric or friction with two contacts); converged only
    if both gaps reached ``PINNED_GAP`` with the gradients at least ``PINNED_CONDITION``
    from parallel all the way."""
    table, act, x0 = held.pairs, held.act, held.x0
    nan = math.nan
    for _ in range(PINNED_ITERATIONS):
        cb, sb, cm, sm = math.cos(pb), math.sin(pb), math.cos(pm), math.sin(pm)
        g1, _, ab1, am1, b1, _, _, _, _ = eval_pair(table[act[0]], cb, sb, cm, sm, x0, ym)
        g2, _, ab2, am2, b2, _, _, _, _ = eval_pair(table[act[1]], cb, sb, cm, sm, x0, ym)
        det = ab1 * am2 - am1 * ab2
        scale = math.sqrt((ab1 * ab1 + am1 * am1) * (ab2 * ab2 + am2 * am2))
        if not (abs(det) >= PINNED_CONDITION * scale and scale > 0.0):
            return pb, pm, nan, nan, False
        if max(abs(g1), abs(g2)) <= PINNED_GAP:
            return pb, pm, (b1 * am2 - am1 * b2) / det, (ab1 * b2 - b1 * ab2) / det, True
        pb -= (g1 * am2 - am1 * g2) / det
        pm -= (ab1 * g2 - g1 * ab2) / det
    return pb, pm, nan, nan, False


@njit_no_refcount
def held_solve(
    held: Contacts, pb: float, pm: float, ym: float
) -> tuple[float, float, float, float, bool]:
    """:func:`pinned_solve` for one contact with the base held: Newton's method on the gap
    in phi_M alone at the height ``ym`` (D); the rate there is ``(0, beta / a_M)``.
    Converged only if the gap reached ``PINNED_GAP`` with ``|a_M|`` at least
    ``PINNED_CONDITION`` of ``|(a_M, beta)|`` all the way (a rate below 1/PINNED_CONDITION
    rad per D: no fold near)."""
    table, act, x0 = held.pairs, held.act, held.x0
    nan = math.nan
    cb, sb = math.cos(pb), math.sin(pb)
    for _ in range(PINNED_ITERATIONS):
        cm, sm = math.cos(pm), math.sin(pm)
        g, _, _, am, b, _, _, _, _ = eval_pair(table[act[0]], cb, sb, cm, sm, x0, ym)
        if not (abs(am) >= PINNED_CONDITION * math.sqrt(am * am + b * b) and am != 0.0):
            return pb, pm, nan, nan, False
        if abs(g) <= PINNED_GAP:
            return pb, pm, 0.0, b / am, True
        pm -= g / am
    return pb, pm, nan, nan, False


@njit_no_refcount
def pinned_step(seg: Segment, step: Step, k1b: float, k1m: float) -> tuple[float, float, bool]:
    """The step ``step`` (its length h in descent, D) along a path pinned by the segment's
    active contacts (two, or one with the base held and no friction), solved instead of
    integrated: Heun's predictor
    from the start rate ``(k1b, k1m)``, then :func:`pinned_solve` (:func:`held_solve`) at
    the step's end height. ``(phi_b, phi_m, ok)``; its error is the solve's round-off, so
    the caller counts it as zero. Not ``ok`` (the caller integrates instead)
    when the solve did not converge, or its solution is not the continuation of the start:
    the rate there not finite or turned against the start's, or the solve moved further
    from the predictor than a quarter of the step's turn (another branch of the contacts'
    solutions, as next to a fold, where two meet).

    The dense output is the cubic Hermite interpolant through both ends and their rates;
    its error estimate (columns 13, 14) is the predictor's distance from the solution,
    O(h^3) against the interpolant's O(h^4)."""
    held, dense = seg.held, seg.dense
    pb, pm, ym, h = step
    # The rate at the Euler point, for Heun's predictor.
    euler_b, euler_m = pb + h * k1b, pm + h * k1m
    vb, vm, _, _ = velocity(held, euler_b, euler_m, ym - h)
    if not math.isfinite(vb + vm):
        return pb, pm, False
    qb = pb + 0.5 * h * (k1b + vb)
    qm = pm + 0.5 * h * (k1m + vm)
    if held.n_active == 2:
        nb, nm, k7b, k7m, converged = pinned_solve(held, qb, qm, ym - h)
    else:
        nb, nm, k7b, k7m, converged = held_solve(held, qb, qm, ym - h)
    if not converged:
        return pb, pm, False
    moved = max(abs(nb - qb), abs(nm - qm))
    if not moved <= 0.25 * max(abs(qb - pb), abs(qm - pm)) + 1e-12:
        return pb, pm, False
    if held.mu > 0.0:
        # The rate is the solve's; velocity also says where friction cannot share the load.
        k7b, k7m, _, _ = velocity(held, nb, nm, ym - h)
    if not (math.isfinite(k7b + k7m) and k7b * k1b + k7m * k1m > 0.0):
        return pb, pm, False
    dense[0, 0], dense[0, 1], dense[0, 2], dense[0, 3] = pb, pm, ym, h
    dense[0, 4] = 1.0
    dense[0, 13], dense[0, 14] = abs(nb - qb), abs(nm - qm)
    _hermite_coefficients(dense, 5, pb, nb, h, k1b, k7b)
    _hermite_coefficients(dense, 9, pm, nm, h, k1m, k7m)
    return nb, nm, True


@njit_no_refcount
def _hermite_coefficients(
    dense: FloatArray, at: int, y0: float, y1: float, h: float, k1: float, k7: float
) -> None:
    """One angle's cubic Hermite interpolant through both ends and their rates in the dense
    output's form (CONTD5's rcont2..rcont5 with the quartic term zero), into row 0 of
    ``dense`` from column ``at``."""
    diff = y1 - y0
    slope_start = h * k1 - diff
    dense[0, at] = diff
    dense[0, at + 1] = slope_start
    dense[0, at + 2] = diff - h * k7 - slope_start
    dense[0, at + 3] = 0.0


@njit_no_refcount
def _dense_coefficients(
    dense: FloatArray, at: int, y0: float, y1: float, h: float, k1: float, k3: float,
    k4: float, k5: float, k6: float, k7: float,
) -> None:  # fmt: skip
    """One angle's interpolant coefficients (CONTD5's rcont2..rcont5) into row 0 of
    ``dense`` from column ``at``. Written out, not through :func:`_hermite_coefficients`
    (its first three): in the integrator's every step the extra call made the S map about
    2 % slower side by side."""
    diff = y1 - y0
    slope_start = h * k1 - diff
    dense[0, at] = diff
    dense[0, at + 1] = slope_start
    dense[0, at + 2] = diff - h * k7 - slope_start
    dense[0, at + 3] = h * (D1 * k1 + D3 * k3 + D4 * k4 + D5 * k5 + D6 * k6 + D7 * k7)


@njit_no_refcount
def dense_angles(dense: FloatArray, row: int, t: float) -> tuple[float, float]:
    """(phi_B, phi_M) a descent ``t`` (D) into the step of a dense-output row (0 <= t <= its
    length): the continuous extension, as accurate as the step (its error is of the order
    of the step's own error estimate), for the price of a few multiplications."""
    d = dense
    s = t / d[row, 3]
    s1 = 1.0 - s
    pb = d[row, 0] + s * (d[row, 5] + s1 * (d[row, 6] + s * (d[row, 7] + s1 * d[row, 8])))
    pm = d[row, 1] + s * (d[row, 9] + s1 * (d[row, 10] + s * (d[row, 11] + s1 * d[row, 12])))
    return pb, pm
