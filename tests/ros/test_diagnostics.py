"""The /diagnostics formatter, without DDS: level, message and values from a stats snapshot."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus

from xface_core.frames import yaw_to_quaternion
from xface_ros.config import SPECS, NodeConfig, config_from_values
from xface_ros.decision import PoseInput, Rejected, evaluate_streamed
from xface_ros.diagnostics import (
    WARMING_UP_MESSAGE,
    diagnostic_array,
    is_warming_up,
    predictor_level,
    predictor_status,
)
from xface_ros.stats import PredictorStats, StatsSnapshot
from xface_ros.worker import PredictionWorker

ROOT = Path(__file__).resolve().parents[2]
NOW_NS = 1_700_000_000_000_000_000

#: The keys docs/ros.md lists for the predictor status, in order.
DOCUMENTED_KEYS = [
    "input_rate_hz", "prediction_rate_hz", "pose_age_s", "received_total", "predicted_total",
    "dropped_total", "dds_lost_reported_total", "dds_lost_total", "input_errors_total",
    "service_calls_total", "recording_errors_total", "last_outcome", "last_accepted",
    "last_input_error", "last_latency_ms", "latency_ms_median", "latency_ms_max",
    "compute_ms_median", "face", "width_m", "h_over_d", "r_p", "damping_ratio", "recording",
    "atlas", "engine", "warm_up_done", "warm_up_total", "warm_up_s",
]  # fmt: skip


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    return config_from_values({spec.name: spec.default for spec in SPECS})


def snapshot(
    stats: PredictorStats, *, received: int = 0, dropped: int = 0, now_ns: int = NOW_NS
) -> StatsSnapshot:
    return stats.take_snapshot(now_ns, received_total=received, dropped_total=dropped)


def ready_stats() -> PredictorStats:
    stats = PredictorStats(start_ns=NOW_NS - 2_000_000_000)  # a 2 s window
    stats.set_warming_up(False)
    return stats


def values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_warming_up_is_a_warning_until_the_simulator_is_loaded(config: NodeConfig) -> None:
    stats = PredictorStats(start_ns=0)
    stats.count_received(NOW_NS)  # poses arriving during the warm-up do not make it OK
    assert predictor_level(snapshot(stats)) == (DiagnosticStatus.WARN, WARMING_UP_MESSAGE)
    stats.set_warming_up(False)
    stats.count_received(NOW_NS)
    assert predictor_level(snapshot(stats))[0] == DiagnosticStatus.OK


@pytest.mark.parametrize(
    ("engine", "message"),
    [
        ("compiles", "warming up: compiling the simulator (3/7, 41 s)"),
        ("cached", "warming up: loading the simulator (3/7)"),
        ("precompiled", "warming up: loading the simulator (3/7)"),
    ],
)
def test_warming_up_says_how_far_the_simulator_has_loaded(
    config: NodeConfig, engine: str, message: str
) -> None:
    clock = [0.0]
    stats = PredictorStats(start_ns=0, monotonic_s=lambda: clock[0])
    stats.start_warm_up(engine)
    stats.set_warm_up_progress(3, 7)
    clock[0] = 41.2
    status = predictor_status(snapshot(stats), config, node_name="n", recording_path="")
    assert (status.level, status.message) == (DiagnosticStatus.WARN, message)
    assert is_warming_up(status.message)
    v = values(status)
    assert (v["engine"], v["warm_up_done"], v["warm_up_total"]) == (engine, "3", "7")
    assert float(v["warm_up_s"]) == pytest.approx(41.2)


def test_a_warm_up_that_compiles_shows_its_seconds_before_the_first_entry_is_done(
    config: NodeConfig,
) -> None:
    clock = [0.0]
    stats = PredictorStats(start_ns=0, monotonic_s=lambda: clock[0])
    stats.start_warm_up("compiles")
    clock[0] = 12.0
    status = predictor_status(snapshot(stats), config, node_name="n", recording_path="")
    assert status.message == "warming up: compiling the simulator (12 s)"


def test_no_pose_in_the_period_is_a_warning() -> None:
    level, message = predictor_level(snapshot(ready_stats()))
    assert level == DiagnosticStatus.WARN
    assert message == "no poses received in the last period"


def test_a_rejected_last_pose_is_an_error_and_a_prediction_is_ok(config: NodeConfig) -> None:
    stats = ready_stats()
    stats.count_received(NOW_NS)
    stats.count_verdict(Rejected(NOW_NS, "stale_stamp", "old"), latency_ms=1.0)
    assert predictor_level(snapshot(stats)) == (
        DiagnosticStatus.ERROR,
        "last pose rejected: stale_stamp",
    )
    stats.count_received(NOW_NS)
    verdict = evaluate_streamed(_centred(), config, receive_ns=NOW_NS, path=False)
    stats.count_verdict(verdict, latency_ms=1.0)
    assert predictor_level(snapshot(stats)) == (DiagnosticStatus.OK, "predicting: last SEATED")


def _centred() -> PoseInput:
    """A fresh, centred, aligned pose 3 widths up: it seats."""
    return PoseInput("xface_base", NOW_NS, (0.0, 0.15, 0.0), yaw_to_quaternion(math.pi))


def test_status_has_the_documented_keys_in_order_and_exact_numbers(config: NodeConfig) -> None:
    stats = ready_stats()
    for _ in range(4):
        stats.count_received(NOW_NS - 500_000_000)  # 0.5 s before the snapshot
    verdict = evaluate_streamed(_centred(), config, receive_ns=NOW_NS, path=False)
    for latency_ms in (1.0, 3.0, 2.0):
        stats.count_verdict(verdict, latency_ms=latency_ms)
    status = predictor_status(
        snapshot(stats, received=4, dropped=1), config, node_name="xface_predictor",
        recording_path="run.rrd",
    )  # fmt: skip
    assert status.name == "xface_predictor: predictor"
    assert status.hardware_id == "xface_base"
    assert [kv.key for kv in status.values] == DOCUMENTED_KEYS
    v = values(status)
    assert float(v["input_rate_hz"]) == pytest.approx(2.0)  # 4 poses in 2 s
    assert float(v["prediction_rate_hz"]) == pytest.approx(1.5)
    assert float(v["pose_age_s"]) == pytest.approx(0.5)
    assert (v["received_total"], v["predicted_total"], v["dropped_total"]) == ("4", "3", "1")
    assert v["last_outcome"] == "SEATED"
    assert v["last_accepted"] == "true"
    assert v["last_input_error"] == ""
    assert v["last_latency_ms"] == "2.0"
    assert (v["latency_ms_median"], v["latency_ms_max"]) == ("2.0", "3.0")
    assert (v["face"], v["width_m"], v["damping_ratio"], v["recording"]) == (
        "X", "0.05", "1.0", "run.rrd",
    )  # fmt: skip


def test_empty_window_statistics_are_nan(config: NodeConfig) -> None:
    status = predictor_status(
        snapshot(PredictorStats(start_ns=0)), config, node_name="n", recording_path=""
    )
    v = values(status)
    for key in ("pose_age_s", "latency_ms_median", "latency_ms_max", "compute_ms_median"):
        assert math.isnan(float(v[key])), key
    assert v["last_accepted"] == ""
    assert v["last_outcome"] == "none"


def test_array_carries_the_status_and_the_stamp(config: NodeConfig) -> None:
    status = predictor_status(
        snapshot(PredictorStats(start_ns=0)), config, node_name="n", recording_path=""
    )
    array = diagnostic_array([status], stamp=Time(sec=12, nanosec=34))
    assert array.status == [status]
    assert (array.header.stamp.sec, array.header.stamp.nanosec) == (12, 34)


def test_docs_list_every_diagnostics_key() -> None:
    docs = (ROOT / "docs" / "ros.md").read_text(encoding="utf-8")
    section = docs.split("### `/diagnostics`", 1)[1].split("\n## ", 1)[0]
    for key in DOCUMENTED_KEYS:
        assert f"`{key}`" in section, key


def test_worker_snapshot_feeds_the_formatter(config: NodeConfig) -> None:
    worker = PredictionWorker(
        config=lambda: config, now_ns=lambda: NOW_NS, wants_path=lambda: False,
        publish=lambda verdict, config: None, logger=None,  # type: ignore[arg-type]
    )  # fmt: skip
    worker.submit(_centred(), receive_ns=NOW_NS)
    status = predictor_status(
        worker.take_stats(NOW_NS + 10**9), config, node_name="n", recording_path=""
    )
    assert status.message == WARMING_UP_MESSAGE  # never started: still warming up
    assert values(status)["received_total"] == "1"
