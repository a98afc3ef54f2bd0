"""The node's topics and services, by name and type, as a planner or a launch file sees them
over DDS, against the contract stored in tests/interfaces.json (docs/ros.md documents it; a
change of it is a change of the interface)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from xface_ros.conversions import typed_interface_problem

#: The node's default name (xface_ros.node).
NODE_NAME = "xface_predictor"

pytestmark = pytest.mark.ros

#: The stored contract (tests/interfaces.json, "ros_interface"): written from xface_ros.names by
#: scripts/evidence/interface_snapshot.py and kept by tests/test_interfaces.py.
STORED: dict[str, Any] = json.loads(
    (Path(__file__).resolve().parents[1] / "interfaces.json").read_text("utf-8")
)["ros_interface"]
#: Where the typed interface is not built, its topic and service do not exist.
ABSENT = set() if typed_interface_problem() is None else set(STORED["typed"])


def _as_seen(entries: dict[str, str]) -> dict[str, str]:
    """Names as the graph shows them for a node in the root namespace (absolute), and the
    entries that exist here."""
    return {
        (name if name.startswith("/") else f"/{name}"): kind
        for name, kind in entries.items()
        if name not in ABSENT
    }


PUBLISHES = _as_seen(STORED["publishes"])
SUBSCRIBES = _as_seen(STORED["subscribes"])
SERVES = _as_seen(STORED["serves"])


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
