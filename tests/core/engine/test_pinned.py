"""integrate.py's pinned steps: solved on the contacts instead of integrated (two contacts,
or one with the base held).

The state they start from is taken off a real path (V 0.5/1, a segment held by two
contacts); the reference is an independent integration of the engine's rate there (the
two contacts' least-dissipation rate as its right-hand side) by classical Runge-Kutta in a
thousand small steps, not the engine's own integrator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.events import solve_or_integrate
from xface_core._engine.integrate import (
    PINNED_GAP,
    dense_angles,
    held_solve,
    pinned_solve,
    pinned_step,
    pins_path,
)
from xface_core._engine.motion import velocity
from xface_core._engine.pairs import pair_at
from xface_core._engine.records import (
    DENSE_WIDTH,
    FREE,
    STEP_MEMO_SLOTS,
    STEP_MEMO_WIDTH,
    Contacts,
    Segment,
    Step,
)
from xface_core.contact import pair_table

NO_SLIP = np.array([FREE, FREE], dtype=np.int64)


class TwoContacts:
    """A state of V 0.5/1 held by two contacts (x0 0.6 D, theta0 -pi/20), units of D."""

    def __init__(self) -> None:
        design = xf.v_face(0.5, 1.0)
        p = xf.predict(design, 0.6 * design.width, -math.pi / 20.0)
        assert p.path is not None
        pairs = p.path.contact_pairs
        rows = np.flatnonzero((pairs[:, 0] >= 0) & (pairs[:, 1] >= 0) & (pairs[:, 2] < 0))
        assert rows.size >= 2, "the path should hold two contacts for a while"
        k = int(rows[0])
        self.table = pair_table(design).data
        self.act = np.array([pairs[k, 0], pairs[k, 1], -1, -1], dtype=np.int64)
        self.pb, self.pm = float(p.path.phi_b[k]), float(p.path.phi_m[k])
        self.x0 = p.x0 / design.width
        self.ym = float(p.path.pivot_m[k, 1]) / design.width

    def rate(self, pb: float, pm: float, ym: float) -> tuple[float, float]:
        vb, vm, _, _ = velocity(self.segment().held, pb, pm, ym)
        return vb, vm

    def gaps(self, pb: float, pm: float, ym: float) -> tuple[float, float]:
        g1 = pair_at(self.table, int(self.act[0]), pb, pm, self.x0, ym)[0]
        g2 = pair_at(self.table, int(self.act[1]), pb, pm, self.x0, ym)[0]
        return g1, g2

    def step(self, h: float) -> tuple[float, float, bool, np.ndarray]:
        seg = self.segment()
        k1b, k1m = self.rate(self.pb, self.pm, self.ym)
        nb, nm, ok = pinned_step(seg, Step(self.pb, self.pm, self.ym, h), k1b, k1m)
        return nb, nm, ok, seg.dense

    def segment(self) -> Segment:
        """The segment of the two contacts, frictionless, both parts free."""
        held = Contacts(self.table, self.act, 2, 0.0, NO_SLIP.copy(), self.x0, 1.0, 1.0, 1.0, 1.0)
        return Segment(
            held, -math.inf, np.zeros((STEP_MEMO_SLOTS + 1, STEP_MEMO_WIDTH)),
            np.zeros((2, DENSE_WIDTH)),
        )  # fmt: skip

    def integrated(self, h: float, n: int = 1000) -> tuple[float, float]:
        """The angles a descent ``h`` on, by classical Runge-Kutta in ``n`` steps on the
        engine's rate (error about (h/n)^4: far below the engine's tolerances)."""
        q = np.array([self.pb, self.pm])
        dt = h / n
        for k in range(n):
            s = k * dt
            k1 = np.array(self.rate(*q, self.ym - s))
            k2 = np.array(self.rate(*(q + 0.5 * dt * k1), self.ym - s - 0.5 * dt))
            k3 = np.array(self.rate(*(q + 0.5 * dt * k2), self.ym - s - 0.5 * dt))
            k4 = np.array(self.rate(*(q + dt * k3), self.ym - s - dt))
            q = q + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return float(q[0]), float(q[1])


@pytest.fixture(scope="module")
def held() -> TwoContacts:
    return TwoContacts()


def test_the_start_is_on_both_contacts(held: TwoContacts) -> None:
    assert max(abs(g) for g in held.gaps(held.pb, held.pm, held.ym)) < 1e-9


def test_a_pinned_step_ends_on_both_contacts(held: TwoContacts) -> None:
    h = 0.002
    nb, nm, ok, _ = held.step(h)
    assert ok
    assert max(abs(g) for g in held.gaps(nb, nm, held.ym - h)) <= PINNED_GAP


def test_a_pinned_step_follows_the_integrated_path(held: TwoContacts) -> None:
    h = 0.002
    nb, nm, ok, _ = held.step(h)
    rb, rm = held.integrated(h)
    assert ok
    # The start is on the contacts to the path's round-off, so both end on them alike.
    assert nb == pytest.approx(rb, abs=1e-9)
    assert nm == pytest.approx(rm, abs=1e-9)


def test_the_pinned_dense_output_meets_the_ends_and_their_rates(held: TwoContacts) -> None:
    h = 0.002
    nb, nm, ok, dense = held.step(h)
    assert ok
    dense[1] = dense[0]
    assert dense_angles(dense, 1, 0.0) == pytest.approx((held.pb, held.pm), abs=1e-15)
    assert dense_angles(dense, 1, h) == pytest.approx((nb, nm), abs=1e-15)
    eps = 1e-7 * h
    end_rate = np.subtract(dense_angles(dense, 1, h), dense_angles(dense, 1, h - eps)) / eps
    assert end_rate == pytest.approx(held.rate(nb, nm, held.ym - h), rel=1e-5)


def test_the_pinned_dense_output_is_near_the_path_inside_the_step(held: TwoContacts) -> None:
    h = 0.002
    _, _, ok, dense = held.step(h)
    assert ok
    dense[1] = dense[0]
    mid = held.integrated(0.5 * h)
    err = max(abs(a - b) for a, b in zip(dense_angles(dense, 1, 0.5 * h), mid, strict=True))
    # Within its own error estimate (the predictor's distance from the solution).
    assert err <= max(dense[0, 13], dense[0, 14])


def test_a_two_contact_segment_steps_by_the_pinned_step(held: TwoContacts) -> None:
    h = 0.002
    nb, nm, _, _ = held.step(h)
    k1b, k1m = held.rate(held.pb, held.pm, held.ym)
    step = Step(held.pb, held.pm, held.ym, h)
    assert solve_or_integrate(held.segment(), step, h, k1b, k1m) == (nb, nm, 0.0, 0.0, True)


def test_which_contacts_pin_the_path() -> None:
    assert pins_path(2, 1.0, 0.0)
    assert pins_path(2, 1.0, 0.3)  # friction shares the load, the path stays pinned
    assert pins_path(1, 0.0, 0.0)  # the base held
    assert not pins_path(1, 0.0, 0.1)  # a held contact with friction may stick
    assert not pins_path(1, 1.0, 0.0)  # both parts free: one contact leaves a freedom
    assert not pins_path(0, 0.0, 0.0)


def test_one_contact_twice_is_not_solved(held: TwoContacts) -> None:
    # Two copies of one contact: parallel gradients, no unique solution.
    act = np.array([held.act[0], held.act[0], -1, -1], dtype=np.int64)
    contacts = held.segment().held._replace(act=act)
    *_, converged = pinned_solve(contacts, held.pb, held.pm, held.ym - 1e-3)
    assert not converged


def test_a_step_past_where_the_contacts_can_hold_is_not_solved(held: TwoContacts) -> None:
    # A descent of a whole D: the two contacts cannot both hold there (or the solve lands
    # far from the predictor): the caller integrates instead.
    _, _, ok, _ = held.step(1.0)
    assert not ok


def test_pinned_solve_returns_the_rate_of_the_contacts(held: TwoContacts) -> None:
    h = 0.002
    nb, nm, vb, vm, converged = pinned_solve(held.segment().held, held.pb, held.pm, held.ym - h)
    assert converged
    assert (vb, vm) == pytest.approx(held.rate(nb, nm, held.ym - h), rel=1e-12)
    assert math.isfinite(vb + vm)


def _held_step(incline, h: float, mu: float = 0.0) -> tuple[float, float, float, float, bool]:
    """A step down the hand-built incline (conftest): one contact, base held."""
    seg = incline.segment(mu=mu)
    k1b, k1m, _, _ = velocity(seg.held, 0.0, incline.phi_m0, incline.y0)
    return solve_or_integrate(seg, incline.step(h), h, k1b, k1m)


@pytest.mark.parametrize("h", [0.05, 0.02, 0.005])
def test_a_held_step_lands_on_the_closed_form_path(incline, h: float) -> None:
    nb, nm, eb, em, ok = _held_step(incline, h)
    assert ok
    assert nb == 0.0
    # Solved, not integrated: the closed form's angle to round-off, with no error estimate.
    assert nm == pytest.approx(incline.phi_m_at(h), abs=1e-13)
    assert (eb, em) == (0.0, 0.0)


def test_a_held_step_with_friction_is_integrated(incline) -> None:
    # With Coulomb friction a held contact may stick: the integrator takes the step (its
    # error estimate is not zero).
    _, _, _, em, ok = _held_step(incline, 0.02, mu=0.1)
    assert ok
    assert em > 0.0


def test_held_solve_returns_the_rate_of_the_held_contact(incline) -> None:
    h = 0.01
    pb, pm, vb, vm, converged = held_solve(
        incline.segment().held, 0.0, incline.phi_m0, incline.y0 - h
    )
    assert converged
    assert pb == 0.0
    wb, wm, _, _ = velocity(incline.segment().held, pb, pm, incline.y0 - h)
    assert (vb, vm) == pytest.approx((wb, wm), rel=1e-12, abs=1e-15)
