"""Messages <-> xface_core types: input checks, status, path, seated pose, markers.

Frames follow :mod:`xface_core.frames`: every pose is the moving pivot frame in the base
pivot frame (``base_frame``), as it was at the start of the prediction; lengths in metres.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion, Vector3
from nav_msgs.msg import Path
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from xface_core.errors import XfaceError
from xface_core.frames import (
    AbsurdDistanceError,
    DockStart,
    NonFiniteInputError,
    NonPlanarOrientationError,
    NonUnitQuaternionError,
    PlanarPose,
    check_distance,
    moving_pose,
    path_poses,
    planar_yaw,
    relative_pose_to_start,
    yaw_to_quaternion,
)
from xface_core.outcome import Outcome
from xface_core.result import Margins, Prediction
from xface_ros.params import NodeConfig

__all__ = [
    "INPUT_ERRORS",
    "STATUS_NAME",
    "Decision",
    "InputRejected",
    "combined_margin",
    "decide",
    "input_error_status",
    "markers_msg",
    "ns_to_stamp",
    "path_indices",
    "path_msg",
    "planar_to_pose",
    "pose_to_planar",
    "prediction_status",
    "seated_pose_msg",
    "stamp_to_ns",
    "start_from_pose",
]

#: Name of every DiagnosticStatus on ``prediction/status``.
STATUS_NAME = "xface_predictor: prediction"

#: Input error codes (the ``input_error`` value of an ERROR status), with what they mean.
INPUT_ERRORS: dict[str, str] = {
    "non_finite": "a position or quaternion component is NaN or infinite",
    "wrong_frame": "header.frame_id is not the base_frame parameter",
    "stale_stamp": "the stamp is older than input_timeout_s",
    "future_stamp": "the stamp lies more than input_timeout_s in the future",
    "unnormalised_quaternion": "the quaternion's norm is not 1",
    "non_planar": "the orientation rolls or pitches beyond max_tilt_rad",
    "absurd_distance": "|x| or |y| is beyond max_distance_widths face widths",
    "no_pose": "no pose has been received yet (service: empty start frame id)",
    "invalid_input": "the simulator refused the start (e.g. the parts interpenetrate)",
    "internal_error": "the simulator failed unexpectedly (a bug: the message has the details)",
}


class InputRejected(Exception):
    """An input pose that is not predicted; ``code`` is a key of :data:`INPUT_ERRORS`."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(f"{code}: {detail}")
        self.code = code
        self.detail = detail


def stamp_to_ns(stamp: Time) -> int:
    """Nanoseconds of a ``builtin_interfaces/Time``."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(ns: int) -> Time:
    """A ``builtin_interfaces/Time`` from nanoseconds (>= 0)."""
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def pose_to_planar(pose: Pose, *, max_tilt_rad: float) -> PlanarPose:
    """The planar pose (x, y, yaw) of a ``geometry_msgs/Pose`` (z is ignored: planar model).

    Raises the :mod:`xface_core.frames` input errors (non-finite, non-unit, non-planar).
    """
    p, q = pose.position, pose.orientation
    if not all(math.isfinite(v) for v in (p.x, p.y, p.z)):
        raise NonFiniteInputError(f"position has a non-finite component: ({p.x}, {p.y}, {p.z})")
    yaw = planar_yaw(q.x, q.y, q.z, q.w, max_tilt_rad=max_tilt_rad)
    return PlanarPose(float(p.x), float(p.y), yaw)


def planar_to_pose(pose: PlanarPose) -> Pose:
    """A ``geometry_msgs/Pose`` at z = 0 rotated about +z by the yaw."""
    qx, qy, qz, qw = yaw_to_quaternion(pose.yaw)
    return Pose(
        position=Point(x=float(pose.x), y=float(pose.y), z=0.0),
        orientation=Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


def start_from_pose(msg: PoseStamped, config: NodeConfig, *, now_ns: int | None) -> DockStart:
    """Check an input pose and convert it to the simulator's start.

    ``now_ns`` is the node clock; None skips the stamp check (planner queries about
    hypothetical poses). Checks run in a fixed order: frame, finiteness, stamp, quaternion,
    distance.

    Raises
    ------
    InputRejected
    """
    frame = msg.header.frame_id
    if frame != config.base_frame:
        raise InputRejected(
            "wrong_frame", f"frame_id {frame!r} is not the base frame {config.base_frame!r}"
        )
    p, q = msg.pose.position, msg.pose.orientation
    values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values):
        raise InputRejected(
            "non_finite", f"position ({p.x}, {p.y}, {p.z}), quaternion ({q.x}, {q.y}, {q.z}, {q.w})"
        )
    if now_ns is not None and config.input_timeout_s > 0.0:
        age_s = (now_ns - stamp_to_ns(msg.header.stamp)) * 1e-9
        if age_s > config.input_timeout_s:
            raise InputRejected(
                "stale_stamp",
                f"pose is {age_s:.3f} s old, input_timeout_s {config.input_timeout_s:g}",
            )
        if -age_s > config.input_timeout_s:
            raise InputRejected(
                "future_stamp", f"pose stamp is {-age_s:.3f} s ahead of the node clock"
            )
    try:
        planar = pose_to_planar(msg.pose, max_tilt_rad=config.max_tilt_rad)
        check_distance(
            planar.x, planar.y, width=config.width_m, max_widths=config.max_distance_widths
        )
    except NonUnitQuaternionError as exc:
        raise InputRejected("unnormalised_quaternion", str(exc)) from exc
    except NonPlanarOrientationError as exc:
        raise InputRejected("non_planar", str(exc)) from exc
    except AbsurdDistanceError as exc:
        raise InputRejected("absurd_distance", str(exc)) from exc
    except XfaceError as exc:  # non-finite after all (cannot happen after the check above)
        raise InputRejected("non_finite", str(exc)) from exc
    return relative_pose_to_start(planar)


def combined_margin(margins: Margins, width: float) -> float:
    """One margin in metres: the smaller of the lateral margin and D times the angle margin.

    The paper's acceptance maps have axes x0 / D and theta0 (rad); measuring both in those
    units and scaling by D gives a length: the distance, along either axis of the map, to the
    nearest pose with another outcome.
    """
    return min(margins.lateral, margins.angle * width)


@dataclass(frozen=True)
class Decision:
    """Whether a prediction counts as accepted, and why."""

    accepted: bool
    margin_m: float | None
    """Combined margin (m), None when margins were not computed."""
    required_m: float
    why: str


def decide(prediction: Prediction, *, required_margin_m: float) -> Decision:
    """Accepted = it seats and (when a margin is required) the combined margin suffices."""
    margin = (
        None
        if prediction.margins is None
        else combined_margin(prediction.margins, prediction.design.width)
    )
    if not prediction.seated:
        return Decision(False, margin, required_margin_m, f"{prediction.outcome.name}")
    if required_margin_m > 0.0:
        if margin is None:
            return Decision(False, None, required_margin_m, "margin required but not computed")
        if margin < required_margin_m:
            return Decision(
                False,
                margin,
                required_margin_m,
                f"seats, but margin {margin:.4g} m < required {required_margin_m:.4g} m",
            )
    return Decision(True, margin, required_margin_m, "seats")


def _kv(key: str, value: object) -> KeyValue:
    if isinstance(value, float):
        text = repr(value)  # round-trips exactly
    elif isinstance(value, bool):
        text = "true" if value else "false"
    else:
        text = str(value)
    return KeyValue(key=key, value=text)


def _stamp_text(stamp: Time) -> str:
    return f"{int(stamp.sec)}.{int(stamp.nanosec):09d}"


def prediction_status(
    prediction: Prediction,
    decision: Decision,
    *,
    stamp: Time,
    compute_s: float,
    hardware_id: str,
) -> DiagnosticStatus:
    """The ``prediction/status`` message of a prediction.

    Level OK when accepted, WARN otherwise (will not seat, or seats without the required
    margin), ERROR when the simulator called the input invalid. The message is
    ``"<OUTCOME>: <reason>"``; values are listed in docs/ros.md.
    """
    if prediction.outcome is Outcome.INVALID_INPUT:
        level = DiagnosticStatus.ERROR
    elif decision.accepted:
        level = DiagnosticStatus.OK
    else:
        level = DiagnosticStatus.WARN
    message = f"{prediction.outcome.name}: {prediction.reason}"
    if prediction.seated and not decision.accepted:
        message += f" ({decision.why})"
    design = prediction.design
    values = [
        _kv("outcome", prediction.outcome.name),
        _kv("outcome_code", int(prediction.outcome)),
        _kv("accepted", decision.accepted),
        _kv("x0_m", prediction.x0),
        _kv("theta0_rad", prediction.theta0),
        _kv("y_start_m", prediction.y_start),
        _kv("required_margin_m", decision.required_m),
    ]
    if prediction.margins is not None:
        m = prediction.margins
        values += [
            _kv("margin_m", float(decision.margin_m) if decision.margin_m is not None else ""),
            _kv("margin_lateral_minus_m", m.lateral_minus),
            _kv("margin_lateral_plus_m", m.lateral_plus),
            _kv("margin_angle_minus_rad", m.angle_minus),
            _kv("margin_angle_plus_rad", m.angle_plus),
        ]
    seat = moving_pose(prediction.pivot_m[0], prediction.pivot_m[1], prediction.phi_m)
    c = prediction.counters
    values += [
        _kv("final_phi_b_rad", prediction.phi_b),
        _kv("final_phi_m_rad", prediction.phi_m),
        _kv("final_x_m", seat.x),
        _kv("final_y_m", seat.y),
        _kv("final_yaw_rad", seat.yaw),
        _kv("steps", c.steps),
        _kv("events", c.events),
        _kv("contact_changes", c.contact_changes),
        _kv("rejected_steps", c.rejected_steps),
        _kv("compute_time_ms", compute_s * 1e3),
        _kv("input_stamp", _stamp_text(stamp)),
        _kv("input_stamp_ns", stamp_to_ns(stamp)),
        _kv("face", design.kind),
        _kv("width_m", design.width),
        _kv("h_over_d", design.h_over_d),
        _kv("r_p", design.r_p),
    ]
    return DiagnosticStatus(
        level=level, name=STATUS_NAME, message=message, hardware_id=hardware_id, values=values
    )


def input_error_status(error: InputRejected, *, stamp: Time, hardware_id: str) -> DiagnosticStatus:
    """The ERROR ``prediction/status`` of a rejected input."""
    return DiagnosticStatus(
        level=DiagnosticStatus.ERROR,
        name=STATUS_NAME,
        message=f"INVALID_INPUT: {error.code}: {error.detail}",
        hardware_id=hardware_id,
        values=[
            _kv("outcome", Outcome.INVALID_INPUT.name),
            _kv("outcome_code", int(Outcome.INVALID_INPUT)),
            _kv("accepted", False),
            _kv("input_error", error.code),
            _kv("input_stamp", _stamp_text(stamp)),
            _kv("input_stamp_ns", stamp_to_ns(stamp)),
        ],
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


def seated_pose_msg(prediction: Prediction, header: Header) -> PoseStamped:
    """The final pose of the moving pivot frame (the seat, when it seats)."""
    final = moving_pose(prediction.pivot_m[0], prediction.pivot_m[1], prediction.phi_m)
    return PoseStamped(header=header, pose=planar_to_pose(final))


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
