"""The xface_msgs interface package: its sources mirror xface_core, and once built from the ROS
wheels (scripts/build_msgs.py) its service carries a DockPrediction over real DDS.

The tests that need the built package skip, saying how to build it, when ``xface_msgs`` is not
importable: whether the set-up builds it is the Makefile's decision, not this file's.
"""

from __future__ import annotations

import importlib.util
import math
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path as PathMsg
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from xface_core.codes import Outcome

ROOT = Path(__file__).resolve().parents[2]
MSG_SOURCE = ROOT / "xface_ros" / "xface_msgs" / "msg" / "DockPrediction.msg"
REPLY_TIMEOUT_S = 60.0

needs_xface_msgs = pytest.mark.skipif(
    importlib.util.find_spec("xface_msgs") is None,
    reason="xface_msgs is not built in this environment: run "
    "`python scripts/build_msgs.py --prefix .venv` to build it from the ROS wheels",
)


def constants_in_msg_source(text: str) -> dict[str, int]:
    """The ``uint8 NAME=VALUE`` constants of a .msg file (comments stripped)."""
    constants = {}
    for line in text.splitlines():
        match = re.fullmatch(r"\s*uint8\s+([A-Z][A-Z0-9_]*)\s*=\s*(\d+)\s*", line.split("#")[0])
        if match:
            constants[match[1]] = int(match[2])
    return constants


def test_dock_prediction_outcome_constants_are_the_outcome_codes_of_xface_core() -> None:
    """Every Outcome has a constant of the same name and number, and there is no other."""
    constants = constants_in_msg_source(MSG_SOURCE.read_text(encoding="utf-8"))
    assert constants == {outcome.name: int(outcome) for outcome in Outcome}


@needs_xface_msgs
def test_built_dock_prediction_has_every_outcome_code() -> None:
    from xface_msgs.msg import DockPrediction

    for outcome in Outcome:
        assert getattr(DockPrediction, outcome.name) == int(outcome)


def _prediction_for(request: Any) -> Any:
    """What the test server answers: values derived from the request, NaN where the node
    would have computed nothing, so the client can check every kind of field came back."""
    from xface_msgs.msg import DockPrediction

    x = float(request.start.pose.position.x)
    return DockPrediction(
        header=request.start.header, outcome=DockPrediction.SEATED, outcome_name="SEATED",
        reason=f"seated from x={x!r}", accepted=True, seated=True, x0=x, theta0=-0.01,
        margin_lateral_minus=0.001, margin_lateral_plus=0.002, margin_angle_minus=0.03,
        margin_angle_plus=0.04, margin=0.001, required_margin=request.required_margin,
        seat_probability=float(request.covariance[0]) if request.has_covariance else math.nan,
        required_probability=request.required_probability, suggested_dx=math.nan,
        suggested_dtheta=math.nan, face_kind="X", face_name="X-Face", width=0.05,
        h_over_d=0.4, r_p=0.5, compute_time=0.002,
    )  # fmt: skip


@pytest.fixture
def ros_nodes(ros_domain_id: int) -> Iterator[tuple[Node, SingleThreadedExecutor]]:
    """One node in this test's own domain (loopback discovery, from the fixture), spun by an
    executor the test drives."""
    context = Context()
    rclpy.init(
        context=context, domain_id=ros_domain_id, signal_handler_options=SignalHandlerOptions.NO
    )
    node = Node("xface_msgs_round_trip", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield node, executor
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)


@needs_xface_msgs
def test_predict_dock_answers_a_dock_prediction_and_a_path_over_dds(
    ros_nodes: tuple[Node, SingleThreadedExecutor],
) -> None:
    from xface_msgs.srv import PredictDock

    node, executor = ros_nodes

    def serve(request: Any, response: Any) -> Any:
        response.prediction = _prediction_for(request)
        response.path = PathMsg(header=request.start.header, poses=[request.start] * 3)
        return response

    node.create_service(PredictDock, "predict_dock", serve)
    client = node.create_client(PredictDock, "predict_dock")
    start = PoseStamped()
    start.header.frame_id = "xface_base"
    start.header.stamp.sec = 12
    start.pose.position.x = 0.0031
    start.pose.position.y = 0.08
    covariance = [0.0] * 36
    covariance[0], covariance[35] = 0.75, 1e-4
    request = PredictDock.Request(
        start=start, has_covariance=True, covariance=covariance, required_margin=0.002,
        required_probability=0.9,
    )  # fmt: skip
    deadline = time.monotonic() + REPLY_TIMEOUT_S
    while not client.service_is_ready() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
    assert client.service_is_ready(), "the service was not discovered over DDS"
    future = client.call_async(request)
    executor.spin_until_future_complete(future, timeout_sec=REPLY_TIMEOUT_S)
    response = future.result()
    assert response is not None, "no response within the time-out"

    got = response.prediction
    assert got.outcome == got.SEATED == int(Outcome.SEATED)
    assert (got.accepted, got.seated, got.reason) == (True, True, "seated from x=0.0031")
    assert (got.header.frame_id, got.header.stamp.sec) == ("xface_base", 12)
    assert got.x0 == 0.0031
    assert (got.required_margin, got.required_probability) == (0.002, 0.9)
    assert got.seat_probability == 0.75  # read from the covariance: the array crossed intact
    assert math.isnan(got.suggested_dx)
    assert math.isnan(got.suggested_dtheta)
    assert (got.face_kind, got.face_name, got.width) == ("X", "X-Face", 0.05)
    assert len(response.path.poses) == 3
    assert response.path.poses[-1].pose.position.y == 0.08
