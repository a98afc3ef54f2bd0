"""The contact mechanics of issue 10, one reproducer per behaviour.

Every case here failed on the engine before the corner rules (commit 682d52e); each comment
gives the independent engine's answer (Chipmunk2D at converged settings, ``xface crosscheck``
or :func:`xface_core.crosscheck.run_cell`), which is what the test asserts, never a table.
"""

from __future__ import annotations

import math

import pytest

import xface_core as xf
from xface_core import Outcome
from xface_core.errors import GeometryError

PI = math.pi


def test_two_convex_corners_slip_past_each_other_instead_of_pinning() -> None:
    # The notch's rim corner meets the base's corner. Held by both normals at once the
    # corners pinned and the parts turned about them like a linkage into the seat; the
    # corners are alternatives, so they slip past and the parts turn apart. Engine: BAD_MATE,
    # phi_B -0.155, phi_M +0.377.
    p = xf.predict(xf.v_face(0.32988, 2.0), -0.7, PI / 10, margins=False)
    assert p.outcome is Outcome.BAD_MATE
    assert p.phi_m - p.phi_b > 0.3


def test_corners_meeting_near_the_seat_do_not_pin_into_a_false_seat() -> None:
    # S H/D 0.5 r_p 1: the base corner (-0.5, 1.25) met the moving corner; pinned, the run
    # turned into the seat. Engine: BAD_MATE (-0.395, +0.712) below the seat height.
    p = xf.predict(xf.s_face(0.5, 1.0), -0.5, PI / 5, margins=False)
    assert p.outcome is Outcome.BAD_MATE
    assert p.phi_m - p.phi_b > 0.8


@pytest.mark.parametrize(
    ("x0", "theta0", "phi_b", "phi_m", "y_m"),
    [
        # Each run meets a corner with a corner as a vertex slides off an edge's end. The
        # edges that end at the corner but do not carry the contact were left out of the
        # touching set by their gap's error (1.03e-9 D against a touching tolerance of
        # 1e-9): without their ways of moving on the run jammed at once (here at y_M 0.989,
        # phi_M 1.097). Engine: BAD_MATE (-0.269, +0.658) at y_M 0.733.
        (0.95, 0.35 * PI, -0.269, 0.658, 0.733),
        # The same meeting reached with longer steps (a turn cap of 0.05 rad): it jammed
        # at y_M 1.281. Engine: BAD_MATE (-0.926, -0.926) at y_M 0.800.
        (-0.6, -PI / 20, -0.926, -0.926, 0.800),
    ],
)
def test_a_vertex_at_a_corner_meeting_a_corner_slips_on(
    x0: float, theta0: float, phi_b: float, phi_m: float, y_m: float
) -> None:
    p = xf.predict(xf.s_face(1.0, 0.0), x0, theta0, margins=False)
    assert p.outcome is Outcome.BAD_MATE
    assert p.phi_b == pytest.approx(phi_b, abs=0.005)
    assert p.phi_m == pytest.approx(phi_m, abs=0.005)
    assert p.pivot_m[1] == pytest.approx(y_m, abs=0.005)


@pytest.mark.parametrize(
    ("face", "x0", "theta0"),
    [
        # After the pinned stretch the contact set toggled between one and two contacts at
        # one state and the run gave up as a jam; the corner slips and the parts seat.
        ("S", 0.6, -PI / 5),
        # The notch flank lies flush on the male flank (two contacts, one normal): both
        # parts turn together while the pivot creeps down, no jam.
        ("V", -0.9, 0.0),
        # A false jam with neither signature.
        ("S", -0.5, -PI / 40),
    ],
)
def test_slipping_corners_and_flush_flanks_seat_where_the_engine_seats(
    face: str, x0: float, theta0: float
) -> None:
    p = xf.predict(xf.make_face(face, 0.0625, 1.0), x0, theta0, margins=False)
    assert p.outcome is Outcome.SEATED, p.reason


def test_a_jam_is_reached_without_chatter() -> None:
    # One contact released and re-touched about a dozen times at one state (27 events, 25
    # contact changes) before the run gave up.
    p = xf.predict(xf.s_face(0.5, 1.0), 0.8, -0.5497787143782138, margins=False)
    assert p.outcome is Outcome.BAD_MATE
    assert p.counters.events <= 8
    assert p.counters.contact_changes <= 4


def test_an_isolated_bad_mate_among_seating_neighbours_seats() -> None:
    # Every neighbour within 1e-12..1e-6 seats.
    p = xf.predict(
        xf.s_face(0.2694506363400104, 0.0), -0.25897290679567986, 0.9492199440672606,
        margins=False,
    )  # fmt: skip
    assert p.outcome is Outcome.SEATED


def test_friction_can_stop_a_part_turning_away() -> None:
    # Physical non-monotonicity: frictionless (and at mu 0.2) the moving part turns to
    # 1.84 rad and jams; from mu 0.3 friction holds it and the parts seat. The engine gives
    # the same at both step sizes (BAD_MATE at mu 0.1 and 0.2, SEATED at 0.3 to 0.6); the
    # old slip-state choice seated only at mu 0.4.
    design = xf.x_face(0.6253735159602775, 0.0)
    x0, theta0 = -0.6102404552338436, 1.5419709276006972
    low = xf.predict(design, x0, theta0, friction=0.2, margins=False)
    assert low.outcome is Outcome.BAD_MATE
    assert low.phi_m == pytest.approx(1.837, abs=0.01)
    for mu in (0.3, 0.4, 0.6):
        assert xf.predict(design, x0, theta0, friction=mu, margins=False).seated


def test_a_design_with_too_many_contact_pairs_is_rejected_up_front() -> None:
    # A 400-vertex outline against another is 320 000 pairs, fine; 800 against 800 would be
    # a 200 MB pair table and seconds per prediction.
    n = 798
    top = [(0.5 - k / (n - 1), 0.05 * math.sin(12 * k / n)) for k in range(n)]
    outline = [(-0.5, -1.0), (0.5, -1.0), *top]
    with pytest.raises(GeometryError, match="vertex-edge pairs"):
        xf.custom_face([outline], [outline], mated_distance=2.0)


@pytest.mark.parametrize("x0", [-0.1, 0.0, 0.1])
def test_a_corner_held_in_a_notch_moves_with_it(x0: float) -> None:
    # S H/D 0.18946, r_p 0, the moving part turned a quarter turn: its corner drops into the
    # base's notch and the two turn together into the seat. The corner test compared the
    # corner's move against the notch, zero to 1e-22 there, with a tolerance relative to that
    # difference and called the motion a cut (a false jam). Engine: SEATED, at xface's pose.
    p = xf.predict(xf.s_face(0.18946, 0.0), x0, -PI / 2, margins=False)
    assert p.outcome is Outcome.SEATED
