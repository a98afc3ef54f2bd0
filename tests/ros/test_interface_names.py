"""The node's topics and services, by name and type, as a planner or a launch file sees them
over DDS: the contract docs/ros.md documents (a change of it is a change of the interface)."""

from __future__ import annotations

import time
from typing import Any

import pytest

from xface_ros.conversions import typed_interface_problem

#: The node's default name (xface_ros.node).
NODE_NAME = "xface_predictor"

pytestmark = pytest.mark.ros

PUBLISHES = {
    "/prediction/accepted": "std_msgs/msg/Bool",
    "/prediction/status": "diagnostic_msgs/msg/DiagnosticStatus",
    "/prediction/path": "nav_msgs/msg/Path",
    "/prediction/seated_pose": "geometry_msgs/msg/PoseStamped",
    "/prediction/markers": "visualization_msgs/msg/MarkerArray",
    "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
}
SUBSCRIBES = {
    "/relative_pose": "geometry_msgs/msg/PoseStamped",
    "/relative_pose_with_covariance": "geometry_msgs/msg/PoseWithCovarianceStamped",
}
SERVES = {
    "/predict": "nav_msgs/srv/GetPlan",
    "/predict_status": "diagnostic_msgs/srv/SelfTest",
}
#: The typed interface, where xface_msgs is built (docs/ros.md, "The typed interface").
if typed_interface_problem() is None:
    PUBLISHES["/prediction/result"] = "xface_msgs/msg/DockPrediction"
    SERVES["/predict_dock"] = "xface_msgs/srv/PredictDock"


def _graph(client: Any, query: str) -> dict[str, str]:
    found = getattr(client.node, query)(NODE_NAME, "/")
    return {name: types[0] for name, types in found}


def _wait_for(client: Any, query: str, expected: dict[str, str]) -> dict[str, str]:
    """The node's entries of ``query`` once ``expected``'s names are all there (discovery
    takes a moment after the node answers), or what was there after 20 s."""
    deadline = time.monotonic() + 20.0
    while True:
        got = _graph(client, query)
        if expected.keys() <= got.keys() or time.monotonic() > deadline:
            return got
        time.sleep(0.2)


def test_the_node_keeps_its_topics_and_services(launch: Any) -> None:
    client = launch(compute_margins=False).client
    publishes = _wait_for(client, "get_publisher_names_and_types_by_node", PUBLISHES)
    assert {k: v for k, v in publishes.items() if k in PUBLISHES} == PUBLISHES
    subscribes = _wait_for(client, "get_subscriber_names_and_types_by_node", SUBSCRIBES)
    assert subscribes == SUBSCRIBES | {
        k: v for k, v in subscribes.items() if k == "/parameter_events"
    }
    services = _wait_for(client, "get_service_names_and_types_by_node", SERVES)
    ours = {k: v for k, v in services.items() if not k.startswith(f"/{NODE_NAME}/")}
    assert ours == SERVES
