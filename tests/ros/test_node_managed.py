"""``--lifecycle``: the managed node, driven through the standard lifecycle services.

A node started with ``python -m xface_ros --lifecycle`` goes through configure, activate,
deactivate, cleanup and shutdown by ``/xface_predictor/change_state`` and reports each state on
``/xface_predictor/get_state``; its services answer only while it is active.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest
import yaml
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
WIDTH = 0.05
#: A transition returns without waiting for the warm-up, but the warm-up's compiling (on a fresh
#: install) holds Python's GIL most of the time, which slows the executor: generous.
TRANSITION_TIMEOUT_S = 300.0
GRAPH_TIMEOUT_S = 60.0


class Manager:
    """A lifecycle manager for the node under test (the test client's node makes the calls)."""

    def __init__(self, client: Any, node: str = "/xface_predictor") -> None:
        self.client = client
        self.change = client.node.create_client(ChangeState, f"{node}/change_state")
        self.get = client.node.create_client(GetState, f"{node}/get_state")

    def transition(self, transition_id: int) -> bool:
        request = ChangeState.Request(transition=Transition(id=transition_id))
        return bool(self.client.call(self.change, request, TRANSITION_TIMEOUT_S).success)

    def state(self) -> int:
        return int(self.client.call(self.get, GetState.Request()).current_state.id)

    def wait_until_answering(self, timeout_s: float = GRAPH_TIMEOUT_S) -> None:
        """Ask ``get_state`` until a reply comes. A request sent just after a service
        appears can lose its reply: ROS 2's service discovery race (the node's response
        writer has not yet matched our response reader; rmw_fastrtps waits 100 ms for it,
        which a loaded machine can exceed: CI lost the first ``get_state`` reply so once).
        The node is started without waiting for its warm-up, so the tests' first call comes
        right then. ``GetState`` changes nothing, so it is safe to send again; a transition
        is not, which is why this runs before any."""
        self.client.call(self.get, GetState.Request(), timeout_s, resend_s=2.0)


def wait_until(condition: Any, timeout_s: float = GRAPH_TIMEOUT_S) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "condition not met in time"
        time.sleep(0.05)


@pytest.fixture
def managed(launch: Any) -> tuple[Any, Manager]:
    running = launch(wait=False, node_args=["--lifecycle"], compute_margins=False)
    manager = Manager(running.client)
    manager.wait_until_answering()
    return running, manager


def test_goes_through_every_transition_with_the_standard_services(
    managed: tuple[Any, Manager],
) -> None:
    _running, manager = managed
    assert manager.state() == State.PRIMARY_STATE_UNCONFIGURED
    steps = [
        (Transition.TRANSITION_CONFIGURE, State.PRIMARY_STATE_INACTIVE),
        (Transition.TRANSITION_ACTIVATE, State.PRIMARY_STATE_ACTIVE),
        (Transition.TRANSITION_DEACTIVATE, State.PRIMARY_STATE_INACTIVE),
        (Transition.TRANSITION_CLEANUP, State.PRIMARY_STATE_UNCONFIGURED),
        (Transition.TRANSITION_UNCONFIGURED_SHUTDOWN, State.PRIMARY_STATE_FINALIZED),
    ]
    for transition_id, expected_state in steps:
        assert manager.transition(transition_id), transition_id
        assert manager.state() == expected_state


def test_answers_only_while_active(managed: tuple[Any, Manager]) -> None:
    from xface_msgs.msg import DockPrediction
    from xface_msgs.srv import PredictDock

    running, manager = managed
    c = running.client
    dock = c.node.create_client(PredictDock, "predict_dock")
    results = c._inbox(DockPrediction, "prediction/result", 10)
    assert manager.transition(Transition.TRANSITION_CONFIGURE)
    # Configured but inactive: no service to call, no prediction for a streamed pose.
    assert not c.status_client.service_is_ready()
    assert not dock.service_is_ready()
    assert manager.transition(Transition.TRANSITION_ACTIVATE)
    c.wait_for_node(running.node)  # configure started the warm-up and did not wait for it
    assert c.call_status().status[0].message.startswith("INVALID_INPUT: no_pose")
    sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, 3 * WIDTH, math.pi))
    assert status.message.startswith("SEATED: ")
    # The typed result's publisher is a lifecycle publisher too: active now.
    sent_ns = c.stamp_ns(sent.header.stamp)
    assert results.wait_for(lambda r: c.stamp_ns(r.header.stamp) == sent_ns).seated
    wait_until(dock.service_is_ready)
    assert manager.transition(Transition.TRANSITION_DEACTIVATE)
    wait_until(lambda: not c.status_client.service_is_ready())
    wait_until(lambda: not dock.service_is_ready())
    wait_until(lambda: c.pose_pub.get_subscription_count() == 0)


def test_the_nav2_lifecycle_recipe_brings_the_node_up_and_down(launch: Any) -> None:
    # config/nav2_lifecycle.yaml, driven as nav2_lifecycle_manager drives its nodes (it is
    # not on PyPI): startup configures and activates each node in order, shutdown
    # deactivates, cleans up and shuts down in reverse; with bond_timeout 0 nothing else.
    recipe = yaml.safe_load((ROOT / "config" / "nav2_lifecycle.yaml").read_text())
    params = recipe["lifecycle_manager_xface"]["ros__parameters"]
    assert params["bond_timeout"] == 0.0  # no bond to form: a positive one aborts bringup
    assert params["autostart"] is True
    running = launch(wait=False, node_args=["--lifecycle"], compute_margins=False)
    managers = [Manager(running.client, f"/{name}") for name in params["node_names"]]
    for manager in managers:
        manager.wait_until_answering()
        assert manager.transition(Transition.TRANSITION_CONFIGURE)
        assert manager.transition(Transition.TRANSITION_ACTIVATE)
        assert manager.state() == State.PRIMARY_STATE_ACTIVE
    c = running.client
    c.wait_for_node(running.node)
    _sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, 3 * WIDTH, math.pi))
    assert status.message.startswith("SEATED: ")
    for transition_id in (
        Transition.TRANSITION_DEACTIVATE, Transition.TRANSITION_CLEANUP,
        Transition.TRANSITION_UNCONFIGURED_SHUTDOWN,
    ):  # fmt: skip
        for manager in reversed(managers):
            assert manager.transition(transition_id), transition_id
    assert all(m.state() == State.PRIMARY_STATE_FINALIZED for m in managers)
