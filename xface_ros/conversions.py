"""Messages <-> plain values and xface_core types: input pose, status, path, seated pose, markers.

The rules (input checks, acceptance) are in :mod:`xface_ros.decision`; this module only
converts.

Frames follow :mod:`xface_core.frames`: every pose is the moving pivot frame in the base
pivot frame (``base_frame``), as it was at the start of the prediction; lengths in metres.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import numpy.typing as npt
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from diagnostic_msgs.srv import SelfTest
from geometry_msgs.msg import (
    Point,
    Pose,
    PoseStamped,
    PoseWithCovarianceStamped,
    Quaternion,
    Vector3,
)
from nav_msgs.msg import Path
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from xface_core.codes import Outcome
from xface_core.frames import (
    PlanarPose,
    path_poses,
    yaw_to_quaternion,
)
from xface_core.geometry import FaceDesign
from xface_core.result import Prediction
from xface_ros.config import NodeConfig
from xface_ros.decision import PoseInput, Predicted, Rejected, Verdict, answer

# The typed interface (xface_msgs) is built after the pip install (scripts/build_msgs.py,
# `make msgs`); without it the node runs without prediction/result and predict_dock.
try:
    from xface_msgs.msg import DockPrediction
    from xface_msgs.srv import PredictDock
except ImportError as exc:
    DockPrediction = PredictDock = None
    _XFACE_MSGS_IMPORT_ERROR: str | None = str(exc)
else:
    _XFACE_MSGS_IMPORT_ERROR = None

__all__ = [
    "DockPrediction",
    "PredictDock",
    "dock_prediction_msg",
    "dock_query_input",
    "input_error_status",
    "key_value",
    "markers_msg",
    "ns_to_stamp",
    "path_indices",
    "path_msg",
    "planar_to_pose",
    "pose_input",
    "prediction_status",
    "seated_pose_msg",
    "self_test_response",
    "stamp_to_ns",
    "status_name",
    "typed_interface_problem",
    "verdict_status",
]


def status_name(node_fqn: str) -> str:
    """Name of every DiagnosticStatus on ``prediction/status``: the node's fully qualified name
    (e.g. ``/left/dock_left``), so statuses of several nodes can be told apart."""
    return f"{node_fqn}: prediction"


def stamp_to_ns(stamp: Time) -> int:
    """Nanoseconds of a ``builtin_interfaces/Time``."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(ns: int) -> Time:
    """A ``builtin_interfaces/Time`` from nanoseconds (>= 0)."""
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def pose_input(msg: PoseStamped) -> PoseInput:
    """The plain values of a received pose, for :mod:`xface_ros.decision` (nothing checked)."""
    p, q = msg.pose.position, msg.pose.orientation
    return PoseInput(
        frame_id=str(msg.header.frame_id),
        stamp_ns=stamp_to_ns(msg.header.stamp),
        position=(float(p.x), float(p.y), float(p.z)),
        orientation=(float(q.x), float(q.y), float(q.z), float(q.w)),
    )


def _x_yaw_block(c: Sequence[float]) -> tuple[float, float, float, float]:
    """The (x, yaw) block of a 6 x 6 row-major pose covariance (indices 0, 5, 30, 35; x0 = x
    and theta0 = yaw - pi, so it is the covariance of (x0, theta0))."""
    return (float(c[0]), float(c[5]), float(c[30]), float(c[35]))


def pose_with_covariance_input(msg: PoseWithCovarianceStamped) -> PoseInput:
    """The plain values of a pose with covariance: the pose, and the (x, yaw) block of its
    covariance (:func:`_x_yaw_block`)."""
    stamped = PoseStamped(header=msg.header, pose=msg.pose.pose)
    return replace(pose_input(stamped), covariance=_x_yaw_block(msg.pose.covariance))


def dock_query_input(request: Any) -> PoseInput:
    """The start of a ``PredictDock`` request as plain values: the pose, and when
    ``has_covariance`` the (x, yaw) block of ``covariance`` (laid out as
    ``PoseWithCovariance``'s, read as the covariance subscription reads it)."""
    start = pose_input(request.start)
    if not request.has_covariance:
        return start
    return replace(start, covariance=_x_yaw_block(request.covariance))


def planar_to_pose(pose: PlanarPose) -> Pose:
    """A ``geometry_msgs/Pose`` at z = 0 rotated about +z by the yaw."""
    qx, qy, qz, qw = yaw_to_quaternion(pose.yaw)
    return Pose(
        position=Point(x=float(pose.x), y=float(pose.y), z=0.0),
        orientation=Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


def key_value(key: str, value: object) -> KeyValue:
    """A diagnostics value: floats as ``repr`` (they parse back exactly), bools as
    ``true`` / ``false``, None as ``""``, anything else as ``str``."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif value is None:
        text = ""
    elif isinstance(value, float):
        text = repr(value)
    else:
        text = str(value)
    return KeyValue(key=key, value=text)


def _stamp_text(stamp_ns: int) -> str:
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return f"{sec}.{nanosec:09d}"


def prediction_status(predicted: Predicted, *, name: str, hardware_id: str) -> DiagnosticStatus:
    """The ``prediction/status`` message of a prediction.

    Level OK when accepted, WARN otherwise (will not seat, or seats without the required
    margin), ERROR when the simulator called the input invalid. The message is
    ``"<OUTCOME>: <reason>"``; values (lengths in m, angles in rad, times in ms) are listed
    in docs/ros.md.
    """
    prediction, decision = predicted.prediction, predicted.decision
    if prediction.outcome is Outcome.INVALID_INPUT:
        level = DiagnosticStatus.ERROR
    elif decision.accepted:
        level = DiagnosticStatus.OK
    else:
        level = DiagnosticStatus.WARN
    message = f"{prediction.outcome.name}: {_reason(predicted)}"
    values = [
        key_value("outcome", prediction.outcome.name),
        key_value("outcome_code", int(prediction.outcome)),
        key_value("accepted", decision.accepted),
        key_value("x0_m", prediction.x0),
        key_value("theta0_rad", prediction.theta0),
        key_value("y_start_m", prediction.y_start),
        key_value("required_margin_m", decision.required_m),
    ]
    if prediction.margins is not None:
        m = prediction.margins
        values += [
            key_value("margin_m", decision.margin_m),
            key_value("margin_lateral_minus_m", m.lateral_minus),
            key_value("margin_lateral_plus_m", m.lateral_plus),
            key_value("margin_angle_minus_rad", m.angle_minus),
            key_value("margin_angle_plus_rad", m.angle_plus),
        ]
    if decision.seat_probability is not None:
        values.append(key_value("seat_probability", decision.seat_probability))
    if decision.suggestion is not None:
        values += [
            key_value("suggest_dx_m", decision.suggestion[0]),
            key_value("suggest_dtheta_rad", decision.suggestion[1]),
        ]
    values += _final_values(predicted)
    values.append(key_value("compute_time_ms", predicted.compute_s * 1e3))
    values += _stamp_values(predicted.stamp_ns)
    values += [key_value(key, value) for key, value in _design_summary(prediction.design)]
    return DiagnosticStatus(
        level=level, name=name, message=message, hardware_id=hardware_id, values=values
    )


def _reason(predicted: Predicted) -> str:
    """Why it ended so, and, when it seats but is not accepted, why not."""
    prediction, decision = predicted.prediction, predicted.decision
    if prediction.seated and not decision.accepted:
        return f"{prediction.reason} ({decision.why})"
    return prediction.reason


def _design_summary(design: FaceDesign) -> list[tuple[str, str | float]]:
    """The design a prediction used, by status key: kind, width D (m), H/D and r_p (NaN for
    a custom face)."""
    return [
        ("face", design.kind),
        ("width_m", design.width),
        ("h_over_d", design.h_over_d),
        ("r_p", design.r_p),
    ]


def _final_values(predicted: Predicted) -> list[KeyValue]:
    """The final state (angles in rad, pose in m and rad) and the simulator's work."""
    p, seat, c = predicted.prediction, predicted.final_pose, predicted.prediction.counters
    return [
        key_value("final_phi_b_rad", p.phi_b),
        key_value("final_phi_m_rad", p.phi_m),
        key_value("final_x_m", seat.x),
        key_value("final_y_m", seat.y),
        key_value("final_yaw_rad", seat.yaw),
        key_value("steps", c.steps),
        key_value("events", c.events),
        key_value("contact_changes", c.contact_changes),
        key_value("rejected_steps", c.rejected_steps),
    ]


def _stamp_values(stamp_ns: int) -> list[KeyValue]:
    return [key_value("input_stamp", _stamp_text(stamp_ns)), key_value("input_stamp_ns", stamp_ns)]


def input_error_status(rejected: Rejected, *, name: str, hardware_id: str) -> DiagnosticStatus:
    """The ERROR ``prediction/status`` of a rejected input."""
    return DiagnosticStatus(
        level=DiagnosticStatus.ERROR,
        name=name,
        message=f"INVALID_INPUT: {rejected.code}: {rejected.detail}",
        hardware_id=hardware_id,
        values=[
            key_value("outcome", Outcome.INVALID_INPUT.name),
            key_value("outcome_code", int(Outcome.INVALID_INPUT)),
            key_value("accepted", False),
            key_value("input_error", rejected.code),
            *_stamp_values(rejected.stamp_ns),
        ],
    )


def verdict_status(verdict: Verdict, *, name: str, hardware_id: str) -> DiagnosticStatus:
    """The ``prediction/status`` message of any verdict: a prediction or a rejected input."""
    if isinstance(verdict, Rejected):
        return input_error_status(verdict, name=name, hardware_id=hardware_id)
    return prediction_status(verdict, name=name, hardware_id=hardware_id)


def typed_interface_problem() -> str | None:
    """Why the typed interface ``xface_msgs`` cannot be used here, with the command that
    builds it; None when it can (its Python module imports and its type support loads)."""
    if _XFACE_MSGS_IMPORT_ERROR is None:
        try:  # a package built for another Python or ROS fails only here
            for msg_type in (DockPrediction, PredictDock):
                type(msg_type).__import_type_support__()
            return None
        except Exception as exc:
            reason = f"{type(exc).__name__}: {exc}"
    else:
        reason = _XFACE_MSGS_IMPORT_ERROR
    return (
        f"the typed interface xface_msgs cannot be used ({reason}): no prediction/result "
        f"topic and no predict_dock service; build it with "
        f"`python scripts/build_msgs.py --prefix {sys.prefix}` (`make msgs` in a checkout)"
    )


def _nan_if_none(value: float | None) -> float:
    return math.nan if value is None else float(value)


def dock_prediction_msg(
    verdict: Verdict,
    header: Header,
    config: NodeConfig,
    *,
    required_margin_m: float | None = None,
    required_probability: float | None = None,
) -> Any:
    """The ``xface_msgs/DockPrediction`` of a verdict: the values of ``prediction/status``
    (:func:`verdict_status`) as typed fields, NaN where nothing was computed.

    ``header``: the pose's stamp and the base frame. A rejected input has outcome
    ``INVALID_INPUT``, ``input_error`` its code, ``reason`` its detail, NaN start, margins
    and compute time; its required margin and probability are ``required_margin_m`` and
    ``required_probability`` (what the query asked) or else the node's ``min_margin`` and
    ``min_seat_probability``, and its design the one ``config`` holds. A prediction carries
    its decision's requirements (``config`` gives only a rejected input's design).
    """
    if isinstance(verdict, Rejected):
        msg = DockPrediction(
            header=header, outcome=int(Outcome.INVALID_INPUT),
            outcome_name=Outcome.INVALID_INPUT.name, reason=verdict.detail,
            input_error=verdict.code, accepted=False, seated=False, x0=math.nan,
            theta0=math.nan, margin=math.nan, compute_time=math.nan,
            required_margin=_first(required_margin_m, config.min_margin),
            required_probability=_first(required_probability, config.min_seat_probability),
            seat_probability=math.nan, suggested_dx=math.nan, suggested_dtheta=math.nan,
        )  # fmt: skip
        _set_margins(msg, None)
        _set_design(msg, config.design)
        return msg
    prediction, decision = verdict.prediction, verdict.decision
    dx, dtheta = (math.nan, math.nan) if decision.suggestion is None else decision.suggestion
    msg = DockPrediction(
        header=header, outcome=int(prediction.outcome), outcome_name=prediction.outcome.name,
        reason=_reason(verdict), input_error="", accepted=decision.accepted,
        seated=prediction.seated, x0=prediction.x0, theta0=prediction.theta0,
        margin=_nan_if_none(decision.margin_m),
        required_margin=decision.required_m, required_probability=decision.required_probability,
        seat_probability=_nan_if_none(decision.seat_probability), suggested_dx=float(dx),
        suggested_dtheta=float(dtheta), compute_time=verdict.compute_s,
    )  # fmt: skip
    _set_margins(msg, prediction)
    _set_design(msg, prediction.design)
    return msg


def _first(value: float | None, default: float) -> float:
    return float(default if value is None else value)


def _set_margins(msg: Any, prediction: Prediction | None) -> None:
    """The directional margins (m, rad) of a DockPrediction, NaN when not computed."""
    m = None if prediction is None else prediction.margins
    msg.margin_lateral_minus = math.nan if m is None else float(m.lateral_minus)
    msg.margin_lateral_plus = math.nan if m is None else float(m.lateral_plus)
    msg.margin_angle_minus = math.nan if m is None else float(m.angle_minus)
    msg.margin_angle_plus = math.nan if m is None else float(m.angle_plus)


def _set_design(msg: Any, design: FaceDesign) -> None:
    """The design summary of a DockPrediction, from the status's (:func:`_design_summary`)."""
    summary = dict(_design_summary(design))
    msg.face_kind = str(summary["face"])
    msg.face_name = design.display_name
    msg.width = float(summary["width_m"])
    msg.h_over_d = float(summary["h_over_d"])
    msg.r_p = float(summary["r_p"])


def self_test_response(
    verdict: Verdict, *, node_fqn: str, name: str, hardware_id: str
) -> SelfTest.Response:
    """The ``predict_status`` answer: ``passed`` 1 when accepted, one status as on
    ``prediction/status`` plus the ``answer`` value (a key of
    :data:`~xface_ros.decision.ANSWERS`), ``id`` the node's fully qualified name."""
    status = verdict_status(verdict, name=name, hardware_id=hardware_id)
    status.values = [key_value("answer", answer(verdict)), *status.values]
    return SelfTest.Response(
        id=node_fqn, passed=b"\x01" if verdict.accepted else b"\x00", status=[status]
    )


def path_indices(n: int, max_poses: int) -> npt.NDArray[np.int64]:
    """Evenly spread sample indices (first and last included), at most ``max_poses``.

    >>> path_indices(10, 4).tolist()
    [0, 3, 6, 9]
    >>> path_indices(3, 100).tolist()
    [0, 1, 2]
    """
    if n <= max_poses:
        return np.arange(n, dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n - 1, max_poses)).astype(np.int64))


def path_msg(prediction: Prediction, header: Header, *, max_poses: int) -> Path:
    """The alignment path of the moving pivot frame as a ``nav_msgs/Path``.

    Every pose carries ``header`` (the input's stamp, the base frame). Empty when the
    prediction has no path.
    """
    msg = Path(header=header)
    if prediction.path is None or len(prediction.path) == 0:
        return msg
    path = prediction.path
    idx = path_indices(len(path), max_poses)
    poses = path_poses(path.pivot_m[idx], path.phi_m[idx])
    msg.poses = [
        PoseStamped(header=header, pose=planar_to_pose(PlanarPose(*map(float, row))))
        for row in poses
    ]
    return msg


def seated_pose_msg(seat: PlanarPose | None, header: Header) -> PoseStamped:
    """The pose the moving pivot frame seats at (:attr:`Predicted.seated_pose
    <xface_ros.decision.Predicted.seated_pose>`) as a ``geometry_msgs/PoseStamped``.

    ``None`` (no seat: it will not seat, or the input was rejected) gives an empty
    ``frame_id`` and a NaN position with the same stamp: the latched topic then says "no seat
    for this input" instead of keeping an earlier seat, and a consumer that ignores the frame
    gets NaN, not a plausible pose.
    """
    if seat is None:
        no_seat = Pose(position=Point(x=math.nan, y=math.nan, z=math.nan))
        return PoseStamped(header=Header(stamp=header.stamp, frame_id=""), pose=no_seat)
    return PoseStamped(header=header, pose=planar_to_pose(seat))


# --- markers ----------------------------------------------------------------------------------

_GREY = ColorRGBA(r=0.6, g=0.6, b=0.6, a=0.6)
_BLUE = ColorRGBA(r=0.2, g=0.4, b=1.0, a=0.6)
_GREEN = ColorRGBA(r=0.1, g=0.8, b=0.2, a=1.0)
_RED = ColorRGBA(r=0.9, g=0.1, b=0.1, a=1.0)
_ORANGE = ColorRGBA(r=1.0, g=0.6, b=0.0, a=1.0)
_WHITE = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)


def _points(xy: npt.NDArray[np.float64], z: float) -> list[Point]:
    return [Point(x=float(x), y=float(y), z=z) for x, y in xy]


def _outline_markers(
    prediction: Prediction,
    header: Header,
    *,
    ns: str,
    phi_b: float,
    y_m: float,
    phi_m: float,
    base_color: ColorRGBA,
    moving_color: ColorRGBA,
) -> Iterable[Marker]:
    design = prediction.design
    w = design.width
    for layer in range(design.n_layers):
        z = 0.1 * w * layer  # layers stacked along +z so RViz shows both X-Face layers
        outlines = (
            ("base", design.base_outline_world(layer, phi_b), base_color),
            (
                "moving",
                design.moving_outline_world(layer, prediction.x0 / w, y_m / w, phi_m),
                moving_color,
            ),
        )
        for offset, (part, poly, color) in enumerate(outlines):
            closed = np.vstack((poly, poly[:1])) * w
            yield Marker(
                header=header,
                ns=f"{ns}/{part}",
                id=layer * 2 + offset,
                type=Marker.LINE_STRIP,
                action=Marker.ADD,
                pose=planar_to_pose(PlanarPose(0.0, 0.0, 0.0)),
                scale=_line_scale(w),
                color=color,
                points=_points(closed, z),
            )


def _line_scale(width: float, fraction: float = 0.01) -> Vector3:
    """Line width (or sphere diameter) as a fraction of the face width."""
    return Vector3(x=fraction * width, y=fraction * width, z=fraction * width)


def _contact_samples(prediction: Prediction) -> list[int]:
    """First and last path samples with an active contact."""
    if prediction.path is None:
        return []
    touching = np.flatnonzero((prediction.path.contact_pairs >= 0).any(axis=1))
    if touching.size == 0:
        return []
    return sorted({int(touching[0]), int(touching[-1])})


def markers_msg(prediction: Prediction, header: Header) -> MarkerArray:
    """RViz markers: both outlines at the start and at the end, the pivot path, contacts.

    The first marker deletes every earlier one (``DELETEALL``), so RViz shows only the
    latest prediction.
    """
    markers: list[Marker] = [Marker(header=header, action=Marker.DELETEALL)]
    end_color = _GREEN if prediction.seated else _RED
    markers += _outline_markers(
        prediction,
        header,
        ns="start",
        phi_b=0.0,
        y_m=prediction.y_start,
        phi_m=prediction.theta0,
        base_color=_GREY,
        moving_color=_BLUE,
    )
    markers += _outline_markers(
        prediction,
        header,
        ns="end",
        phi_b=prediction.phi_b,
        y_m=prediction.pivot_m[1],
        phi_m=prediction.phi_m,
        base_color=end_color,
        moving_color=end_color,
    )
    w = prediction.design.width
    if prediction.path is not None and len(prediction.path) > 0:
        markers.append(
            Marker(
                header=header,
                ns="path",
                id=0,
                type=Marker.LINE_STRIP,
                action=Marker.ADD,
                pose=planar_to_pose(PlanarPose(0.0, 0.0, 0.0)),
                scale=_line_scale(w),
                color=_ORANGE,
                points=_points(prediction.path.pivot_m, 0.0),
            )
        )
        points: list[npt.NDArray[np.float64]] = []
        for sample in _contact_samples(prediction):
            pts, _normals = prediction.contact_points(sample)
            points.append(np.asarray(pts, dtype=np.float64).reshape(-1, 2))
        if points:
            markers.append(
                Marker(
                    header=header,
                    ns="contacts",
                    id=0,
                    type=Marker.SPHERE_LIST,
                    action=Marker.ADD,
                    pose=planar_to_pose(PlanarPose(0.0, 0.0, 0.0)),
                    scale=_line_scale(w, 0.04),
                    color=_WHITE,
                    points=_points(np.vstack(points), 0.0),
                )
            )
    return MarkerArray(markers=markers)
