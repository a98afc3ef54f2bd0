"""The node over real DDS: streamed predictions, the planner service, bad input, diagnostics.

One node process (default configuration, config/xface.yaml) serves every test in this
module; a test client in the same ROS domain publishes poses and reads the outputs. Every
answer is checked against :func:`xface_core.predict.predict` for the same input.
"""

from __future__ import annotations

import math
import time
from typing import Any

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path as PathMsg
from visualization_msgs.msg import Marker

from xface_core.atlas.margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION
from xface_core.codes import Outcome
from xface_core.frames import (
    PlanarPose,
    path_poses,
    planar_yaw,
    relative_pose_to_start,
    wrap_angle,
)
from xface_core.geometry import make_face
from xface_core.predict import predict
from xface_core.result import Prediction
from xface_ros.conversions import path_indices
from xface_ros.decision import combined_margin

pytestmark = pytest.mark.ros

WIDTH = 0.05  # config/xface.yaml
DESIGN = make_face("X", 0.25, 1.0, width=WIDTH)
MAX_PATH_POSES = 1000
Y_START = 3.0 * WIDTH  # clear of contact for every angle used here

#: (x0 / D, theta0): seats, seats, jams, out of reach, misses the base, seats (mirror side).
POSES = [(0.0, 0.0), (0.3, 0.2), (0.9, 0.8), (2.5, 0.0), (1.5, 0.3), (-0.4, -0.3)]


def expected_for(msg: PoseStamped) -> Prediction:
    """What the core predicts for a pose message, converted as the node's contract says."""
    o = msg.pose.orientation
    planar = PlanarPose(msg.pose.position.x, msg.pose.position.y, planar_yaw(o.x, o.y, o.z, o.w))
    start = relative_pose_to_start(planar)
    return predict(DESIGN, start.x0, start.theta0, y_start=start.y_start, path=True, margins=True)


def assert_path_equals(path: PathMsg, expected: Prediction) -> None:
    assert expected.path is not None
    idx = path_indices(len(expected.path), MAX_PATH_POSES)
    poses = path_poses(expected.path.pivot_m[idx], expected.path.phi_m[idx])
    assert len(path.poses) == len(poses)
    for got, (x, y, yaw) in zip(path.poses, poses, strict=True):
        assert got.header.frame_id == "xface_base"
        assert got.pose.position.x == pytest.approx(x, abs=1e-12)
        assert got.pose.position.y == pytest.approx(y, abs=1e-12)
        o = got.pose.orientation
        assert abs(math.remainder(planar_yaw(o.x, o.y, o.z, o.w) - yaw, 2 * math.pi)) < 1e-9


def stream_pose(
    running: Any, x0_widths: float, theta0: float, **kwargs: Any
) -> tuple[PoseStamped, DiagnosticStatus]:
    c = running.client
    yaw = wrap_angle(theta0 + math.pi)
    return c.publish_until_status(  # type: ignore[no-any-return]
        lambda: c.pose_msg(x0_widths * WIDTH, Y_START, yaw), **kwargs
    )


@pytest.mark.parametrize(("x0_widths", "theta0"), POSES)
def test_streamed_prediction_equals_the_core(
    shared_node: Any, x0_widths: float, theta0: float
) -> None:
    c = shared_node.client
    bools_before = c.accepted.count()
    sent, status = stream_pose(
        shared_node, x0_widths, theta0, also=lambda ns: c.wait_path(ns) is not None
    )
    sent_ns = c.stamp_ns(sent.header.stamp)
    expected = expected_for(sent)
    v = c.values(status)

    assert v["outcome"] == expected.outcome.name
    assert status.message == f"{expected.outcome.name}: {expected.reason}"
    assert status.level == (DiagnosticStatus.OK if expected.seated else DiagnosticStatus.WARN)
    assert v["accepted"] == ("true" if expected.seated else "false")
    assert float(v["x0_m"]) == expected.x0
    assert float(v["theta0_rad"]) == expected.theta0
    assert float(v["y_start_m"]) == expected.y_start
    assert float(v["final_phi_b_rad"]) == pytest.approx(expected.phi_b, abs=1e-12)
    assert float(v["final_phi_m_rad"]) == pytest.approx(expected.phi_m, abs=1e-12)
    assert float(v["final_y_m"]) == pytest.approx(expected.pivot_m[1], abs=1e-12)
    assert int(v["steps"]) == expected.counters.steps
    assert int(v["events"]) == expected.counters.events
    assert expected.margins is not None
    # Margins are defined to the search's resolution (1e-4 D, 1e-5 rad): once the node's
    # acceptance atlas is ready it finds the same flips from other brackets.
    lateral, angle = LATERAL_RESOLUTION * WIDTH, ANGLE_RESOLUTION
    m = expected.margins
    assert float(v["margin_lateral_minus_m"]) == pytest.approx(m.lateral_minus, abs=lateral)
    assert float(v["margin_lateral_plus_m"]) == pytest.approx(m.lateral_plus, abs=lateral)
    assert float(v["margin_angle_minus_rad"]) == pytest.approx(m.angle_minus, abs=angle)
    assert float(v["margin_angle_plus_rad"]) == pytest.approx(m.angle_plus, abs=angle)
    assert float(v["margin_m"]) == pytest.approx(
        combined_margin(m, WIDTH), abs=max(lateral, angle * WIDTH)
    )

    path = c.wait_path(sent_ns)
    assert path is not None
    assert path.header.frame_id == "xface_base"
    assert_path_equals(path, expected)

    if expected.seated:
        seat = c.seated.wait_for(lambda p: c.stamp_ns(p.header.stamp) == sent_ns)
        o = seat.pose.orientation
        assert seat.pose.position.x == pytest.approx(expected.pivot_m[0], abs=1e-12)
        assert seat.pose.position.y == pytest.approx(expected.pivot_m[1], abs=1e-12)
        yaw = planar_yaw(o.x, o.y, o.z, o.w)
        assert yaw == pytest.approx(wrap_angle(expected.phi_m + math.pi), abs=1e-9)

    # Every Bool published for this pose (one per copy sent) says the same.
    c.accepted.wait_for(lambda _m: c.accepted.count() > bools_before)
    new_bools = c.accepted.snapshot()[bools_before:]
    assert new_bools
    assert {b.data for b in new_bools} == {expected.seated}


def test_seated_pose_is_replaced_by_a_later_failure(shared_node: Any) -> None:
    c = shared_node.client
    seats, _ = stream_pose(shared_node, 0.0, 0.0)
    seat = c.seated.wait_for(lambda p: c.stamp_ns(p.header.stamp) == c.stamp_ns(seats.header.stamp))
    assert seat.header.frame_id == "xface_base"
    fails, _ = stream_pose(shared_node, 2.5, 0.0)  # out of reach
    no_seat = c.seated.wait_for(
        lambda p: c.stamp_ns(p.header.stamp) == c.stamp_ns(fails.header.stamp)
    )
    assert no_seat.header.frame_id == ""
    assert math.isnan(no_seat.pose.position.x)


def test_markers_show_the_prediction_when_subscribed(shared_node: Any) -> None:
    c = shared_node.client
    markers = c.subscribe_markers()
    sent, _status = stream_pose(
        shared_node, 0.3, 0.2,
        also=lambda ns: bool(
            _wait_quietly(markers, lambda m: c.stamp_ns(m.markers[0].header.stamp) == ns)
        ),
    )  # fmt: skip
    sent_ns = c.stamp_ns(sent.header.stamp)
    array = markers.wait_for(lambda m: c.stamp_ns(m.markers[0].header.stamp) == sent_ns)
    assert array.markers[0].action == Marker.DELETEALL
    namespaces = {m.ns for m in array.markers[1:]}
    assert {"start/base", "start/moving", "end/base", "end/moving", "path"} <= namespaces
    path_marker = next(m for m in array.markers if m.ns == "path")
    expected = expected_for(sent)
    assert expected.path is not None
    assert len(path_marker.points) == len(expected.path)


def _wait_quietly(inbox: Any, predicate: Any, timeout_s: float = 2.0) -> Any:
    try:
        return inbox.wait_for(predicate, timeout_s)
    except TimeoutError:
        return None


def plan_start(c: Any, x0_widths: float, theta0: float, frame: str = "xface_base") -> PoseStamped:
    return c.pose_msg(x0_widths * WIDTH, Y_START, wrap_angle(theta0 + math.pi), frame_id=frame,
                      stamp_ns=0)  # fmt: skip


def test_service_returns_the_path_for_a_pose_that_seats(shared_node: Any) -> None:
    c = shared_node.client
    start = plan_start(c, 0.3, 0.2)
    plan = c.call_plan(start)
    expected = expected_for(start)
    assert expected.seated
    assert plan.header.frame_id == "xface_base"
    assert_path_equals(plan, expected)


def test_service_returns_an_empty_plan_for_a_pose_that_does_not_seat(shared_node: Any) -> None:
    c = shared_node.client
    start = plan_start(c, 0.9, 0.8)
    assert not expected_for(start).seated
    assert c.call_plan(start).poses == []


def test_service_with_an_empty_frame_uses_the_latest_streamed_pose(shared_node: Any) -> None:
    c = shared_node.client
    empty = PoseStamped()  # frame_id "" = the latest received pose
    sent, _ = stream_pose(shared_node, -0.4, -0.3)
    expected = expected_for(sent)
    assert expected.seated
    assert_path_equals(c.call_plan(empty), expected)
    sent, _ = stream_pose(shared_node, 2.5, 0.0)
    assert not expected_for(sent).seated
    assert c.call_plan(empty).poses == []


def test_service_tolerance_is_the_required_combined_margin(shared_node: Any) -> None:
    c = shared_node.client
    start = plan_start(c, 0.3, 0.2)
    expected = expected_for(start)
    assert expected.seated
    assert expected.margins is not None
    margin = combined_margin(expected.margins, WIDTH)
    assert 0.0 < margin < math.inf
    assert len(c.call_plan(start, tolerance=0.5 * margin).poses) > 0
    assert c.call_plan(start, tolerance=2.0 * margin).poses == []


def test_service_refuses_a_start_in_another_frame(shared_node: Any) -> None:
    c = shared_node.client
    assert c.call_plan(plan_start(c, 0.3, 0.2, frame="map")).poses == []


def bad_messages() -> list[tuple[str, Any]]:
    """(expected input_error, a function client -> bad message with a fresh stamp)."""
    yaw = math.pi
    tilted = (0.0, math.sin(0.15), 0.0, math.cos(0.15))  # pitch 0.3 rad
    ten_s = 10**10

    def at(c: Any, **kwargs: Any) -> PoseStamped:
        args = {"x": 0.0, "y": Y_START, "yaw": yaw} | kwargs
        return c.pose_msg(args.pop("x"), args.pop("y"), args.pop("yaw"), **args)

    return [
        ("wrong_frame", lambda c: at(c, frame_id="map")),
        ("non_finite", lambda c: at(c, x=math.nan)),
        ("non_finite", lambda c: at(c, y=math.inf)),
        ("stale_stamp", lambda c: at(c, stamp_ns=c.next_stamp_ns() - ten_s)),
        ("future_stamp", lambda c: at(c, stamp_ns=c.next_stamp_ns() + ten_s)),
        ("unnormalised_quaternion", lambda c: at(c, quaternion=(0.0, 0.0, 1.0, 0.5))),
        ("non_planar", lambda c: at(c, quaternion=tilted)),
        ("absurd_distance", lambda c: at(c, x=100.0)),  # 2000 widths
        ("invalid_input", lambda c: at(c, y=0.0)),  # the parts interpenetrate
        ("not_facing", lambda c: at(c, quaternion=(0.0, 0.0, 0.0, 1.0))),  # back to back
    ]


@pytest.mark.parametrize(
    ("code", "make_bad"), bad_messages(), ids=lambda p: p if isinstance(p, str) else ""
)
def test_bad_input_gives_an_error_status_and_the_node_keeps_serving(
    shared_node: Any, code: str, make_bad: Any
) -> None:
    c = shared_node.client
    _sent, status = c.publish_until_status(lambda: make_bad(c))
    v = c.values(status)
    assert status.level == DiagnosticStatus.ERROR
    assert v["input_error"] == code
    assert v["outcome"] == Outcome.INVALID_INPUT.name
    assert status.message.startswith(f"INVALID_INPUT: {code}: ")
    # Still serving: the next good pose gets its prediction.
    _sent, good = stream_pose(shared_node, 0.0, 0.0)
    assert good.level == DiagnosticStatus.OK
    assert shared_node.node.process.poll() is None


def test_diagnostics_report_rate_age_outcome_latency_and_drops(shared_node: Any) -> None:
    c = shared_node.client
    stream_pose(shared_node, 0.0, 0.0)
    since = time.time_ns()

    def recent_predictor_status(array: Any) -> bool:
        return c.stamp_ns(array.header.stamp) > since and any(
            s.name == "/xface_predictor: predictor" for s in array.status
        )

    array = c.diagnostics.wait_for(recent_predictor_status, timeout_s=10.0)
    status = next(s for s in array.status if s.name == "/xface_predictor: predictor")
    v = c.values(status)
    for key in (
        "input_rate_hz", "pose_age_s", "last_outcome", "latency_ms_median", "dropped_total",
        "received_total", "predicted_total", "compute_ms_median",
    ):  # fmt: skip
        assert key in v, key
    assert int(v["received_total"]) >= int(v["predicted_total"]) >= 1
    assert int(v["dropped_total"]) >= 0
    assert v["last_outcome"] in {o.name for o in Outcome}
    assert float(v["pose_age_s"]) >= 0.0
