"""Hand-worked cases: the integrated path against closed-form geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core.contact import pair_table


def _closed_form_phi_m(row: np.ndarray, x0: float, y_m: float, near: float) -> float:
    """Angle of a moving part (base held fixed) whose vertex v lies on the fixed base edge's
    line: n . (P_M - R(phi) v - e0) = 0, i.e. A cos(phi) + B sin(phi) = C."""
    vx, vy, e0x, e0y, nx, ny = row[1], row[2], row[3], row[4], row[7], row[8]
    a = -(nx * vx + ny * vy)
    b = nx * vy - ny * vx
    c = -(nx * (x0 - e0x) + ny * (y_m - e0y))
    r, psi = math.hypot(a, b), math.atan2(b, a)
    acos = math.acos(max(-1.0, min(1.0, c / r)))
    candidates = [psi + acos, psi - acos]
    candidates = [(t + math.pi) % (2 * math.pi) - math.pi for t in candidates]
    return min(candidates, key=lambda t: abs(t - near))


@pytest.mark.parametrize(("face", "x0", "theta0"), [("X", 0.3, 0.25), ("X", -0.6, -0.2)])
def test_vertex_sliding_on_fixed_incline_follows_closed_form(
    face: str, x0: float, theta0: float
) -> None:
    design = xf.make_face(face, 0.5, 1.0)
    p = xf.predict(design, x0, theta0, damping_ratio=math.inf)
    table = pair_table(design).data
    checked = 0
    for k in range(len(p.path)):
        pairs = p.path.contact_pairs[k]
        active = pairs[pairs >= 0]
        if len(active) != 1 or table[active[0], 0] != 0.0:  # one moving vertex on a base edge
            continue
        assert p.path.phi_b[k] == 0.0
        expected = _closed_form_phi_m(table[active[0]], x0, p.path.pivot_m[k, 1], p.path.phi_m[k])
        assert p.path.phi_m[k] == pytest.approx(expected, abs=1e-9)
        checked += 1
    assert checked >= 5


def test_equal_damping_turns_both_parts() -> None:
    p = xf.predict(xf.x_face(0.5, 1.0), 0.3, 0.25)
    assert np.ptp(p.path.phi_b) > 1e-3


def test_locked_base_never_turns() -> None:
    p = xf.predict(xf.x_face(0.5, 1.0), 0.3, 0.25, damping_ratio=math.inf)
    assert np.all(p.path.phi_b == 0.0)


def test_seat_angle_matches_the_distance_condition() -> None:
    # Seated means P_M = L(-sin phi, cos phi) with x = x0: sin phi = -x0 / L.
    design = xf.x_face(1.0, 1.0)
    for x0 in (-0.5, 0.25, 0.9):
        p = xf.predict(design, x0, 0.0)
        assert p.outcome is xf.Outcome.SEATED
        assert math.sin(p.phi_m) == pytest.approx(-x0 / design.mated_distance, abs=1e-9)


@pytest.mark.parametrize("h", [0.25, 0.5, 1.0, 2.0])
@pytest.mark.parametrize("x0", [0.2, -0.6])
def test_aligned_slide_seats_below_the_incline_slope_and_jams_above(h: float, x0: float) -> None:
    # Sliding along an incline of slope H/D needs mu < tan(alpha) = H/D (the wedge condition).
    design = xf.x_face(h, 1.0)
    assert xf.predict(design, x0, 0.0, friction=0.8 * h).outcome is xf.Outcome.SEATED
    jammed = xf.predict(design, x0, 0.0, friction=1.25 * h)
    assert jammed.outcome is xf.Outcome.BAD_MATE


def test_zero_friction_is_the_frictionless_model() -> None:
    design = xf.s_face(0.5, 1.0)
    a = xf.predict(design, 0.3, 0.2)
    b = xf.predict(design, 0.3, 0.2, friction=0.0)
    assert (a.phi_b, a.phi_m, a.pivot_m) == (b.phi_b, b.phi_m, b.pivot_m)


def test_friction_never_enlarges_the_flat_x_face_map() -> None:
    design = xf.x_face(0.5, 1.0)
    m = [xf.acceptance_map(design, friction=mu, grid=21).M for mu in (0.0, 0.2, 0.4)]
    assert m[0] >= m[1] >= m[2]
