#!/usr/bin/env python3
"""Cold start: how long a new user waits for the first answer after installing xface.

    python3 scripts/bench/bench_cold_start.py                     # every kind: 10-20 minutes
    python3 scripts/bench/bench_cold_start.py --kinds wheel,readonly --out cold_start.md
    python3 scripts/bench/bench_cold_start.py --source ~/xface --also-cold --keep

Issue 35: the build compiles the engine into the package (setup.py runs ``python -m
xface_core.precompile``), so the first ``xface predict`` of a fresh install should take at
most 3 times the second instead of compiling first. This script measures that as a new user
meets it. It clones the repository's HEAD into a temporary folder (uncommitted files never
leak in; ``--source PATH`` takes a tree instead, copied without .git, build output or a
precompiled engine), and for each install kind makes a fresh virtualenv (``python3.11 -m
venv``, not timed) and times:

* wheel: ``python -m build --wheel`` (``build`` installed into a scratch venv when missing, or
  ``pip wheel --no-deps`` when that fails; the notes say which), then ``pip install <wheel>``
  (core only), separately;
* pip: ``pip install <tree>`` (the build included);
* editable: ``pip install -e <copy of the tree>`` (the build writes the engine into the tree);
* readonly: the same wheel, every xface command run as user ``nobody`` (setpriv or runuser:
  needs root), who cannot write the venv: the shipped engine must serve without numba
  writing anything;
* node: ``pip install '<wheel>[ros]'``, then ``xface-predictor --ros-args -p record:=false``
  and an rclpy client (this file, ``--node-client``, run by the venv's python) that publishes
  the same dock on ``relative_pose`` every 0.2 s: the time from the node's start to its first
  ``prediction/status``, then a second answer's latency from publish to status. ROS stays on
  this machine: ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, ROS_STATIC_PEERS empty and
  ``--domain-id`` (200-230).

For every kind, with an empty user cache (HOME and XDG_CACHE_HOME in a fresh temporary folder,
no NUMBA_* or XFACE_* variables), in this one run: the engine's state
(``runner.engine_state().describe()``), then the first ``xface predict --x0 0.1 --theta0
0.2`` and a second identical one, wall seconds and the child's CPU seconds (``os.wait4``),
and their ratio. ``--also-cold`` adds a wheel built with ``XFACE_PRECOMPILE=0`` (the engine
then compiles on first use, 1-2 minutes; reported, not checked).

Prints a Markdown table and notes (``--out FILE`` writes them too). Exit 1 when a kind's
first/second ratio exceeds 3, a kind could not be measured, the node did not answer within
120 s of its start, or its first answer after its first start took more than 3 times the one
after a second start of the same install. Removes its temporary folders and stops its
processes at the end (``--keep`` keeps the folders, logs included). Uses the standard library
only.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import math
import os
import platform
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = Path(__file__).resolve()

KINDS = ("wheel", "pip", "editable", "readonly", "node")
#: The ``--also-cold`` row: a wheel without the shipped engine (not held to MAX_RATIO).
COLD_KIND = "wheel, XFACE_PRECOMPILE=0"
#: Issue 35's criterion: the first ``xface predict`` at most this many times the second.
MAX_RATIO = 3.0
PREDICT_ARGS = ("predict", "--x0", "0.1", "--theta0", "0.2")
DEFAULT_PYTHON = "python3.11"
#: Where a venv for user ``nobody`` may find a Python it can read (after ``--python``).
READONLY_PYTHONS = ("/usr/bin/python3.11", "/usr/local/bin/python3.11")
READONLY_USER = "nobody"
READONLY_GROUP = "nogroup"

INSTALL_TIMEOUT_S = 1800.0
PREDICT_TIMEOUT_S = 600.0
#: The node must answer within this many seconds of its start.
NODE_ANSWER_TIMEOUT_S = 120.0
SECOND_ANSWER_TIMEOUT_S = 30.0
#: After the first answer, statuses of poses queued before it are drained this long.
DRAIN_S = 1.0
PUBLISH_PERIOD_S = 0.2
NODE_STOP_TIMEOUT_S = 30.0
DOMAIN_IDS = range(200, 231)
#: The node's defaults (config/xface.yaml): face width and the frame poses must carry.
NODE_WIDTH_M = 0.05
BASE_FRAME = "xface_base"
#: The streamed dock starts this many widths above the base (as xface_ros.pose_source).
START_WIDTHS = 3.0
NODE_COMMAND = ("xface-predictor", "--ros-args", "-p", "record:=false")

#: Prints the engine's state and why the shipped engine does not serve (JSON, last line).
ENGINE_PROBE = (
    "import json; from xface_core import runner; s = runner.engine_state(); "
    "print(json.dumps([s.describe(), s.why_not_precompiled]))"
)
MANIFEST_PROBE = (
    "from xface_core._engine import precompiled as p; "
    "print(p.read_manifest(), p.manifest_problem(p.read_manifest(), p.host_triple()))"
)
#: Variables a new user's shell would not carry into xface: numba's settings, ours, another
#: Python's or venv's, and ROS/DDS set-ups (the node gets loopback-only ones of its own).
USER_ENV_DROPPED = (
    "NUMBA_",
    "XFACE_",
    "PYTHON",
    "VIRTUAL_ENV",
    "ROS_",
    "RMW_",
    "FASTRTPS_",
    "FASTDDS_",
    "CYCLONEDDS_",
    "AMENT_",
    "COLCON_",
)
#: Variables the builds and installs do not inherit (pip's own settings stay).
TOOL_ENV_DROPPED = ("NUMBA_", "XFACE_", "PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")
#: Not copied from a source tree: VCS, venvs, build output, caches, a precompiled engine.
COPY_IGNORED = (
    ".git",
    ".venv",
    "build",
    "dist",
    "*.egg-info",
    "__pycache__",
    "_compiled",
    ".pytest_cache",
    ".mypy_cache",
    ".ruff_cache",
    ".hypothesis",
    ".benchmarks",
)
HEADER = (
    "kind",
    "install s",
    "engine state",
    "first predict s (CPU s)",
    "second s (CPU s)",
    "first/second",
    "node: first answer after start s",
    "node: second answer s",
    "node: first answer after a second start s",
)
MISSING = "-"


class StepFailed(RuntimeError):
    """A step of a kind failed; the message says which and why (with its log's last lines)."""


# --------------------------------------------------------------------------------------------
# Pure pieces: arguments, results, the table, the verdict
# --------------------------------------------------------------------------------------------


def parse_kinds(text: str) -> tuple[str, ...]:
    """``wheel,node`` -> the kinds in the script's order (``all``: every kind)."""
    names = {name.strip() for name in text.split(",") if name.strip()}
    if names == {"all"}:
        return KINDS
    unknown = sorted(names - set(KINDS))
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown kind {', '.join(unknown) or '(none)'}; choose from {','.join(KINDS)}"
        )
    return tuple(kind for kind in KINDS if kind in names)


def parse_domain_id(text: str) -> int:
    """A ROS domain id in :data:`DOMAIN_IDS`."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value not in DOMAIN_IDS:
        raise argparse.ArgumentTypeError(
            f"the ROS domain id must be {DOMAIN_IDS.start}-{DOMAIN_IDS.stop - 1}, got {text!r}"
        )
    return value


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="bench_cold_start.py",
        description=(__doc__ or "").splitlines()[0],
        epilog="See the module docstring for what each kind measures.",
    )
    parser.add_argument(
        "--source",
        type=Path,
        help="measure this tree (copied) instead of a clone of the repository's HEAD",
    )
    parser.add_argument(
        "--kinds",
        type=parse_kinds,
        default=KINDS,
        help=f"comma-separated install kinds (default: all of {','.join(KINDS)})",
    )
    parser.add_argument(
        "--also-cold",
        action="store_true",
        help="also a wheel built with XFACE_PRECOMPILE=0 (compiles for 1-2 minutes)",
    )
    parser.add_argument("--out", type=Path, help="also write the report (Markdown) here")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folders")
    parser.add_argument(
        "--python",
        default=DEFAULT_PYTHON,
        help=f"the Python that makes the venvs (default {DEFAULT_PYTHON})",
    )
    parser.add_argument(
        "--domain-id",
        type=parse_domain_id,
        default=DOMAIN_IDS.start + os.getpid() % len(DOMAIN_IDS),
        help=f"ROS_DOMAIN_ID of the node kind ({DOMAIN_IDS.start}-{DOMAIN_IDS.stop - 1})",
    )
    parser.add_argument("--node-client", metavar="JSON", help=argparse.SUPPRESS)
    return parser.parse_args(argv)


@dataclass(frozen=True)
class Timed:
    """One child process: wall seconds, its CPU seconds (user + system), exit code, output."""

    wall_s: float
    cpu_s: float
    returncode: int
    output: str = ""


@dataclass
class Result:
    """What one install kind measured (None: not measured)."""

    kind: str
    install_s: float | None = None
    build_s: float | None = None
    engine: str = ""
    first: Timed | None = None
    second: Timed | None = None
    node_first_s: float | None = None
    node_second_s: float | None = None
    node_restart_s: float | None = None
    """The first answer after a second start of the node in the same install."""
    error: str | None = None
    notes: list[str] = field(default_factory=list)
    checked: bool = True
    """False: reported only, not held to :data:`MAX_RATIO` (the ``--also-cold`` row)."""

    @property
    def ratio(self) -> float | None:
        """First over second ``xface predict`` wall time."""
        if self.first is None or self.second is None or self.second.wall_s <= 0.0:
            return None
        return self.first.wall_s / self.second.wall_s


def _seconds(value: float | None, digits: int) -> str:
    return MISSING if value is None else f"{value:.{digits}f}"


def _predict_cell(timed: Timed | None) -> str:
    if timed is None:
        return MISSING
    cell = f"{timed.wall_s:.2f} ({timed.cpu_s:.2f})"
    return cell if timed.returncode == 0 else f"{cell} exit {timed.returncode}"


def row_cells(result: Result) -> list[str]:
    """The table's cells of one result, in :data:`HEADER`'s order."""
    install = _seconds(result.install_s, 1)
    if result.build_s is not None:
        install += f" (build {result.build_s:.1f})"
    ratio = result.ratio
    if result.error is not None:
        verdict = "failed"
    elif ratio is None:
        verdict = MISSING
    else:
        verdict = f"{ratio:.2f}" + ("" if result.checked else " (not checked)")
    return [
        result.kind,
        install,
        result.engine.replace("|", "/") or MISSING,
        _predict_cell(result.first),
        _predict_cell(result.second),
        verdict,
        _seconds(result.node_first_s, 1),
        _seconds(result.node_second_s, 2),
        _seconds(result.node_restart_s, 1),
    ]


def format_table(results: Iterable[Result]) -> str:
    """The Markdown table of ``results``."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += ["| " + " | ".join(row_cells(result)) + " |" for result in results]
    return "\n".join(lines)


def failures(results: Iterable[Result], max_ratio: float = MAX_RATIO) -> list[str]:
    """Why the run fails issue 35's check (empty: it passes): a kind that could not be
    measured (the node's missing answer included), or a first ``xface predict`` more than
    ``max_ratio`` times the second (rows with ``checked`` False are exempt from the ratio)."""
    found = []
    for result in results:
        ratio = result.ratio
        if result.error is not None:
            found.append(f"{result.kind}: {result.error}")
        elif not result.checked:
            continue
        elif ratio is None:
            found.append(f"{result.kind}: the predict ratio was not measured")
        elif ratio > max_ratio:
            found.append(f"{result.kind}: the first xface predict took {ratio:.1f}x the second")
        first, again = result.node_first_s, result.node_restart_s
        if first is not None and again is not None and first > max_ratio * again:
            found.append(
                f"{result.kind}: the node's first answer after its first start took "
                f"{first / again:.1f}x the one after a second start"
            )
    return found


def format_report(
    results: Sequence[Result], *, header: Sequence[str], total_s: float | None
) -> str:
    """Title, set-up lines, the table, the verdict, the total time and each kind's notes."""
    bad = failures(results)
    lines = [
        "## Cold start (scripts/bench/bench_cold_start.py)",
        "",
        *header,
        "",
        format_table(results),
    ]
    lines += [""]
    if bad:
        lines += ["**Issue 35's criterion is not met:**", *(f"- {why}" for why in bad)]
    else:
        lines.append(
            f"Issue 35's criterion is met: every first xface predict took at most {MAX_RATIO:g}x "
            "the second, and the node answered."
        )
    if total_s is not None:
        lines += ["", f"Total run time: {total_s:.0f} s ({total_s / 60:.1f} min)."]
    noted = [result for result in results if result.notes or result.error]
    if noted:
        lines += ["", "Notes:"]
    for result in noted:
        for note in result.notes + ([f"failed: {result.error}"] if result.error else []):
            lines.append(f"- {result.kind}: {note}")
    return "\n".join(lines) + "\n"


def relative_pose_m(
    x0_widths: float, theta0_rad: float, width_m: float, start_widths: float
) -> tuple[float, float, float, float]:
    """``relative_pose`` of the dock ``(x0, theta0)`` (x0 in face widths) as the node reads it
    (xface_core.frames.start_to_relative_pose): the moving pivot at ``(x0, start)`` in metres,
    its yaw ``theta0 + pi`` about +z; returns ``(x_m, y_m, qz, qw)``."""
    yaw = math.remainder(theta0_rad + math.pi, 2.0 * math.pi)
    if yaw == -math.pi:
        yaw = math.pi
    return (x0_widths * width_m, start_widths * width_m, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


def user_env(
    base: Mapping[str, str], home: Path, bin_dir: Path, dropped: Sequence[str] = USER_ENV_DROPPED
) -> dict[str, str]:
    """A new user's environment: ``base`` without the ``dropped`` prefixes, an empty cache
    (HOME and XDG_CACHE_HOME in ``home``) and the venv's ``bin_dir`` first on PATH."""
    env = {key: value for key, value in base.items() if not key.startswith(tuple(dropped))}
    env["HOME"] = str(home)
    env["XDG_CACHE_HOME"] = str(home / ".cache")
    env["PATH"] = os.pathsep.join([str(bin_dir), *filter(None, [base.get("PATH")])])
    return env


def ros_env(env: Mapping[str, str], domain_id: int) -> dict[str, str]:
    """``env`` with ROS kept on this machine: loopback discovery, no static peers."""
    return {
        **env,
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_STATIC_PEERS": "",
        "ROS_DOMAIN_ID": str(domain_id),
    }


def copy_tree(source: Path, dest: Path) -> Path:
    """A clean copy of a source tree (none of :data:`COPY_IGNORED`)."""
    shutil.copytree(source, dest, ignore=shutil.ignore_patterns(*COPY_IGNORED), symlinks=True)
    return dest


def build_messages(output: str, most: int = 6) -> list[str]:
    """What an install's build said about the engine: setup.py's and the precompile's
    ``xface:`` lines, and the last line of each traceback (the error a failed step hid)."""
    found = []
    for line in output.splitlines():
        text = line.strip()
        if text.startswith("xface:") or re.match(r"\w+(Error|Exception): ", text):
            found.append(text[:200])
    return list(dict.fromkeys(found))[:most]


def tail(text: str, lines: int = 12) -> str:
    """The last ``lines`` non-empty lines of ``text``, indented for a message."""
    kept = [line for line in text.splitlines() if line.strip()][-lines:]
    return "\n    ".join(["", *kept]) if kept else " (no output)"


# --------------------------------------------------------------------------------------------
# Child processes
# --------------------------------------------------------------------------------------------


def run_timed(
    cmd: Sequence[str | os.PathLike[str]],
    *,
    env: Mapping[str, str] | None = None,
    cwd: Path | None = None,
    timeout_s: float = PREDICT_TIMEOUT_S,
    log: Path | None = None,
) -> Timed:
    """Run ``cmd`` to its end: wall seconds, the CPU seconds ``os.wait4`` reports for it (its
    waited-for descendants included), exit code (-N: killed by signal N; the timeout kills
    it) and its output (stdout and stderr, also written to ``log``)."""
    with tempfile.TemporaryFile() as out:
        start = time.perf_counter()
        proc = subprocess.Popen(
            [str(part) for part in cmd], env=env, cwd=cwd, stdout=out, stderr=subprocess.STDOUT
        )
        timer = threading.Timer(timeout_s, _kill, args=(proc.pid,))
        timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            timer.cancel()
        wall_s = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        text = out.read().decode("utf-8", errors="replace")
    if log is not None:
        log.write_text(text)
    return Timed(wall_s, usage.ru_utime + usage.ru_stime, proc.returncode, text)


def _kill(pid: int) -> None:
    """SIGKILL by PID without reaping (the caller's ``os.wait4`` does that)."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGKILL)


def stop_process(proc: subprocess.Popen[bytes], name: str, notes: list[str]) -> int | None:
    """SIGINT, then wait; SIGKILL by PID only when it has not ended after
    :data:`NODE_STOP_TIMEOUT_S` (noted). Its exit code."""
    if proc.poll() is not None:
        return proc.returncode
    proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout=NODE_STOP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        notes.append(
            f"{name} (PID {proc.pid}) ignored SIGINT for {NODE_STOP_TIMEOUT_S:.0f} s: killed"
        )
        return proc.wait()


def user_prefix(user: str = READONLY_USER, group: str = READONLY_GROUP) -> list[str]:
    """The command prefix that runs a program as ``user`` (setpriv, else runuser)."""
    if os.geteuid() != 0:
        raise StepFailed(f"running commands as {user} needs root (this is uid {os.geteuid()})")
    if shutil.which("setpriv"):
        return ["setpriv", f"--reuid={user}", f"--regid={group}", "--clear-groups"]
    if shutil.which("runuser"):
        return ["runuser", "-u", user, "--"]
    raise StepFailed("neither setpriv nor runuser is installed")


def numba_files(roots: Iterable[Path]) -> set[Path]:
    """numba's cache files below ``roots``, not counting a shipped engine (``_compiled``)."""
    found: set[Path] = set()
    for root in roots:
        if root.is_dir():
            found |= {
                path
                for pattern in ("*.nbi", "*.nbc")
                for path in root.rglob(pattern)
                if "_compiled" not in path.parts
            }
    return found


# --------------------------------------------------------------------------------------------
# The node's client (runs in the node venv's Python: python bench_cold_start.py --node-client)
# --------------------------------------------------------------------------------------------


def node_client(config: Mapping[str, Any]) -> dict[str, Any]:
    """Publish the dock on ``relative_pose`` every ``period_s`` until a status arrives on
    ``prediction/status`` (reliable, as the node's RESULT_QOS); drain; publish again and time
    that answer. Times are ``time.monotonic()`` (one clock for every process of the machine);
    the first answer is counted from ``config["t0"]``, the node's start."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticStatus
    from geometry_msgs.msg import PoseStamped
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
        qos_profile_sensor_data,
    )

    from xface_ros import names

    t0, period_s = float(config["t0"]), float(config["period_s"])
    x_m, y_m, qz, qw = config["pose"]
    answers: list[tuple[float, int | None, str]] = []  # (arrival, input stamp ns, message)
    sent: dict[int, float] = {}  # stamp ns -> when it was published
    report: dict[str, Any] = {"error": None}
    rclpy.init()
    node = rclpy.create_node("xface_cold_start_client")
    try:

        def on_status(msg: Any) -> None:
            stamps = [kv.value for kv in msg.values if kv.key == "input_stamp_ns"]
            stamp = int(stamps[0]) if stamps and stamps[0].lstrip("-").isdigit() else None
            answers.append((time.monotonic(), stamp, str(msg.message)))

        result_qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=10,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
        )
        node.create_subscription(DiagnosticStatus, names.STATUS, on_status, result_qos)
        pub = node.create_publisher(PoseStamped, names.POSES, qos_profile_sensor_data)
        report["client_ready_s"] = time.monotonic() - t0

        def publish() -> None:
            msg = PoseStamped()
            now = node.get_clock().now()
            msg.header.stamp = now.to_msg()
            msg.header.frame_id = config["frame"]
            msg.pose.position.x, msg.pose.position.y = float(x_m), float(y_m)
            msg.pose.orientation.z, msg.pose.orientation.w = float(qz), float(qw)
            sent[now.nanoseconds] = time.monotonic()
            pub.publish(msg)

        def answer(deadline: float, old: set[int] | None) -> tuple[float, int | None, str]:
            """The first status (with ``old``: for a pose not in it), publishing meanwhile."""
            next_s = 0.0
            while True:
                for arrival, stamp, message in answers:
                    if old is None or (stamp is not None and stamp not in old):
                        return arrival, stamp, message
                now = time.monotonic()
                if now >= deadline:
                    raise TimeoutError
                if now >= next_s:
                    publish()
                    next_s = now + period_s
                rclpy.spin_once(node, timeout_sec=max(0.0, min(next_s, deadline) - now))

        try:
            arrival, _, message = answer(t0 + float(config["timeout_s"]), None)
        except TimeoutError:
            report["error"] = f"no status within {config['timeout_s']:.0f} s of the node's start"
            return report
        report.update(first_s=arrival - t0, first_message=message, published=len(sent))
        drain_until = time.monotonic() + float(config["drain_s"])
        while time.monotonic() < drain_until:
            rclpy.spin_once(node, timeout_sec=0.05)
        answers.clear()
        try:
            deadline = time.monotonic() + float(config["second_s"])
            arrival, stamp, message = answer(deadline, set(sent))
        except TimeoutError:
            report["error"] = f"no second status within {config['second_s']:.0f} s"
            return report
        assert stamp is not None
        report.update(second_s=arrival - sent[stamp], second_message=message)
        return report
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


# --------------------------------------------------------------------------------------------
# The run
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Wheel:
    path: Path
    build_s: float
    notes: tuple[str, ...]


class ColdStart:
    """One run: a work folder, the source tree, the wheels built so far, live processes."""

    def __init__(self, args: argparse.Namespace, work: Path) -> None:
        self.args = args
        self.work = work
        self.logs = work / "logs"
        self.logs.mkdir()
        self.started = time.perf_counter()
        self.source = work / "source"
        self.header: list[str] = []
        self.processes: list[subprocess.Popen[bytes]] = []
        self._wheels: dict[bool, Wheel] = {}
        self._builder: tuple[str, str, str] | None = None
        self.tool_env = {
            key: value for key, value in os.environ.items() if not key.startswith(TOOL_ENV_DROPPED)
        }

    def say(self, message: str) -> None:
        elapsed_s = time.perf_counter() - self.started
        print(f"[{elapsed_s:6.0f} s] {message}", file=sys.stderr, flush=True)

    def step(
        self,
        name: str,
        cmd: Sequence[str | os.PathLike[str]],
        *,
        env: Mapping[str, str] | None = None,
        cwd: Path | None = None,
        timeout_s: float = INSTALL_TIMEOUT_S,
        check: bool = True,
    ) -> Timed:
        """Run one step with its output in logs/NAME.log; StepFailed on a non-zero exit.

        It runs in ``cwd``, by default the run's own folder, never where the script was
        started: there a ``build/`` folder (a setup.py build's output, as in a checkout)
        is a namespace package that shadows the ``build`` tool, so ``import build`` passed
        and ``python -m build`` then failed."""
        self.say(f"{name}: {shlex.join(str(part) for part in cmd)}")
        log = self.logs / f"{name}.log"
        cwd = self.work if cwd is None else cwd
        timed = run_timed(cmd, env=env or self.tool_env, cwd=cwd, timeout_s=timeout_s, log=log)
        self.say(f"{name}: exit {timed.returncode} after {timed.wall_s:.1f} s")
        if check and timed.returncode != 0:
            raise StepFailed(f"{name} exited {timed.returncode} ({log}):{tail(timed.output)}")
        return timed

    # -- source, venvs, installs -------------------------------------------------------------

    def prepare_source(self) -> None:
        """The clean tree every kind copies: a clone of HEAD, or ``--source`` copied."""
        if self.args.source is not None:
            copy_tree(self.args.source.resolve(), self.source)
            self.header.append(f"Source: the tree {self.args.source.resolve()} (copied).")
            return
        repo = Path(self._git(ROOT, "rev-parse", "--show-toplevel"))
        head = self._git(repo, "rev-parse", "HEAD")
        self.step("clone", ["git", "clone", "--quiet", "--no-checkout", str(repo), self.source])
        self.step("checkout", ["git", "-C", self.source, "checkout", "--quiet", "--detach", head])
        dirty = self._git(repo, "status", "--porcelain", "--untracked-files=no").splitlines()
        subject = self._git(repo, "log", "-1", "--format=%h %s", "HEAD")
        subject = subject if len(subject) <= 72 else subject[:69] + "..."
        self.header.append(
            f"Source: a clone of HEAD {subject} ({repo}); {len(dirty)} file(s) with uncommitted "
            "changes there are not measured."
        )

    @staticmethod
    def _git(repo: Path, *args: str) -> str:
        done = subprocess.run(
            ["git", "-C", str(repo), *args], capture_output=True, text=True, check=True
        )
        return done.stdout.strip()

    def venv(self, name: str, python: str | None = None) -> Path:
        path = self.work / name / "venv"
        path.parent.mkdir(exist_ok=True)
        self.step(f"{name}-venv", [python or self.args.python, "-m", "venv", path])
        return path

    def pip_install(
        self, name: str, venv: Path, *targets: str | Path, check: bool = True, verbose: bool = False
    ) -> Timed:
        """``pip install``; ``verbose``: with the build's own output (pip hides it otherwise)."""
        cmd = [venv / "bin" / "python", "-m", "pip", "install", "--progress-bar", "off"]
        return self.step(
            f"{name}-install", [*cmd, *(["-v"] if verbose else []), *targets], check=check
        )

    def home(self, name: str, owner: str | None = None) -> Path:
        """A fresh, empty HOME with an empty .cache (owned by ``owner`` when given)."""
        home = Path(tempfile.mkdtemp(prefix=f"home-{name}-", dir=self.work))
        (home / ".cache").mkdir()
        if owner is not None:
            for path in (home, home / ".cache"):
                shutil.chown(path, owner, READONLY_GROUP)
        return home

    def builder(self) -> tuple[str, str, str]:
        """The Python that builds wheels, the tool (``build`` or ``pip``) and a note."""
        if self._builder is None:
            python = self.args.python
            probe = self.step("build-probe", [python, "-c", "import build"], check=False)
            if probe.returncode == 0:
                self._builder = (python, "build", f"python -m build --wheel ({python} has it)")
            else:
                scratch = self.venv("build-env")
                own = str(scratch / "bin" / "python")
                if self.pip_install("build-env", scratch, "build", check=False).returncode == 0:
                    how = "python -m build --wheel (build installed into a scratch venv)"
                    self._builder = (own, "build", how)
                else:
                    how = "pip wheel --no-deps (the build package could not be installed)"
                    self._builder = (own, "pip", how)
        return self._builder

    def wheel(self, *, precompile: bool) -> Wheel:
        """The wheel of the source tree (built once per run and ``precompile``)."""
        if precompile in self._wheels:
            return self._wheels[precompile]
        name = "wheel-build" if precompile else "cold-wheel-build"
        src = copy_tree(self.source, self.work / f"{name}-src")
        dist = self.work / f"{name}-dist"
        env = dict(self.tool_env)
        if not precompile:
            env["XFACE_PRECOMPILE"] = "0"
        python, tool, how = self.builder()
        if tool == "build":
            cmd = [python, "-m", "build", "--wheel", "--outdir", dist, src]
        else:
            cmd = [python, "-m", "pip", "wheel", "--no-deps", "--wheel-dir", dist, src]
        timed = self.step(name, cmd, env=env)
        said = [f"the build said: {line}" for line in build_messages(timed.output)]
        (path,) = dist.glob("*.whl")
        with zipfile.ZipFile(path) as archive:
            shipped = [n for n in archive.namelist() if "/_engine/_compiled/" in n]
        size_mib = path.stat().st_size / 2**20
        note = (
            f"wheel {path.name} ({size_mib:.1f} MiB) built with {how}; "
            f"{len(shipped)} files of precompiled engine in it"
        )
        notes = (note, *said)
        self._wheels[precompile] = Wheel(path, timed.wall_s, notes)
        return self._wheels[precompile]

    # -- measures ----------------------------------------------------------------------------

    def engine_state(
        self, result: Result, venv: Path, env: Mapping[str, str], home: Path, prefix: list[str]
    ) -> None:
        """``engine_state().describe()`` in the install (and the manifest check when the
        shipped engine does not serve)."""
        python = str(venv / "bin" / "python")
        probe = run_timed([*prefix, python, "-c", ENGINE_PROBE], env=env, cwd=home)
        try:
            result.engine, why = json.loads(probe.output.strip().splitlines()[-1])
        except (IndexError, ValueError):
            result.engine = "unknown (the probe failed)"
            result.notes.append(f"engine_state() exited {probe.returncode}:{tail(probe.output)}")
            return
        if why:
            result.notes.append(f"why_not_precompiled: {why}")
        if result.engine != "ready (precompiled)":
            check = run_timed([*prefix, python, "-c", MANIFEST_PROBE], env=env, cwd=home)
            result.notes.append(f"manifest check: {check.output.strip()[-600:]}")

    def predicts(
        self,
        result: Result,
        venv: Path,
        *,
        prefix: list[str] | None = None,
        owner: str | None = None,
        watched: Sequence[Path] = (),
    ) -> None:
        """The engine's state, then two identical ``xface predict`` runs, empty user cache."""
        prefix = prefix or []
        home = self.home(result.kind.split(",")[0], owner)
        env = user_env(self.tool_env, home, venv / "bin")
        self.engine_state(result, venv, env, home, prefix)
        roots = [home, *watched]
        before = numba_files(roots)
        cmd = [*prefix, str(venv / "bin" / "xface"), *PREDICT_ARGS]
        tag = result.kind.replace(", ", "-").replace("=", "")
        self.say(f"{result.kind}: engine {result.engine}; {shlex.join(cmd)} twice")
        runs = []
        for label in ("first", "second"):
            log = self.logs / f"{tag}-predict-{label}.log"
            runs.append(run_timed(cmd, env=env, cwd=home, timeout_s=PREDICT_TIMEOUT_S, log=log))
            self.say(f"{result.kind}: {label} predict {runs[-1].wall_s:.2f} s")
        result.first, result.second = runs
        bad = [run for run in runs if run.returncode != 0]
        if bad:
            raise StepFailed(f"xface predict exited {bad[0].returncode}:{tail(bad[0].output)}")
        if runs[0].output != runs[1].output:
            result.notes.append("the two predicts printed different answers")
        written = numba_files(roots) - before
        result.notes.append(f"numba cache files the two predicts wrote: {len(written)}")

    def node_answers(self, result: Result, venv: Path, *, restart: bool = False) -> None:
        """Start the node, time its first and a second answer to the client, stop both
        (``restart``: a second start, of which only the first answer is kept)."""
        home = self.home("node-ros-again" if restart else "node-ros")
        env = ros_env(user_env(self.tool_env, home, venv / "bin"), self.args.domain_id)
        config = {
            "period_s": PUBLISH_PERIOD_S,
            "timeout_s": NODE_ANSWER_TIMEOUT_S,
            "second_s": SECOND_ANSWER_TIMEOUT_S,
            "drain_s": DRAIN_S,
            "frame": BASE_FRAME,
            "pose": relative_pose_m(0.1, 0.2, NODE_WIDTH_M, START_WIDTHS),
        }
        node_log = self.logs / ("node-again.log" if restart else "node.log")
        client_log = self.logs / ("node-client-again.log" if restart else "node-client.log")
        cmd = [str(venv / "bin" / NODE_COMMAND[0]), *NODE_COMMAND[1:]]
        self.say(f"node: {shlex.join(cmd)} in ROS domain {self.args.domain_id}")
        with node_log.open("wb") as node_out, client_log.open("wb") as client_out:
            config["t0"] = time.monotonic()
            node = subprocess.Popen(cmd, env=env, cwd=home, stdout=node_out, stderr=node_out)
            self.processes.append(node)
            client_cmd = [str(venv / "bin" / "python"), str(SCRIPT), "--node-client"]
            client = subprocess.Popen(
                [*client_cmd, json.dumps(config)],
                env=env,
                cwd=home,
                stdout=client_out,
                stderr=client_out,
            )
            self.processes.append(client)
            limit_s = NODE_ANSWER_TIMEOUT_S + SECOND_ANSWER_TIMEOUT_S + 60.0
            try:
                client.wait(timeout=limit_s)
            except subprocess.TimeoutExpired:
                result.notes.append(f"the client did not end within {limit_s:.0f} s")
            finally:
                stop_process(client, "the client", result.notes)
                code = stop_process(node, "xface-predictor", result.notes)
        result.notes.append(f"xface-predictor's exit code on SIGINT: {code}")
        log_lines = node_log.read_text(errors="replace").splitlines()
        said = [line.strip() for line in log_lines if "simulator" in line][:2]
        result.notes += [f"node log: {line[-160:]}" for line in said]
        lines = client_log.read_text(errors="replace").strip().splitlines()
        try:
            report = json.loads(lines[-1])
        except (IndexError, ValueError):
            raise StepFailed(f"the client did not report:{tail(chr(10).join(lines))}") from None
        if restart:
            result.node_restart_s = report.get("first_s")
            if report["error"]:
                raise StepFailed(f"node, second start: {report['error']}")
            return
        result.node_first_s = report.get("first_s")
        result.node_second_s = report.get("second_s")
        if "first_message" in report:
            result.notes.append(
                f"first answer {report['first_message'][:90]!r} after "
                f"{report['published']} poses published; client subscribed "
                f"{report['client_ready_s']:.1f} s after the node's start"
            )
        if report["error"]:
            raise StepFailed(f"node: {report['error']}")

    # -- kinds -------------------------------------------------------------------------------

    def run_wheel(self, result: Result, *, precompile: bool = True) -> None:
        """The wheel kind; ``precompile=False``: the ``--also-cold`` row (not checked)."""
        result.checked = precompile
        wheel = self.wheel(precompile=precompile)
        result.build_s = wheel.build_s
        result.notes += wheel.notes
        venv = self.venv("wheel" if precompile else "cold")
        result.install_s = self.pip_install(venv.parent.name, venv, wheel.path).wall_s
        self.predicts(result, venv, watched=[venv])

    def run_source(self, result: Result, *, editable: bool) -> None:
        """``pip install [-e] <copy of the tree>``: pip runs the build (and the precompile)."""
        src = copy_tree(self.source, self.work / f"{result.kind}-src")
        venv = self.venv(result.kind)
        targets = ["-e", src] if editable else [src]
        timed = self.pip_install(result.kind, venv, *targets, verbose=True)
        result.install_s = timed.wall_s
        result.notes += [f"the build said: {line}" for line in build_messages(timed.output)]
        self.predicts(result, venv, watched=[venv, src] if editable else [venv])

    def run_readonly(self, result: Result) -> None:
        prefix = user_prefix()
        python, version = self.readonly_python(prefix)
        result.notes.append(f"venv made with {python} ({version}), which {READONLY_USER} can run")
        wheel = self.wheel(precompile=True)
        result.notes.append(f"the wheel of the wheel kind; commands run as: {shlex.join(prefix)}")
        venv = self.venv("readonly", python)
        result.install_s = self.pip_install("readonly", venv, wheel.path).wall_s
        for path in (self.work, venv.parent, venv):  # folders this run made
            path.chmod(path.stat().st_mode | 0o005)
        site = next((venv / "lib").glob("python3*/site-packages"))
        writable = run_timed([*prefix, "/bin/sh", "-c", 'test -w "$1"', "sh", str(site)])
        if writable.returncode == 0:
            raise StepFailed(f"{READONLY_USER} can write {site}: not a read-only install")
        result.notes.append(f"{READONLY_USER} cannot write the venv's site-packages (checked)")
        self.predicts(result, venv, prefix=prefix, owner=READONLY_USER, watched=[venv])

    def readonly_python(self, prefix: list[str]) -> tuple[str, str]:
        """A Python 3.11 whose interpreter and standard library user nobody can read (a
        Python under /root, as pyenv's, is not): its path and version."""
        tried = []
        for candidate in dict.fromkeys([self.args.python, *READONLY_PYTHONS]):
            exe = shutil.which(candidate)
            if exe is None:
                continue
            code = "import os, sys; print(os.path.realpath(sys.executable), sys.base_prefix)"
            probe = subprocess.run([exe, "-c", code], capture_output=True, text=True, check=False)
            if probe.returncode != 0:
                continue
            real, base = probe.stdout.split()
            version = subprocess.run(
                [real, "-c", "import sys; print(sys.version.split()[0])"],
                capture_output=True,
                text=True,
                check=False,
            ).stdout.strip()
            minor = ".".join(version.split(".")[:2])
            stdlib = f"{base}/lib/python{minor}/os.py"
            test = [*prefix, "/bin/sh", "-c", 'test -x "$1" && test -r "$2"', "sh", real, stdlib]
            if run_timed(test).returncode == 0:
                return real, version
            tried.append(real)
        raise StepFailed(f"no Python 3.11 that {READONLY_USER} can run (tried {tried})")

    def run_node(self, result: Result) -> None:
        wheel = self.wheel(precompile=True)
        result.notes.append("the wheel of the wheel kind, with its [ros] extra")
        venv = self.venv("node")
        result.install_s = self.pip_install("node", venv, f"{wheel.path}[ros]").wall_s
        site = next((venv / "lib").glob("python3*/site-packages"))
        before = numba_files([site])
        try:
            self.node_answers(result, venv)
            self.node_answers(result, venv, restart=True)
        finally:
            written = numba_files([site]) - before
            if written:
                result.notes.append(
                    f"the node wrote {len(written)} numba cache files into the venv (removed "
                    "before the predicts, which start from a fresh install's state)"
                )
            for path in written:
                path.unlink()
        self.predicts(result, venv, watched=[venv])

    def run(self) -> list[Result]:
        self.header.append(
            f"Machine: {platform.system()} {platform.machine()}, {os.cpu_count()} CPUs; "
            f"{datetime.now(UTC):%Y-%m-%d %H:%M} UTC; venvs made with {self.args.python}."
        )
        self.prepare_source()
        load_start = os.getloadavg()[0]
        kinds: list[str] = list(self.args.kinds) + ([COLD_KIND] if self.args.also_cold else [])
        runners = {
            "wheel": self.run_wheel,
            "pip": functools.partial(self.run_source, editable=False),
            "editable": functools.partial(self.run_source, editable=True),
            "readonly": self.run_readonly,
            "node": self.run_node,
            COLD_KIND: functools.partial(self.run_wheel, precompile=False),
        }
        results = []
        for kind in kinds:
            result = Result(kind)
            results.append(result)
            self.say(f"== {kind}")
            try:
                runners[kind](result)
            except (StepFailed, OSError, subprocess.SubprocessError, ValueError) as error:
                result.error = str(error)
                self.say(f"{kind}: FAILED: {error}")
        self.header.append(
            f"Load average (1 min, the machine is shared): {load_start:.1f} at the start, "
            f"{os.getloadavg()[0]:.1f} at the end."
        )
        return results

    def stop_all(self) -> None:
        """Stop every process this run started that still runs (SIGINT, then SIGKILL)."""
        for proc in self.processes:
            stop_process(proc, f"PID {proc.pid}", [])


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.node_client is not None:
        print(json.dumps(node_client(json.loads(args.node_client))), flush=True)
        return 0
    started = time.perf_counter()
    command = shlex.join(
        ["scripts/bench/bench_cold_start.py", *(sys.argv[1:] if argv is None else argv)]
    )
    work = Path(tempfile.mkdtemp(prefix="xface-cold-start-"))
    bench = ColdStart(args, work)
    results: list[Result] = []
    try:
        results = bench.run()
    finally:
        bench.stop_all()
        if args.keep:
            print(f"kept: {work}", file=sys.stderr)
        else:
            shutil.rmtree(work, ignore_errors=True)
    total_s = time.perf_counter() - started
    header = [f"Command: `{command}`", "", *(f"{line}  " for line in bench.header)]
    report = format_report(results, header=header, total_s=total_s)
    print(report)
    if args.out is not None:
        args.out.write_text(report)
    with contextlib.suppress(BrokenPipeError):
        for why in failures(results):
            print(f"FAIL: {why.splitlines()[0]}", file=sys.stderr)
    return 1 if failures(results) else 0


if __name__ == "__main__":
    raise SystemExit(main())
