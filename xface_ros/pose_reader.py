"""The pose inputs taken on a thread of their own, outside rclpy's executor.

rclpy's ``SingleThreadedExecutor`` rebuilds its wait set in Python from every entity of the
node (parameter services, the two services, the timer, guard conditions, QoS-event handlers:
about 20) for every message it takes. On a 1 kHz pose stream that was about 0.4 ms of
interpreter time per pose, holding the GIL four tenths of the time, and the prediction
worker's own Python waited for it: margins from the atlas took 2-2.5 times as long in the
node as in one process (docs/notes/2026-11-24-pose-reader.md).

So the two pose subscriptions sit in a :class:`ReadByPoseReader` callback group, which the
executor never runs, and a :class:`PoseReader` thread waits on them alone, as rclpy's own
``wait_for_message`` does (a wait set of the subscriptions, their QoS-event handlers and a
guard condition). It takes every message and hands it to the node's callback, which only
converts it and puts it into the worker's slot (newest wins, as before). The executor keeps
the services, the parameters and the diagnostics timer.

The subscriptions' QoS-event handlers (message lost, incompatible QoS or type) run on the
reader too: left to the executor they would wake it for every message the reader has not yet
taken (with Fast DDS they wait on the data reader's status condition, which data also
raises), and it spun at 100 % of a core.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterable, Sequence
from typing import Any, cast

from rclpy.callback_groups import CallbackGroup
from rclpy.context import Context
from rclpy.event_handler import EventHandler
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription

from xface_ros.threadname import name_os_thread

__all__ = ["THREAD_NAME", "PoseReader", "ReadByPoseReader"]

#: The reader thread's name (also for the operating system: ``top -H``, ros_stress.py).
THREAD_NAME = "xface_poses"
#: How long one wait lasts before the reader checks whether to stop (ns); :meth:`PoseReader.stop`
#: wakes it at once through its guard condition.
_WAIT_NS = 200_000_000
#: Seconds between repeats of the log line of a failing callback.
_LOG_THROTTLE_S = 5.0
#: Pause after an unexpected failure of a wait or a take, before the next wait (s).
_RETRY_S = 0.01


class ReadByPoseReader(CallbackGroup):
    """A callback group the executor never runs: a :class:`PoseReader` takes its
    subscriptions' messages and QoS events."""

    def can_execute(self, entity: Any) -> bool:
        return False

    def beginning_execution(self, entity: Any) -> bool:
        return False

    def ending_execution(self, entity: Any) -> None:
        """Never called: nothing of this group begins execution in an executor."""


class PoseReader:
    """Takes every message of ``subscriptions`` on its own thread and calls the
    subscription's own callback with it, in arrival order per subscription; also runs the
    subscriptions' QoS-event handlers.

    Start it with :meth:`start` once the subscriptions exist (each in a
    :class:`ReadByPoseReader` group) and :meth:`stop` it before they are destroyed. A
    callback that raises is logged (at most every few seconds) and the reader goes on: one
    bad message must not end the stream.
    """

    def __init__(
        self,
        context: Context,
        subscriptions: Sequence[Subscription],
        logger: Any,
    ) -> None:
        for sub in subscriptions:
            if not isinstance(sub.callback_group, ReadByPoseReader):
                raise ValueError(
                    f"{sub.topic_name}: the executor would take its messages too "
                    "(create it with callback_group=ReadByPoseReader())"
                )
        self._context = context
        self._subscriptions = list(subscriptions)
        self._logger = logger
        self._stop = threading.Event()
        self._wake = GuardCondition(None, None, context=context)
        self._thread = threading.Thread(target=self._run, name=THREAD_NAME, daemon=True)
        self.taken = 0  # messages handed to a callback

    def start(self) -> None:
        self._thread.start()

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def stop(self, timeout_s: float = 5.0) -> None:
        """End the thread and wait up to ``timeout_s`` for it (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        with contextlib.suppress(Exception):  # a context already down ends the wait itself
            self._wake.trigger()
        if self._thread.is_alive():
            self._thread.join(timeout=timeout_s)
        with contextlib.suppress(Exception):  # as above: nothing left to release
            self._wake.destroy()

    # --- the reader thread ------------------------------------------------------------------

    def _run(self) -> None:
        name_os_thread(THREAD_NAME)
        subs = self._subscriptions
        # rclpy annotates Subscription.event_handlers as one handler; it is a list of them.
        events = [h for sub in subs for h in cast(Iterable[EventHandler], sub.event_handlers)]
        wait_set = _rclpy.WaitSet(len(subs), 1, 0, 0, 0, len(events), self._context.handle)
        while not self._stop.is_set() and self._context.ok():
            try:
                self._wait_and_take(wait_set, subs, events)
            except Exception as exc:
                if self._stop.is_set() or not self._context.ok():
                    return  # the context went down under the wait or a take: shutting down
                # Unexpected: say so and go on (a reader that ended quietly would leave the
                # node answering services but never another pose).
                self._logger.error(f"pose reader: {exc!r}", throttle_duration_sec=_LOG_THROTTLE_S)
                self._stop.wait(_RETRY_S)

    def _wait_and_take(
        self, wait_set: Any, subs: list[Subscription], events: list[EventHandler]
    ) -> None:
        """One wait on the subscriptions, their events and the stop guard; then every ready
        event handled and every waiting message taken."""
        wait_set.clear_entities()
        for sub in subs:
            wait_set.add_subscription(sub.handle)
        for handler in events:
            handler.add_to_wait_set(wait_set)
        wait_set.add_guard_condition(self._wake.handle)
        wait_set.wait(_WAIT_NS)
        for handler in events:
            if handler.is_ready(wait_set):
                event = handler.take_data()
                if event is not None and handler.callback is not None:
                    self._call(handler.callback, event)
        ready = wait_set.get_ready_entities("subscription")
        for sub in subs:
            if sub.handle.pointer in ready:
                self._take_all(sub)

    def _take_all(self, sub: Subscription) -> None:
        """Every message waiting in ``sub``'s reader queue, oldest first (the slot the
        callback fills keeps the newest and counts the rest as dropped)."""
        while not self._stop.is_set():
            taken = sub.handle.take_message(sub.msg_type, sub.raw)
            if taken is None:
                return
            self.taken += 1
            self._call(sub.callback, taken[0])

    def _call(self, callback: Callable[[Any], None], arg: Any) -> None:
        try:
            callback(arg)
        except Exception as exc:
            if self._stop.is_set() or not self._context.ok():
                return  # shutting down: the worker or the publishers may be gone
            self._logger.error(
                f"pose input callback failed: {exc!r}", throttle_duration_sec=_LOG_THROTTLE_S
            )
