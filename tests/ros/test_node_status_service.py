"""``predict_status`` (diagnostic_msgs/SelfTest): the answer, its reason and margins in one call.

Each test starts a node of its own (``launch``), so "no pose yet" is a fresh node's state;
``input_timeout_s`` is long, so that only a deliberately old stamp is stale on a slow machine.
"""

from __future__ import annotations

import math
from typing import Any

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

pytestmark = pytest.mark.ros

WIDTH = 0.05
Y_START = 3.0 * WIDTH
TIMEOUT_S = 30.0
SETTINGS = {"compute_margins": False, "input_timeout_s": TIMEOUT_S}


def answer_after(running: Any, make_pose: Any) -> Any:
    """Stream a pose until the node has taken it, then ask; the SelfTest response."""
    c = running.client
    c.publish_until_status(lambda: make_pose(c))
    return c.call_status()


def one_status(response: Any, running: Any) -> tuple[DiagnosticStatus, dict[str, str]]:
    assert response.id == "/xface_predictor"
    assert len(response.status) == 1
    status = response.status[0]
    return status, running.client.values(status)


def test_no_pose_yet(launch: Any) -> None:
    running = launch(**SETTINGS)
    status, v = one_status(running.client.call_status(), running)
    assert v["answer"] == "no_pose"
    assert v["input_error"] == "no_pose"
    assert status.level == DiagnosticStatus.ERROR
    assert "no pose received yet" in status.message


def test_stale_latest_pose(launch: Any) -> None:
    running = launch(**SETTINGS)
    old_ns = 2 * int(TIMEOUT_S * 1e9)
    response = answer_after(
        running, lambda c: c.pose_msg(0.0, Y_START, math.pi, stamp_ns=c.next_stamp_ns() - old_ns)
    )
    status, v = one_status(response, running)
    assert v["answer"] == "stale"
    assert v["input_error"] == "stale_stamp"
    assert "old" in status.message
    assert response.passed == b"\x00"


def test_invalid_latest_pose(launch: Any) -> None:
    running = launch(**SETTINGS)
    response = answer_after(
        running, lambda c: c.pose_msg(0.0, Y_START, 0.0, quaternion=(0.0, 0.0, 0.0, 1.0))
    )
    status, v = one_status(response, running)
    assert v["answer"] == "invalid"
    assert v["input_error"] == "not_facing"
    assert "do not face each other" in status.message


def test_latest_pose_that_will_not_seat(launch: Any) -> None:
    running = launch(**SETTINGS)
    response = answer_after(running, lambda c: c.pose_msg(0.9 * WIDTH, Y_START, math.pi + 0.8))
    status, v = one_status(response, running)
    assert v["answer"] == "will_not_seat"
    assert v["outcome"] != "SEATED"
    assert status.level == DiagnosticStatus.WARN
    assert status.message.startswith(f"{v['outcome']}: ")
    assert response.passed == b"\x00"


def test_latest_pose_that_seats_with_its_margins(launch: Any) -> None:
    running = launch(**SETTINGS, min_margin=1e-6)  # a required margin makes it search them
    response = answer_after(running, lambda c: c.pose_msg(0.0, Y_START, math.pi))
    status, v = one_status(response, running)
    assert v["answer"] == "seats"
    assert status.level == DiagnosticStatus.OK
    assert status.message.startswith("SEATED: ")
    assert float(v["margin_m"]) > 1e-6
    assert response.passed == b"\x01"
