"""The ``xface_predictor`` node: relative poses in, docking predictions out.

Threads: the executor (one thread) runs the subscription, the ``predict`` service, the
parameter services and the diagnostics timer (in separate callback groups, so the node also
works under a multi-threaded executor); one worker thread simulates the streamed poses. The
subscription only stores the newest pose in a :class:`~xface_ros.latest.LatestSlot` (an
overwritten, unprocessed pose is counted as dropped), so a pose stream faster than the
simulator never queues up.

The interface (topics, QoS, service, parameters) is documented in docs/ros.md.
"""

from __future__ import annotations

import math
import statistics
import sys
import threading
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.event_handler import QoSMessageLostInfo, SubscriptionEventCallbacks
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Bool, Header
from visualization_msgs.msg import MarkerArray

from xface_core.errors import XfaceError
from xface_core.frames import DockStart
from xface_core.outcome import Outcome
from xface_core.predict import predict
from xface_core.result import Prediction
from xface_ros.conversions import (
    InputRejected,
    decide,
    input_error_status,
    markers_msg,
    path_msg,
    prediction_status,
    seated_pose_msg,
    stamp_to_ns,
    start_from_pose,
)
from xface_ros.latest import LatestSlot, Received
from xface_ros.params import (
    DESIGN_PARAMETERS,
    ConfigError,
    NodeConfig,
    config_from_values,
    current_values,
    declare_parameters,
    default_record_path,
    merged_values,
)

__all__ = ["NODE_NAME", "XfacePredictor", "main"]

NODE_NAME = "xface_predictor"

#: Results: reliable, a short queue (subscribers that fall behind lose old results, not new).
RESULT_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
#: Latest-state topics: a late subscriber still gets the last value.
LATCHED_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
#: Bulky per-prediction topics: only the newest matters.
BULK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: Seconds between repeats of the same throttled log line.
LOG_THROTTLE_S = 5.0


@dataclass
class _Window:
    """Counters and samples since the last diagnostics message."""

    received: int = 0
    predicted: int = 0
    latency_ms: list[float] = field(default_factory=list)
    compute_ms: list[float] = field(default_factory=list)


class _Stats:
    """Thread-safe counters for /diagnostics."""

    #: Bound on the samples kept per diagnostics window (memory stays flat at any rate).
    MAX_SAMPLES = 5000

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.window = _Window()
        self.window_start_ns = 0
        self.predicted_total = 0
        self.input_errors_total = 0
        self.dds_lost_total = 0
        self.service_calls_total = 0
        self.recording_errors_total = 0
        self.last_outcome = "none"
        self.last_accepted: bool | None = None
        self.last_error = ""
        self.last_stamp_ns: int | None = None
        self.last_latency_ms = math.nan
        self.latencies: deque[float] = deque(maxlen=self.MAX_SAMPLES)

    def received(self, stamp_ns: int) -> None:
        with self.lock:
            self.window.received += 1
            self.last_stamp_ns = stamp_ns

    def predicted(self, outcome: str, accepted: bool, latency_ms: float, compute_ms: float) -> None:
        with self.lock:
            self.predicted_total += 1
            self.window.predicted += 1
            self.last_outcome = outcome
            self.last_accepted = accepted
            self.last_error = ""
            self.last_latency_ms = latency_ms
            if len(self.window.latency_ms) < self.MAX_SAMPLES:
                self.window.latency_ms.append(latency_ms)
                self.window.compute_ms.append(compute_ms)

    def input_error(self, code: str) -> None:
        with self.lock:
            self.input_errors_total += 1
            self.last_outcome = Outcome.INVALID_INPUT.name
            self.last_accepted = None
            self.last_error = code

    def take_window(self, now_ns: int) -> tuple[_Window, float]:
        """The window since the last call and its length (s)."""
        with self.lock:
            window, self.window = self.window, _Window()
            start, self.window_start_ns = self.window_start_ns, now_ns
        return window, max((now_ns - start) * 1e-9, 1e-9)


class XfacePredictor(Node):
    """Predicts docking acceptance for a stream of relative poses and for planner queries."""

    def __init__(self, **node_kwargs: Any) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        # Raises (and so refuses to start) on out-of-range or inconsistent overrides.
        self._config: NodeConfig = declare_parameters(self)
        self._config_lock = threading.Lock()
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self._slot: LatestSlot[PoseStamped] = LatestSlot()
        self._stats = _Stats()
        self._stats.window_start_ns = self._now_ns()
        self._recording: Any = None
        self._recording_path = ""
        self._open_recording(self._config)

        # Before the node offers anything: the first simulation loads (on a fresh checkout,
        # compiles) the simulator, which can take tens of seconds; a node whose service is up
        # answers promptly.
        self._warm_up()

        input_group = MutuallyExclusiveCallbackGroup()
        service_group = MutuallyExclusiveCallbackGroup()
        timer_group = MutuallyExclusiveCallbackGroup()
        self._accepted_pub = self.create_publisher(Bool, "prediction/accepted", RESULT_QOS)
        self._status_pub = self.create_publisher(DiagnosticStatus, "prediction/status", RESULT_QOS)
        self._path_pub = self.create_publisher(Path, "prediction/path", BULK_QOS)
        self._seated_pub = self.create_publisher(PoseStamped, "prediction/seated_pose", LATCHED_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "prediction/markers", BULK_QOS)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", RESULT_QOS)
        self._pose_sub = self.create_subscription(
            PoseStamped,
            "relative_pose",
            self._on_pose,
            qos_profile_sensor_data,
            callback_group=input_group,
            event_callbacks=SubscriptionEventCallbacks(message_lost=self._on_message_lost),
        )
        self._service = self.create_service(
            GetPlan, "predict", self._on_predict_request, callback_group=service_group
        )
        self._diagnostics_timer = self.create_timer(
            self._config.diagnostics_period_s, self._publish_diagnostics, callback_group=timer_group
        )

        self._stop = threading.Event()
        self._worker = threading.Thread(target=self._work, name="xface_predictor", daemon=True)
        self._worker.start()
        self.get_logger().info(
            f"predicting for the {self._describe(self._config)}; poses on "
            f"{self._pose_sub.topic_name} in frame {self._config.base_frame!r}"
        )

    # --- parameters -------------------------------------------------------------------------

    @property
    def config(self) -> NodeConfig:
        """The current validated configuration."""
        with self._config_lock:
            return self._config

    @staticmethod
    def _describe(config: NodeConfig) -> str:
        return (
            f"{config.face}-Face D={config.width_m:g} m H/D={config.h_over_d:g} "
            f"r_p={config.r_p:g} c_B/c_M={config.damping_ratio:g} friction={config.friction:g}"
        )

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        try:
            config_from_values(merged_values(self.config.values(), params))
        except ConfigError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params: list[Parameter]) -> None:
        try:
            config = config_from_values(current_values(self), check_physics=False)
        except ConfigError as exc:  # validated already; keep the old config if it happens
            self.get_logger().error(f"parameter change not applied: {exc}")
            return
        with self._config_lock:
            self._config = config
        names = {p.name for p in params}
        if names & DESIGN_PARAMETERS:
            self.get_logger().info(f"next prediction uses the {self._describe(config)}")

    # --- input ------------------------------------------------------------------------------

    def _now_ns(self) -> int:
        return int(self.get_clock().now().nanoseconds)

    def _on_pose(self, msg: PoseStamped) -> None:
        self._slot.put(msg, receive_ns=self._now_ns())
        self._stats.received(stamp_to_ns(msg.header.stamp))

    def _on_message_lost(self, info: QoSMessageLostInfo) -> None:
        with self._stats.lock:
            self._stats.dds_lost_total = int(info.total_count)

    # --- the worker -------------------------------------------------------------------------

    def _work(self) -> None:
        while not self._stop.is_set():
            item = self._slot.take(timeout_s=0.2)
            if item is None:
                continue
            try:
                self._process(item)
            except Exception as exc:  # a bug in one prediction must not end the stream
                if not self.context.ok():
                    return  # shutdown under way: the publishers are gone, nothing to report
                self._report_internal_error(item.message, exc)

    def _report_internal_error(self, msg: PoseStamped, exc: Exception) -> None:
        try:
            self._reject(msg, InputRejected("internal_error", repr(exc)))
        except Exception:
            if self.context.ok():  # not a shutdown race: a real failure, keep its traceback
                raise

    def _warm_up(self) -> None:
        """One prediction so the first real pose does not pay for loading compiled code."""
        config = self._config
        t0 = time.perf_counter()
        try:
            # margins=True also loads the batch kernel the margin search and min_margin use.
            predict(config.design, 0.0, 0.0, path=True, margins=True)
        except Exception as exc:  # reported again, per pose, by the worker loop
            self.get_logger().warning(f"warm-up prediction failed: {exc!r}")
            return
        elapsed = time.perf_counter() - t0
        if elapsed > 1.0:
            self.get_logger().info(f"simulator loaded in {elapsed:.1f} s")

    def _process(self, item: Received[PoseStamped]) -> None:
        msg = item.message
        config = self.config
        try:
            # Judge the stamp on arrival: waiting for the worker is our delay, not the input's.
            start = start_from_pose(msg, config, now_ns=item.receive_ns)
            need_path = (
                self._path_pub.get_subscription_count() > 0
                or self._markers_pub.get_subscription_count() > 0
                or self._recording is not None
            )
            t0 = time.perf_counter()
            try:
                prediction = _predict_start(
                    config, start, path=need_path, margins=config.need_margins
                )
            except XfaceError as exc:
                raise InputRejected("invalid_input", str(exc)) from exc
            compute_s = time.perf_counter() - t0
            if prediction.outcome is Outcome.INVALID_INPUT:
                raise InputRejected("invalid_input", prediction.reason)
        except InputRejected as exc:
            self._reject(msg, exc)
            return
        self._publish(msg, prediction, config, compute_s)

    def _reject(self, msg: PoseStamped, error: InputRejected) -> None:
        self._stats.input_error(error.code)
        self._status_pub.publish(
            input_error_status(error, stamp=msg.header.stamp, hardware_id=self.config.base_frame)
        )
        self.get_logger().error(
            f"pose rejected: {error.code}: {error.detail}", throttle_duration_sec=LOG_THROTTLE_S
        )

    def _publish(
        self, msg: PoseStamped, prediction: Prediction, config: NodeConfig, compute_s: float
    ) -> None:
        decision = decide(prediction, required_margin_m=config.min_margin)
        header = Header(stamp=msg.header.stamp, frame_id=config.base_frame)
        self._accepted_pub.publish(Bool(data=decision.accepted))
        self._status_pub.publish(
            prediction_status(
                prediction,
                decision,
                stamp=msg.header.stamp,
                compute_s=compute_s,
                hardware_id=config.base_frame,
            )
        )
        latency_ms = (self._now_ns() - stamp_to_ns(msg.header.stamp)) * 1e-6
        if prediction.seated:
            self._seated_pub.publish(seated_pose_msg(prediction, header))
        if prediction.path is not None and self._path_pub.get_subscription_count() > 0:
            self._path_pub.publish(path_msg(prediction, header, max_poses=config.max_path_poses))
        if self._markers_pub.get_subscription_count() > 0:
            self._markers_pub.publish(markers_msg(prediction, header))
        self._stats.predicted(
            prediction.outcome.name, decision.accepted, latency_ms, compute_s * 1e3
        )
        self._record(prediction, stamp_to_ns(msg.header.stamp))

    # --- recording ---------------------------------------------------------------------------

    def _open_recording(self, config: NodeConfig) -> None:
        if not config.record:
            return
        try:
            from xface_core import recording
        except ImportError as exc:
            self.get_logger().error(f"record is true but xface_core.recording is missing: {exc}")
            return
        path = config.record_path or default_record_path()
        self._recording = recording.new_recording(
            application_id="xface", path=path, url=config.record_url or None
        )
        self._recording_path = path
        self.get_logger().info(
            f"recording predictions to {path}"
            + (f" and {config.record_url}" if config.record_url else "")
        )

    def _record(self, prediction: Prediction, stamp_ns: int) -> None:
        if self._recording is None:
            return
        from xface_core import recording

        try:
            recording.log_prediction(self._recording, prediction, ros_stamp_ns=stamp_ns)
        except Exception as exc:  # a recording problem must never stop the predictions
            with self._stats.lock:
                self._stats.recording_errors_total += 1
            self.get_logger().error(
                f"recording failed: {exc!r}", throttle_duration_sec=LOG_THROTTLE_S
            )

    # --- planner service ---------------------------------------------------------------------

    def _on_predict_request(
        self, request: GetPlan.Request, response: GetPlan.Response
    ) -> GetPlan.Response:
        """GetPlan: ``plan`` is the alignment path when the start is accepted, else empty.

        An empty ``start.header.frame_id`` means the latest streamed pose (subject to
        ``input_timeout_s``); an explicit start is not checked for staleness (planners ask
        about hypothetical poses). ``tolerance`` > 0 is the required combined margin (m);
        0 uses ``min_margin``. ``goal`` is ignored: the goal is the seat.
        """
        config = self.config
        with self._stats.lock:
            self._stats.service_calls_total += 1
        start_msg: PoseStamped = request.start
        now_ns: int | None = None
        if not start_msg.header.frame_id:
            latest = self._slot.latest
            if latest is None:
                return self._reject_query(response, config, "no_pose", "no pose received yet")
            start_msg = latest.message
            now_ns = self._now_ns()
        tolerance = float(request.tolerance)
        required = (
            tolerance if (math.isfinite(tolerance) and tolerance > 0.0) else config.min_margin
        )
        try:
            start = start_from_pose(start_msg, config, now_ns=now_ns)
            prediction = _predict_start(
                config, start, path=True, margins=config.need_margins or required > 0.0
            )
        except InputRejected as exc:
            return self._reject_query(response, config, exc.code, exc.detail)
        except XfaceError as exc:
            return self._reject_query(response, config, "invalid_input", str(exc))
        except Exception as exc:  # a bug in the simulator must not take the node down
            return self._reject_query(response, config, "internal_error", repr(exc))
        header = Header(stamp=start_msg.header.stamp, frame_id=config.base_frame)
        decision = decide(prediction, required_margin_m=required)
        response.plan = (
            path_msg(prediction, header, max_poses=config.max_path_poses)
            if decision.accepted
            else Path(header=header)
        )
        self.get_logger().info(
            f"predict: x0={start.x0:.4g} m theta0={start.theta0:.4g} rad -> "
            f"{prediction.outcome.name}, {'accepted' if decision.accepted else 'rejected'} "
            f"({decision.why})",
            throttle_duration_sec=1.0,
        )
        return response

    def _reject_query(
        self, response: GetPlan.Response, config: NodeConfig, code: str, detail: str
    ) -> GetPlan.Response:
        response.plan = Path(header=Header(frame_id=config.base_frame))
        self.get_logger().warning(
            f"predict: empty plan, {code}: {detail}", throttle_duration_sec=LOG_THROTTLE_S
        )
        return response

    # --- diagnostics -------------------------------------------------------------------------

    def _publish_diagnostics(self) -> None:
        now_ns = self._now_ns()
        window, span_s = self._stats.take_window(now_ns)
        config = self.config
        stats = self._stats
        with stats.lock:
            last_stamp_ns = stats.last_stamp_ns
            snapshot = {
                "received_total": self._slot.received,
                "predicted_total": stats.predicted_total,
                "dropped_total": self._slot.dropped,
                "dds_lost_total": stats.dds_lost_total,
                "input_errors_total": stats.input_errors_total,
                "service_calls_total": stats.service_calls_total,
                "recording_errors_total": stats.recording_errors_total,
                "last_outcome": stats.last_outcome,
                "last_accepted": stats.last_accepted,
                "last_input_error": stats.last_error,
                "last_latency_ms": stats.last_latency_ms,
            }
        pose_age_s = math.nan if last_stamp_ns is None else (now_ns - last_stamp_ns) * 1e-9
        values = {
            "input_rate_hz": window.received / span_s,
            "prediction_rate_hz": window.predicted / span_s,
            "pose_age_s": pose_age_s,
            **snapshot,
            "latency_ms_median": _median(window.latency_ms),
            "latency_ms_max": max(window.latency_ms, default=math.nan),
            "compute_ms_median": _median(window.compute_ms),
            "face": config.face,
            "width_m": config.width_m,
            "h_over_d": config.h_over_d,
            "r_p": config.r_p,
            "damping_ratio": config.damping_ratio,
            "recording": self._recording_path,
        }
        if window.received == 0:
            level, message = DiagnosticStatus.WARN, "no poses received in the last period"
        elif snapshot["last_input_error"]:
            level = DiagnosticStatus.ERROR
            message = f"last pose rejected: {snapshot['last_input_error']}"
        else:
            level, message = DiagnosticStatus.OK, f"predicting: last {snapshot['last_outcome']}"
        status = DiagnosticStatus(
            level=level,
            name=f"{self.get_name()}: predictor",
            message=message,
            hardware_id=config.base_frame,
            values=[KeyValue(key=k, value=_text(v)) for k, v in values.items()],
        )
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self._diagnostics_pub.publish(array)

    # --- shutdown ---------------------------------------------------------------------------

    def close(self) -> None:
        """Stop the worker and finish the recording (idempotent)."""
        self._stop.set()
        self._slot.close()
        if self._worker.is_alive():
            self._worker.join(timeout=30.0)
        if self._recording is not None:
            rec, self._recording = self._recording, None
            try:
                rec.flush(timeout_sec=10.0)
                rec.disconnect()
            except Exception as exc:  # report, but never turn a clean shutdown into a crash
                self._say_at_shutdown(f"could not finish the recording: {exc!r}", error=True)
            else:
                self._say_at_shutdown(f"recording finished: {self._recording_path}")

    def _say_at_shutdown(self, text: str, *, error: bool = False) -> None:
        """Log, or print once the context is gone (rosout is closed by then)."""
        if self.context.ok():
            logger = self.get_logger()
            (logger.error if error else logger.info)(text)
        else:
            print(f"[{self.get_name()}] {text}", file=sys.stderr, flush=True)

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


def _predict_start(
    config: NodeConfig, start: DockStart, *, path: bool, margins: bool
) -> Prediction:
    """Predict one start with the node's current design and physics (stream and service)."""
    return predict(
        config.design,
        start.x0,
        start.theta0,
        y_start=start.y_start,
        damping_ratio=config.damping_ratio,
        friction=config.friction,
        path=path,
        margins=margins,
    )


def _median(values: Sequence[float]) -> float:
    return statistics.median(values) if values else math.nan


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT or SIGTERM; 0 on a clean shutdown, 2 on a bad configuration.

    rclpy's own handlers catch both signals (``SignalHandlerOptions.ALL``): they shut the
    context down, ``spin`` returns, and the ``finally`` block finishes the recording.
    """
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.ALL)
    node: XfacePredictor | None = None
    # One executor thread: rclpy's SingleThreadedExecutor takes a 1 kHz pose stream with far
    # fewer losses than its MultiThreadedExecutor (scripts/ros_stress.py, docs/ros.md); the
    # simulation runs in the worker thread, so callbacks stay short.
    executor = SingleThreadedExecutor()
    code = 0
    try:
        node = XfacePredictor()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ConfigError, ParameterException) as exc:  # out of range, wrong type, inconsistent
        print(f"{NODE_NAME}: refusing to start: {exc}", file=sys.stderr, flush=True)
        code = 2
    finally:
        if node is not None:
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown()
    return code
