"""The node's main loop tells a failure caused by a signal's shutdown from a real error.

rclpy's signal handler shuts the context down from a thread of its own; the executor can fail
inside rcl (take_message: "Unable to convert call argument") just before the context shows
as down. Seen once in CI under a 1 kHz stream (tests/ros/test_shutdown_under_load.py).
"""

from __future__ import annotations

import threading

import pytest

from xface_ros import node


def test_a_failure_just_before_the_context_goes_down_is_the_shutdown(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    down = threading.Event()
    monkeypatch.setattr(node.rclpy, "ok", lambda: not down.is_set())
    threading.Timer(0.05, down.set).start()  # the signal handler's thread, a moment later
    node._shutdown_race(RuntimeError("Unable to convert call argument '0' to Python object"))


def test_a_failure_with_no_shutdown_behind_it_is_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[int] = []
    monkeypatch.setattr(node.rclpy, "ok", lambda: asked.append(1) or True)
    monkeypatch.setattr(node, "SHUTDOWN_GRACE_S", 0.1)
    with pytest.raises(RuntimeError, match="a real error"):
        node._shutdown_race(RuntimeError("a real error"))
    assert len(asked) > 2  # it kept looking for a shutdown that never came


def test_a_failure_after_the_context_is_down_is_the_shutdown(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(node.rclpy, "ok", lambda: False)
    node._shutdown_race(RuntimeError("failed to initialize wait set"))
