"""The README's first command: the node on its default configuration, fed by a pose source.

``python -m xface_ros.demo`` (or ``make demo``)

1. starts ``xface_predictor`` as a separate process (``python -m xface_ros`` with
   config/xface.yaml when this is a source checkout, the built-in defaults otherwise) with a
   rerun recording switched on when :mod:`xface_core.viz.recording` is available;
2. runs the bundled :class:`~xface_ros.pose_source.PoseSource` once through its sweep (poses
   that seat, jam, lie out of reach or miss the base, and one invalid input) and prints every
   answer as it arrives, one word per meaning: ``accepted``, ``will not seat``, ``invalid``;
3. asks the planner service (``predict``, nav_msgs/GetPlan) about one pose and shows the
   answer;
4. stops the node with SIGINT (which finishes the recording) after the sweep, after
   ``--duration`` seconds (default 15) or on Ctrl-C, and exits 0 when the node exited cleanly
   and predictions arrived.

DDS discovery stays on this host (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) in a ROS domain
of its own: ``ROS_DOMAIN_ID`` when set (``make demo`` sets one), else ``--domain-id``.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path
from types import FrameType
from typing import Any

__all__ = ["main"]

#: Default ROS domain of the demo when the environment sets none (tests use 100..199).
DEFAULT_DOMAIN_ID = 42
REPO_PARAMS = Path(__file__).resolve().parents[1] / "config" / "xface.yaml"


def _isolate_ros(domain_id: int) -> None:
    """Keep DDS on loopback, in one domain; inherited by the node process."""
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ["ROS_STATIC_PEERS"] = ""
    os.environ.setdefault("ROS_DOMAIN_ID", str(domain_id))


def _parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m xface_ros.demo", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--duration", type=float, default=15.0, help="seconds to run (default 15)")
    parser.add_argument("--rate", type=float, default=2.0, help="poses per second (default 2)")
    parser.add_argument(
        "--record", type=Path, default=Path("xface-demo.rrd"),
        help="where the .rrd recording goes (default ./xface-demo.rrd)",
    )  # fmt: skip
    parser.add_argument("--no-record", action="store_true", help="do not write a recording")
    parser.add_argument(
        "--params-file", type=Path, default=REPO_PARAMS if REPO_PARAMS.is_file() else None,
        help="node parameters (default config/xface.yaml of the checkout, if there is one)",
    )  # fmt: skip
    parser.add_argument(
        "--domain-id", type=int, default=DEFAULT_DOMAIN_ID,
        help=f"ROS domain when ROS_DOMAIN_ID is unset (default {DEFAULT_DOMAIN_ID})",
    )  # fmt: skip
    return parser.parse_args(argv)


def _node_command(args: argparse.Namespace, record_path: Path | None) -> list[str]:
    command = [sys.executable, "-m", "xface_ros", "--ros-args"]
    if args.params_file is not None:
        command += ["--params-file", str(args.params_file)]
    if record_path is not None:
        command += ["-p", "record:=true", "-p", f"record_path:={record_path}"]
    return command


def _shared_parameters(params_file: Path | None) -> dict[str, object]:
    """The node parameters the pose source must agree with (face width, frame)."""
    if params_file is None:
        return {}
    import yaml

    data = yaml.safe_load(params_file.read_text(encoding="utf-8")) or {}
    node_params = data.get("xface_predictor", data.get("/**", {})).get("ros__parameters", {})
    return {k: node_params[k] for k in ("width_m", "base_frame") if k in node_params}


def _raise_keyboard_interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Run the demo; 0 when predictions arrived and the node shut down cleanly."""
    args = _parse(argv)
    _isolate_ros(args.domain_id)
    # Imported here, after the environment is set (rclpy reads it when a context starts).
    import rclpy
    from diagnostic_msgs.msg import DiagnosticStatus
    from nav_msgs.srv import GetPlan
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.signals import SignalHandlerOptions

    from xface_ros.node import RESULT_QOS
    from xface_ros.pose_source import DEMO_SWEEP, PoseSource

    recording_available = importlib.util.find_spec("xface_core.viz.recording") is not None
    record_path = None if args.no_record or not recording_available else args.record.resolve()
    if record_path is not None and record_path.exists():
        record_path.unlink()  # a stale file from an earlier run would look like this run's
    print(
        f"xface demo: ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, discovery on localhost only; "
        f"running {args.duration:g} s once the node is up (Ctrl-C stops earlier)",
        flush=True,
    )
    node = subprocess.Popen(_node_command(args, record_path), start_new_session=True)
    # SIGTERM stops the demo like Ctrl-C; the node gets exactly one SIGINT from us either way.
    signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    executor = SingleThreadedExecutor()
    counts: Counter[str] = Counter()
    accepted = Counter[bool]()
    started = time.monotonic()
    lock = threading.Lock()

    ready_at = [started]  # the clock of the printed answers starts when the node is ready

    def show(status: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in status.values}
        outcome = values.get("outcome", "?")
        is_accepted = values.get("accepted") == "true"
        t = time.monotonic() - ready_at[0]
        with lock:
            counts[outcome] += 1
            if "input_error" not in values:
                accepted[is_accepted] += 1
        if "input_error" in values:
            print(f"{t:6.1f}  {'':>9} {'':>8}    {'-':<12} {'invalid':<13} {status.message}")
            return
        margin = values.get("margin_m", "")
        # The margin of a refused pose is the distance to another outcome, not to a seat.
        extra = f"{float(margin):.4f}" if margin and is_accepted else ""
        verdict = "accepted" if is_accepted else "will not seat"
        x0, theta0 = float(values["x0_m"]), float(values["theta0_rad"])
        compute_ms = float(values["compute_time_ms"])
        why = "" if is_accepted else status.message.split(": ", 1)[-1]
        print(
            f"{t:6.1f}  {x0:+9.4f} {theta0:+8.3f} -> {outcome:<12} {verdict:<13} {extra:>8} "
            f"{compute_ms:8.1f}  {why}",
            flush=True,
        )

    code = 1
    spin_thread: threading.Thread | None = None
    try:
        listener = rclpy.create_node("xface_demo_listener")
        listener.create_subscription(DiagnosticStatus, "prediction/status", show, RESULT_QOS)
        client = listener.create_client(GetPlan, "predict")
        executor.add_node(listener)
        print("xface demo: starting the node (a fresh checkout compiles the simulator first)")
        spin_thread = threading.Thread(target=executor.spin, daemon=True)
        spin_thread.start()
        deadline = time.monotonic() + 300.0  # a fresh checkout compiles the simulator first
        next_note = time.monotonic() + 5.0
        while not client.service_is_ready():
            if node.poll() is not None or time.monotonic() > deadline:
                print("xface demo: the node did not come up", file=sys.stderr, flush=True)
                return 1
            if time.monotonic() >= next_note:  # say that the silence is the compiler
                waited = time.monotonic() - started
                print(f"xface demo: still starting ({waited:.0f} s; compiling)", flush=True)
                next_note += 5.0
            time.sleep(0.1)
        source = PoseSource(
            parameter_overrides=[
                Parameter("rate_hz", value=args.rate),
                *(Parameter(k, value=v) for k, v in _shared_parameters(args.params_file).items()),
            ]
        )
        ready_at[0] = time.monotonic()
        print(f"xface demo: node ready after {ready_at[0] - started:.1f} s", flush=True)
        print(f"{'t (s)':>6}  {'x0 (m)':>9} {'theta0':>8}    {'outcome':<12} {'answer':<13} "
              f"{'margin':>8} {'ms':>8}  why")  # fmt: skip
        executor.add_node(source)
        end = time.monotonic() + args.duration
        while time.monotonic() < end and node.poll() is None:
            with lock:
                answered = sum(counts.values())
            if answered >= len(DEMO_SWEEP):  # the whole sweep once: every kind of answer
                break
            time.sleep(0.1)
        executor.remove_node(source)
        _ask_planner(client, source.pose_of(*DEMO_SWEEP[1]))
        if node.poll() is not None:
            print(f"xface demo: the node exited early ({node.returncode})", file=sys.stderr)
            return 1
    except KeyboardInterrupt:
        print("\nxface demo: interrupted", flush=True)
    finally:
        node_code = _stop(node)
        executor.shutdown(timeout_sec=5.0)
        if spin_thread is not None:  # stopped before the context it waits on goes away
            spin_thread.join(timeout=5.0)
        rclpy.try_shutdown()
        predicted = accepted[True] + accepted[False]
        print(
            f"xface demo: {predicted} predictions ({accepted[True]} accepted, "
            f"{accepted[False]} will not seat), {sum(counts.values()) - predicted} invalid; "
            + ", ".join(f"{name} {n}" for name, n in sorted(counts.items())),
            flush=True,
        )
        if record_path is not None:
            size = record_path.stat().st_size if record_path.exists() else 0
            print(f"xface demo: recording {record_path} ({size} bytes)")
            # The viewer comes with the venv: name it by its path, so the line runs as
            # printed without activating the venv.
            viewer = Path(sys.executable).with_name("rerun")
            command = str(viewer) if viewer.exists() else "rerun"
            print(f"xface demo: view it with: {command} {record_path}")
        elif not recording_available:
            print("xface demo: no recording (xface_core.viz.recording is not available)")
        print(f"xface demo: node exited with code {node_code}", flush=True)
        code = 0 if (node_code == 0 and predicted > 0) else 1
    return code


def _ask_planner(client: Any, start: Any) -> None:
    """One planner query (nav_msgs/GetPlan on ``predict``) and its answer: a plan is the
    path to the seat, an empty plan a refusal (docs/ros.md)."""
    from nav_msgs.srv import GetPlan

    request = GetPlan.Request(start=start)
    x = start.pose.position.x
    print(f"xface demo: planner query GetPlan(start x={x:+.4f} m, ...) on predict", flush=True)
    future = client.call_async(request)
    deadline = time.monotonic() + 30.0
    while not future.done() and time.monotonic() < deadline:
        time.sleep(0.05)
    if not future.done():
        print("xface demo: the planner query got no answer within 30 s", flush=True)
        return
    poses = future.result().plan.poses
    answer = f"a plan of {len(poses)} poses to the seat" if poses else "an empty plan (refused)"
    print(f"xface demo: planner answer: {answer}", flush=True)


def _stop(node: subprocess.Popen[bytes]) -> int:
    """SIGINT the node once and wait for it (kill after 30 s)."""
    if node.poll() is None:
        node.send_signal(signal.SIGINT)
    try:
        return node.wait(timeout=30.0)
    except subprocess.TimeoutExpired:
        node.kill()
        return node.wait()


if __name__ == "__main__":
    raise SystemExit(main())
