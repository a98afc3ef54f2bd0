"""scripts/bench/ros_stress.py: CPU per thread name, read from /proc (the run itself is
tests/ros/test_stress.py)."""

from __future__ import annotations

import importlib
import os
import sys
import threading
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "bench"))
stress = importlib.import_module("ros_stress")

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def test_cpu_is_summed_by_thread_name_and_a_busy_thread_shows() -> None:
    from xface_ros.threadname import name_os_thread

    before = stress.cpu_by_thread(os.getpid())
    spun, read = threading.Event(), threading.Event()

    def spin() -> None:
        name_os_thread("cpu_test_spin")
        end = time.thread_time() + 0.3  # this thread's CPU: sure to add clock ticks
        while time.thread_time() < end:
            pass
        spun.set()
        read.wait(timeout=30.0)  # a thread that has ended is gone from /proc/<pid>/task

    thread = threading.Thread(target=spin)
    thread.start()
    assert spun.wait(timeout=30.0)
    after = stress.cpu_by_thread(os.getpid())
    read.set()
    thread.join(timeout=30.0)
    spent = stress.cpu_spent(before, after)
    assert spent.get("cpu_test_spin", 0.0) > 0.0
    assert list(spent.values()) == sorted(spent.values(), reverse=True)


def test_threads_that_did_not_run_are_left_out() -> None:
    assert stress.cpu_spent({"a": 1.0, "b": 2.0}, {"a": 1.0, "b": 2.5, "c": 0.25}) == {
        "b": 0.5,
        "c": 0.25,
    }
