"""Tests of xface_core.frames: quaternion -> planar yaw, and the relative pose convention."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from xface_core.errors import InputError, XfaceValueError
from xface_core.frames import (
    AbsurdDistanceError,
    DockStart,
    NonFiniteInputError,
    NonPlanarOrientationError,
    NonUnitQuaternionError,
    PlanarPose,
    check_distance,
    mated_pose,
    moving_pose,
    path_poses,
    planar_yaw,
    relative_pose_to_start,
    start_to_relative_pose,
    wrap_angle,
    yaw_to_quaternion,
)
from xface_core.geometry import FaceDesign, s_face, v_face, x_face

Quaternion = tuple[float, float, float, float]

angles = st.floats(min_value=-50.0, max_value=50.0, allow_nan=False)
yaws = st.floats(min_value=-math.pi, max_value=math.pi)


def quaternion_multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    """Hamilton product of two (x, y, z, w) quaternions: the rotation a after b."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def roll_quaternion(roll: float) -> Quaternion:
    return (math.sin(0.5 * roll), 0.0, 0.0, math.cos(0.5 * roll))


def pitch_quaternion(pitch: float) -> Quaternion:
    return (0.0, math.sin(0.5 * pitch), 0.0, math.cos(0.5 * pitch))


def angle_difference(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2.0 * math.pi))


@given(angles)
def test_wrap_angle_lands_in_half_open_interval_and_keeps_the_direction(angle: float) -> None:
    wrapped = wrap_angle(angle)
    assert -math.pi < wrapped <= math.pi
    assert math.cos(wrapped) == pytest.approx(math.cos(angle), abs=1e-12)
    assert math.sin(wrapped) == pytest.approx(math.sin(angle), abs=1e-12)


def test_wrap_angle_maps_both_ends_of_the_circle_to_plus_pi() -> None:
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert wrap_angle(3.0 * math.pi) == pytest.approx(math.pi)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_wrap_angle_rejects_non_finite(bad: float) -> None:
    with pytest.raises(NonFiniteInputError):
        wrap_angle(bad)


@given(yaws)
def test_planar_yaw_inverts_yaw_to_quaternion(yaw: float) -> None:
    assert angle_difference(planar_yaw(*yaw_to_quaternion(yaw)), yaw) < 1e-12


@given(yaws)
def test_negated_quaternion_is_the_same_yaw(yaw: float) -> None:
    qx, qy, qz, qw = yaw_to_quaternion(yaw)
    assert angle_difference(planar_yaw(-qx, -qy, -qz, -qw), yaw) < 1e-12


def test_slightly_unnormalised_quaternion_within_tolerance_is_accepted() -> None:
    qx, qy, qz, qw = ((1.0 + 5e-4) * c for c in yaw_to_quaternion(0.7))
    assert planar_yaw(qx, qy, qz, qw) == pytest.approx(0.7, abs=1e-12)


@pytest.mark.parametrize("scale", [0.0, 0.99, 1.01, 2.0])
def test_unnormalised_quaternion_is_rejected(scale: float) -> None:
    q = tuple(scale * c for c in yaw_to_quaternion(0.7))
    with pytest.raises(NonUnitQuaternionError, match="norm"):
        planar_yaw(*q)


@pytest.mark.parametrize("index", range(4))
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_quaternion_component_is_rejected(index: int, bad: float) -> None:
    q = list(yaw_to_quaternion(0.3))
    q[index] = bad
    with pytest.raises(NonFiniteInputError):
        planar_yaw(*q)


@pytest.mark.parametrize("make_tilt", [roll_quaternion, pitch_quaternion])
@given(yaw=yaws, tilt=st.floats(min_value=-0.04, max_value=0.04))
def test_small_roll_or_pitch_is_accepted_and_keeps_the_yaw(
    make_tilt: Callable[[float], Quaternion], yaw: float, tilt: float
) -> None:
    q = quaternion_multiply(yaw_to_quaternion(yaw), make_tilt(tilt))  # yaw after tilt
    assert angle_difference(planar_yaw(*q, max_tilt_rad=0.05), yaw) < 1e-9


@pytest.mark.parametrize("make_tilt", [roll_quaternion, pitch_quaternion])
@pytest.mark.parametrize("tilt", [-0.3, 0.06, 1.0, math.pi])
def test_roll_or_pitch_beyond_tolerance_is_rejected(
    make_tilt: Callable[[float], Quaternion], tilt: float
) -> None:
    q = quaternion_multiply(yaw_to_quaternion(1.0), make_tilt(tilt))
    with pytest.raises(NonPlanarOrientationError, match="tilts"):
        planar_yaw(*q, max_tilt_rad=0.05)


def test_the_tilt_tolerance_is_the_combined_roll_and_pitch() -> None:
    # Roll 0.04 then pitch 0.04 tilts the z axis by about 0.0566 rad.
    q = quaternion_multiply(roll_quaternion(0.04), pitch_quaternion(0.04))
    planar_yaw(*q, max_tilt_rad=0.06)
    with pytest.raises(NonPlanarOrientationError):
        planar_yaw(*q, max_tilt_rad=0.055)


def test_input_errors_are_xface_value_errors() -> None:
    # The ROS node and callers catching ValueError both rely on this hierarchy.
    for cls in (
        NonFiniteInputError,
        NonUnitQuaternionError,
        NonPlanarOrientationError,
        AbsurdDistanceError,
    ):
        assert issubclass(cls, InputError)
        assert issubclass(cls, ValueError)


@given(
    x=st.floats(min_value=-1.0, max_value=1.0),
    y=st.floats(min_value=-1.0, max_value=1.0),
    yaw=yaws,
)
def test_start_conversion_round_trips(x: float, y: float, yaw: float) -> None:
    pose = PlanarPose(x, y, yaw)
    start = relative_pose_to_start(pose)
    assert start.x0 == x
    assert start.y_start == y
    assert -math.pi < start.theta0 <= math.pi
    back = start_to_relative_pose(start)
    assert back.x == x
    assert back.y == y
    assert angle_difference(back.yaw, yaw) < 1e-12


def test_facing_pose_is_theta_zero() -> None:
    # The two +y axes point at each other: the moving part is in the mated orientation.
    start = relative_pose_to_start(PlanarPose(0.01, 0.3, math.pi))
    assert start == DockStart(x0=0.01, theta0=0.0, y_start=0.3)
    # A moving part turned a little counter-clockwise from facing.
    assert relative_pose_to_start(PlanarPose(0.0, 0.3, -math.pi + 0.1)).theta0 == (
        pytest.approx(0.1)
    )


@pytest.mark.parametrize("design", [x_face(0.25, 2.0, width=0.05), v_face(1.0, 0.5, width=2.0)])
def test_mated_pose_at_zero_offset_is_l_straight_up_facing(design: FaceDesign) -> None:
    pose = mated_pose(design, 0.0)
    length = design.mated_distance * design.width
    assert pose.x == pytest.approx(0.0, abs=1e-15)
    assert pose.y == pytest.approx(length)
    assert pose.yaw == pytest.approx(math.pi)


@given(fraction=st.floats(min_value=-1.0, max_value=1.0))
def test_mated_pose_keeps_x0_at_pivot_distance_l(fraction: float) -> None:
    design = s_face(0.5, 1.0, width=0.1)
    length = design.mated_distance * design.width
    x0 = fraction * length
    pose = mated_pose(design, x0)
    assert pose.x == pytest.approx(x0, abs=1e-12)
    assert math.hypot(pose.x, pose.y) == pytest.approx(length)
    # The moving part seats turned by phi = asin(-x0 / L), which is its simulator angle.
    start = relative_pose_to_start(pose)
    assert start.theta0 == pytest.approx(design.seated_angle(x0), abs=1e-12)


def test_mated_pose_out_of_reach_raises() -> None:
    design = x_face(0.25, 0.0, width=1.0)
    with pytest.raises(XfaceValueError, match="mated distance"):
        mated_pose(design, 0.3)


@given(
    x=st.floats(min_value=-1.0, max_value=1.0),
    y=st.floats(min_value=0.5, max_value=5.0),
    phi=st.floats(min_value=-1.5, max_value=1.5),
)
def test_moving_pose_places_the_moving_outline_where_the_geometry_does(
    x: float, y: float, phi: float
) -> None:
    # A body point v of the moving frame, transformed by the relative pose (a plain rigid
    # transform), must land where the simulator's geometry puts it (P - R(phi) v).
    design = x_face(0.25, 2.0)
    pose = moving_pose(x, y, phi)
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    for layer in range(design.n_layers):
        body = design.moving_layers[layer]
        by_pose = np.column_stack(
            (pose.x + c * body[:, 0] - s * body[:, 1], pose.y + s * body[:, 0] + c * body[:, 1])
        )
        np.testing.assert_allclose(
            by_pose, design.moving_outline_world(layer, x, y, phi), atol=1e-12
        )


def test_path_poses_matches_moving_pose_per_sample() -> None:
    pivots = np.array([[0.01, 0.4], [0.01, 0.3], [0.01, 0.25]])
    phis = np.array([0.2, 0.1, -3.0])
    poses = path_poses(pivots, phis)
    assert poses.shape == (3, 3)
    for row, pivot, phi in zip(poses, pivots, phis, strict=True):
        expected = moving_pose(pivot[0], pivot[1], phi)
        assert row[0] == expected.x
        assert row[1] == expected.y
        assert row[2] == pytest.approx(expected.yaw, abs=1e-12)
    assert np.all((poses[:, 2] > -math.pi) & (poses[:, 2] <= math.pi))


def test_path_poses_rejects_mismatched_or_non_finite_input() -> None:
    with pytest.raises(XfaceValueError, match="rows"):
        path_poses(np.zeros((3, 2)), np.zeros(2))
    with pytest.raises(NonFiniteInputError):
        path_poses([[0.0, math.nan]], [0.0])


def test_check_distance_accepts_near_and_rejects_absurd_or_non_finite() -> None:
    check_distance(0.049, -49.9, width=0.05)  # 998 widths: far but possible
    with pytest.raises(AbsurdDistanceError, match=r"\|x\|"):
        check_distance(50.1, 0.0, width=0.05)
    with pytest.raises(AbsurdDistanceError, match=r"\|y\|"):
        check_distance(0.0, -2.0, width=0.05, max_widths=10.0)
    with pytest.raises(NonFiniteInputError):
        check_distance(math.inf, 0.0, width=0.05)
    with pytest.raises(XfaceValueError, match="width"):
        check_distance(0.0, 0.0, width=0.0)
