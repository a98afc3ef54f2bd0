"""scripts/bench/ros_stress.py: CPU per thread name, read from /proc (the run itself is
tests/ros/test_stress.py)."""

from __future__ import annotations

import importlib
import math
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


def test_the_table_streams_every_rate_without_and_with_a_covariance_then_the_overload() -> None:
    assert stress.table_rows([10.0, 100.0], 1000.0) == [
        (10.0, False), (10.0, True), (100.0, False), (100.0, True), (1000.0, False),
    ]  # fmt: skip
    assert stress.table_rows([30.0], 0.0) == [(30.0, False), (30.0, True)]


def test_each_row_is_held_to_the_issue_s_goals() -> None:
    assert stress.goals(30.0, False, False) == {"answered_share": 1.0, "latency_ms_p99": 10.0}
    assert stress.goals(100.0, False, False)["cpu_share_node"] == 0.3
    assert stress.goals(100.0, True, False) == {"answered_share": 0.99, "latency_ms_p99": 20.0}
    assert stress.goals(1000.0, False, True) == {"latency_ms_p99": 20.0}


def test_a_share_must_reach_its_goal_and_a_latency_stay_under_it() -> None:
    goal = {"answered_share": 0.99, "latency_ms_p99": 20.0, "cpu_share_node": 0.3}
    run = {"answered_share": 0.989, "latency_ms_p99": 20.0, "cpu_share_node": 0.31}
    assert stress.met(run, goal) == {
        "answered_share": False, "latency_ms_p99": True, "cpu_share_node": False,
    }  # fmt: skip


def test_rss_growth_is_counted_after_the_warm_up() -> None:
    # 5 MiB in the first minute, then 0.5 MiB a minute for 9 minutes.
    timeline = [(float(t), 100.0 + (5.0 if t >= 60 else 0.0) + 0.5 * max(t - 60, 0) / 60)
                for t in range(601)]  # fmt: skip
    growth, slope = stress.rss_growth(timeline, 60.0)
    assert growth == pytest.approx(4.5)
    assert slope == pytest.approx(0.5)
    assert all(math.isnan(v) for v in stress.rss_growth(timeline[:30], 60.0))
