"""The ``xface_predictor`` node: relative poses in, docking predictions out (the wiring).

The node declares its parameters (:mod:`xface_ros.params`), creates its publishers, the pose
subscriptions, the services (``predict``, ``predict_status``, and where ``xface_msgs`` is
built the typed ``predict_dock`` with its ``prediction/result`` topic) and the diagnostics
timer, and hands work on:

* the two pose subscriptions are read by a :class:`~xface_ros.pose_reader.PoseReader` on a
  thread of their own, not by the executor (whose wait set costs 0.4 ms of Python a message);
  each pose is converted to plain values and submitted to the
  :class:`~xface_ros.worker.PredictionWorker` (its own thread: newest pose wins), which warms
  the simulator up first, decides each pose with :mod:`xface_ros.decision` and calls back
  :meth:`XfacePredictor._publish_verdict`;
* the services decide their queries in the executor thread with the same decision module
  (during the warm-up they wait for the simulator to load, then answer);
* the timer formats the worker's stats with :mod:`xface_ros.diagnostics`.

Neither node kind waits for the warm-up, which takes minutes where the simulator compiles: the
plain node's constructor makes every interface and the worker thread warms up behind them;
with ``--lifecycle``, ``configure`` starts that warm-up and returns, ``activate`` opens the
inputs (docs/ros.md, "Lifecycle mode"); ``/diagnostics`` says "warming up" with its progress
until it is over. ``main()`` checks the parameter files, then owns init, spin and shutdown.
The interface (topics, QoS, service, parameters) is documented in docs/ros.md.
"""

from __future__ import annotations

import argparse
import re
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from diagnostic_msgs.srv import SelfTest
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import Path
from nav_msgs.srv import GetPlan
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.event_handler import (
    PublisherEventCallbacks,
    QoSMessageLostInfo,
    SubscriptionEventCallbacks,
)
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNodeMixin, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_dict_from_yaml_file
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
from std_msgs.msg import Bool, Header
from visualization_msgs.msg import MarkerArray

if TYPE_CHECKING:
    from xface_core.geometry import FaceDesign

from xface_ros import names
from xface_ros.atlas_keeper import AtlasKeeper
from xface_ros.config import (
    CUSTOM_FACE,
    not_a_regular_file,
    params_file_applied,
    params_file_paths,
    unknown_parameters_message,
)
from xface_ros.conversions import (
    DockPrediction,
    PredictDock,
    dock_prediction_msg,
    dock_query_input,
    markers_msg,
    ns_to_stamp,
    path_msg,
    pose_input,
    pose_with_covariance_input,
    seated_pose_msg,
    self_test_response,
    status_name,
    typed_interface_problem,
    verdict_status,
)
from xface_ros.decision import (
    PoseInput,
    Rejected,
    Verdict,
    evaluate_dock_query,
    evaluate_query,
)
from xface_ros.diagnostics import diagnostic_array, predictor_status
from xface_ros.params import (
    DESIGN_PARAMETERS,
    GEOMETRY_PARAMETERS,
    SPECS,
    ConfigError,
    NodeConfig,
    config_from_values,
    current_values,
    declare_parameters,
    merged_values,
)
from xface_ros.pose_reader import PoseReader, ReadByPoseReader
from xface_ros.recorder import Recorder
from xface_ros.worker import LOG_THROTTLE_S, PredictionWorker

__all__ = ["NODE_NAME", "XfaceLifecyclePredictor", "XfacePredictor", "main"]

NODE_NAME = "xface_predictor"

#: A query for the latest streamed pose (an empty frame id, as in GetPlan's start).
_LATEST = PoseInput(
    frame_id="", stamp_ns=0, position=(0.0, 0.0, 0.0), orientation=(0.0, 0.0, 0.0, 1.0)
)

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

#: The outputs' publishers take no QoS-event handlers. rclpy's defaults log an incompatible
#: QoS or message type offered to a subscriber, which that subscriber's own default handler
#: logs too; and the executor adds every handler to its wait set again for every message it
#: takes (the six outputs' 12 handlers cost it about a fifth of its CPU:
#: docs/notes/2026-11-23-node-cpu-per-thread.md).
OUTPUT_EVENT_CALLBACKS = PublisherEventCallbacks(use_default_callbacks=False)


class _Predictor(Node):
    """The wiring both node kinds share: parameters, outputs, inputs and their callbacks.

    Outputs (publishers, the recording, the worker) and inputs (the pose subscription, the
    services, the diagnostics timer) are made and released by separate methods, so the plain
    node can make everything at once and the managed node in its transitions. Callback groups
    keep the subscription, the services and the timer apart, so the node also works under a
    multi-threaded executor.
    """

    def __init__(self, *, params_files: Sequence[str] = (), **node_kwargs: Any) -> None:
        """``params_files``: the ``--params-file`` paths of the command line, to warn when none
        of their values reached this node (see :meth:`_warn_unapplied_params_files`)."""
        super().__init__(NODE_NAME, **node_kwargs)
        # First: a misspelt name may be why the values below are refused.
        self._warn_unknown_parameters()
        # Raises (and so refuses to start) on out-of-range or inconsistent overrides.
        self._config: NodeConfig = declare_parameters(self)
        self._warn_unapplied_params_files(params_files)
        self._status_name = status_name(self.get_fully_qualified_name())
        self._config_lock = threading.Lock()
        # The values of the last accepted change and the config validated from them: applied
        # as it is, so a face file is read once per change (a second read could find another
        # file, or one that fails).
        self._validated: tuple[dict[str, Any], NodeConfig] | None = None
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self._publishers_made: list[Any] = []
        self._inputs: list[tuple[Any, Any]] = []  # (entity, its destroy method)
        self._recorder: Recorder | None = None
        self._worker: PredictionWorker | None = None
        self._pose_reader: PoseReader | None = None
        self._result_pub: Any = None
        # The typed interface (prediction/result, predict_dock) is optional: said once here.
        self._typed_problem = typed_interface_problem()
        if self._typed_problem is not None:
            self.get_logger().warning(self._typed_problem)

    @property
    def _running_worker(self) -> PredictionWorker:
        """The worker: inputs exist only while it does (between making and releasing outputs)."""
        if self._worker is None:
            raise RuntimeError("the predictor's outputs are released")
        return self._worker

    # --- making and releasing the interfaces ------------------------------------------------

    def _publisher(self, msg_type: Any, topic: str, qos: QoSProfile) -> Any:
        """A publisher (the managed node makes lifecycle publishers)."""
        publisher = self.create_publisher(
            msg_type, topic, qos, event_callbacks=OUTPUT_EVENT_CALLBACKS
        )
        self._publishers_made.append(publisher)
        return publisher

    def _make_outputs(self) -> None:
        """Publishers, the recording and the worker (not started: its thread warms up first)."""
        self._accepted_pub = self._publisher(Bool, names.ACCEPTED, RESULT_QOS)
        self._status_pub = self._publisher(DiagnosticStatus, names.STATUS, RESULT_QOS)
        self._path_pub = self._publisher(Path, names.PATH, BULK_QOS)
        self._seated_pub = self._publisher(PoseStamped, names.SEATED_POSE, LATCHED_QOS)
        self._markers_pub = self._publisher(MarkerArray, names.MARKERS, BULK_QOS)
        self._diagnostics_pub = self._publisher(DiagnosticArray, names.DIAGNOSTICS, RESULT_QOS)
        if self._typed_problem is None:
            self._result_pub = self._publisher(DockPrediction, names.RESULT, RESULT_QOS)
        self._recorder = Recorder.open(self.config, self.get_logger())
        self._worker = PredictionWorker(
            config=lambda: self.config,
            now_ns=self._now_ns,
            wants_path=self._wants_path,
            publish=self._publish_verdict,
            logger=self.get_logger(),
            recorder=self._recorder,
            shutting_down=lambda: not self.context.ok(),
            atlas=AtlasKeeper(self.get_logger()),
        )

    def _make_inputs(self) -> None:
        """The pose subscriptions, the services and the diagnostics timer."""
        pose_sub = self.create_subscription(
            PoseStamped,
            names.POSES,
            self._on_pose,
            qos_profile_sensor_data,
            callback_group=ReadByPoseReader(),
            event_callbacks=SubscriptionEventCallbacks(message_lost=self._on_message_lost),
        )
        # The same stream with its uncertainty: the status then also carries the seat
        # probability (and, below min_seat_probability, a suggested correction).
        cov_sub = self.create_subscription(
            PoseWithCovarianceStamped,
            names.POSES_WITH_COVARIANCE,
            self._on_pose_with_covariance,
            qos_profile_sensor_data,
            callback_group=ReadByPoseReader(),
        )
        # The poses are taken on a thread of their own, not by the executor (pose_reader).
        self._pose_reader = PoseReader(self.context, [pose_sub, cov_sub], self.get_logger())
        self._pose_reader.start()
        plan_service = self.create_service(
            GetPlan,
            names.PREDICT,
            self._on_predict_request,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        # The planner's answer with its reason in one call: a common type (no interface package
        # to build), the status of prediction/status plus "answer" (docs/ros.md says why).
        status_service = self.create_service(
            SelfTest,
            names.PREDICT_STATUS,
            self._on_status_request,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        timer = self.create_timer(
            self.config.diagnostics_period_s,
            self._publish_diagnostics,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        self._inputs = [
            (pose_sub, self.destroy_subscription),
            (cov_sub, self.destroy_subscription),
            (plan_service, self.destroy_service),
            (status_service, self.destroy_service),
            (timer, self.destroy_timer),
        ]
        if self._typed_problem is None:
            # The typed answer: a DockPrediction and the path (docs/ros.md, predict_dock).
            dock_service = self.create_service(
                PredictDock,
                names.PREDICT_DOCK,
                self._on_predict_dock_request,
                callback_group=MutuallyExclusiveCallbackGroup(),
            )
            self._inputs.append((dock_service, self.destroy_service))
        self.get_logger().info(
            f"predicting for the {self._describe(self.config)}; poses on "
            f"{pose_sub.topic_name} in frame {self.config.base_frame!r}"
        )

    def _release_inputs(self) -> None:
        self._stop_pose_reader()
        inputs, self._inputs = self._inputs, []
        for entity, destroy in inputs:
            destroy(entity)

    def _release_outputs(self) -> None:
        """Stop the worker, finish the recording, then release the publishers."""
        self.close()
        publishers, self._publishers_made = self._publishers_made, []
        for publisher in publishers:
            self.destroy_publisher(publisher)

    # --- parameters -------------------------------------------------------------------------

    @property
    def config(self) -> NodeConfig:
        """The current validated configuration."""
        with self._config_lock:
            return self._config

    @staticmethod
    def _describe(config: NodeConfig) -> str:
        if config.face == CUSTOM_FACE:
            return (
                f"custom face '{config.design.display_name}' ({config.face_file}) "
                f"D={config.width_m:g} m "
                f"c_B/c_M={config.damping_ratio:g} friction={config.friction:g}"
            )
        return (
            f"{config.face}-Face D={config.width_m:g} m H/D={config.h_over_d:g} "
            f"r_p={config.r_p:g} c_B/c_M={config.damping_ratio:g} friction={config.friction:g}"
        )

    def _warn_unapplied_params_files(self, paths: Sequence[str]) -> None:
        """Warn about a params file whose keys match another node (it then sets nothing here).

        rcl matches a file's keys against the node's name and namespace; a file written for
        ``xface_predictor`` silently does nothing for ``/left/dock_left``. rclpy keeps the
        matched overrides in ``_parameter_overrides`` (no public accessor in Jazzy).
        """
        overrides = {name: p.value for name, p in self._parameter_overrides.items()}
        for path in paths:
            try:
                msgs = parameter_dict_from_yaml_file(path)
            except Exception:  # rcl read it already; whatever it was, there is no list to check
                continue
            file_values = {
                name: Parameter.from_parameter_msg(msg).value for name, msg in msgs.items()
            }
            if file_values and not params_file_applied(file_values, overrides):
                self.get_logger().warning(
                    f"params file {path} sets none of this node's parameters: none of its keys "
                    f"matches {self.get_fully_qualified_name()}; running on built-in defaults "
                    f"(key the file with '/**:' or '{self.get_fully_qualified_name()}:')"
                )

    def _warn_unknown_parameters(self) -> None:
        """Warn, in one line, about overrides (params file, ``-p``) this node has no parameter
        for: rclpy drops them without a word, so a misspelt ``widht_m`` would leave
        ``width_m`` at its default. rclpy keeps the overrides rcl matched to this node in
        ``_parameter_overrides`` (no public accessor in Jazzy). Known: this node's parameters
        and those rclpy declared already (``use_sim_time``...)."""
        known = [*(spec.name for spec in SPECS), *self.list_parameters([], 0).names]
        message = unknown_parameters_message(self._parameter_overrides, known)
        if message is not None:
            self.get_logger().warning(message)

    def _kept_design(self, params: list[Parameter]) -> FaceDesign | None:
        """The node's design, for a change that sets none of its geometry's parameters (then
        no face file is read: a file moved or edited since it was read changes nothing until
        ``face_file`` is set again); None, to build it from the values."""
        if {p.name for p in params} & GEOMETRY_PARAMETERS:
            return None
        return self.config.design

    def _validate_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Accept a change only if the whole set after it makes a config; else refuse it with
        the reason (returned and logged) and keep the config the node runs with."""
        self._validated = None
        values = merged_values(current_values(self), params)
        try:
            config = config_from_values(values, design=self._kept_design(params))
        except ConfigError as exc:
            reason = str(exc)
        # Broad on purpose: an exception out of this callback ends the node (rclpy raises it
        # out of spin); whatever a value makes the validation raise, it is the value's fault.
        except Exception as exc:
            reason = f"cannot validate: {type(exc).__name__}: {exc}"
        else:
            self._validated = (values, config)
            return SetParametersResult(successful=True)
        self.get_logger().warning(f"parameter change refused: {reason}")
        return SetParametersResult(successful=False, reason=reason)

    def _apply_parameters(self, params: list[Parameter]) -> None:
        validated, self._validated = self._validated, None
        values = current_values(self)
        try:
            if validated is not None and validated[0] == values:
                config = validated[1]
            else:
                config = config_from_values(values, design=self._kept_design(params))
        except Exception as exc:  # validated already; keep the old config if it happens
            self.get_logger().error(f"parameter change not applied: {exc}")
            return
        with self._config_lock:
            self._config = config
        if {p.name for p in params} & DESIGN_PARAMETERS:
            self.get_logger().info(f"next prediction uses the {self._describe(config)}")

    # --- input ------------------------------------------------------------------------------

    def _now_ns(self) -> int:
        return int(self.get_clock().now().nanoseconds)

    def _on_pose(self, msg: PoseStamped) -> None:
        self._running_worker.submit(pose_input(msg), receive_ns=self._now_ns())

    def _on_pose_with_covariance(self, msg: PoseWithCovarianceStamped) -> None:
        self._running_worker.submit(pose_with_covariance_input(msg), receive_ns=self._now_ns())

    def _on_message_lost(self, info: QoSMessageLostInfo) -> None:
        self._running_worker.stats.set_dds_lost_reported_total(info.total_count)

    # --- output of the worker (runs on the worker thread) -----------------------------------

    def _wants_path(self) -> bool:
        """Someone subscribes to the path or the markers (which draw the path)."""
        return _subscribed(self._path_pub) or _subscribed(self._markers_pub)

    def _publish_verdict(self, verdict: Verdict, config: NodeConfig) -> None:
        """Publish a streamed pose's verdict with the config it was decided with."""
        header = Header(stamp=ns_to_stamp(verdict.stamp_ns), frame_id=config.base_frame)
        # The volatile outputs are built only for someone: a message nobody subscribes to
        # is dropped by DDS anyway, and building the status and the typed result costs about
        # 0.15 ms a pose of the worker's 2 (docs/ros.md, Rates).
        if not isinstance(verdict, Rejected) and _subscribed(self._accepted_pub):
            self._accepted_pub.publish(Bool(data=verdict.accepted))
        if _subscribed(self._status_pub):
            self._status_pub.publish(
                verdict_status(verdict, name=self._status_name, hardware_id=config.base_frame)
            )
        if self._result_pub is not None and _subscribed(self._result_pub):
            self._result_pub.publish(dock_prediction_msg(verdict, header, config))
        # Every verdict replaces the latched seat: a seat never outlives a later failure.
        self._seated_pub.publish(seated_pose_msg(verdict.seated_pose, header))
        if isinstance(verdict, Rejected):
            return
        prediction = verdict.prediction
        if prediction.path is not None and _subscribed(self._path_pub):
            self._path_pub.publish(path_msg(prediction, header, max_poses=config.max_path_poses))
        if _subscribed(self._markers_pub):
            self._markers_pub.publish(markers_msg(prediction, header))

    # --- planner service ---------------------------------------------------------------------

    def _on_predict_request(
        self, request: GetPlan.Request, response: GetPlan.Response
    ) -> GetPlan.Response:
        """GetPlan: ``plan`` is the alignment path when the start is accepted, else empty.

        An empty ``start.header.frame_id`` means the latest streamed pose (subject to
        ``input_timeout_s``); an explicit start is not checked for staleness (planners ask
        about hypothetical poses). ``tolerance`` > 0 is the required combined margin (m);
        0 uses ``min_margin``; a negative or non-finite one is refused (``bad_tolerance``).
        ``goal`` is ignored: the goal is the seat.
        """
        config = self.config
        verdict = self._query(
            evaluate_query, pose_input(request.start), config,
            tolerance_m=float(request.tolerance),
        )  # fmt: skip
        response.plan = self._answer_path(verdict, config, names.PREDICT)
        return response

    def _on_predict_dock_request(self, request: Any, response: Any) -> Any:
        """PredictDock: the start's ``DockPrediction`` and its path (empty unless accepted).

        The start as for ``predict`` (an empty frame id: the latest streamed pose); with
        ``has_covariance`` the (x, yaw) block of ``covariance`` gives the seat probability as
        on ``relative_pose_with_covariance``. ``required_margin`` (m) and
        ``required_probability`` 0 use ``min_margin`` and ``min_seat_probability``; a negative
        or non-finite one is answered as refused (``bad_required_margin``,
        ``bad_required_probability``).
        """
        config = self.config
        required_margin = float(request.required_margin)
        required_probability = float(request.required_probability)
        verdict = self._query(
            evaluate_dock_query, dock_query_input(request), config,
            required_margin=required_margin, required_probability=required_probability,
        )  # fmt: skip
        header = Header(stamp=ns_to_stamp(verdict.stamp_ns), frame_id=config.base_frame)
        response.prediction = dock_prediction_msg(
            verdict, header, config,
            required_margin_m=required_margin or config.min_margin,
            required_probability=required_probability or config.min_seat_probability,
        )  # fmt: skip
        response.path = self._answer_path(verdict, config, names.PREDICT_DOCK)
        return response

    def _answer_path(self, verdict: Verdict, config: NodeConfig, service: str) -> Path:
        """A query's path (empty unless accepted), and the query logged (throttled)."""
        if isinstance(verdict, Rejected):
            self.get_logger().warning(
                f"{service}: empty plan, {verdict.code}: {verdict.detail}",
                throttle_duration_sec=LOG_THROTTLE_S,
            )
            return Path(header=Header(frame_id=config.base_frame))
        header = Header(stamp=ns_to_stamp(verdict.stamp_ns), frame_id=config.base_frame)
        self.get_logger().info(
            f"{service}: x0={verdict.start.x0:.4g} m theta0={verdict.start.theta0:.4g} rad -> "
            f"{verdict.prediction.outcome.name}, "
            f"{'accepted' if verdict.accepted else 'rejected'} ({verdict.decision.why})",
            throttle_duration_sec=1.0,
        )
        if not verdict.accepted:
            return Path(header=header)
        return path_msg(verdict.prediction, header, max_poses=config.max_path_poses)

    def _query(
        self,
        evaluate: Callable[..., Verdict],
        start: PoseInput,
        config: NodeConfig,
        **required: float,
    ) -> Verdict:
        """A counted planner query: ``start`` (empty frame: the latest pose) against ``config``,
        with ``evaluate``'s requirements (:mod:`xface_ros.decision`)."""
        self._running_worker.stats.count_service_call()
        worker = self._running_worker
        return evaluate(
            start,
            worker.latest_pose,
            config,
            now_ns=self._now_ns(),
            atlas=worker.current_atlas(config),
            **required,
        )

    def _on_status_request(
        self, _request: SelfTest.Request, _response: SelfTest.Response
    ) -> SelfTest.Response:
        """SelfTest: the latest streamed pose's answer, reason and margins in one call.

        The same question as GetPlan with an empty start (``min_margin`` required), answered
        with the status of ``prediction/status`` plus ``answer`` (no_pose, stale, invalid,
        will_not_seat, seats_without_margin, seats); ``passed`` is 1 when accepted.
        """
        config = self.config
        verdict = self._query(evaluate_query, _LATEST, config, tolerance_m=0.0)
        return self_test_response(
            verdict,
            node_fqn=self.get_fully_qualified_name(),
            name=self._status_name,
            hardware_id=config.base_frame,
        )

    # --- diagnostics -------------------------------------------------------------------------

    def _publish_diagnostics(self) -> None:
        snapshot = self._running_worker.take_stats(self._now_ns())
        status = predictor_status(
            snapshot,
            self.config,
            node_name=self.get_fully_qualified_name(),
            recording_path=self._recorder.path if self._recorder is not None else "",
            atlas=self._running_worker.atlas_state,
        )
        stamp = self.get_clock().now().to_msg()
        self._diagnostics_pub.publish(diagnostic_array([status], stamp=stamp))

    # --- shutdown ---------------------------------------------------------------------------

    def _stop_pose_reader(self) -> None:
        reader, self._pose_reader = self._pose_reader, None
        if reader is not None:
            reader.stop()

    def close(self) -> None:
        """Stop the pose reader and the worker, and finish the recording (idempotent)."""
        self._stop_pose_reader()
        worker, self._worker = self._worker, None
        if worker is not None:
            worker.stop(timeout_s=30.0)
        recorder, self._recorder = self._recorder, None
        if recorder is None:
            return
        try:
            recorder.finish(timeout_s=10.0)
        except Exception as exc:  # report, but never turn a clean shutdown into a crash
            self._say_at_shutdown(f"could not finish the recording: {exc!r}", error=True)
        else:
            self._say_at_shutdown(f"recording finished: {recorder.path}")

    def _say_at_shutdown(self, text: str, *, error: bool = False) -> None:
        """Log, or print once the context is gone (rosout is closed by then)."""
        if self.context.ok():
            logger = self.get_logger()
            (logger.error if error else logger.info)(text)
        else:
            print(f"[{self.get_name()}] {text}", file=sys.stderr, flush=True)

    def destroy_node(self) -> None:
        self.close()
        # rclpy's Node.destroy_node is unannotated; mypy's untyped_calls_exclude does not
        # reach a call through super().
        super().destroy_node()  # type: ignore[no-untyped-call]


class XfacePredictor(_Predictor):
    """The plain node: every interface exists from construction until the node is destroyed.

    The constructor does not simulate: the worker warms the simulator up on its own thread
    (seconds on a fresh checkout, which compiles it) while every interface already exists.
    """

    def __init__(self, *, params_files: Sequence[str] = (), **node_kwargs: Any) -> None:
        super().__init__(params_files=params_files, **node_kwargs)
        self._make_outputs()
        self._make_inputs()
        self._running_worker.start()


class XfaceLifecyclePredictor(LifecycleNodeMixin, _Predictor):
    """The managed node (``--lifecycle``), driven by ``<node>/change_state``.

    * constructed (unconfigured): parameters only;
    * ``configure``: publishers (lifecycle publishers, silent until active), the recording, and
      the worker, whose warm-up it starts and does not wait for: loading the simulator takes
      minutes where it compiles, and a lifecycle manager waits on each transition before it
      brings up the next node; until it is over ``/diagnostics`` (once active) says "warming
      up" and the services answer only once the simulator is loaded;
    * ``activate``: the pose subscriptions, the services and the diagnostics timer;
    * ``deactivate``: those released again (no answers, no predictions);
    * ``cleanup`` / ``shutdown``: the worker stopped, the recording finished, all released.
    """

    def __init__(self, *, params_files: Sequence[str] = (), **node_kwargs: Any) -> None:
        _Predictor.__init__(self, params_files=params_files, **node_kwargs)
        LifecycleNodeMixin.__init__(self, enable_communication_interface=True)

    def _publisher(self, msg_type: Any, topic: str, qos: QoSProfile) -> Any:
        publisher = self.create_lifecycle_publisher(
            msg_type, topic, qos, event_callbacks=OUTPUT_EVENT_CALLBACKS
        )
        self._publishers_made.append(publisher)
        return publisher

    def destroy_publisher(self, publisher: Any) -> bool:
        return bool(self.destroy_lifecycle_publisher(publisher))

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._make_outputs()
        self._running_worker.start()  # warms up on its own thread, then predicts
        self.get_logger().info("configured; the simulator warms up in the background")
        return super().on_configure(state)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._make_inputs()
        return super().on_activate(state)  # enables the lifecycle publishers

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release_inputs()
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release_outputs()
        return super().on_cleanup(state)

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release_inputs()
        self._release_outputs()
        return super().on_shutdown(state)


class CommandLineError(Exception):
    """A command line the node cannot start with (a parameter file it cannot read, ROS
    arguments rcl refuses): one line for the user, exit code 2."""


#: How the layout of a ROS parameter file goes, for the error about one that does not.
PARAMS_LAYOUT = "'<node name or /**>:', then 'ros__parameters:', then 'name: value' lines"


def _subscribed(publisher: Any) -> bool:
    """Someone subscribes to ``publisher``'s topic (a lifecycle publisher counts its
    subscribers while inactive too: it drops what it is given then)."""
    # get_subscription_count is unannotated in rclpy: int() types it.
    return int(publisher.get_subscription_count()) > 0


def params_layout_problem(data: object, where: str = "") -> str | None:
    """What in a parameter file's parsed YAML is off rcl's layout (None: nothing).

    Node names (or ``/**``; namespaces nest as keys) down to ``ros__parameters``, a mapping
    of names to values. rcl takes an empty file and a lone string without a word and then sets
    nothing, which a user who passed a file never means, so both are refused here as well.

    >>> params_layout_problem({"/**": {"ros__parameters": {"face": "V"}}}) is None
    True
    >>> params_layout_problem("face: V")
    "expected '<node name or /**>:', then 'ros__parameters:', then 'name: value' lines"
    >>> params_layout_problem({"xface_predictor": {"face": "V"}})
    "'xface_predictor/face' is a value where a node name or 'ros__parameters:' belongs"
    """
    if not where and (not isinstance(data, dict) or not data):
        return f"expected {PARAMS_LAYOUT}"
    assert isinstance(data, dict)
    for key, value in data.items():
        if key == "ros__parameters":
            if not where:
                return "'ros__parameters:' needs a node name (or /**) above it"
            if not isinstance(value, dict):
                return f"'{where}ros__parameters' must map parameter names to values"
        elif isinstance(value, dict):
            problem = params_layout_problem(value, f"{where}{key}/")
            if problem is not None:
                return problem
        else:
            return f"'{where}{key}' is a value where a node name or 'ros__parameters:' belongs"
    return None


def params_file_problem(path: str) -> str | None:
    """Why the node cannot start with the parameter file ``path``, in one line (None: none).

    Checked before rclpy: rcl refuses a missing file or broken YAML with a traceback of its
    own, and runs without a word on a file that sets nothing (a lone string, nothing at all).
    A FIFO or a device is refused without opening it (opening a FIFO blocks until a writer
    comes).
    """
    kind = not_a_regular_file(path)
    if kind is not None:
        return f"cannot read parameter file {path}: it is {kind}, not a regular file"
    try:
        with open(path, encoding="utf-8") as stream:
            data = yaml.safe_load(stream)
    except OSError as exc:
        return f"cannot read parameter file {path}: {exc.strerror or exc}"
    except UnicodeDecodeError as exc:
        return f"cannot read parameter file {path}: not UTF-8 text ({exc.reason})"
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = "" if mark is None else f" at line {mark.line + 1}, column {mark.column + 1}"
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        return f"parameter file {path} is not valid YAML: {problem}{where}"
    except RecursionError:
        return f"parameter file {path} is nested too deeply to read"
    # yaml raises more than YAMLError on hostile text: ValueError on an integer of more than
    # 4,300 digits (Python's limit), MemoryError... Any of them is the file's fault.
    except Exception as exc:
        text = " ".join(str(exc).split())
        return f"cannot read parameter file {path}: {type(exc).__name__}: {text}"
    layout = params_layout_problem(data)
    if layout is not None:
        return f"parameter file {path} is not in ROS's layout: {layout}"
    return None


def _rcl_argument_error(exc: Exception) -> str:
    """rcl's refusal of the ROS arguments without its source locations (``, at parse.c:806``)."""
    text = " ".join(str(exc).split())
    text = re.sub(r"(, at \S+:\d+)+$", "", text).removeprefix("Failed to parse ROS arguments: ")
    params_file = re.fullmatch(
        r"Couldn't parse params file: '--params-file (.*)'\. Error: (.*)", text
    )
    if params_file is not None:
        return f"cannot use parameter file {params_file[1]}: {params_file[2]}"
    return text


def _parse_options(argv: Sequence[str]) -> argparse.Namespace:
    """The node's own options (outside ``--ros-args``); argv[0] is the program.

    Raises :class:`CommandLineError` for a parameter file that cannot be used and for ROS
    arguments rcl refuses; argparse exits 2 with usage on an unknown option."""
    for path in params_file_paths(argv):
        problem = params_file_problem(path)
        if problem is not None:
            raise CommandLineError(problem)
    parser = argparse.ArgumentParser(
        prog="xface-predictor", description="Run the xface_predictor ROS 2 node."
    )
    parser.add_argument(
        "--lifecycle",
        action="store_true",
        help="start as a managed (lifecycle) node, driven by <node>/change_state",
    )
    try:
        own_args = remove_ros_args(list(argv))[1:]
    except RuntimeError as exc:  # rcl's RCLInvalidROSArgsError: e.g. a mixed list, a bad -p
        raise CommandLineError(_rcl_argument_error(exc)) from None
    return parser.parse_args(own_args)


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT or SIGTERM; 0 on a clean shutdown, 2 on a bad configuration
    or command line (one line on stderr, before rclpy starts).

    rclpy's own handlers catch both signals (``SignalHandlerOptions.ALL``): they shut the
    context down, ``spin`` returns, and the ``finally`` block finishes the recording.
    """
    argv = sys.argv if args is None else args
    try:
        options = _parse_options(argv)
    except CommandLineError as exc:
        print(f"{NODE_NAME}: error: {exc}", file=sys.stderr, flush=True)
        return 2
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.ALL)
    node: _Predictor | None = None
    # One executor thread for the services, parameters and timer: rclpy's
    # SingleThreadedExecutor took a 1 kHz pose stream with far fewer losses than its
    # MultiThreadedExecutor (scripts/bench/ros_stress.py, docs/ros.md); the poses are now read by
    # the pose reader's thread and simulated in the worker's, so callbacks stay short.
    executor = SingleThreadedExecutor()
    code = 0
    try:
        kind = XfaceLifecyclePredictor if options.lifecycle else XfacePredictor
        node = kind(params_files=params_file_paths(argv))
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ConfigError, ParameterException) as exc:  # out of range, wrong type, inconsistent
        print(f"{NODE_NAME}: refusing to start: {exc}", file=sys.stderr, flush=True)
        code = 2
    except Exception as exc:
        _shutdown_race(exc)
    finally:
        _finish(node, executor)
    return code


#: How long an exception inside the executor may wait for a signal's shutdown to show (s).
SHUTDOWN_GRACE_S = 2.0


def _shutdown_race(exc: Exception) -> None:
    """Re-raise ``exc`` unless the context is already down.

    A signal's handler shuts the context down from its own thread while the executor runs; a
    spin that was then building its wait set, taking a message or publishing fails inside rcl
    ("failed to initialize wait set: the given context is not valid", a RuntimeError in
    take_message) instead of returning. Once the context is down, that is the shutdown itself.
    rclpy's handler runs on a thread of its own, so the failure can come before the context is
    marked down: wait up to ``SHUTDOWN_GRACE_S`` for it (a real error, with no signal behind
    it, is raised after that wait).
    """
    deadline = time.monotonic() + SHUTDOWN_GRACE_S
    while rclpy.ok() and time.monotonic() < deadline:
        time.sleep(0.01)
    if rclpy.ok():
        raise exc
    print(f"{NODE_NAME}: shutting down ({type(exc).__name__} at shutdown)", file=sys.stderr)


def _finish(node: _Predictor | None, executor: SingleThreadedExecutor) -> None:
    """Stop the worker, finish the recording, release the node, the executor and the context.

    The recording comes first and on its own (``close`` never raises): whatever fails after it
    while the context is going down must not turn a clean shutdown into exit code 1.
    """
    if node is not None:
        node.close()
    try:
        if node is not None:
            node.destroy_node()
        executor.shutdown()
    except Exception as exc:
        _shutdown_race(exc)
    finally:
        rclpy.try_shutdown()
