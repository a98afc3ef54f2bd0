"""Neither node kind waits for the simulator: interfaces first, warm-up after.

The node runs in this process (its own rclpy context in this test's ROS domain, discovery on
localhost) with a warm-up that blocks until the test releases it, standing in for a first
start that compiles the simulator. Meanwhile the service answers correctly and /diagnostics
says "warming up" with the warm-up's progress; a managed node's ``configure`` returns; once
released, streamed poses are predicted.
"""

from __future__ import annotations

import contextlib
import math
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from xface_core.geometry import make_face
from xface_core.predict import predict
from xface_core.runner import EngineState
from xface_ros.config import NodeConfig
from xface_ros.diagnostics import is_warming_up
from xface_ros.node import XfaceLifecyclePredictor, XfacePredictor, _Predictor

pytestmark = pytest.mark.ros

WIDTH = 0.05
Y_START = 3.0 * WIDTH
#: Longest the test waits for anything (s); the blocked warm-up gives up after it too.
WAIT_S = 60.0


#: The engine as on a fresh install: its first simulation compiles.
COMPILES = EngineState(ready=False, source="compiles", compile_estimate_s=60.0)
#: The progress the held engine reports before it waits: 3 of 7 entry points compiled.
HELD_AT, ENTRY_POINTS = 3, 7


@contextlib.contextmanager
def in_process(
    node_kind: type[_Predictor], domain_id: int, release: threading.Event
) -> Iterator[_Predictor]:
    """Spin a node of ``node_kind`` in this process (a context of its own in ``domain_id``);
    at the end ``release`` its warm-up, then take it all down."""
    context = Context()
    rclpy.init(context=context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
    node = node_kind(context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()
    try:
        yield node
    finally:
        release.set()
        executor.shutdown(timeout_sec=5.0)
        spin.join(timeout=5.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def hold_the_engine(
    monkeypatch: pytest.MonkeyPatch, entered: threading.Event, release: threading.Event
) -> None:
    """The node's engine compiles, and its warm-up stops at ``HELD_AT`` of ``ENTRY_POINTS``
    (setting ``entered``) until ``release``; so do the warm-up predictions (a node that runs
    them before it returns from a callback would wait for ``release`` there)."""

    def held_engine(progress: Callable[[int, int], None]) -> None:
        for done in range(1, ENTRY_POINTS + 1):
            if done == HELD_AT + 1:
                entered.set()
                release.wait(timeout=WAIT_S)
            progress(done, ENTRY_POINTS)

    monkeypatch.setattr("xface_ros.worker.engine_state", lambda: COMPILES)
    monkeypatch.setattr("xface_ros.worker.warm_up_engine", held_engine)
    monkeypatch.setattr("xface_ros.worker.warm_up_simulator", lambda _config: release.wait(WAIT_S))


@pytest.fixture
def held_node(
    ros_domain_id: int, monkeypatch: pytest.MonkeyPatch
) -> Iterator[tuple[threading.Event, XfacePredictor]]:
    """Run an XfacePredictor in this process whose warm-up predictions wait for the returned
    event."""
    entered, release = threading.Event(), threading.Event()

    def blocked_warm_up(_config: NodeConfig) -> None:
        entered.set()
        release.wait(timeout=WAIT_S)

    monkeypatch.setattr("xface_ros.worker.warm_up_simulator", blocked_warm_up)
    with in_process(XfacePredictor, ros_domain_id, release) as node:
        assert isinstance(node, XfacePredictor)  # returned although the warm-up is blocked
        assert entered.wait(timeout=WAIT_S)
        assert not release.is_set()
        yield release, node


@pytest.fixture
def held_engine(ros_domain_id: int, monkeypatch: pytest.MonkeyPatch) -> Iterator[threading.Event]:
    """Run an XfacePredictor in this process whose engine compiles and holds at 3 of 7 entry
    points until the returned event is set."""
    entered, release = threading.Event(), threading.Event()
    hold_the_engine(monkeypatch, entered, release)
    with in_process(XfacePredictor, ros_domain_id, release):
        assert entered.wait(timeout=WAIT_S)
        yield release


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
    assert is_warming_up(predictor_message(warming) or "")

    release_warm_up.set()
    _sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, Y_START, math.pi))
    assert status.message.startswith("SEATED")
    c.diagnostics.wait_for(lambda a: not is_warming_up(predictor_message(a) or "warming"), WAIT_S)


def predictor_values(array: DiagnosticArray) -> dict[str, str]:
    status = next(s for s in array.status if s.name.endswith(": predictor"))
    return {kv.key: kv.value for kv in status.values}


def test_diagnostics_say_how_far_a_compiling_warm_up_has_come(
    held_engine: threading.Event, ros_client: Any
) -> None:
    c = ros_client
    warming = c.diagnostics.wait_for(lambda a: predictor_message(a) is not None, WAIT_S)
    message = predictor_message(warming)
    assert message is not None
    assert message.startswith(f"warming up: compiling the simulator ({HELD_AT}/{ENTRY_POINTS}, ")
    values = predictor_values(warming)
    assert (values["engine"], values["warm_up_done"], values["warm_up_total"]) == (
        "compiles", str(HELD_AT), str(ENTRY_POINTS),
    )  # fmt: skip
    held_engine.set()
    done = c.diagnostics.wait_for(lambda a: not is_warming_up(predictor_message(a) or "w"), WAIT_S)
    assert predictor_values(done)["warm_up_done"] == str(ENTRY_POINTS)


def test_a_managed_nodes_configure_returns_while_the_simulator_still_loads(
    ros_domain_id: int, monkeypatch: pytest.MonkeyPatch, ros_client: Any
) -> None:
    entered, release = threading.Event(), threading.Event()
    hold_the_engine(monkeypatch, entered, release)
    c = ros_client
    change = c.node.create_client(ChangeState, "/xface_predictor/change_state")

    def transition(transition_id: int) -> bool:
        request = ChangeState.Request(transition=Transition(id=transition_id))
        return bool(c.call(change, request, WAIT_S).success)

    with in_process(XfaceLifecyclePredictor, ros_domain_id, release):
        assert transition(Transition.TRANSITION_CONFIGURE)  # returns: the warm-up is held
        assert entered.wait(timeout=WAIT_S)
        assert not release.is_set()
        assert transition(Transition.TRANSITION_ACTIVATE)
        warming = c.diagnostics.wait_for(lambda a: predictor_message(a) is not None, WAIT_S)
        assert is_warming_up(predictor_message(warming) or "")
        release.set()
        _sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, Y_START, math.pi))
        assert status.message.startswith("SEATED")


def test_the_outputs_add_no_qos_event_handlers_to_the_executors_wait(
    held_node: tuple[threading.Event, XfacePredictor],
) -> None:
    """The executor adds every QoS-event handler to its wait set for every message it takes
    (docs/ros.md, "CPU per thread"): the seven outputs (with the typed prediction/result) have
    none, the pose inputs keep rclpy's default warnings and the stream's message-lost count."""
    node = held_node[1]
    outputs = {p.topic_name: len(p.event_handlers) for p in node._publishers_made}
    assert len(outputs) == 7
    assert set(outputs.values()) == {0}
    inputs = {s.topic_name: len(s.event_handlers) for s in node.subscriptions}
    assert inputs["/relative_pose"] > inputs["/relative_pose_with_covariance"] > 0
