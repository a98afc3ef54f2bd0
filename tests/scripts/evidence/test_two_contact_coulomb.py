"""scripts/evidence/two_contact_coulomb.py: the quasi-static Coulomb problem solved by enumeration.

Hand-made contacts whose answers are known on paper (an incline below and above its wedge
angle, a flat edge without friction, a vertex at the bottom of a notch) make the tests able to
fail; one of xface's stops (X 1/3, mu 0.3, issue 37) is solved at its recorded state.
"""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
coulomb = importlib.import_module("two_contact_coulomb")
State: Any = coulomb.State
Contact: Any = coulomb.Contact

SLOPE = 0.3  # rad: the incline's angle; its wedge condition is mu < tan(0.3) = 0.309
LEVER = 2.0  # D: the moving vertex sits this far straight below its pivot


def _incline_contact(pivot: tuple[float, float]) -> Any:
    """A moving vertex LEVER below its pivot on a held base's edge sloping down to the right
    (outward normal (sin a, cos a), the edge running right to left like a CCW outline's top)."""
    a = SLOPE
    return Contact(
        label="incline",
        vertex_part="moving",
        point=(pivot[0], pivot[1] - LEVER),
        normal=(math.sin(a), math.cos(a)),
        tangent=(-math.cos(a), math.sin(a)),
    )


def test_an_incline_below_its_wedge_angle_slides_one_way_with_the_hand_solution() -> None:
    # By hand: the vertex moves (LEVER w, -1); no gap rate gives w = cot(a) / LEVER; the slip
    # runs along -t, so friction is +mu lam along t; the moment LEVER F_x = c_M w gives
    # lam = cot(a) / (LEVER^2 (sin a - mu cos a)).
    state = State(phi_b=0.0, phi_m=0.1, x0=0.3, y_m=5.0)
    mu = 0.2
    motions = coulomb.admissible_motions([_incline_contact((0.3, 5.0))], state, mu, math.inf)
    assert len(motions) == 1
    (m,) = motions
    assert m.modes == ("slide-",)
    assert m.w_b == pytest.approx(0.0, abs=1e-12)
    assert m.w_m == pytest.approx(1.0 / math.tan(SLOPE) / LEVER, rel=1e-12)
    lam = 1.0 / math.tan(SLOPE) / (LEVER**2 * (math.sin(SLOPE) - mu * math.cos(SLOPE)))
    assert m.lam[0] == pytest.approx(lam, rel=1e-12)
    assert m.friction[0] == pytest.approx(mu * lam, rel=1e-12)
    assert m.slip_rate[0] == pytest.approx(-1.0 / math.sin(SLOPE), rel=1e-12)


@pytest.mark.parametrize("mu", [0.32, 0.5, 2.0])
def test_an_incline_above_its_wedge_angle_is_a_wedge(mu: float) -> None:
    state = State(phi_b=0.0, phi_m=0.1, x0=0.3, y_m=5.0)
    assert coulomb.admissible_motions([_incline_contact((0.3, 5.0))], state, mu, math.inf) == []


def test_the_wedge_angle_of_an_incline_is_found_by_bisection() -> None:
    state = State(phi_b=0.0, phi_m=0.1, x0=0.3, y_m=5.0)
    crit = coulomb.critical_friction([_incline_contact((0.3, 5.0))], state, math.inf, hi=1.0)
    assert crit == pytest.approx(math.tan(SLOPE), abs=1e-9)


def test_a_frictionless_vertex_on_a_flat_edge_has_exactly_one_sliding_motion() -> None:
    # By hand (base pivot at the origin, c_B = 2 c_M): the moving vertex at (a, 1) on the base's
    # top edge, moving pivot (0, 2). Moments a lam = w_M, -a lam = 2 w_B and no gap rate
    # -1 + a (w_M - w_B) = 0 give lam = 2 / (3 a^2), w_M = 2 / (3 a), w_B = -1 / (3 a); the
    # vertex slips at w_M + w_B = 1 / (3 a) along +x, i.e. along -t.
    a = 0.4
    flat = Contact("flat", "moving", (a, 1.0), (0.0, 1.0), (-1.0, 0.0))
    motions = coulomb.admissible_motions([flat], State(0.0, 0.0, 0.0, 2.0), 0.0, 2.0)
    assert [m.modes for m in motions] == [("slide-",)]
    (m,) = motions
    assert (m.w_b, m.w_m) == pytest.approx((-1 / (3 * a), 2 / (3 * a)), rel=1e-12)
    assert m.lam[0] == pytest.approx(2 / (3 * a * a), rel=1e-12)
    assert m.drive == pytest.approx(-m.lam[0], rel=1e-12)  # the drive pushes the part down


@pytest.mark.parametrize("mu", [0.0, 0.3, 5.0])
def test_a_vertex_at_the_bottom_of_a_symmetric_notch_cannot_descend(mu: float) -> None:
    # Both flanks face the vertex; the held base cannot turn; the vertex moves (LEVER w, -1),
    # which cuts into one flank or the other whatever w is, and friction cannot help.
    pivot = (0.0, 3.0)
    tip = (0.0, 3.0 - LEVER)
    half = 0.6
    left = Contact(
        "left", "moving", tip, (math.cos(half), math.sin(half)), (math.sin(half), -math.cos(half))
    )
    right = Contact(
        "right", "moving", tip, (-math.cos(half), math.sin(half)), (math.sin(half), math.cos(half))
    )
    state = State(0.0, 0.0, *pivot)
    assert coulomb.admissible_motions([left, right], state, mu, math.inf) == []
    # Either flank alone lets it slide down (a check that the wedge comes from the pair).
    assert coulomb.admissible_motions([left], state, mu, math.inf) or mu > 1 / math.tan(half)


def _random_contact(rng: np.random.Generator, state: Any) -> Any:
    angle = rng.uniform(0.0, 2 * math.pi)
    normal = (math.cos(angle), math.sin(angle))
    point = (float(rng.uniform(-1, 1)), float(rng.uniform(0.5, state.y_m - 0.5)))
    part = "moving" if rng.uniform() < 0.5 else "base"
    return Contact("random", part, point, normal, (normal[1], -normal[0]))


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), ratio=st.floats(0.1, 10.0))
def test_without_friction_one_contact_moves_by_the_least_dissipation_projection(
    seed: int, ratio: float
) -> None:
    # Frictionless, the motion is the projection of "no turn" onto {gdot >= 0} in the metric
    # diag(c_B, c_M): w = lam C^-1 gn with lam = max(0, -gn0) / (gn' C^-1 gn). The script
    # computes the moments from cross products; that they equal lam gn (reciprocity) is checked.
    rng = np.random.default_rng(seed)
    state = State(0.0, 0.0, float(rng.uniform(-1, 1)), 3.0)
    contact = _random_contact(rng, state)
    gn, gn0, *_ = coulomb.contact_kinematics(contact, state)
    c_inv = np.array([1.0 / ratio, 1.0])
    lam = max(0.0, -gn0) / float(gn @ (c_inv * gn))
    rates = coulomb.distinct_rates(coulomb.admissible_motions([contact], state, 0.0, ratio))
    assert len(rates) == 1
    assert rates[0] == pytest.approx(tuple(lam * c_inv * gn), rel=1e-7, abs=1e-9)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), mu=st.floats(0.0, 1.0))
def test_the_mirror_image_of_a_state_has_the_mirrored_motions(seed: int, mu: float) -> None:
    rng = np.random.default_rng(seed)
    state = State(0.0, 0.0, float(rng.uniform(-1, 1)), 3.0)
    contacts = [_random_contact(rng, state) for _ in range(2)]

    def mirrored(c: Any) -> Any:
        # x -> -x: points and normals mirror; any tangent along the edge will do (it only
        # names the slip direction), so the mirrored one is negated
        return Contact(
            c.label,
            c.vertex_part,
            (-c.point[0], c.point[1]),
            (-c.normal[0], c.normal[1]),
            (c.tangent[0], -c.tangent[1]),
        )

    mirror_state = State(0.0, 0.0, -state.x0, state.y_m)
    here = coulomb.admissible_motions(contacts, state, mu, 1.0)
    there = coulomb.admissible_motions([mirrored(c) for c in contacts], mirror_state, mu, 1.0)
    got = sorted((round(-m.w_b, 6), round(-m.w_m, 6)) for m in there)
    assert sorted((round(m.w_b, 6), round(m.w_m, 6)) for m in here) == got


#: Where xface stops X H/D 1 r_p 3, mu 0.3, x0 -0.7 D, theta0 pi/10 (predict at ca5ad80).
X13_STOP = State(
    phi_b=-0.06553922217061457, phi_m=0.26067280953683464, x0=-0.7, y_m=7.1517920968086255
)


def test_xface_stop_on_x_1_3_is_a_wedge_at_its_friction_and_slides_below_it() -> None:
    from xface_core import x_face

    contacts = coulomb.find_contacts(x_face(1.0, 3.0), X13_STOP)
    assert len(contacts) == 2
    assert all(c.end_distance > 0.1 for c in contacts)  # inside their edges: no corner rule
    assert coulomb.admissible_motions(contacts, X13_STOP, 0.3, 1.0) == []
    (m,) = coulomb.admissible_motions(contacts, X13_STOP, 0.28, 1.0)
    assert m.modes == ("slide+", "slide-")
    assert (m.w_b, m.w_m) == pytest.approx((3.204, -3.177), abs=1e-3)
    assert m.drive < 0.0  # the drive pushes
    assert 0.28 < coulomb.critical_friction(contacts, X13_STOP, 1.0, hi=0.3) < 0.3


#: Where xface stops S H/D 0.0625 r_p 1, mu 0.2, x0 -0.6 D, theta0 0.15 pi (predict at
#: 43ba2f6): the faces aligned, turning together on two held pairs of their flanks.
S_STOP = State(phi_b=0.2824204554112048, phi_m=0.28242045541120386, x0=-0.6, y_m=1.9783354924664334)


def _s_face() -> Any:
    from xface_core import s_face

    return s_face(0.0625, 1.0)


def test_pair_gap_follows_a_found_pair_to_another_state() -> None:
    face = _s_face()
    contacts = coulomb.find_contacts(face, S_STOP)
    assert [coulomb.pair_gap(face, S_STOP, c) for c in contacts] == pytest.approx(
        [c.gap for c in contacts], abs=1e-15
    )
    moved = State(S_STOP.phi_b + 0.01, S_STOP.phi_m - 0.02, S_STOP.x0, S_STOP.y_m + 0.03)
    wide = {c.label: c.gap for c in coulomb.find_contacts(face, moved, touch=0.5)}
    for c in contacts:
        assert coulomb.pair_gap(face, moved, c) == pytest.approx(wide[c.label], abs=1e-15)
        assert abs(wide[c.label]) > 1e-4  # the move opened or closed the pair


@pytest.mark.parametrize("rise", [3e-2, 1e-3, -1e-3])
def test_on_contacts_keeps_every_pair_closed_at_another_height(rise: float) -> None:
    face = _s_face()
    contacts = coulomb.find_contacts(face, S_STOP)
    here, left = coulomb.on_contacts(face, contacts, S_STOP, S_STOP.y_m + rise)
    assert left < 1e-13
    assert max(abs(coulomb.pair_gap(face, here, c)) for c in contacts) == left
    assert here.y_m == S_STOP.y_m + rise
    assert here.x0 == S_STOP.x0
    assert abs(here.phi_m - S_STOP.phi_m) > 1e-4  # the parts had to turn to keep touching


def test_xface_stop_on_s_0_0625_is_a_pole_of_the_drive() -> None:
    verdict = coulomb.rigid_stop(_s_face(), S_STOP, 0.2, 1.0)
    assert verdict.kind == "pole"
    assert verdict.contacts == 2
    assert verdict.pole is not None
    assert 0.95 < verdict.pole < 1.0


def test_at_a_lower_friction_the_same_state_is_no_stop() -> None:
    # At mu 0.1 the faces slide on through this state (xface seats from the same start).
    verdict = coulomb.rigid_stop(_s_face(), S_STOP, 0.1, 1.0)
    assert verdict.kind == ""
    assert verdict.detail == "a motion is admissible 0.0001 D past the stop"


def test_a_state_before_the_stop_is_no_stop() -> None:
    face = _s_face()
    before, _ = coulomb.on_contacts(face, coulomb.find_contacts(face, S_STOP), S_STOP, 1.99)
    assert coulomb.rigid_stop(face, before, 0.2, 1.0).kind == ""


def test_xface_stop_on_x_1_3_is_a_wedge_for_rigid_stop() -> None:
    from xface_core import x_face

    verdict = coulomb.rigid_stop(x_face(1.0, 3.0), X13_STOP, 0.3, 1.0)
    assert verdict.kind == "wedge"
    assert verdict.critical_mu is not None
    assert 0.28 < verdict.critical_mu < 0.3


def test_at_a_pole_no_member_of_a_near_null_family_passes_for_a_motion() -> None:
    # At the stop the balance is singular: a point far along a direction null only to
    # round-off (forces of 1e12) met a tolerance relative to the whole solution with a gap
    # rate of -0.54; every equation is now held to its own scale.
    face = _s_face()
    contacts = coulomb.find_contacts(face, S_STOP)
    assert coulomb.admissible_motions(contacts, S_STOP, 0.2, 1.0) == []
    verdict = coulomb.rigid_stop(face, S_STOP, 0.2, 1.0)
    assert verdict.kind == "pole"  # the pole test comes first
