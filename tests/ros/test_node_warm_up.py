"""The node's constructor does not wait for the simulator: interfaces first, warm-up after.

The node runs in this process (its own rclpy context in this test's ROS domain, discovery on
localhost) with a warm-up that blocks until the test releases it, standing in for a first
start that compiles the simulator. Meanwhile the service answers correctly and /diagnostics
says "warming up"; once released, streamed poses are predicted.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from xface_core.geometry import make_face
from xface_core.predict import predict
from xface_ros.config import NodeConfig
from xface_ros.diagnostics import WARMING_UP_MESSAGE
from xface_ros.node import XfacePredictor

pytestmark = pytest.mark.ros

WIDTH = 0.05
Y_START = 3.0 * WIDTH
#: Longest the test waits for anything (s); the blocked warm-up gives up after it too.
WAIT_S = 60.0


@pytest.fixture
def held_node(
    ros_domain_id: int, monkeypatch: pytest.MonkeyPatch
) -> Iterator[tuple[threading.Event, XfacePredictor]]:
    """Run an XfacePredictor in this process whose warm-up waits for the returned event."""
    entered, release = threading.Event(), threading.Event()

    def blocked_warm_up(_config: NodeConfig) -> None:
        entered.set()
        release.wait(timeout=WAIT_S)

    monkeypatch.setattr("xface_ros.worker.warm_up_simulator", blocked_warm_up)
    context = Context()
    rclpy.init(
        context=context, domain_id=ros_domain_id, signal_handler_options=SignalHandlerOptions.NO
    )
    node = XfacePredictor(context=context)  # returns although the warm-up is blocked
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()
    try:
        assert entered.wait(timeout=WAIT_S)
        assert not release.is_set()
        yield release, node
    finally:
        release.set()
        executor.shutdown(timeout_sec=5.0)
        spin.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


@pytest.fixture
def release_warm_up(held_node: tuple[threading.Event, XfacePredictor]) -> threading.Event:
    """The event that releases the in-process node's warm-up."""
    return held_node[0]


def predictor_message(array: DiagnosticArray) -> str | None:
    return next((s.message for s in array.status if s.name.endswith(": predictor")), None)


def test_service_answers_and_diagnostics_say_warming_up_before_the_warm_up_ends(
    release_warm_up: threading.Event, ros_client: Any
) -> None:
    c = ros_client
    assert c.plan_client.wait_for_service(timeout_sec=WAIT_S)
    seats = c.pose_msg(0.3 * WIDTH, Y_START, 0.2 + math.pi, stamp_ns=0)
    expected = predict(make_face("X", 0.25, 1.0, width=WIDTH), 0.3 * WIDTH, 0.2, y_start=Y_START)
    assert expected.seated
    plan = c.call_plan(seats)
    assert len(plan.poses) > 0
    assert plan.poses[-1].pose.position.y == pytest.approx(expected.pivot_m[1], abs=1e-9)
    assert c.call_plan(c.pose_msg(0.9 * WIDTH, Y_START, 0.8 + math.pi, stamp_ns=0)).poses == []

    warming = c.diagnostics.wait_for(lambda a: predictor_message(a) is not None, WAIT_S)
    assert predictor_message(warming) == WARMING_UP_MESSAGE

    release_warm_up.set()
    _sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, Y_START, math.pi))
    assert status.message.startswith("SEATED")
    c.diagnostics.wait_for(lambda a: predictor_message(a) not in (None, WARMING_UP_MESSAGE), WAIT_S)


def test_the_outputs_add_no_qos_event_handlers_to_the_executors_wait(
    held_node: tuple[threading.Event, XfacePredictor],
) -> None:
    """The executor adds every QoS-event handler to its wait set for every message it takes
    (docs/ros.md, "CPU per thread"): the six outputs have none, the pose inputs keep rclpy's
    default warnings and the stream's message-lost count."""
    node = held_node[1]
    outputs = {p.topic_name: len(p.event_handlers) for p in node._publishers_made}
    assert len(outputs) == 6
    assert set(outputs.values()) == {0}
    inputs = {s.topic_name: len(s.event_handlers) for s in node.subscriptions}
    assert inputs["/relative_pose"] > inputs["/relative_pose_with_covariance"] > 0
