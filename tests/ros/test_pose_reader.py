"""The pose inputs read on their own thread (xface_ros.pose_reader), over real DDS."""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest
import rclpy
from rclpy.context import Context
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Int32

from xface_ros.pose_reader import THREAD_NAME, PoseReader, ReadByPoseReader

#: Reliable with a queue deep enough for every message a test sends: none may be lost.
RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
WAIT_S = 10.0


@dataclass
class Received:
    """What a reader's callback saw: the values and the thread each came on."""

    values: list[int] = field(default_factory=list)
    threads: set[str] = field(default_factory=set)
    cond: threading.Condition = field(default_factory=threading.Condition)

    def add(self, msg: Int32) -> None:
        with self.cond:
            self.values.append(int(msg.data))
            self.threads.add(threading.current_thread().name)
            self.cond.notify_all()

    def wait_count(self, n: int) -> list[int]:
        with self.cond:
            self.cond.wait_for(lambda: len(self.values) >= n, timeout=WAIT_S)
            return list(self.values)


class ListLogger:
    def __init__(self) -> None:
        self.errors: list[str] = []

    def error(self, message: str, **kwargs: Any) -> None:
        self.errors.append(message)


@dataclass
class Ros:
    context: Context
    node: Node
    executor: SingleThreadedExecutor


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[Ros]:
    """A node in a context of its own, spun by an executor on a thread (as in the node)."""
    context = Context()
    rclpy.init(
        context=context, domain_id=ros_domain_id, signal_handler_options=SignalHandlerOptions.NO
    )
    node = Node("xface_pose_reader_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def spin() -> None:
        with contextlib.suppress(ExternalShutdownException):
            executor.spin()

    thread = threading.Thread(target=spin, daemon=True)
    thread.start()
    try:
        yield Ros(context, node, executor)
    finally:
        rclpy.try_shutdown(context=context)
        thread.join(timeout=WAIT_S)
        node.destroy_node()


def publish_when_matched(node: Node, topic: str, values: list[int]) -> None:
    pub = node.create_publisher(Int32, topic, RELIABLE)
    deadline = time.monotonic() + WAIT_S
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    for v in values:
        pub.publish(Int32(data=v))


def test_the_group_lets_the_executor_run_nothing_of_it(ros: Ros) -> None:
    group = ReadByPoseReader()
    sub = ros.node.create_subscription(
        Int32,
        "poses",
        lambda _: None,
        RELIABLE,
        callback_group=group,
        event_callbacks=SubscriptionEventCallbacks(message_lost=lambda _: None),
    )
    entities = [sub, *sub.event_handlers]
    assert len(entities) > 1  # the subscription and its QoS-event handlers
    for entity in entities:
        assert entity.callback_group is group
        assert not ros.executor.can_execute(entity)
        assert not group.beginning_execution(entity)


def test_every_message_reaches_the_callback_in_order_on_the_reader_thread(ros: Ros) -> None:
    got = Received()
    sub = ros.node.create_subscription(
        Int32, "poses", got.add, RELIABLE, callback_group=ReadByPoseReader()
    )
    reader = PoseReader(ros.context, [sub], ListLogger())
    reader.start()
    try:
        publish_when_matched(ros.node, "poses", list(range(50)))
        assert got.wait_count(50) == list(range(50))
        assert got.threads == {THREAD_NAME}  # taken by the reader, never by the executor
        assert reader.taken == 50
    finally:
        reader.stop()


def test_two_subscriptions_are_read_by_one_reader(ros: Ros) -> None:
    first, second = Received(), Received()
    subs = [
        ros.node.create_subscription(Int32, topic, inbox.add, RELIABLE, callback_group=group)
        for topic, inbox, group in (
            ("poses", first, ReadByPoseReader()),
            ("poses_with_covariance", second, ReadByPoseReader()),
        )
    ]
    reader = PoseReader(ros.context, subs, ListLogger())
    reader.start()
    try:
        publish_when_matched(ros.node, "poses", [1, 2, 3])
        publish_when_matched(ros.node, "poses_with_covariance", [7, 8])
        assert first.wait_count(3) == [1, 2, 3]
        assert second.wait_count(2) == [7, 8]
    finally:
        reader.stop()


#: A best-effort publisher cannot serve a RELIABLE subscription: the subscription gets a
#: "requested incompatible QoS" event, which the reader handles beside the messages.
BEST_EFFORT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)


@contextlib.contextmanager
def reading_beside_an_incompatible_publisher(
    ros: Ros, on_message: Any, on_incompatible: Any
) -> Iterator[None]:
    """A reader of a reliable "poses" subscription with an incompatible-QoS handler, running
    while a best-effort publisher of the topic exists."""
    callbacks = SubscriptionEventCallbacks(incompatible_qos=on_incompatible)
    sub = ros.node.create_subscription(
        Int32, "poses", on_message, RELIABLE, callback_group=ReadByPoseReader(),
        event_callbacks=callbacks,
    )  # fmt: skip
    reader = PoseReader(ros.context, [sub], ListLogger())
    reader.start()
    try:
        ros.node.create_publisher(Int32, "poses", BEST_EFFORT)
        yield
    finally:
        reader.stop()


def test_a_qos_event_reaches_its_handler_on_the_reader_thread(ros: Ros) -> None:
    events: list[tuple[int, str]] = []
    seen = threading.Event()

    def on_incompatible(info: Any) -> None:
        events.append((int(info.total_count), threading.current_thread().name))
        seen.set()

    with reading_beside_an_incompatible_publisher(ros, lambda _: None, on_incompatible):
        assert seen.wait(WAIT_S)
        assert events[0][0] >= 1
        assert {thread for _, thread in events} == {THREAD_NAME}


def test_messages_keep_flowing_beside_a_qos_event(ros: Ros) -> None:
    got = Received()
    with reading_beside_an_incompatible_publisher(ros, got.add, lambda _: None):
        publish_when_matched(ros.node, "poses", list(range(20)))
        assert got.wait_count(20) == list(range(20))


def test_a_failing_callback_is_logged_and_the_reader_goes_on(ros: Ros) -> None:
    got = Received()

    def callback(msg: Int32) -> None:
        if msg.data == 1:
            raise ValueError("bad pose")
        got.add(msg)

    logger = ListLogger()
    sub = ros.node.create_subscription(
        Int32, "poses", callback, RELIABLE, callback_group=ReadByPoseReader()
    )
    reader = PoseReader(ros.context, [sub], logger)
    reader.start()
    try:
        publish_when_matched(ros.node, "poses", [0, 1, 2])
        assert got.wait_count(2) == [0, 2]
        assert reader.running
        assert len(logger.errors) == 1
        assert "bad pose" in logger.errors[0]
    finally:
        reader.stop()


def test_stop_ends_the_thread_and_is_idempotent(ros: Ros) -> None:
    sub = ros.node.create_subscription(
        Int32, "poses", lambda _: None, RELIABLE, callback_group=ReadByPoseReader()
    )
    reader = PoseReader(ros.context, [sub], ListLogger())
    reader.start()
    assert reader.running
    reader.stop()
    assert not reader.running
    reader.stop()
    assert not reader.running


def test_a_subscription_the_executor_would_also_run_is_refused(ros: Ros) -> None:
    sub = ros.node.create_subscription(Int32, "poses", lambda _: None, RELIABLE)
    with pytest.raises(ValueError, match="ReadByPoseReader"):
        PoseReader(ros.context, [sub], ListLogger())


def test_an_unexpected_failure_is_logged_and_the_reader_goes_on(ros: Ros) -> None:
    got, logger = Received(), ListLogger()
    sub = ros.node.create_subscription(
        Int32, "poses", got.add, RELIABLE, callback_group=ReadByPoseReader()
    )
    reader = PoseReader(ros.context, [sub], logger)
    original = reader._wait_and_take
    failures = [RuntimeError("rmw hiccup")]

    def flaky(*args: Any) -> None:
        if failures:
            raise failures.pop()
        original(*args)

    reader._wait_and_take = flaky  # type: ignore[method-assign]
    reader.start()
    try:
        publish_when_matched(ros.node, "poses", [5, 6])
        assert got.wait_count(2) == [5, 6]
        assert reader.running
        assert logger.errors == ["pose reader: RuntimeError('rmw hiccup')"]
    finally:
        reader.stop()
