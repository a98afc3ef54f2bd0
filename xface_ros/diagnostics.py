"""The ``/diagnostics`` message of the node, built from a stats snapshot (the formatter).

One ``DiagnosticStatus`` named ``<node>: predictor`` per period. Level and message:

* ``WARN`` "warming up: ..." until the worker has loaded the simulator, with its progress
  (``warming up: compiling the simulator (3/7, 41 s)``, ``warming up: loading the simulator
  (3/7)``; :func:`warming_up_message`): a client waits for a message that does not start with
  :data:`WARMING_UP_PREFIX`;
* ``WARN`` when no pose arrived during the period;
* ``ERROR`` when the last pose was rejected;
* ``OK`` otherwise.

The values (keys listed in docs/ros.md) are the snapshot's counters and rates, the window's
latency and compute-time statistics (ms), the design, the atlas's state and the warm-up's
progress (``engine``, ``warm_up_done``, ``warm_up_total``, ``warm_up_s``). Needs the message
packages, not a running ROS context: tested without DDS (tests/ros/test_diagnostics.py).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from xface_ros.config import NodeConfig
from xface_ros.conversions import key_value
from xface_ros.stats import StatsCounts, StatsSnapshot

__all__ = [
    "WARMING_UP_MESSAGE",
    "WARMING_UP_PREFIX",
    "diagnostic_array",
    "is_warming_up",
    "predictor_level",
    "predictor_status",
    "predictor_values",
    "warming_up_message",
]

#: How every message of the status begins while the node warms up (what a client tests).
WARMING_UP_PREFIX = "warming up"
#: The message of the status while the simulator loads, before its progress is known.
WARMING_UP_MESSAGE = f"{WARMING_UP_PREFIX}: loading the simulator"


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


def is_warming_up(message: str) -> bool:
    """Whether a predictor status's ``message`` says the node is still warming up."""
    return message.startswith(WARMING_UP_PREFIX)


def warming_up_message(counts: StatsCounts) -> str:
    """The warming-up message with the warm-up's progress: entry points done of all, and the
    seconds so far when it compiles (minutes on a fresh install: the number shows it moving).

    >>> warming_up_message(
    ...     StatsCounts(engine="compiles", warm_up_done=3, warm_up_total=7, warm_up_s=41.2)
    ... )
    'warming up: compiling the simulator (3/7, 41 s)'
    >>> warming_up_message(StatsCounts(engine="cached", warm_up_done=3, warm_up_total=7))
    'warming up: loading the simulator (3/7)'
    >>> warming_up_message(StatsCounts()) == WARMING_UP_MESSAGE  # before the progress is known
    True
    """
    compiles = counts.engine == "compiles"
    progress = [f"{counts.warm_up_done}/{counts.warm_up_total}"] if counts.warm_up_total else []
    if compiles:
        progress.append(f"{counts.warm_up_s:.0f} s")
    if not progress:
        return WARMING_UP_MESSAGE
    verb = "compiling" if compiles else "loading"
    return f"{WARMING_UP_PREFIX}: {verb} the simulator ({', '.join(progress)})"


def predictor_level(snapshot: StatsSnapshot) -> tuple[bytes, str]:
    """The status level (``DiagnosticStatus.OK`` etc.) and its message."""
    counts = snapshot.counts
    if counts.warming_up:
        return DiagnosticStatus.WARN, warming_up_message(counts)
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
    margins are searched exactly). The warm-up's keys come last: added after the others, so
    readers of the earlier keys see them where they were."""
    level, message = predictor_level(snapshot)
    values = predictor_values(snapshot, config, recording_path=recording_path)
    values["atlas"] = atlas
    counts = snapshot.counts
    values["engine"] = counts.engine
    values["warm_up_done"] = counts.warm_up_done
    values["warm_up_total"] = counts.warm_up_total
    values["warm_up_s"] = counts.warm_up_s
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
