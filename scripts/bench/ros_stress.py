#!/usr/bin/env python3
"""Stress the xface_predictor node: a fast PoseStamped stream into a node process.

    .venv/bin/python scripts/bench/ros_stress.py --table --duration 30 --soak-minutes 10
    .venv/bin/python scripts/bench/ros_stress.py               # one run: 1 kHz for 10 s
    .venv/bin/python scripts/bench/ros_stress.py --rate 200 --duration 3 --json out.json

Starts the node as its own process (``python -m xface_ros`` with config/xface.yaml), then
from this process:

* publishes poses at ``--rate`` Hz for ``--duration`` s from a dedicated thread, cycling
  through poses that seat and poses that do not, each with a sensor's noise added (``--jitter-m``,
  ``--jitter-rad``: no two alike) and stamped when it is sent; with ``--covariance SIGMA_M
  SIGMA_RAD`` as ``PoseWithCovarianceStamped`` on ``relative_pose_with_covariance``, whose
  (x, yaw) block is diag(SIGMA_M^2, SIGMA_RAD^2), so every status carries a seat probability;
* receives every ``prediction/status`` and takes the latency from the input stamp to the
  arrival of the status here (so it includes both DDS hops, the wait for the worker and the
  simulation);
* calls the ``predict`` service every 0.25 s during the stream (responsiveness);
* samples the node's resident memory from /proc;
* reads the CPU time the node's threads and its own used during the stream, by thread name
  (/proc/<pid>/task: the node's worker is ``xface_predictor``, its pose reader
  ``xface_poses``, its executor ``python``,
  Fast DDS's threads ``dds.*``);
* reads the node's counters from ``/diagnostics`` after the stream has drained;
* stops the node with SIGINT and records its exit code.

Prints a summary (and writes it as JSON with ``--json``). With ``--table`` it runs the rate
table of docs/ros.md instead: each of ``--rates`` (10, 30 and 100 Hz) with margins (the
config's default) and with a covariance of 2 mm and 0.05 rad, then a ``--overload-rate``
stream (1 kHz), each for ``--duration`` s on a fresh node, and prints per row the share of
poses answered (statuses received for poses sent), the poses dropped because a newer one
came (newest wins), the median, p99 and largest latency, the node's CPU in cores (its CPU
time over the stream's wall time) and its RSS growth, with the goals each row is held to
and whether it met them. ``--soak-minutes M`` then streams 100 Hz with the covariance for M
minutes and reports how the node's RSS moved after the first minute (growth and
least-squares slope, read once a second). Discovery stays on this host, in
ROS domain ``--domain-id`` (default: ``ROS_DOMAIN_ID`` if set, else 199).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

#: (x0 / D, theta0 rad) cycled by the stream: seats, seats, jams, out of reach, misses.
POSES = [(0.0, 0.0), (0.3, 0.2), (0.9, 0.8), (2.5, 0.0), (1.5, 0.3), (-0.4, -0.3)]
WIDTH = 0.05  # config/xface.yaml
#: Default noise on each streamed pose (a camera's or lidar's pose estimate): 0.5 mm and
#: 5 mrad standard deviation, so no two queries are alike.
JITTER_M = 0.0005
JITTER_RAD = 0.005
Y_START = 3.0 * WIDTH


def rss_mib(pid: int) -> float:
    """Resident set size of a process in MiB (/proc/<pid>/status, VmRSS)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError(f"no VmRSS for pid {pid}")


def cpu_by_thread(pid: int) -> dict[str, float]:
    """CPU time (user + system, s) a process has used, summed by its threads' names
    (/proc/<pid>/task/*/stat: Fast DDS names its threads, Python's show the program's name)."""
    tick = os.sysconf("SC_CLK_TCK")
    used: dict[str, float] = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            stat = (task / "stat").read_text()
        except OSError:  # the thread ended between the listing and the read
            continue
        name = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2 :].split()
        used[name] = used.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return used


def cpu_spent(before: dict[str, float], after: dict[str, float]) -> dict[str, float]:
    """CPU seconds by thread name between two :func:`cpu_by_thread` readings, largest first."""
    spent = {name: after[name] - before.get(name, 0.0) for name in after}
    used = [(name, round(s, 3)) for name, s in spent.items() if s > 0]
    return dict(sorted(used, key=lambda kv: -kv[1]))


def percentile(values: list[float], q: float) -> float:
    """The q-th percentile (0..100, nearest rank) of ``values``; NaN when empty."""
    if not values:
        return math.nan
    ordered = sorted(values)
    rank = max(0, min(len(ordered) - 1, math.ceil(q / 100.0 * len(ordered)) - 1))
    return ordered[rank]


def run_stress(
    *,
    rate_hz: float,
    duration_s: float,
    domain_id: int,
    params_file: Path,
    node_args: list[str],
    log_path: Path | None,
    jitter_m: float = 0.0,
    jitter_rad: float = 0.0,
    seed: int = 0,
    covariance: tuple[float, float] | None = None,
) -> dict[str, Any]:
    """Run one stress session; returns the measurements (see the module docstring)."""
    env = dict(os.environ)
    env.update(
        ROS_DOMAIN_ID=str(domain_id),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_STATIC_PEERS="",
        PYTHONUNBUFFERED="1",
    )
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS")})
    command = [sys.executable, "-m", "xface_ros", "--ros-args", "--params-file", str(params_file)]
    log = open(log_path, "w") if log_path else subprocess.DEVNULL  # noqa: SIM115
    node = subprocess.Popen(
        command + node_args, env=env, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT
    )

    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
    from nav_msgs.srv import GetPlan
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import qos_profile_sensor_data
    from rclpy.signals import SignalHandlerOptions

    from xface_core.frames import DockStart, start_to_relative_pose
    from xface_ros import names
    from xface_ros.conversions import planar_to_pose
    from xface_ros.node import NODE_NAME, RESULT_QOS

    context = Context()
    rclpy.init(context=context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
    client_node = rclpy.create_node("xface_stress", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(client_node)

    lock = threading.Lock()
    latencies_ms: list[float] = []
    compute_ms: list[float] = []
    probabilities: list[float] = []
    with_margins = [0]  # statuses that carry the four margins
    outcomes: dict[str, int] = {}
    # Per outcome: the latency and simulation time of each status (a run's median moves with
    # the mix of outcomes the worker happens to pick under load: newest wins).
    by_outcome: dict[str, tuple[list[float], list[float]]] = {}
    diagnostics: list[dict[str, str]] = []

    def on_status(status: DiagnosticStatus) -> None:
        now = time.time_ns()
        values = {kv.key: kv.value for kv in status.values}
        outcome = values.get("outcome", "?")
        with lock:
            outcomes[outcome] = outcomes.get(outcome, 0) + 1
            lat_of, comp_of = by_outcome.setdefault(outcome, ([], []))
            if "input_stamp_ns" in values:
                latencies_ms.append((now - int(values["input_stamp_ns"])) * 1e-6)
                lat_of.append(latencies_ms[-1])
            if "compute_time_ms" in values:
                compute_ms.append(float(values["compute_time_ms"]))
                comp_of.append(compute_ms[-1])
            if values.get("seat_probability"):
                probabilities.append(float(values["seat_probability"]))
            if "margin_lateral_minus_m" in values:
                with_margins[0] += 1

    def on_diagnostics(array: DiagnosticArray) -> None:
        for status in array.status:
            if status.name == f"/{NODE_NAME}: predictor":
                with lock:
                    diagnostics.append({kv.key: kv.value for kv in status.values})

    client_node.create_subscription(DiagnosticStatus, names.STATUS, on_status, RESULT_QOS)
    client_node.create_subscription(DiagnosticArray, names.DIAGNOSTICS, on_diagnostics, 10)
    if covariance is None:
        pub = client_node.create_publisher(PoseStamped, names.POSES, qos_profile_sensor_data)
    else:
        pub = client_node.create_publisher(
            PoseWithCovarianceStamped, names.POSES_WITH_COVARIANCE, qos_profile_sensor_data
        )
    plan_client = client_node.create_client(GetPlan, names.PREDICT)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()

    result: dict[str, Any] = {
        "rate_hz": rate_hz, "duration_s": duration_s, "covariance_sigmas": covariance,
    }  # fmt: skip
    try:
        deadline = time.monotonic() + 300.0  # a fresh checkout compiles the simulator first
        while not (plan_client.service_is_ready() and pub.get_subscription_count() > 0):
            if node.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"node did not come up (exit code {node.poll()})")
            time.sleep(0.05)
        time.sleep(1.0)  # let the worker finish its warm-up prediction
        # The node builds its acceptance atlas in the background after the warm-up: measure
        # the steady state, with margins from the atlas, not the build (docs/atlas.md).
        while not any(d.get("atlas") in ("ready", "failed") for d in diagnostics):
            if node.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError("the node's atlas did not become ready")
            time.sleep(0.1)
        # Every message its own pose: the cycle's poses with a sensor's noise added (no two
        # queries alike, as from a real pose estimate), made before the stream starts.
        rng = np.random.default_rng(seed)
        messages = []
        for i in range(round(rate_hz * duration_s)):
            x0_widths, theta0 = POSES[i % len(POSES)]
            start = DockStart(
                x0_widths * WIDTH + rng.normal(0.0, jitter_m),
                theta0 + rng.normal(0.0, jitter_rad),
                Y_START,
            )
            pose = planar_to_pose(start_to_relative_pose(start))
            if covariance is None:
                msg = PoseStamped()
                msg.pose = pose
            else:
                msg = PoseWithCovarianceStamped()
                msg.pose.pose = pose
                cov6 = [0.0] * 36
                cov6[0], cov6[35] = covariance[0] ** 2, covariance[1] ** 2  # x, yaw
                msg.pose.covariance = cov6
            msg.header.frame_id = "xface_base"
            messages.append(msg)

        rss_start = rss_mib(node.pid)
        cpu_node_start, cpu_client_start = cpu_by_thread(node.pid), cpu_by_thread(os.getpid())
        rss_samples = [rss_start]
        rss_timeline = [(0.0, rss_start)]  # (s since the stream began, MiB)
        sent = 0
        stop = threading.Event()

        def publish_stream() -> None:
            nonlocal sent
            period = 1.0 / rate_hz
            t0 = time.perf_counter()
            n_total = round(rate_hz * duration_s)
            for i in range(n_total):
                target = t0 + i * period
                delay = target - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
                msg = messages[i]
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(
                    time.time_ns(), 1_000_000_000
                )
                pub.publish(msg)
                sent += 1
            stop.set()

        service_times_ms: list[float] = []
        service_failures = 0
        request = GetPlan.Request()  # empty start frame: "use the latest streamed pose"
        stream_start = time.perf_counter()
        publisher = threading.Thread(target=publish_stream, daemon=True)
        publisher.start()
        while not stop.is_set():
            t = time.perf_counter()
            future = plan_client.call_async(request)
            answered = False
            while time.perf_counter() - t < 5.0:
                if future.done():
                    answered = True
                    break
                time.sleep(0.001)
            if answered:
                service_times_ms.append((time.perf_counter() - t) * 1e3)
            else:
                service_failures += 1
            rss_samples.append(rss_mib(node.pid))
            if time.perf_counter() - stream_start >= len(rss_timeline):  # about 1 a second
                rss_timeline.append((time.perf_counter() - stream_start, rss_samples[-1]))
            stop.wait(0.25)
        publisher.join()
        stream_s = time.perf_counter() - stream_start
        cpu_node = cpu_spent(cpu_node_start, cpu_by_thread(node.pid))
        cpu_client = cpu_spent(cpu_client_start, cpu_by_thread(os.getpid()))
        # Drain: the worker finishes its last pose; then two diagnostics periods.
        time.sleep(3.0)
        rss_end = rss_mib(node.pid)
        with lock:
            last_diag = diagnostics[-1] if diagnostics else {}
            lat = list(latencies_ms)
            comp = list(compute_ms)
            probs = list(probabilities)
            outs = dict(outcomes)
            per_outcome = {
                name: {
                    "statuses": len(lat_of),
                    "latency_ms_median": statistics.median(lat_of) if lat_of else math.nan,
                    "compute_ms_median": statistics.median(comp_of) if comp_of else math.nan,
                }
                for name, (lat_of, comp_of) in sorted(by_outcome.items())
            }
        received = int(last_diag.get("received_total", "0"))
        result.update(
            sent=sent,
            stream_s=stream_s,
            achieved_rate_hz=sent / stream_s,
            node_received=received,
            node_predicted=int(last_diag.get("predicted_total", "0")),
            node_dropped_newest_wins=int(last_diag.get("dropped_total", "0")),
            node_input_errors=int(last_diag.get("input_errors_total", "0")),
            node_dds_lost_reported=int(last_diag.get("dds_lost_reported_total", "0")),
            dds_lost=sent - received,
            statuses_received=len(lat),
            outcomes=outs,
            latency_ms_median=statistics.median(lat) if lat else math.nan,
            latency_ms_p99=percentile(lat, 99.0),
            latency_ms_max=max(lat, default=math.nan),
            compute_ms_median=statistics.median(comp) if comp else math.nan,
            statuses_with_probability=len(probs),
            seat_probability_straddling=sum(1 for q in probs if 0.0 < q < 1.0),
            statuses_with_margins=with_margins[0],
            by_outcome=per_outcome,
            service_calls=len(service_times_ms) + service_failures,
            service_answered=len(service_times_ms),
            service_ms_median=statistics.median(service_times_ms) if service_times_ms else math.nan,
            service_ms_max=max(service_times_ms, default=math.nan),
            rss_mib_start=rss_start,
            rss_mib_end=rss_end,
            rss_mib_peak=max([*rss_samples, rss_end]),
            rss_timeline=rss_timeline,
            answered_share=min(1.0, len(lat) / sent) if sent else math.nan,
            cpu_share_node=sum(cpu_node.values()) / stream_s,
            node_alive_after_stream=node.poll() is None,
            cpu_s_node=cpu_node,
            cpu_s_client=cpu_client,
        )
    finally:
        if node.poll() is None:
            node.send_signal(signal.SIGINT)
        try:
            result["node_exit_code"] = node.wait(timeout=60.0)
        except subprocess.TimeoutExpired:
            node.kill()
            result["node_exit_code"] = node.wait()
        # Stop the spinning thread before anything it uses is destroyed (a thread still in
        # the wait set at interpreter exit aborts the process).
        executor.shutdown(timeout_sec=5.0)
        spin.join(timeout=5.0)
        client_node.destroy_node()
        rclpy.try_shutdown(context=context)
        if log_path:
            log.close()  # type: ignore[union-attr]
    return result


def summary(r: dict[str, Any]) -> str:
    lines = [
        (
            f"stream: {r['sent']} poses in {r['stream_s']:.2f} s "
            f"({r['achieved_rate_hz']:.0f} Hz, asked {r['rate_hz']:g} Hz)"
        ),
        (
            f"node: received {r['node_received']}, predicted {r['node_predicted']}, "
            f"dropped (newest wins) {r['node_dropped_newest_wins']}, input errors "
            f"{r['node_input_errors']}"
        ),
        (
            f"lost before the node (best-effort DDS, reader queue of 5): {r['dds_lost']} "
            f"(the node's message-lost event reported {r['node_dds_lost_reported']})"
        ),
        (
            f"latency stamp -> status received: median {r['latency_ms_median']:.2f} ms, "
            f"p99 {r['latency_ms_p99']:.2f} ms, max {r['latency_ms_max']:.2f} ms "
            f"({r['statuses_received']} statuses)"
        ),
        (
            f"simulation per pose: median {r['compute_ms_median']:.2f} ms; statuses with "
            f"margins: {r['statuses_with_margins']}"
        ),
        (
            f"statuses with a seat probability: {r['statuses_with_probability']} "
            f"({r['seat_probability_straddling']} strictly between 0 and 1)"
        ),
        "per outcome (statuses, median latency, median simulation): "
        + "; ".join(
            f"{name} {v['statuses']}, {v['latency_ms_median']:.2f} ms, "
            f"{v['compute_ms_median']:.2f} ms"
            for name, v in r.get("by_outcome", {}).items()
        ),
        (
            f"service during the stream: {r['service_answered']}/{r['service_calls']} "
            f"answered, median {r['service_ms_median']:.1f} ms, max {r['service_ms_max']:.1f} ms"
        ),
        (
            f"node RSS: {r['rss_mib_start']:.1f} MiB at start, {r['rss_mib_end']:.1f} MiB at "
            f"end, peak {r['rss_mib_peak']:.1f} MiB"
        ),
        f"outcomes: {r['outcomes']}",
        (
            f"CPU during the stream ({r['stream_s']:.1f} s; by thread name): node "
            f"{sum(r['cpu_s_node'].values()):.2f} s {r['cpu_s_node']}; this client "
            f"{sum(r['cpu_s_client'].values()):.2f} s {r['cpu_s_client']}"
        ),
        (
            f"node alive after the stream: {r['node_alive_after_stream']}; "
            f"exit code on SIGINT: {r['node_exit_code']}"
        ),
    ]
    return "\n".join(lines)


#: The sensor rates of the table (Hz), each streamed without and with a covariance.
TABLE_RATES = (10.0, 30.0, 100.0)
#: The overload row: far above what the worker can simulate, so the newest pose wins.
OVERLOAD_HZ = 1000.0
#: The covariance of the table's second stream of each rate: 2 mm and 0.05 rad (x, yaw).
TABLE_SIGMAS = (0.002, 0.05)
#: The soak's warm-up: RSS growth is counted from here (the first minute fills caches).
SOAK_WARM_UP_S = 60.0


def table_rows(rates: list[float], overload_hz: float) -> list[tuple[float, bool]]:
    """(rate, with covariance) of every row: each rate without and with, then the overload."""
    rows = [(rate, cov) for rate in rates for cov in (False, True)]
    return rows + ([(overload_hz, False)] if overload_hz > 0 else [])


def goals(rate_hz: float, covariance: bool, overload: bool) -> dict[str, float]:
    """The targets a row is held to (docs/ros.md): answered share, p99 latency (ms), and at
    100 Hz without covariance the node's CPU (cores)."""
    if overload:
        return {"latency_ms_p99": 20.0}
    if covariance:
        return {"answered_share": 0.99, "latency_ms_p99": 20.0}
    out = {"answered_share": 1.0, "latency_ms_p99": 10.0}
    if rate_hz >= 100.0:
        out["cpu_share_node"] = 0.3
    return out


def met(result: dict[str, Any], goal: dict[str, float]) -> dict[str, bool]:
    """Per goal: whether the run met it (a share at least, a latency or CPU at most)."""
    return {
        key: (result[key] >= bound if key == "answered_share" else result[key] <= bound)
        for key, bound in goal.items()
    }


def rss_growth(timeline: list[tuple[float, float]], warm_up_s: float) -> tuple[float, float]:
    """RSS growth (MiB) from the first sample at or after ``warm_up_s`` to the last, and the
    least-squares slope over the same span (MiB per minute); NaN when the run is shorter."""
    late = [(t, m) for t, m in timeline if t >= warm_up_s]
    if len(late) < 2:
        return math.nan, math.nan
    t = np.array([p[0] for p in late]) / 60.0
    m = np.array([p[1] for p in late])
    return float(m[-1] - m[0]), float(np.polyfit(t, m, 1)[0])


def run_table(
    rates: list[float], overload_hz: float, soak_minutes: float, **stress: Any
) -> dict[str, Any]:
    """Every row of the rate table (a fresh node each), then the soak: 100 Hz with a
    covariance for ``soak_minutes`` (0: none), whose RSS is read every second."""
    rows = []
    for rate, with_cov in table_rows(rates, overload_hz):
        cov = TABLE_SIGMAS if with_cov else None
        run = run_stress(**{**stress, "rate_hz": rate, "covariance": cov})
        goal = goals(rate, with_cov, rate == overload_hz)
        rows.append({"run": run, "goals": goal, "met": met(run, goal)})
        print(
            f"{rate:g} Hz, {'covariance' if with_cov else 'margins'}: answered "
            f"{run['answered_share']:.1%}, p99 {run['latency_ms_p99']:.2f} ms",
            file=sys.stderr, flush=True,
        )  # fmt: skip
    soak = None
    if soak_minutes > 0:
        run = run_stress(
            **{**stress, "rate_hz": 100.0, "covariance": TABLE_SIGMAS,
               "duration_s": 60.0 * soak_minutes},
        )  # fmt: skip
        growth, slope = rss_growth(run["rss_timeline"], SOAK_WARM_UP_S)
        soak = {"run": run, "rss_growth_mib": growth, "rss_slope_mib_per_min": slope}
    return {"rows": rows, "soak": soak}


def table_summary(t: dict[str, Any]) -> str:
    """The rate table as Markdown (docs/ros.md), then the soak's line."""
    lines = [
        (
            "| stream | sent | answered | dropped (newest wins) | latency median / p99 / max "
            "(ms) | node CPU (cores) | RSS growth (MiB) | goals |"
        ),
        "|---|---:|---:|---:|---|---:|---:|---|",
    ]
    for row in t["rows"]:
        r = row["run"]
        kind = "covariance" if r["covariance_sigmas"] else "margins"
        goal = ", ".join(
            f"{_GOAL_NAMES[k]} {_bound(k, v)}: {'met' if row['met'][k] else 'NOT met'}"
            for k, v in row["goals"].items()
        )
        lines.append(
            f"| {r['rate_hz']:g} Hz, {kind} | {r['sent']} | {r['answered_share']:.1%} | "
            f"{r['node_dropped_newest_wins']} | {r['latency_ms_median']:.2f} / "
            f"{r['latency_ms_p99']:.2f} / {r['latency_ms_max']:.2f} | {r['cpu_share_node']:.2f} | "
            f"{r['rss_mib_end'] - r['rss_mib_start']:+.1f} | {goal} |"
        )
    soak = t.get("soak")
    if soak:
        r = soak["run"]
        lines.append(
            f"\nsoak: 100 Hz with covariance for {r['stream_s'] / 60:.1f} min: answered "
            f"{r['answered_share']:.1%}, p99 {r['latency_ms_p99']:.2f} ms, node RSS "
            f"{r['rss_mib_start']:.1f} MiB at start, {r['rss_mib_end']:.1f} at end; after the "
            f"first {SOAK_WARM_UP_S:g} s it grew {soak['rss_growth_mib']:+.2f} MiB "
            f"(slope {soak['rss_slope_mib_per_min']:+.3f} MiB/min)"
        )
    return "\n".join(lines)


_GOAL_NAMES = {"answered_share": "answered", "latency_ms_p99": "p99", "cpu_share_node": "CPU"}


def _bound(key: str, value: float) -> str:
    if key == "answered_share":
        return f">= {value:.0%}"
    return f"<= {value:g} ms" if key.startswith("latency") else f"<= {value:g} core"


def _sound(result: dict[str, Any]) -> bool:
    return bool(result["node_exit_code"] == 0 and result["node_alive_after_stream"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rate", type=float, default=1000.0, help="poses per second")
    parser.add_argument("--duration", type=float, default=10.0, help="seconds of stream")
    parser.add_argument(
        "--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID") or 199)
    )
    parser.add_argument("--params-file", type=Path, default=ROOT / "config" / "xface.yaml")
    parser.add_argument(
        "--node-arg", action="append", default=[], metavar="ARG",
        help="extra node argument after --ros-args (repeat), e.g. --node-arg=-p "
        "--node-arg=compute_margins:=false",
    )  # fmt: skip
    parser.add_argument(
        "--jitter-m", type=float, default=JITTER_M,
        help="standard deviation of the noise added to each pose's x0 (m)",
    )  # fmt: skip
    parser.add_argument(
        "--jitter-rad", type=float, default=JITTER_RAD,
        help="standard deviation of the noise added to each pose's theta0 (rad)",
    )  # fmt: skip
    parser.add_argument("--seed", type=int, default=0, help="seed of the noise")
    parser.add_argument(
        "--covariance", type=float, nargs=2, metavar=("SIGMA_M", "SIGMA_RAD"),
        help="stream PoseWithCovarianceStamped with these standard deviations of x and yaw",
    )  # fmt: skip
    parser.add_argument(
        "--table", action="store_true",
        help="the rate table: every --rates rate without and with a covariance (2 mm, 0.05 "
        "rad), then the --overload-rate stream, each --duration s on a fresh node",
    )  # fmt: skip
    parser.add_argument(
        "--rates", type=lambda v: [float(r) for r in v.split(",")], default=list(TABLE_RATES),
        metavar="HZ,HZ", help="the table's sensor rates (default 10,30,100)",
    )  # fmt: skip
    parser.add_argument(
        "--overload-rate", type=float, default=OVERLOAD_HZ, metavar="HZ",
        help="the table's overload row (default 1000; 0: none)",
    )  # fmt: skip
    parser.add_argument(
        "--soak-minutes", type=float, default=0.0, metavar="MIN",
        help="with --table: also stream 100 Hz with a covariance this long and report the "
        "node's RSS growth after the first minute (the docs: 10)",
    )  # fmt: skip
    parser.add_argument("--json", type=Path, help="also write the results here")
    parser.add_argument("--node-log", type=Path, help="write the node's output here")
    args = parser.parse_args(argv)
    if args.rate <= 0 or args.duration <= 0 or any(r <= 0 for r in args.rates):
        parser.error("rates and durations must be positive")
    if args.soak_minutes < 0 or args.overload_rate < 0:
        parser.error("--soak-minutes and --overload-rate must be >= 0")
    stress: dict[str, Any] = {
        "rate_hz": args.rate,
        "duration_s": args.duration,
        "domain_id": args.domain_id,
        "params_file": args.params_file,
        "node_args": args.node_arg,
        "log_path": args.node_log,
        "jitter_m": args.jitter_m,
        "jitter_rad": args.jitter_rad,
        "seed": args.seed,
        "covariance": (args.covariance[0], args.covariance[1]) if args.covariance else None,
    }
    if args.table:
        table = run_table(args.rates, args.overload_rate, args.soak_minutes, **stress)
        print(table_summary(table), flush=True)
        if args.json:
            args.json.write_text(json.dumps(table, indent=2, sort_keys=True))
        runs = [row["run"] for row in table["rows"]]
        runs += [table["soak"]["run"]] if table["soak"] else []
        return 0 if all(_sound(run) for run in runs) else 1
    result = run_stress(**stress)
    print(summary(result), flush=True)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2, sort_keys=True))
    return 0 if _sound(result) else 1


if __name__ == "__main__":
    raise SystemExit(main())
