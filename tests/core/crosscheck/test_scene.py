"""The Chipmunk2D scene: geometry helpers, classification of end states, and real runs of
cells whose answer does not depend on the engine's artefacts."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

import xface_core as xf
from xface_core.crosscheck.scene import (
    DEFAULT_ENGINE,
    EngineSettings,
    classify,
    convex_pieces,
    rounded_polygon,
    run_cell,
    vertical_gap,
)

X_FACE = xf.x_face(0.25, 2.0)
L = X_FACE.mated_distance  # 4.25
SQUARE = np.array([(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)])


# --- geometry -------------------------------------------------------------------------------


@pytest.mark.parametrize("design", [xf.v_face(0.5, 1.0), xf.s_face(0.5, 1.0)])
def test_convex_pieces_cover_a_non_convex_layer_exactly(design: xf.FaceDesign) -> None:
    for poly in (*design.base_layers, *design.moving_layers):
        pieces = convex_pieces(poly)
        for p in pieces:
            shape = shapely.Polygon(p)
            assert shape.convex_hull.area == pytest.approx(shape.area, rel=1e-12)
        union = shapely.union_all([shapely.Polygon(p) for p in pieces])
        assert union.symmetric_difference(shapely.Polygon(poly)).area < 1e-12


def test_rounding_keeps_the_edges_and_cuts_only_the_corners() -> None:
    r = 0.002
    rounded = shapely.Polygon(rounded_polygon(SQUARE, r))
    # Four corners of (1 - pi/4) r^2 each come off; the edge midpoints stay where they were.
    assert shapely.Polygon(SQUARE).area - rounded.area == pytest.approx((4 - math.pi) * r * r, 1e-2)
    for mid in [(0.0, 0.5), (0.5, 0.0), (0.0, -0.5), (-0.5, 0.0)]:
        assert rounded.exterior.distance(shapely.Point(mid)) < 1e-12
    assert np.array_equal(rounded_polygon(SQUARE, 0.0), SQUARE)


def test_vertical_gap_is_the_drop_to_first_touch_either_way_round() -> None:
    below = SQUARE
    assert vertical_gap(SQUARE + np.array([0.3, 1.25]), below) == pytest.approx(0.25)
    # A base vertex under a moving edge: a diamond under a square.
    diamond = np.array([(0.0, 0.0), (0.5, 0.5), (0.0, 1.0), (-0.5, 0.5)])
    assert vertical_gap(SQUARE + np.array([0.0, 2.0]), diamond) == pytest.approx(0.5)
    assert vertical_gap(SQUARE + np.array([2.0, 3.0]), below) == math.inf  # passes beside it
    touching = SQUARE + np.array([0.0, 0.99995])  # overlapping by 5e-5: inside the margin
    assert vertical_gap(touching, below, margin=1e-4) == pytest.approx(-5e-5)


# --- classification of end states -------------------------------------------------------------


def _classify(**state: float | bool) -> str | None:
    """The outcome's name for the aligned seated state with ``state`` changed (None: go on)."""
    base: dict[str, float | bool] = {
        "phi_b": 0.0,
        "phi_m": 0.0,
        "x_m": 0.0,
        "y_m": L,
        "x0": 0.0,
        "L": L,
        "stalled": True,
        "clear_ahead": False,
        "had_contact": True,
    }
    verdict = classify(**{**base, **state})  # type: ignore[arg-type]
    return None if verdict is None else verdict[0].name


def test_a_stall_at_the_mated_pose_is_seated_within_the_tolerances() -> None:
    # 1e-2 rad between the angles; 1e-2 D per D of L (4.25 here) for the pivot.
    phi = math.asin(-0.3 / L)
    y = L * math.cos(phi)
    assert _classify(x0=0.3, x_m=0.3, phi_b=phi, phi_m=phi + 0.009, y_m=y) == "SEATED"
    assert _classify(x0=0.3, x_m=0.3, phi_b=phi, phi_m=phi + 0.011, y_m=y) == "BAD_MATE"
    assert _classify(x0=0.3, x_m=0.3, phi_b=phi, phi_m=phi, y_m=y + 0.05) == "BAD_MATE"


def test_end_states_map_to_their_outcomes() -> None:
    outcome = {
        "jammed": _classify(phi_m=0.3, y_m=L + 0.2),
        "below the seat": _classify(y_m=L - 0.05, stalled=False),
        "passed": _classify(clear_ahead=True, y_m=L - 1.0),
        "never touched": _classify(clear_ahead=True, had_contact=False),
        "spun": _classify(phi_m=3.2, stalled=False, y_m=L + 1.0),
        "still moving": _classify(phi_m=0.3, y_m=L + 0.2, stalled=False),
        "moving through the seat": _classify(stalled=False),
    }
    assert outcome == {
        "jammed": "BAD_MATE",
        "below the seat": "BAD_MATE",
        "passed": "PASSED",
        "never touched": "NO_CONTACT",
        "spun": "BAD_MATE",
        "still moving": None,
        "moving through the seat": None,
    }


def test_settings_are_validated() -> None:
    with pytest.raises(ValueError, match="step"):
        EngineSettings(step=0.0)
    with pytest.raises(ValueError, match="corner_radius"):
        EngineSettings(corner_radius=-1e-3)


# --- real runs --------------------------------------------------------------------------------


def test_aligned_pose_seats_with_sharp_and_rounded_corners() -> None:
    for settings in (DEFAULT_ENGINE, DEFAULT_ENGINE.rounded()):
        run = run_cell(X_FACE, 0.0, 0.0, settings=settings)
        assert run.outcome is xf.Outcome.SEATED, run
        assert abs(run.phi_b) < 1e-3
        assert abs(run.phi_m) < 1e-3
        assert run.y_m == pytest.approx(L, abs=1e-3)
        assert not run.hit_budget


def test_an_offset_seat_lands_on_xface_s_angle() -> None:
    run = run_cell(X_FACE, 0.3, 0.2)
    ours = xf.predict(X_FACE, 0.3, 0.2, margins=False)
    assert run.outcome is ours.outcome is xf.Outcome.SEATED
    assert run.phi_m == pytest.approx(ours.phi_m, abs=1e-3)
    assert run.phi_b == pytest.approx(ours.phi_b, abs=1e-3)


def test_far_out_pose_fails() -> None:
    run = run_cell(X_FACE, 0.95, 1.4)
    assert run.outcome is xf.Outcome.BAD_MATE
    assert run.reason == "below the seat height"


def test_a_fixed_base_does_not_turn() -> None:
    run = run_cell(X_FACE, 0.3, 0.2, physics=xf.Physics(damping_ratio=math.inf))
    ours = xf.predict(X_FACE, 0.3, 0.2, damping_ratio=math.inf, margins=False)
    assert run.phi_b == 0.0
    assert run.outcome is ours.outcome


def test_bad_input_and_out_of_reach_end_before_the_engine() -> None:
    assert run_cell(X_FACE, math.nan, 0.0).outcome is xf.Outcome.INVALID_INPUT
    assert run_cell(X_FACE, 5.0, 0.0).outcome is xf.Outcome.OUT_OF_REACH
    overlapping = run_cell(X_FACE, 0.0, 0.0, y_start=3.0)
    assert overlapping.outcome is xf.Outcome.INVALID_INPUT


def test_an_exhausted_budget_is_unresolved_not_a_slip() -> None:
    tight = EngineSettings(max_travel=0.01)
    run = run_cell(X_FACE, 0.3, 0.2, settings=tight)
    assert run.outcome is xf.Outcome.UNRESOLVED
    assert run.hit_budget


# --- the stepping loop's shortcuts ------------------------------------------------------------


def _step_through_space_only(space: object) -> object:
    def step_each(dt: float, n: int) -> None:
        for _ in range(n):
            space.step(dt)  # type: ignore[attr-defined]

    return step_each


@pytest.mark.parametrize(
    ("design", "physics", "pose"),
    [
        (X_FACE, xf.Physics(), (0.3, 0.2)),
        (xf.v_face(0.5, 1.0), xf.Physics(friction=0.3), (-0.1, -0.2)),
        (xf.s_face(0.5, 1.0), xf.Physics(damping_ratio=2.0), (0.1, 0.3)),
    ],
)
def test_stepping_through_the_c_step_changes_no_bit_of_a_run(
    monkeypatch: pytest.MonkeyPatch,
    design: xf.FaceDesign,
    physics: xf.Physics,
    pose: tuple[float, float],
) -> None:
    from xface_core.crosscheck import scene

    for settings in (DEFAULT_ENGINE, DEFAULT_ENGINE.rounded()):
        fast = run_cell(design, *pose, physics=physics, settings=settings)
        with monkeypatch.context() as patched:
            patched.setattr(scene, "_stepper", _step_through_space_only)
            wrapped = run_cell(design, *pose, physics=physics, settings=settings)
        assert fast == wrapped
        assert fast.steps > 2 * settings.check_every  # stepped in batches, not ended at once


@given(
    st.lists(
        st.tuples(*(st.floats(-10.0, 10.0, allow_nan=False) for _ in range(3))),
        min_size=1,
        max_size=40,
    ),
    st.integers(1, 6),
)
def test_the_stall_window_moves_as_the_mean_of_its_two_halves(
    states: list[tuple[float, float, float]], half: int
) -> None:
    from xface_core.crosscheck.scene import _StallWindow

    window = _StallWindow(half)
    for state in states:
        window.push(*state)
    last = np.asarray(states[-2 * half :])
    assert window.full == (len(states) >= 2 * half)
    if window.full:
        dy, db, dm = last[half:].mean(axis=0) - last[:half].mean(axis=0)
        assert window.moved((2.0, 3.0)) == math.sqrt(dy * dy + 2.0 * db * db + 3.0 * dm * dm)
    window.clear()
    assert not window.full
