"""The ``/diagnostics`` message of the node, built from a stats snapshot (the formatter).

One ``DiagnosticStatus`` named ``<node>: predictor`` per period. Level and message:

* ``WARN`` "warming up ..." until the worker has loaded the simulator;
* ``WARN`` when no pose arrived during the period;
* ``ERROR`` when the last pose was rejected;
* ``OK`` otherwise.

The values (keys listed in docs/ros.md) are the snapshot's counters and rates, the window's
latency and compute-time statistics (ms) and the design. Needs the message packages, not a
running ROS context: tested without DDS (tests/ros/test_diagnostics.py).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from xface_ros.config import NodeConfig
from xface_ros.conversions import key_value
from xface_ros.decision import StatsSnapshot

__all__ = [
    "WARMING_UP_MESSAGE",
    "diagnostic_array",
    "predictor_level",
    "predictor_status",
    "predictor_values",
]

#: The message of the status while the simulator loads (a fresh checkout compiles it).
WARMING_UP_MESSAGE = "warming up: loading the simulator"


def _median(values: Sequence[float]) -> float:
    return statistics.median(values) if values else math.nan


def predictor_values(
    snapshot: StatsSnapshot, config: NodeConfig, *, recording_path: str
) -> dict[str, object]:
    """The status's values, in the documented order (rates in Hz, ages in s, times in ms)."""
    window, span_s, counts = snapshot.window, snapshot.window_s, snapshot.counts
    return {
        "input_rate_hz": window.received / span_s,
        "prediction_rate_hz": window.predicted / span_s,
        "pose_age_s": snapshot.pose_age_s,
        "received_total": snapshot.received_total,
        "predicted_total": counts.predicted_total,
        "dropped_total": snapshot.dropped_total,
        "dds_lost_reported_total": counts.dds_lost_reported_total,
        # The old name, kept for existing readers: it never counted the poses lost in DDS.
        "dds_lost_total": counts.dds_lost_reported_total,
        "input_errors_total": counts.input_errors_total,
        "service_calls_total": counts.service_calls_total,
        "recording_errors_total": counts.recording_errors_total,
        "last_outcome": counts.last_outcome,
        "last_accepted": counts.last_accepted,
        "last_input_error": counts.last_input_error,
        "last_latency_ms": counts.last_latency_ms,
        "latency_ms_median": _median(window.latency_ms),
        "latency_ms_max": max(window.latency_ms, default=math.nan),
        "compute_ms_median": _median(window.compute_ms),
        "face": config.face,
        "width_m": config.width_m,
        "h_over_d": config.h_over_d,
        "r_p": config.r_p,
        "damping_ratio": config.damping_ratio,
        "recording": recording_path,
    }


def predictor_level(snapshot: StatsSnapshot) -> tuple[bytes, str]:
    """The status level (``DiagnosticStatus.OK`` etc.) and its message."""
    counts = snapshot.counts
    if counts.warming_up:
        return DiagnosticStatus.WARN, WARMING_UP_MESSAGE
    if snapshot.window.received == 0:
        return DiagnosticStatus.WARN, "no poses received in the last period"
    if counts.last_input_error:
        return DiagnosticStatus.ERROR, f"last pose rejected: {counts.last_input_error}"
    return DiagnosticStatus.OK, f"predicting: last {counts.last_outcome}"


def predictor_status(
    snapshot: StatsSnapshot,
    config: NodeConfig,
    *,
    node_name: str,
    recording_path: str,
    atlas: str = "off",
) -> DiagnosticStatus:
    """The node's ``<node_name>: predictor`` status (``hardware_id`` = ``base_frame``);
    ``atlas`` is the acceptance atlas's state (off, building, ready, failed: until it is ready
    margins are searched exactly)."""
    level, message = predictor_level(snapshot)
    values = predictor_values(snapshot, config, recording_path=recording_path)
    values["atlas"] = atlas
    return DiagnosticStatus(
        level=level,
        name=f"{node_name}: predictor",
        message=message,
        hardware_id=config.base_frame,
        values=[key_value(key, value) for key, value in values.items()],
    )


def diagnostic_array(statuses: Sequence[DiagnosticStatus], *, stamp: Time) -> DiagnosticArray:
    """The ``/diagnostics`` message: ``statuses`` stamped with ``stamp`` (the node clock)."""
    array = DiagnosticArray(status=list(statuses))
    array.header.stamp = stamp
    return array
