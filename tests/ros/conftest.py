"""Fixtures for the node tests: the node as a separate process, and a test-side ROS client.

Every node runs as ``python -m xface_ros --ros-args --params-file <file>`` in its own ROS
domain (100..199, from the suite's allocator in tests/conftest.py) with discovery on this
host only; the client joins the same domain in-process with its own rclpy context.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from diagnostic_msgs.srv import SelfTest
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path as PathMsg
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import Parameter as ParameterMsg
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Bool
from visualization_msgs.msg import MarkerArray

from xface_core.frames import yaw_to_quaternion
from xface_ros.diagnostics import is_warming_up

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_PARAMS_FILE = ROOT / "config" / "xface.yaml"
NODE_NAME = "xface_predictor"
#: The node's fully qualified name when started without remapping (status names carry it).
NODE_FQN = f"/{NODE_NAME}"
BASE_FRAME = "xface_base"

#: Generous: a cold start loads rclpy and Fast DDS, and where the simulator is not precompiled
#: or cached the node compiles it (numba, minutes of CPU) before it is warmed up, on a shared
#: machine.
STARTUP_TIMEOUT_S = 300.0
REPLY_TIMEOUT_S = 60.0
#: A query to the node (plan, status) without a reply after this long is sent again.
QUERY_RESEND_S = 5.0

M = TypeVar("M")

# Loading message type support imports rosidl_generator_py, which imports lark, which imports
# the stdlib's deprecated sre_parse and sre_constants, and the suite turns DeprecationWarning
# into errors. Import it once here with just that warning silenced (not ours to fix; later
# imports hit the module cache).
with warnings.catch_warnings():
    warnings.filterwarnings(
        "ignore",
        message=r"module .sre_(parse|constants). is deprecated",
        category=DeprecationWarning,
    )
    import rosidl_generator_py  # noqa: F401


def write_params(path: Path, *, key: str = "/**", **overrides: Any) -> Path:
    """A params file: config/xface.yaml with ``overrides`` applied, under the node key ``key``."""
    data = yaml.safe_load(DEFAULT_PARAMS_FILE.read_text(encoding="utf-8"))
    data["/**"]["ros__parameters"].update(overrides)
    data = {key: data["/**"]}
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def ros_env(domain_id: int) -> dict[str, str]:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["ROS_STATIC_PEERS"] = ""
    env["PYTHONUNBUFFERED"] = "1"
    return env


@dataclass
class NodeProcess:
    """The node under test, started as a separate process."""

    process: subprocess.Popen[str]
    log_path: Path

    @property
    def pid(self) -> int:
        return self.process.pid

    def log(self) -> str:
        return self.log_path.read_text(encoding="utf-8", errors="replace")

    def stop(self, sig: int = signal.SIGINT, timeout_s: float = 60.0) -> int:
        """Send ``sig`` and return the exit code (kills and fails after ``timeout_s``)."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
        try:
            return self.process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
            pytest.fail(f"node did not exit {timeout_s:g} s after signal {sig}:\n{self.log()}")

    def wait_exit(self, timeout_s: float) -> int:
        return self.process.wait(timeout=timeout_s)

    def rss_kib(self) -> int:
        """Resident set size of the node process (KiB), from /proc."""
        return rss_kib(self.pid)


def start_node_process(
    domain_id: int,
    params_file: Path,
    log_path: Path,
    extra_args: list[str] | None = None,
    node_args: list[str] | None = None,
) -> NodeProcess:
    """``extra_args`` go after ``--ros-args``; ``node_args`` (the node's own options, such as
    ``--lifecycle``) before it."""
    command = [
        sys.executable, "-m", "xface_ros", *(node_args or []), "--ros-args",
        "--params-file", str(params_file), *(extra_args or []),
    ]  # fmt: skip
    log = log_path.open("w", encoding="utf-8")
    process = subprocess.Popen(
        command, cwd=log_path.parent, env=ros_env(domain_id), stdout=log,
        stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    log.close()
    return NodeProcess(process, log_path)


@dataclass
class Inbox(Generic[M]):
    """Messages received on one topic, in arrival order, with a condition to wait on."""

    messages: list[M] = field(default_factory=list)
    cond: threading.Condition = field(default_factory=threading.Condition)

    def add(self, msg: M) -> None:
        with self.cond:
            self.messages.append(msg)
            self.cond.notify_all()

    def wait_for(self, predicate: Callable[[M], bool], timeout_s: float = REPLY_TIMEOUT_S) -> M:
        """The first message (already received or arriving) that satisfies ``predicate``."""
        deadline = time.monotonic() + timeout_s
        with self.cond:
            checked = 0
            while True:
                for msg in self.messages[checked:]:
                    if predicate(msg):
                        return msg
                checked = len(self.messages)
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise TimeoutError(f"no matching message within {timeout_s:g} s")
                self.cond.wait(timeout=remaining)

    def count(self) -> int:
        with self.cond:
            return len(self.messages)

    def snapshot(self) -> list[M]:
        with self.cond:
            return list(self.messages)


def status_values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def stamp_ns(msg_stamp: Any) -> int:
    return int(msg_stamp.sec) * 1_000_000_000 + int(msg_stamp.nanosec)


class RosClient:
    """A test-side node: publishes poses, subscribes to every output, calls the service."""

    values = staticmethod(status_values)
    stamp_ns = staticmethod(stamp_ns)

    def __init__(self, domain_id: int, *, node_fqn: str = NODE_FQN) -> None:
        """``node_fqn``: the node under test; the client joins its namespace, so the node's
        relative topics and service resolve to the same names on both sides."""
        self.node_fqn = node_fqn
        self.context = Context()
        rclpy.init(
            context=self.context, domain_id=domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )  # fmt: skip
        namespace = node_fqn.rsplit("/", 1)[0] or "/"
        self.node = Node("xface_test_client", namespace=namespace, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        latched = QoSProfile(
            depth=1,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        self.pose_pub = self.node.create_publisher(PoseStamped, "relative_pose", 10)
        self.accepted: Inbox[Bool] = self._inbox(Bool, "prediction/accepted", 100)
        self.status: Inbox[DiagnosticStatus] = self._inbox(
            DiagnosticStatus, "prediction/status", 100
        )
        self.path: Inbox[PathMsg] = self._inbox(PathMsg, "prediction/path", 10)
        self.seated: Inbox[PoseStamped] = self._inbox(
            PoseStamped, "prediction/seated_pose", latched
        )
        self.markers: Inbox[MarkerArray] | None = None
        self.diagnostics: Inbox[DiagnosticArray] = self._inbox(DiagnosticArray, "/diagnostics", 10)
        self.plan_client = self.node.create_client(GetPlan, "predict")
        self.status_client = self.node.create_client(SelfTest, "predict_status")
        self.param_client = AsyncParameterClient(self.node, node_fqn)
        self._stamp_ns = 0
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        # close() shuts the context down under the executor.
        with contextlib.suppress(ExternalShutdownException):
            self.executor.spin()

    def _inbox(self, msg_type: Any, topic: str, qos: Any) -> Inbox[Any]:
        inbox: Inbox[Any] = Inbox()
        self.node.create_subscription(msg_type, topic, inbox.add, qos)
        return inbox

    def subscribe_markers(self) -> Inbox[MarkerArray]:
        self.markers = self._inbox(MarkerArray, "prediction/markers", 10)
        return self.markers

    def wait_for_node(self, node: NodeProcess, timeout_s: float = STARTUP_TIMEOUT_S) -> None:
        """Wait until the node's service is up, it subscribes to our pose topic and its
        diagnostics say the warm-up is over (its interfaces come up before the warm-up)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if node.process.poll() is not None:
                pytest.fail(f"node exited with {node.process.returncode}:\n{node.log()}")
            if (
                self.plan_client.service_is_ready()
                and self.pose_pub.get_subscription_count() > 0
                and self.node_warmed_up()
            ):
                return
            time.sleep(0.1)
        pytest.fail(f"node not ready within {timeout_s:g} s:\n{node.log()}")

    def node_warmed_up(self) -> bool:
        """A predictor status on /diagnostics that no longer says "warming up"."""
        return any(
            status.name == f"{self.node_fqn}: predictor" and not is_warming_up(status.message)
            for array in self.diagnostics.snapshot()
            for status in array.status
        )

    def next_stamp_ns(self) -> int:
        """A fresh stamp (node clock = wall clock on this host), strictly increasing."""
        self._stamp_ns = max(self._stamp_ns + 1, time.time_ns())
        return self._stamp_ns

    def pose_msg(
        self,
        x: float,
        y: float,
        yaw: float,
        *,
        frame_id: str = BASE_FRAME,
        stamp_ns: int | None = None,
        quaternion: tuple[float, float, float, float] | None = None,
    ) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = frame_id
        ns = self.next_stamp_ns() if stamp_ns is None else stamp_ns
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)
        msg.pose.position.x, msg.pose.position.y = x, y
        qx, qy, qz, qw = yaw_to_quaternion(yaw) if quaternion is None else quaternion
        o = msg.pose.orientation
        o.x, o.y, o.z, o.w = qx, qy, qz, qw
        return msg

    def publish_until_status(
        self,
        make_msg: Callable[[], PoseStamped],
        *,
        also: Callable[[int], bool] = lambda stamp: True,
        timeout_s: float = REPLY_TIMEOUT_S,
    ) -> tuple[PoseStamped, DiagnosticStatus]:
        """Publish fresh copies of a pose until a status for one of them arrives.

        Poses go out on a best-effort topic and the node may not have matched every output
        subscription yet, so one publish is not enough. ``also(stamp_ns)`` may wait for more
        outputs of the same stamp (path, seated pose) before the status counts.
        """
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            msg = make_msg()
            sent_ns = stamp_ns(msg.header.stamp)
            self.pose_pub.publish(msg)

            def for_this_pose(status: DiagnosticStatus, ns: int = sent_ns) -> bool:
                return status_values(status).get("input_stamp_ns") == str(ns)

            try:
                status = self.status.wait_for(for_this_pose, 2.0)
            except TimeoutError:
                continue
            if also(sent_ns):
                return msg, status
        raise TimeoutError(f"no status for the pose within {timeout_s:g} s")

    def wait_path(self, sent_ns: int, timeout_s: float = 2.0) -> PathMsg | None:
        try:
            return self.path.wait_for(lambda p: stamp_ns(p.header.stamp) == sent_ns, timeout_s)
        except TimeoutError:
            return None

    def call_plan(
        self, start: PoseStamped, tolerance: float = 0.0, timeout_s: float = REPLY_TIMEOUT_S
    ) -> PathMsg:
        request = GetPlan.Request(start=start, tolerance=tolerance)
        return self.call(self.plan_client, request, timeout_s, resend_s=QUERY_RESEND_S).plan

    def call_status(self, timeout_s: float = REPLY_TIMEOUT_S) -> Any:
        """``predict_status`` (SelfTest): the latest pose's answer in one call."""
        return self.call(self.status_client, SelfTest.Request(), timeout_s, resend_s=QUERY_RESEND_S)

    def call(
        self,
        client: Any,
        request: Any,
        timeout_s: float = REPLY_TIMEOUT_S,
        *,
        resend_s: float | None = None,
    ) -> Any:
        """Wait for ``client``'s service, call it and return the first response.

        With ``resend_s``, the request is sent again each time that long passes without a
        reply (every request sent stays pending: whichever answers first counts). A reply
        can be lost to ROS 2's service discovery race (the server's response writer not yet
        matched to our reader when it answers; see test_node_managed's fixture), so only
        a question that changes nothing (a plan, the latest status) is sent again."""
        assert client.wait_for_service(timeout_sec=timeout_s)
        pending = [client.call_async(request)]
        resend_at = [math.inf if resend_s is None else time.monotonic() + resend_s]

        def resend() -> None:
            now = time.monotonic()
            if resend_s is not None and now > resend_at[0]:
                pending.append(client.call_async(request))
                resend_at[0] = now + resend_s

        done = _first_done(pending, timeout_s, resend)
        for other in pending:
            if other is not done:
                client.remove_pending_request(other)
        return done.result()

    def set_parameters(self, **values: Any) -> list[Any]:
        """SetParameters on the node; the list of SetParametersResult (one per parameter)."""
        assert self.param_client.wait_for_services(timeout_sec=REPLY_TIMEOUT_S)
        params = [Parameter(name, value=value) for name, value in values.items()]
        future = self.param_client.set_parameters(params)
        return list(_result(future, REPLY_TIMEOUT_S).results)

    def get_parameter(self, name: str) -> Any:
        future = self.param_client.get_parameters([name])
        value = _result(future, REPLY_TIMEOUT_S).values[0]
        return Parameter.from_parameter_msg(ParameterMsg(name=name, value=value)).value

    def close(self) -> None:
        # Stop the spinning thread before the node and context it uses are destroyed.
        self.executor.shutdown(timeout_sec=5.0)
        self._thread.join(timeout=5.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def _first_done(
    futures: list[Any], timeout_s: float, tick: Callable[[], None] = lambda: None
) -> Any:
    """The first of ``futures`` (a list ``tick`` may add to while waiting) that is done,
    polled every 10 ms; TimeoutError after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while True:
        for future in futures:
            if future.done():
                return future
        if time.monotonic() > deadline:
            raise TimeoutError(f"no reply within {timeout_s:g} s")
        tick()
        time.sleep(0.01)


def _result(future: Any, timeout_s: float) -> Any:
    return _first_done([future], timeout_s).result()


def rss_kib(pid: int) -> int:
    """Resident set size of a process (KiB), from /proc."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError(f"no VmRSS for pid {pid}")


# --- fixtures ---------------------------------------------------------------------------------


@dataclass
class Running:
    """A started node and a connected client in the same domain."""

    node: NodeProcess
    client: RosClient
    domain_id: int
    params_file: Path

    def env(self) -> dict[str, str]:
        """The environment of a process that talks to this node (same domain, loopback)."""
        return ros_env(self.domain_id)


@pytest.fixture
def launch(ros_domain_id: int, tmp_path: Path) -> Iterator[Callable[..., Running]]:
    """Start the node with parameter overrides (in a params file) and connect a client.

    Everything started is stopped at teardown; a node that is still running then must exit
    with code 0 on SIGINT.
    """
    nodes: list[NodeProcess] = []
    clients: list[RosClient] = []

    def _launch(
        *,
        wait: bool = True,
        extra_args: list[str] | None = None,
        node_args: list[str] | None = None,
        node_fqn: str = NODE_FQN,
        params_key: str = "/**",
        **overrides: Any,
    ) -> Running:
        n = len(nodes)
        params = write_params(tmp_path / f"params{n}.yaml", key=params_key, **overrides)
        node = start_node_process(
            ros_domain_id, params, tmp_path / f"node{n}.log", extra_args, node_args
        )
        nodes.append(node)  # before anything else can fail: teardown always stops it
        client = RosClient(ros_domain_id, node_fqn=node_fqn)
        clients.append(client)
        if wait:
            client.wait_for_node(node)
        return Running(node, client, ros_domain_id, params)

    yield _launch
    for client in clients:
        client.close()
    codes = [node.stop(signal.SIGINT) if node.process.poll() is None else None for node in nodes]
    for node, code in zip(nodes, codes, strict=True):
        assert code in (None, 0), node.log()


@pytest.fixture
def ros_client(ros_domain_id: int) -> Iterator[RosClient]:
    """A test-side client in this test's domain, for a node the test runs itself."""
    client = RosClient(ros_domain_id)
    try:
        yield client
    finally:
        client.close()


@pytest.fixture(scope="module")
def shared_node(
    ros_domain_allocator: Any, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Running]:
    """One node on the default config (plus a path subscriber) for read-only tests."""
    domain_id = ros_domain_allocator.allocate()
    tmp = tmp_path_factory.mktemp("shared_node")
    params = write_params(tmp / "params.yaml")
    node = start_node_process(domain_id, params, tmp / "node.log")
    client: RosClient | None = None
    try:
        client = RosClient(domain_id)
        client.wait_for_node(node)
        yield Running(node, client, domain_id, params)
    finally:
        if client is not None:
            client.close()
        code = node.stop(signal.SIGINT)
        ros_domain_allocator.release(domain_id)
        assert code == 0, node.log()
