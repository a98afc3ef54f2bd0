"""Messages <-> core types, without starting DDS."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from xface_core.frames import (
    PlanarPose,
    mated_pose,
    path_poses,
    planar_yaw,
    relative_pose_to_start,
    yaw_to_quaternion,
)
from xface_core.outcome import Outcome
from xface_core.predict import predict
from xface_core.result import Counters, Margins, Prediction
from xface_ros.conversions import (
    INPUT_ERRORS,
    InputRejected,
    combined_margin,
    decide,
    input_error_status,
    markers_msg,
    ns_to_stamp,
    path_indices,
    path_msg,
    prediction_status,
    seated_pose_msg,
    stamp_to_ns,
    start_from_pose,
)
from xface_ros.params import SPECS, NodeConfig, config_from_values

NOW_NS = 1_700_000_000_000_000_000


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    return config_from_values({spec.name: spec.default for spec in SPECS})


def pose(
    x: float = 0.01,
    y: float = 0.15,
    yaw: float = math.pi - 0.2,
    *,
    frame: str = "xface_base",
    stamp_ns: int = NOW_NS,
    quaternion: tuple[float, float, float, float] | None = None,
) -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = frame
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.pose.position.x, msg.pose.position.y = x, y
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = yaw_to_quaternion(yaw) if quaternion is None else quaternion
    return msg


def values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_stamp_round_trips() -> None:
    assert stamp_to_ns(ns_to_stamp(NOW_NS + 123)) == NOW_NS + 123


def test_good_pose_converts_like_the_frames_module(config: NodeConfig) -> None:
    msg = pose()
    start = start_from_pose(msg, config, now_ns=NOW_NS + 1000)
    o = msg.pose.orientation
    expected = relative_pose_to_start(PlanarPose(0.01, 0.15, planar_yaw(o.x, o.y, o.z, o.w)))
    assert start == expected
    assert start.theta0 == pytest.approx(-0.2)


def bad_inputs() -> list[tuple[str, dict[str, Any]]]:
    s = math.sin(0.2)
    return [
        ("wrong_frame", {"frame": "map"}),
        ("wrong_frame", {"frame": ""}),
        ("non_finite", {"x": math.nan}),
        ("non_finite", {"y": math.inf}),
        ("non_finite", {"quaternion": (0.0, 0.0, math.nan, 1.0)}),
        ("stale_stamp", {"stamp_ns": NOW_NS - 2_000_000_000}),
        ("stale_stamp", {"stamp_ns": 0}),
        ("future_stamp", {"stamp_ns": NOW_NS + 2_000_000_000}),
        ("unnormalised_quaternion", {"quaternion": (0.0, 0.0, 0.0, 0.0)}),
        ("unnormalised_quaternion", {"quaternion": (0.0, 0.0, 1.0, 1.0)}),
        ("non_planar", {"quaternion": (s, 0.0, 0.0, math.cos(0.2))}),  # roll 0.4 rad
        ("absurd_distance", {"x": 60.0}),  # 1200 widths of 5 cm
        ("absurd_distance", {"y": -51.0}),
    ]


@pytest.mark.parametrize(("code", "kwargs"), bad_inputs())
def test_each_bad_input_is_rejected_with_its_code(
    config: NodeConfig, code: str, kwargs: dict[str, Any]
) -> None:
    assert code in INPUT_ERRORS
    with pytest.raises(InputRejected) as info:
        start_from_pose(pose(**kwargs), config, now_ns=NOW_NS)
    assert info.value.code == code
    status = input_error_status(info.value, stamp=ns_to_stamp(NOW_NS), hardware_id="xface_base")
    assert status.level == DiagnosticStatus.ERROR
    assert values(status)["input_error"] == code
    assert status.message.startswith(f"INVALID_INPUT: {code}: ")


def test_planner_queries_skip_the_stamp_check(config: NodeConfig) -> None:
    start = start_from_pose(pose(stamp_ns=0), config, now_ns=None)
    assert start.x0 == 0.01


def test_zero_timeout_disables_the_stamp_check(config: NodeConfig) -> None:
    no_timeout = replace(config, input_timeout_s=0.0)
    assert start_from_pose(pose(stamp_ns=0), no_timeout, now_ns=NOW_NS).x0 == 0.01


def hand_prediction(outcome: Outcome, margins: Margins | None, config: NodeConfig) -> Prediction:
    """A Prediction built by hand: only the fields the decision reads matter here."""
    return Prediction(
        design=config.design, x0=0.0, theta0=0.0, y_start=0.2, outcome=outcome, reason="r",
        phi_b=0.0, phi_m=0.0, pivot_m=(0.0, 0.1), counters=Counters(1, 1, 1), margins=margins,
    )  # fmt: skip


def test_combined_margin_is_the_smaller_of_lateral_and_width_times_angle() -> None:
    margins = Margins(lateral_minus=0.02, lateral_plus=0.03, angle_minus=0.5, angle_plus=0.1)
    assert combined_margin(margins, 0.05) == pytest.approx(0.005)  # 0.1 rad x 5 cm
    assert combined_margin(margins, 1.0) == pytest.approx(0.02)


def test_decision_accepts_a_seat_with_enough_margin(config: NodeConfig) -> None:
    margins = Margins(0.02, 0.03, 0.5, 0.1)
    seated = hand_prediction(Outcome.SEATED, margins, config)
    assert decide(seated, required_margin_m=0.0).accepted
    assert decide(seated, required_margin_m=0.004).accepted
    short = decide(seated, required_margin_m=0.006)
    assert not short.accepted
    assert "margin" in short.why


def test_decision_rejects_every_other_outcome_whatever_the_margin(config: NodeConfig) -> None:
    for outcome in Outcome:
        if outcome is not Outcome.SEATED:
            p = hand_prediction(outcome, Margins(1.0, 1.0, 1.0, 1.0), config)
            assert not decide(p, required_margin_m=0.0).accepted


def test_decision_without_margins_cannot_meet_a_required_margin(config: NodeConfig) -> None:
    seated = hand_prediction(Outcome.SEATED, None, config)
    assert decide(seated, required_margin_m=0.0).accepted
    assert not decide(seated, required_margin_m=0.001).accepted


def test_status_levels_follow_the_decision(config: NodeConfig) -> None:
    stamp = ns_to_stamp(NOW_NS)
    levels = {}
    for outcome, required in [
        (Outcome.SEATED, 0.0),
        (Outcome.SEATED, 1.0),
        (Outcome.BAD_MATE, 0.0),
        (Outcome.INVALID_INPUT, 0.0),
    ]:
        p = hand_prediction(outcome, Margins(0.01, 0.01, 0.1, 0.1), config)
        status = prediction_status(
            p, decide(p, required_margin_m=required), stamp=stamp, compute_s=0.001,
            hardware_id="xface_base",
        )  # fmt: skip
        levels[(outcome, required)] = status.level
    assert levels == {
        (Outcome.SEATED, 0.0): DiagnosticStatus.OK,
        (Outcome.SEATED, 1.0): DiagnosticStatus.WARN,
        (Outcome.BAD_MATE, 0.0): DiagnosticStatus.WARN,
        (Outcome.INVALID_INPUT, 0.0): DiagnosticStatus.ERROR,
    }


@pytest.fixture(scope="module")
def seated(config: NodeConfig) -> Prediction:
    prediction = predict(config.design, 0.015, 0.2, y_start=0.15, path=True)
    assert prediction.outcome is Outcome.SEATED
    return prediction


def test_status_values_carry_the_prediction_exactly(seated: Prediction) -> None:
    stamp = ns_to_stamp(NOW_NS + 7)
    status = prediction_status(
        seated, decide(seated, required_margin_m=0.0), stamp=stamp, compute_s=0.002,
        hardware_id="xface_base",
    )  # fmt: skip
    v = values(status)
    assert status.message.startswith("SEATED: ")
    assert v["outcome_code"] == str(int(Outcome.SEATED))
    assert float(v["final_phi_b_rad"]) == seated.phi_b
    assert float(v["final_phi_m_rad"]) == seated.phi_m
    assert float(v["final_y_m"]) == seated.pivot_m[1]
    assert int(v["steps"]) == seated.counters.steps
    assert int(v["input_stamp_ns"]) == NOW_NS + 7
    assert v["input_stamp"] == f"{(NOW_NS + 7) // 10**9}.{(NOW_NS + 7) % 10**9:09d}"
    assert float(v["compute_time_ms"]) == pytest.approx(2.0)


def test_path_indices_keep_ends_and_bound_the_count() -> None:
    for n, cap in [(1, 5), (5, 5), (6, 5), (20001, 1000), (3, 2)]:
        idx = path_indices(n, cap)
        assert idx[0] == 0
        assert idx[-1] == n - 1
        assert len(idx) <= cap
        assert np.all(np.diff(idx) > 0)


def test_path_message_holds_the_predicted_poses(seated: Prediction) -> None:
    assert seated.path is not None
    header = Header(frame_id="xface_base", stamp=ns_to_stamp(NOW_NS))
    msg = path_msg(seated, header, max_poses=100000)
    expected = path_poses(seated.path.pivot_m, seated.path.phi_m)
    assert len(msg.poses) == len(seated.path) == expected.shape[0]
    for pose_msg, (x, y, yaw) in zip(msg.poses, expected, strict=True):
        assert pose_msg.header.frame_id == "xface_base"
        assert stamp_to_ns(pose_msg.header.stamp) == NOW_NS
        assert pose_msg.pose.position.x == x
        assert pose_msg.pose.position.y == y
        o = pose_msg.pose.orientation
        assert abs(math.remainder(planar_yaw(o.x, o.y, o.z, o.w) - yaw, 2 * math.pi)) < 1e-12
    short = path_msg(seated, header, max_poses=3)
    assert len(short.poses) == min(3, len(seated.path))


def test_seated_pose_is_the_mated_pose_of_the_offset(seated: Prediction) -> None:
    msg = seated_pose_msg(seated, Header(frame_id="xface_base"))
    expected = mated_pose(seated.design, seated.x0)
    o = msg.pose.orientation
    assert msg.pose.position.x == pytest.approx(expected.x, abs=1e-9)
    assert msg.pose.position.y == pytest.approx(expected.y, abs=1e-6)
    assert planar_yaw(o.x, o.y, o.z, o.w) == pytest.approx(expected.yaw, abs=1e-6)


def test_markers_clear_then_draw_outlines_path_and_contacts(seated: Prediction) -> None:
    header = Header(frame_id="xface_base", stamp=ns_to_stamp(NOW_NS))
    markers = markers_msg(seated, header).markers
    assert markers[0].action == Marker.DELETEALL
    namespaces = {m.ns for m in markers[1:]}
    assert {"start/base", "start/moving", "end/base", "end/moving", "path", "contacts"} <= (
        namespaces
    )
    design = seated.design
    w = design.width
    start_moving = next(m for m in markers if m.ns == "start/moving" and m.id == 1)
    outline = design.moving_outline_world(0, seated.x0 / w, seated.y_start / w, seated.theta0) * w
    drawn = np.array([(p.x, p.y) for p in start_moving.points])
    np.testing.assert_allclose(drawn[:-1], outline, atol=1e-12)
    np.testing.assert_allclose(drawn[-1], drawn[0])  # closed
    assert all(m.header.frame_id == "xface_base" for m in markers)
