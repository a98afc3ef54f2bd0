"""Messages <-> core types, without starting DDS."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from xface_core.codes import Outcome
from xface_core.frames import (
    DockStart,
    PlanarPose,
    mated_pose,
    path_poses,
    planar_yaw,
    relative_pose_to_start,
    yaw_to_quaternion,
)
from xface_core.predict import predict
from xface_core.result import Margins, Prediction
from xface_ros.conversions import (
    input_error_status,
    key_value,
    markers_msg,
    ns_to_stamp,
    path_indices,
    path_msg,
    pose_input,
    prediction_status,
    seated_pose_msg,
    self_test_response,
    stamp_to_ns,
)
from xface_ros.decision import (
    INPUT_ERRORS,
    PoseInput,
    Predicted,
    Rejected,
    check_pose,
    decide,
)
from xface_ros.params import SPECS, NodeConfig, config_from_values

NOW_NS = 1_700_000_000_000_000_000
NAME = "/xface_predictor: prediction"


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    return config_from_values({spec.name: spec.default for spec in SPECS})


def message(
    x: float, y: float, z: float, quaternion: tuple[float, ...], stamp_ns: int
) -> PoseStamped:
    """A pose message in the base frame (m, quaternion x, y, z, w, ns)."""
    msg = PoseStamped()
    msg.header.frame_id = "xface_base"
    msg.header.stamp = ns_to_stamp(stamp_ns)
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = x, y, z
    o.x, o.y, o.z, o.w = quaternion
    return msg


def values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_stamp_round_trips() -> None:
    assert stamp_to_ns(ns_to_stamp(NOW_NS + 123)) == NOW_NS + 123


def test_pose_input_carries_the_message_values_exactly() -> None:
    msg = message(0.01, 0.15, 0.7, (0.1, 0.2, 0.3, 0.4), NOW_NS + 5)
    assert pose_input(msg) == PoseInput(
        "xface_base", NOW_NS + 5, (0.01, 0.15, 0.7), (0.1, 0.2, 0.3, 0.4)
    )


def test_good_pose_converts_like_the_frames_module(config: NodeConfig) -> None:
    q = yaw_to_quaternion(math.pi - 0.2)
    start = check_pose(pose_input(message(0.01, 0.15, 0.0, q, NOW_NS)), config, now_ns=NOW_NS)
    assert start == relative_pose_to_start(PlanarPose(0.01, 0.15, planar_yaw(*q)))


@pytest.mark.parametrize("code", sorted(INPUT_ERRORS))
def test_each_input_error_gives_an_error_status(code: str) -> None:
    status = input_error_status(Rejected(NOW_NS, code, "why"), name=NAME, hardware_id="xface_base")
    assert status.level == DiagnosticStatus.ERROR
    assert values(status)["input_error"] == code
    assert values(status)["input_stamp_ns"] == str(NOW_NS)
    assert status.message == f"INVALID_INPUT: {code}: why"


def test_status_answer_says_passed_and_why(seated_verdict: Predicted) -> None:
    response = self_test_response(
        seated_verdict, node_fqn="/xface_predictor", name=NAME, hardware_id="xface_base"
    )
    assert response.passed == b"\x01"
    assert values(response.status[0])["answer"] == "seats"
    assert response.status[0].message.startswith("SEATED: ")


def test_no_seat_is_stated_with_an_empty_frame_and_nan() -> None:
    msg = seated_pose_msg(None, Header(stamp=ns_to_stamp(NOW_NS), frame_id="xface_base"))
    assert msg.header.frame_id == ""
    assert stamp_to_ns(msg.header.stamp) == NOW_NS
    assert math.isnan(msg.pose.position.x)
    assert math.isnan(msg.pose.position.y)


def test_key_values_parse_back_exactly() -> None:
    assert key_value("a", 0.1 + 0.2).value == repr(0.1 + 0.2)
    assert key_value("a", True).value == "true"
    assert key_value("a", None).value == ""
    assert key_value("a", 3).value == "3"


def predicted(
    prediction: Prediction,
    *,
    required_m: float = 0.0,
    stamp_ns: int = NOW_NS,
    compute_s: float = 0.001,
) -> Predicted:
    start = DockStart(prediction.x0, prediction.theta0, prediction.y_start)
    decision = decide(prediction, required_margin_m=required_m)
    return Predicted(stamp_ns, start, prediction, decision, compute_s)


@pytest.fixture(scope="module")
def seated(config: NodeConfig) -> Prediction:
    prediction = predict(config.design, 0.015, 0.2, y_start=0.15, path=True)
    assert prediction.outcome is Outcome.SEATED
    return prediction


@pytest.fixture(scope="module")
def seated_verdict(seated: Prediction) -> Predicted:
    return predicted(seated)


def test_status_levels_follow_the_decision(seated: Prediction) -> None:
    levels = {}
    for outcome, required in [
        (Outcome.SEATED, 0.0),
        (Outcome.SEATED, 1.0),
        (Outcome.BAD_MATE, 0.0),
        (Outcome.INVALID_INPUT, 0.0),
    ]:
        p = replace(seated, outcome=outcome, margins=Margins(0.01, 0.01, 0.1, 0.1))
        status = prediction_status(
            predicted(p, required_m=required), name=NAME, hardware_id="xface_base"
        )
        levels[(outcome, required)] = status.level
    assert levels == {
        (Outcome.SEATED, 0.0): DiagnosticStatus.OK,
        (Outcome.SEATED, 1.0): DiagnosticStatus.WARN,
        (Outcome.BAD_MATE, 0.0): DiagnosticStatus.WARN,
        (Outcome.INVALID_INPUT, 0.0): DiagnosticStatus.ERROR,
    }


def test_status_values_carry_the_prediction_exactly(seated: Prediction) -> None:
    status = prediction_status(
        predicted(seated, stamp_ns=NOW_NS + 7, compute_s=0.002), name=NAME, hardware_id="xface_base"
    )
    v = values(status)
    assert status.name == NAME
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
    seat = predicted(seated).seated_pose
    assert seat is not None
    msg = seated_pose_msg(seat, Header(frame_id="xface_base"))
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
