"""The prediction worker without ROS: warm-up on its thread, newest pose, publish, count, record.

The node's side (clock, logger, publishing, subscriber counts) is faked with plain callables;
nothing here imports rclpy (tests/ros/test_decision.py runs this module with ROS blocked).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from xface_core.frames import yaw_to_quaternion
from xface_core.result import Prediction
from xface_core.runner import EngineState
from xface_ros.atlas_keeper import AtlasKeeper
from xface_ros.config import SPECS, NodeConfig, config_from_values
from xface_ros.decision import PoseInput, Predicted, Rejected, Verdict
from xface_ros.latest import Received
from xface_ros.worker import PredictionWorker

NOW_NS = 1_700_000_000_000_000_000
LATER_NS = NOW_NS + 3_000_000  # the clock 3 ms after the stamp
WIDTH = 0.05
WAIT_S = 60.0  # generous: the first simulation in a process loads the compiled kernels


class FakeLogger:
    """Collects log lines per level."""

    def __init__(self) -> None:
        self.lines: dict[str, list[str]] = {"info": [], "warning": [], "error": []}

    def info(self, message: str, **kwargs: Any) -> None:
        self.lines["info"].append(message)

    def warning(self, message: str, **kwargs: Any) -> None:
        self.lines["warning"].append(message)

    def error(self, message: str, **kwargs: Any) -> None:
        self.lines["error"].append(message)


class Published:
    """The node's publish callback: keeps the verdicts, can be told to fail."""

    def __init__(self, *, fail_first: int = 0) -> None:
        self.verdicts: list[Verdict] = []
        self.configs: list[NodeConfig] = []
        self.fail_first = fail_first
        self.cond = threading.Condition()

    def __call__(self, verdict: Verdict, config: NodeConfig) -> None:
        with self.cond:
            if self.fail_first > 0:
                self.fail_first -= 1
                raise RuntimeError("publisher broke")
            self.verdicts.append(verdict)
            self.configs.append(config)
            self.cond.notify_all()

    def wait_for(self, n: int) -> list[Verdict]:
        with self.cond:
            assert self.cond.wait_for(lambda: len(self.verdicts) >= n, timeout=WAIT_S)
            return list(self.verdicts)


class FakeRecorder:
    def __init__(self, *, fail: bool = False) -> None:
        self.recorded: list[tuple[Prediction, int, bool]] = []
        self.fail = fail
        self.path = "fake.rrd"

    def record(self, prediction: Prediction, *, stamp_ns: int, accepted: bool) -> None:
        if self.fail:
            raise OSError("disk full")
        self.recorded.append((prediction, stamp_ns, accepted))


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    defaults = config_from_values({spec.name: spec.default for spec in SPECS})
    return replace(defaults, compute_margins=False)  # fast: one simulation per pose


def at_start(x0_widths: float, theta0: float, *, stamp_ns: int = NOW_NS) -> PoseInput:
    q = yaw_to_quaternion(theta0 + math.pi)
    return PoseInput("xface_base", stamp_ns, (x0_widths * WIDTH, 3.0 * WIDTH, 0.0), q)


def make_worker(config: NodeConfig, publish: Published, **kwargs: Any) -> PredictionWorker:
    options: dict[str, Any] = {
        "config": lambda: config,
        "now_ns": lambda: LATER_NS,
        "wants_path": lambda: False,
        "publish": publish,
        "logger": FakeLogger(),
        "warm_up": lambda _config: None,
        "load_engine": lambda _progress: None,
    } | kwargs
    return PredictionWorker(**options)


@pytest.fixture
def workers() -> Iterator[list[PredictionWorker]]:
    """Every worker a test appends here is stopped at teardown."""
    started: list[PredictionWorker] = []
    yield started
    for worker in started:
        worker.stop(timeout_s=WAIT_S)


def test_the_warm_up_runs_on_the_worker_thread_and_poses_wait_for_it(
    config: NodeConfig, workers: list[PredictionWorker]
) -> None:
    entered, release = threading.Event(), threading.Event()
    warm_up_thread: list[str] = []

    def slow_warm_up(_config: NodeConfig) -> None:
        warm_up_thread.append(threading.current_thread().name)
        # Named for the OS too (top -H, ros_stress.py's CPU per thread), on Linux.
        task = Path(f"/proc/self/task/{threading.get_native_id()}/comm")
        if task.exists():
            warm_up_thread.append(task.read_text().strip())
        entered.set()
        assert release.wait(timeout=WAIT_S)

    publish = Published()
    worker = make_worker(config, publish, warm_up=slow_warm_up)
    workers.append(worker)
    worker.start()  # returns at once: the warm-up is the thread's business
    assert worker.warming_up
    worker.submit(at_start(0.0, 0.0), receive_ns=NOW_NS)
    assert entered.wait(timeout=WAIT_S)
    assert publish.verdicts == []  # the one thread that predicts is still warming up
    assert worker.take_stats(LATER_NS).counts.warming_up
    release.set()
    (verdict,) = publish.wait_for(1)
    assert isinstance(verdict, Predicted)
    assert not worker.warming_up
    assert warm_up_thread[0] == "xface_predictor"
    assert warm_up_thread[1:] in ([], ["xface_predictor"])


def test_a_failed_warm_up_is_logged_and_ends_the_warm_up(
    config: NodeConfig, workers: list[PredictionWorker]
) -> None:
    def broken(_config: NodeConfig) -> None:
        raise RuntimeError("no kernels")

    publish, logger = Published(), FakeLogger()
    worker = make_worker(config, publish, warm_up=broken, logger=logger)
    workers.append(worker)
    worker.start()
    worker.submit(at_start(0.0, 0.0), receive_ns=NOW_NS)
    publish.wait_for(1)
    assert not worker.warming_up
    assert any("warm-up prediction failed" in line for line in logger.lines["warning"])


COMPILES = EngineState(
    ready=False, source="compiles", compile_estimate_s=60.0,
    why_not_precompiled="no precompiled engine in this install",
)  # fmt: skip
CACHED = EngineState(ready=True, source="cached", compile_estimate_s=0.0)


@pytest.mark.parametrize("state", [COMPILES, CACHED], ids=["compiles", "cached"])
def test_the_warm_up_logs_the_engine_state_and_says_so_first_when_it_compiles(
    config: NodeConfig,
    workers: list[PredictionWorker],
    monkeypatch: pytest.MonkeyPatch,
    state: EngineState,
) -> None:
    from xface_ros import worker as worker_module

    monkeypatch.setattr(worker_module, "engine_state", lambda: state)
    publish, logger = Published(), FakeLogger()
    worker = make_worker(config, publish, warm_up=lambda _config: None, logger=logger)
    workers.append(worker)
    worker.start()
    worker.submit(at_start(0.0, 0.0), receive_ns=NOW_NS)
    publish.wait_for(1)
    said = [line for line in logger.lines["info"] if line.startswith("simulator: ")]
    why = "" if state.ready else "; no precompiled engine in this install"
    assert said == [f"simulator: {state.describe()}{why}"]  # one line, and why it compiles
    assert (worker_module.COMPILING_LOG in logger.lines["info"]) is not state.ready
    assert worker.take_stats(LATER_NS).counts.engine == state.source


class HeldEngine:
    """A stand-in for ``warm_up_engine``: reports ``held_at`` of ``total`` entry points done,
    then waits for :attr:`release` before it reports the rest."""

    def __init__(self, *, held_at: int = 3, total: int = 7) -> None:
        self.held_at, self.total = held_at, total
        self.entered, self.release = threading.Event(), threading.Event()
        self.reported: list[int] = []

    def __call__(self, progress: Any) -> None:
        for done in range(1, self.total + 1):
            if done == self.held_at + 1:
                self.entered.set()
                assert self.release.wait(timeout=WAIT_S)
            self.reported.append(done)
            progress(done, self.total)


def test_the_warm_up_counts_the_engines_progress_for_the_diagnostics(
    config: NodeConfig, workers: list[PredictionWorker], monkeypatch: pytest.MonkeyPatch
) -> None:
    from xface_ros import worker as worker_module

    monkeypatch.setattr(worker_module, "engine_state", lambda: COMPILES)
    engine = HeldEngine(held_at=3, total=7)
    worker = make_worker(config, Published(), load_engine=engine)
    workers.append(worker)
    worker.start()
    assert engine.entered.wait(timeout=WAIT_S)
    counts = worker.take_stats(LATER_NS).counts
    assert (counts.warming_up, counts.warm_up_done, counts.warm_up_total) == (True, 3, 7)
    engine.release.set()
    deadline = time.monotonic() + WAIT_S
    while worker.warming_up and time.monotonic() < deadline:
        time.sleep(0.01)
    counts = worker.take_stats(LATER_NS).counts
    assert (counts.warming_up, counts.warm_up_done, counts.warm_up_total) == (False, 7, 7)


def test_a_worker_stopped_while_it_warms_up_stops_after_the_entry_in_progress(
    config: NodeConfig,
) -> None:
    engine = HeldEngine(held_at=1, total=7)
    predicted: list[NodeConfig] = []
    atlas_builds: list[Any] = []

    def build(*args: Any) -> Any:
        atlas_builds.append(args)
        raise RuntimeError("not wanted")

    worker = make_worker(
        config, Published(), load_engine=engine, warm_up=predicted.append,
        atlas=AtlasKeeper(FakeLogger(), build=build),
    )  # fmt: skip
    worker.start()
    assert engine.entered.wait(timeout=WAIT_S)
    worker.stop(timeout_s=0.0)  # told to stop while the second entry point loads
    engine.release.set()
    worker.stop(timeout_s=WAIT_S)
    assert not worker._thread.is_alive()
    assert engine.reported == [1, 2]  # the entry in progress finished, no later one began
    assert predicted == []
    assert atlas_builds == []


def test_a_prediction_is_published_with_its_config_and_counted(config: NodeConfig) -> None:
    publish = Published()
    worker = make_worker(config, publish)
    verdict = worker.process(Received(at_start(0.3, 0.2), receive_ns=NOW_NS))
    assert isinstance(verdict, Predicted)
    assert verdict.accepted
    assert verdict.prediction.path is None  # nobody wants the path
    assert publish.verdicts == [verdict]
    assert publish.configs == [config]
    snap = worker.take_stats(LATER_NS)
    assert snap.counts.predicted_total == 1
    assert snap.counts.last_outcome == "SEATED"
    assert snap.counts.last_accepted is True
    assert snap.counts.last_latency_ms == pytest.approx(3.0)


def test_paths_are_computed_only_when_wanted(config: NodeConfig) -> None:
    wanted = make_worker(config, Published(), wants_path=lambda: True)
    verdict = wanted.process(Received(at_start(0.3, 0.2), receive_ns=NOW_NS))
    assert isinstance(verdict, Predicted)
    assert verdict.prediction.path is not None


def test_a_rejected_pose_is_published_counted_and_logged(config: NodeConfig) -> None:
    publish, logger = Published(), FakeLogger()
    worker = make_worker(config, publish, logger=logger)
    tilted = replace(at_start(0.0, 0.0), orientation=(0.0, math.sin(0.15), 0.0, math.cos(0.15)))
    verdict = worker.process(Received(tilted, receive_ns=NOW_NS))
    assert isinstance(verdict, Rejected)
    assert verdict.code == "non_planar"
    assert publish.verdicts == [verdict]
    snap = worker.take_stats(LATER_NS)
    assert snap.counts.input_errors_total == 1
    assert snap.counts.last_input_error == "non_planar"
    assert logger.lines["error"] == [f"pose rejected: non_planar: {verdict.detail}"]


def test_the_stamp_is_judged_at_arrival_not_when_the_worker_gets_to_it(
    config: NodeConfig,
) -> None:
    worker = make_worker(config, Published(), now_ns=lambda: NOW_NS + 10**10)  # 10 s later
    verdict = worker.process(Received(at_start(0.0, 0.0), receive_ns=NOW_NS))
    assert isinstance(verdict, Predicted)


def test_newest_pose_wins_and_older_ones_count_as_dropped(
    config: NodeConfig, workers: list[PredictionWorker]
) -> None:
    publish = Published()
    worker = make_worker(config, publish)
    workers.append(worker)
    for i in range(3):  # before the thread runs: all wait in the one slot
        worker.submit(at_start(0.0, 0.0, stamp_ns=NOW_NS + i), receive_ns=NOW_NS + i)
    worker.start()
    (verdict,) = publish.wait_for(1)
    assert verdict.stamp_ns == NOW_NS + 2
    latest = worker.latest_pose
    assert latest is not None
    assert latest.stamp_ns == NOW_NS + 2
    snap = worker.take_stats(LATER_NS)
    assert (snap.received_total, snap.dropped_total, snap.window.received) == (3, 2, 3)


def test_a_failing_publish_becomes_an_internal_error_and_the_worker_goes_on(
    config: NodeConfig, workers: list[PredictionWorker]
) -> None:
    publish = Published(fail_first=1)
    worker = make_worker(config, publish)
    workers.append(worker)
    worker.start()
    worker.submit(at_start(0.0, 0.0), receive_ns=NOW_NS)
    (error,) = publish.wait_for(1)
    assert isinstance(error, Rejected)
    assert error.code == "internal_error"
    assert "publisher broke" in error.detail
    worker.submit(at_start(0.0, 0.0, stamp_ns=NOW_NS + 1), receive_ns=NOW_NS + 1)
    assert isinstance(publish.wait_for(2)[1], Predicted)


def test_a_failing_publish_during_shutdown_ends_the_worker_quietly(
    config: NodeConfig, workers: list[PredictionWorker]
) -> None:
    publish = Published(fail_first=100)
    worker = make_worker(config, publish, shutting_down=lambda: True)
    workers.append(worker)
    worker.submit(at_start(0.0, 0.0), receive_ns=NOW_NS)
    worker.start()
    worker._thread.join(timeout=WAIT_S)
    assert not worker._thread.is_alive()
    assert publish.verdicts == []


def test_predictions_are_recorded_and_recording_failures_counted(config: NodeConfig) -> None:
    recorder = FakeRecorder()
    worker = make_worker(config, Published(), recorder=recorder)
    verdict = worker.process(Received(at_start(0.3, 0.2), receive_ns=NOW_NS))
    assert isinstance(verdict, Predicted)
    assert verdict.prediction.path is not None  # a recording wants the path
    assert recorder.recorded == [(verdict.prediction, NOW_NS, verdict.accepted)]

    logger = FakeLogger()
    failing = make_worker(config, Published(), recorder=FakeRecorder(fail=True), logger=logger)
    failing.process(Received(at_start(0.3, 0.2), receive_ns=NOW_NS))
    assert failing.take_stats(LATER_NS).counts.recording_errors_total == 1
    assert logger.lines["error"] == ["recording failed: OSError('disk full')"]


def test_a_prediction_is_recorded_even_when_its_publishing_fails(config: NodeConfig) -> None:
    # At shutdown the context can go down between the status and the seated pose's publish;
    # the status may already be out, so the recording must still hold the prediction.
    recorder = FakeRecorder()
    worker = make_worker(config, Published(fail_first=1), recorder=recorder)
    with pytest.raises(RuntimeError, match="publisher broke"):
        worker.process(Received(at_start(0.3, 0.2), receive_ns=NOW_NS))
    assert [stamp for _, stamp, _ in recorder.recorded] == [NOW_NS]
    assert recorder.recorded[0][0].seated


def test_stop_is_idempotent(config: NodeConfig) -> None:
    worker = make_worker(config, Published())
    worker.start()
    worker.stop(timeout_s=WAIT_S)
    worker.stop(timeout_s=WAIT_S)
    assert not worker._thread.is_alive()


def test_stop_waits_for_an_atlas_build_still_running(config: NodeConfig) -> None:
    # The build starts after the warm-up; a process must not exit (and rclpy not go) while it
    # runs on its daemon thread.
    started, finished = threading.Event(), threading.Event()

    def slow_build(design: Any, physics: Any, cache_dir: str, cancel: Any) -> Any:
        started.set()
        time.sleep(0.3)
        finished.set()
        raise RuntimeError("no atlas needed here")

    worker = make_worker(config, Published(), atlas=AtlasKeeper(FakeLogger(), build=slow_build))
    worker.start()
    assert started.wait(timeout=WAIT_S)
    worker.stop(timeout_s=WAIT_S)
    assert finished.is_set()


WARM_UP_PROBE = """
from xface_core import _engine
from xface_ros.config import SPECS, config_from_values
from xface_ros.worker import warm_up_simulator

warm_up_simulator(config_from_values({spec.name: spec.default for spec in SPECS}))
for name in ("simulate_path", "simulate_final", "simulate_many"):
    print(name, len(getattr(_engine.simulate, name).signatures))
"""


def test_the_warm_up_loads_every_compiled_entry_a_pose_can_take() -> None:
    # A fresh process: a dispatcher has signatures only once called (compiled or loaded
    # from the cache), so what the warm-up did not touch shows up as 0.
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", WARM_UP_PROBE], capture_output=True, text=True, timeout=600,
        check=True,
    ).stdout  # fmt: skip
    loaded = dict(line.split() for line in out.splitlines())
    assert loaded == {"simulate_path": "1", "simulate_final": "1", "simulate_many": "1"}
