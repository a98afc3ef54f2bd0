"""The README's first command: the node on its default configuration, fed by a pose source.

``python -m xface_ros.demo`` (or ``make demo``)

1. starts ``xface_predictor`` as a separate process (``python -m xface_ros`` with
   config/xface.yaml when this is a source checkout, the built-in defaults otherwise) with a
   rerun recording switched on when :mod:`xface_core.viz.recording` is available;
2. waits until the node is **ready**: its ``/diagnostics`` no longer says "warming up" (its
   service exists at once, but where the simulator compiles the first answer takes minutes),
   saying every 5 s how far the warm-up has come, for up to ``--ready-timeout`` seconds
   (default 600: a compile on a loaded 2-core machine takes minutes);
3. only then starts its clock: runs the bundled :class:`~xface_ros.pose_source.PoseSource`
   through its sweep (poses that seat, jam, lie out of reach or miss the base, and one invalid
   input) until every kind of answer has come or ``--duration`` seconds (default 15) have
   passed, printing every answer as it arrives, one word per meaning: ``accepted``, ``will not
   seat``, ``invalid``;
4. asks the planner service (``predict``, nav_msgs/GetPlan) about one pose and shows the
   answer;
5. stops the node with one SIGINT and waits for it to finish its recording (killing it only
   if it has not exited 120 s later, and then saying so), and checks the recording with
   ``rerun rrd verify``.

It exits 0 only when every kind of answer and the planner's answer came, the node exited with
code 0 and the recording (if any) verified; its last line says which of these failed.

DDS discovery stays on this host (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) in a ROS domain
of its own: ``ROS_DOMAIN_ID`` when set (``make demo`` sets one), else ``--domain-id``.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from xface_ros import names

if TYPE_CHECKING:  # imported at run time only after the environment is set (main)
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.executors import Executor

    from xface_ros.pose_source import PoseSource

__all__ = ["EVERY_KIND", "main", "wait_until_ready"]

#: Default ROS domain of the demo when the environment sets none (tests use 100..199).
DEFAULT_DOMAIN_ID = 42
#: The answers the sweep shows (outcome -> what the summary calls it); the demo fails
#: without any one of them.
EVERY_KIND = {
    "SEATED": "seats",
    "BAD_MATE": "jams",
    "OUT_OF_REACH": "out of reach",
    "NO_CONTACT": "a miss",
    "INVALID_INPUT": "an invalid input",
}
#: Longest wait for the node's warm-up (s): a compile takes 60-130 s of CPU, more on a
#: loaded machine.
READY_TIMEOUT_S = 600.0
#: Seconds between two lines about the warm-up while the demo waits for it.
PROGRESS_EVERY_S = 5.0
#: Longest wait for the node's interfaces to match ours once it is warmed up (s).
MATCH_TIMEOUT_S = 60.0
#: The planner query: longest wait for its answer, and how often it is asked again meanwhile
#: (a reply can be lost while the service's endpoints are still matching; GetPlan changes
#: nothing, so asking again is safe).
PLANNER_TIMEOUT_S = 30.0
PLANNER_RESEND_S = 5.0
#: How long the node may take to exit after its SIGINT (s): it stops its worker and an atlas
#: build (up to 30 s each) and finishes the recording; killed after that.
STOP_TIMEOUT_S = 120.0
#: Longest run of ``rerun rrd verify`` (s).
VERIFY_TIMEOUT_S = 120.0
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
    for flag, default, what in (
        ("--duration", 15.0, "seconds the sweep may take once the node is ready"),
        ("--ready-timeout", READY_TIMEOUT_S, "seconds to wait for the node's warm-up"),
        ("--rate", 2.0, "poses per second"),
    ):
        parser.add_argument(flag, type=float, default=default, help=f"{what} (default {default:g})")
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


def wait_until_ready(
    node_message: Callable[[], str | None],
    node_running: Callable[[], bool],
    *,
    timeout_s: float,
    say: Callable[[str], None],
    every_s: float = PROGRESS_EVERY_S,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> str | None:
    """Wait until the node says it is no longer warming up; None then, else why not.

    ``node_message`` gives the message of the node's latest predictor status on
    ``/diagnostics`` (None before the first). Every ``every_s`` seconds the wait is said with
    that message ("the node is warming up: compiling the simulator (3/7, 41 s)"), so a
    minutes-long compile is not silence. Gives up when ``node_running`` turns False or after
    ``timeout_s`` seconds.
    """
    from xface_ros.diagnostics import is_warming_up

    started = clock()
    next_note = started + every_s
    while True:
        message = node_message()
        if message is not None and not is_warming_up(message):
            return None
        if not node_running():
            return "the node exited before it was ready"
        waited = clock() - started
        if waited > timeout_s:
            last = message or "no /diagnostics from it"
            return f"the node was not ready within {timeout_s:g} s ({last})"
        if clock() >= next_note:
            state = f"is {message}" if message else "is starting (no /diagnostics yet)"
            say(f"xface demo: {waited:3.0f} s, the node {state}")
            next_note += every_s
        sleep(0.1)


@dataclass
class Answers:
    """What came back from the node: every answer's outcome, and the planner's answer."""

    outcomes: Counter[str] = field(default_factory=Counter)
    accepted: Counter[bool] = field(default_factory=Counter)
    planner: str | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)

    def count(self, outcome: str, accepted: bool | None) -> None:
        """One answer; ``accepted`` None for an invalid input."""
        with self.lock:
            self.outcomes[outcome] += 1
            if accepted is not None:
                self.accepted[accepted] += 1

    def missing(self) -> list[str]:
        """The kinds of answer (:data:`EVERY_KIND`) that have not come."""
        with self.lock:
            return [name for outcome, name in EVERY_KIND.items() if not self.outcomes[outcome]]

    def total(self) -> int:
        with self.lock:
            return sum(self.outcomes.values())


def main(argv: list[str] | None = None) -> int:
    """Run the demo; 0 when every kind of answer and the planner's came, the node exited
    cleanly and its recording verified."""
    args = _parse(argv)
    _isolate_ros(args.domain_id)
    # Imported here, after the environment is set (rclpy reads it when a context starts).
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    from xface_ros.pose_source import DEMO_SWEEP

    recording_available = importlib.util.find_spec("xface_core.viz.recording") is not None
    record_path = _fresh_record_path(args, recording_available)
    print(
        f"xface demo: ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, discovery on localhost only; "
        f"up to {args.duration:g} s of poses once the node is ready (Ctrl-C stops earlier)",
        flush=True,
    )
    started = time.monotonic()
    node = subprocess.Popen(_node_command(args, record_path), start_new_session=True)
    # SIGTERM stops the demo like Ctrl-C; the node gets exactly one SIGINT from us either way.
    signal.signal(signal.SIGTERM, _raise_keyboard_interrupt)

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    executor = SingleThreadedExecutor()
    answers = Answers()
    failures: list[str] = []
    spin_thread: threading.Thread | None = None
    try:
        listener = _Listener(executor, answers, started)
        print("xface demo: starting the node; it is ready once its simulator has loaded")
        spin_thread = threading.Thread(target=executor.spin, daemon=True)
        spin_thread.start()
        problem = _wait_for_the_node(listener, node, args)
        if problem is not None:
            failures.append(problem)
            print(f"xface demo: {problem}", file=sys.stderr, flush=True)
            return 1
        source = _run_the_sweep(listener, executor, node, args, started)
        answers.planner = _ask_planner(listener.client, source.pose_of(*DEMO_SWEEP[1]))
        if node.poll() is not None:
            failures.append(f"the node exited early ({node.returncode})")
    except KeyboardInterrupt:
        print("\nxface demo: interrupted", flush=True)
        failures.append("interrupted")
    finally:
        node_code, killed = _shut_down(node, executor, spin_thread)
        failures += _summarise(answers, node_code, killed)
        if record_path is not None:
            failures += _check_recording(record_path, killed)
        elif not recording_available:
            print("xface demo: no recording (xface_core.viz.recording is not available)")
        verdict = "OK" if not failures else "FAILED: " + "; ".join(failures)
        print(f"xface demo: {verdict}", flush=True)
    return 0 if not failures else 1


def _fresh_record_path(args: argparse.Namespace, recording_available: bool) -> Path | None:
    """Where the node records (None: no recording), with no file there yet."""
    record_path = None if args.no_record or not recording_available else args.record.resolve()
    if record_path is not None and record_path.exists():
        record_path.unlink()  # a stale file from an earlier run would look like this run's
    return record_path


class _Listener:
    """The demo's side of ROS: prints and counts the node's answers as they come, keeps its
    latest predictor status from ``/diagnostics``, and is the planner service's client."""

    def __init__(self, executor: Executor, answers: Answers, started: float) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
        from nav_msgs.srv import GetPlan

        from xface_ros.node import RESULT_QOS

        self.answers = answers
        self.ready_at = started  # the clock of the printed answers starts when the node is ready
        self.node_status: DiagnosticStatus | None = None  # the node's latest predictor status
        self.node = rclpy.create_node("xface_demo_listener")
        self.status_sub = self.node.create_subscription(
            DiagnosticStatus, names.STATUS, self.show, RESULT_QOS
        )
        self.node.create_subscription(
            DiagnosticArray, names.DIAGNOSTICS, self.keep_node_status, RESULT_QOS
        )
        self.client = self.node.create_client(GetPlan, names.PREDICT)
        executor.add_node(self.node)

    def show(self, status: DiagnosticStatus) -> None:
        """Count one answer and print it, one line."""
        values = {kv.key: kv.value for kv in status.values}
        outcome = values.get("outcome", "?")
        is_accepted = values.get("accepted") == "true"
        t = time.monotonic() - self.ready_at
        self.answers.count(outcome, None if "input_error" in values else is_accepted)
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

    def keep_node_status(self, array: DiagnosticArray) -> None:
        for status in array.status:
            if status.name.endswith(": predictor"):
                self.node_status = status

    def node_message(self) -> str | None:
        """The message of the node's latest predictor status; None before the first."""
        status = self.node_status
        return status.message if status is not None else None

    def matched(self) -> bool:
        """Whether the node's service, answers and pose subscription match ours."""
        return bool(
            self.client.service_is_ready()
            and self.status_sub.get_publisher_count() > 0
            and self.node.count_subscribers(names.POSES) > 0
        )


def _wait_for_the_node(
    listener: _Listener, node: subprocess.Popen[bytes], args: argparse.Namespace
) -> str | None:
    """Wait until the node is warmed up and its interfaces match ours; None then, else why
    not."""
    problem = wait_until_ready(
        listener.node_message,
        lambda: node.poll() is None,
        timeout_s=args.ready_timeout,
        say=lambda line: print(line, flush=True),
    )
    if problem is None and not _wait_for(listener.matched, MATCH_TIMEOUT_S):
        problem = f"the node's topics and service did not match ours within {MATCH_TIMEOUT_S:g} s"
    return problem


def _run_the_sweep(
    listener: _Listener,
    executor: Executor,
    node: subprocess.Popen[bytes],
    args: argparse.Namespace,
    started: float,
) -> PoseSource:
    """Start the clock and the pose source, and let it run until every kind of answer has
    come or ``--duration`` has passed; the source (stopped), to ask the planner about."""
    from rclpy.parameter import Parameter

    from xface_ros.pose_source import DEMO_SWEEP, PoseSource

    source = PoseSource(
        parameter_overrides=[
            Parameter("rate_hz", value=args.rate),
            *(Parameter(k, value=v) for k, v in _shared_parameters(args.params_file).items()),
        ]
    )
    listener.ready_at = time.monotonic()
    status = listener.node_status
    engine = {kv.key: kv.value for kv in status.values}.get("engine", "?") if status else "?"
    print(
        f"xface demo: node ready after {listener.ready_at - started:.1f} s (simulator: {engine})",
        flush=True,
    )
    print(f"{'t (s)':>6}  {'x0 (m)':>9} {'theta0':>8}    {'outcome':<12} {'answer':<13} "
          f"{'margin':>8} {'ms':>8}  why")  # fmt: skip
    executor.add_node(source)
    end = time.monotonic() + args.duration
    answers = listener.answers
    while time.monotonic() < end and node.poll() is None:
        # The whole sweep once, with every kind of answer (a pose lost before the node's
        # subscription matched comes round again).
        if answers.total() >= len(DEMO_SWEEP) and not answers.missing():
            break
        time.sleep(0.1)
    executor.remove_node(source)
    return source


def _shut_down(
    node: subprocess.Popen[bytes], executor: Executor, spin_thread: threading.Thread | None
) -> tuple[int, bool]:
    """Stop the node (:func:`_stop`) and then the demo's side of ROS; the node's exit code,
    and whether it had to be killed."""
    import rclpy

    node_code, killed = _stop(node)
    executor.shutdown(timeout_sec=5.0)
    if spin_thread is not None:  # stopped before the context it waits on goes away
        spin_thread.join(timeout=5.0)
    rclpy.try_shutdown()
    return node_code, killed


def _wait_for(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Poll ``condition`` every 0.1 s for up to ``timeout_s``; whether it came true."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)
    return True


def _summarise(answers: Answers, node_code: int, killed: bool) -> list[str]:
    """Print what came back and how the node ended; the failures among them."""
    failures = []
    accepted, refused = answers.accepted[True], answers.accepted[False]
    predicted = accepted + refused
    print(
        f"xface demo: {predicted} predictions ({accepted} accepted, {refused} will not seat), "
        f"{answers.total() - predicted} invalid; "
        + ", ".join(f"{name} {n}" for name, n in sorted(answers.outcomes.items())),
        flush=True,
    )
    kinds = ", ".join(f"{name} {answers.outcomes[o]}" for o, name in EVERY_KIND.items())
    missing = answers.missing()
    print(
        f"xface demo: every kind of answer: {kinds}"
        + (f" (missing: {', '.join(missing)})" if missing else "")
    )
    if missing:
        failures.append(f"missing answers: {', '.join(missing)}")
    print(f"xface demo: planner answer: {answers.planner or 'none'}", flush=True)
    if answers.planner is None:
        failures.append("no planner answer")
    if killed:
        print(f"xface demo: node killed after {STOP_TIMEOUT_S:g} s without exiting on SIGINT")
        failures.append("node killed")
    else:
        print(f"xface demo: node exited with code {node_code}", flush=True)
        if node_code != 0:
            failures.append(f"node exit code {node_code}")
    return failures


def _check_recording(record_path: Path, killed: bool) -> list[str]:
    """Verify the recording with ``rerun rrd verify`` and say so; the failures."""
    if not record_path.exists():
        print(f"xface demo: no recording was written to {record_path}", flush=True)
        return ["no recording"]
    size = record_path.stat().st_size
    verified, detail = _verify_recording(record_path)
    if not verified:
        why = "the node was killed, so it is unfinished; " if killed else ""
        print(f"xface demo: recording {record_path} ({size} bytes) is NOT good: {why}{detail}")
        return ["recording does not verify"]
    print(f"xface demo: recording {record_path} ({size} bytes): {detail}")
    # The viewer comes with the venv: name it by its path, so the line runs as printed
    # without activating the venv.
    print(f"xface demo: view it with: {_rerun_command() or 'rerun'} {record_path}", flush=True)
    return []


def _rerun_command() -> str | None:
    """The rerun CLI: the venv's (beside this interpreter), else the one on PATH."""
    beside = Path(sys.executable).with_name("rerun")
    return str(beside) if beside.exists() else shutil.which("rerun")


def _verify_recording(path: Path) -> tuple[bool, str]:
    """``rerun rrd verify PATH`` (footers included): whether it passed, and what it said."""
    rerun = _rerun_command()
    if rerun is None:
        return False, "no rerun command to verify it with (pip install '.[viz]')"
    try:
        run = subprocess.run(
            [rerun, "rrd", "verify", str(path)],
            capture_output=True, text=True, timeout=VERIFY_TIMEOUT_S, check=False,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return False, f"rerun rrd verify did not finish within {VERIFY_TIMEOUT_S:g} s"
    if run.returncode == 0:
        return True, "verified (rerun rrd verify)"
    # Its first line names the problem ('"x.rrd": Missing RRD footer / no RRD manifests'),
    # the last only counts the errors.
    said = [line.strip() for line in (run.stderr + run.stdout).splitlines() if line.strip()]
    return False, f"rerun rrd verify failed: {said[0] if said else f'exit code {run.returncode}'}"


def _ask_planner(client: Any, start: Any) -> str | None:
    """One planner query (nav_msgs/GetPlan on ``predict``), printed with its answer: a plan
    is the path to the seat, an empty plan a refusal (docs/ros.md); None without an answer
    within :data:`PLANNER_TIMEOUT_S`."""
    from nav_msgs.srv import GetPlan

    request = GetPlan.Request(start=start)
    x = start.pose.position.x
    print(f"xface demo: planner query GetPlan(start x={x:+.4f} m, ...) on predict", flush=True)
    pending = [client.call_async(request)]
    deadline = time.monotonic() + PLANNER_TIMEOUT_S
    resend_at = time.monotonic() + PLANNER_RESEND_S
    while not any(future.done() for future in pending):
        if time.monotonic() > deadline:
            print(f"xface demo: the planner query got no answer within {PLANNER_TIMEOUT_S:g} s")
            return None
        if time.monotonic() > resend_at:
            pending.append(client.call_async(request))
            resend_at += PLANNER_RESEND_S
        time.sleep(0.05)
    done = next(future for future in pending if future.done())
    for future in pending:
        if future is not done:
            client.remove_pending_request(future)
    poses = done.result().plan.poses
    return f"a plan of {len(poses)} poses to the seat" if poses else "an empty plan (refused)"


def _stop(node: subprocess.Popen[bytes]) -> tuple[int, bool]:
    """SIGINT the node once and wait for it to finish its recording; its exit code, and
    whether it had to be killed (after :data:`STOP_TIMEOUT_S`: its recording is unfinished)."""
    if node.poll() is None:
        node.send_signal(signal.SIGINT)
    try:
        return node.wait(timeout=STOP_TIMEOUT_S), False
    except subprocess.TimeoutExpired:
        print(
            f"xface demo: the node did not exit within {STOP_TIMEOUT_S:g} s of SIGINT: killing "
            "it (its recording is unfinished)",
            file=sys.stderr,
            flush=True,
        )
        node.kill()
        return node.wait(), True


if __name__ == "__main__":
    raise SystemExit(main())
