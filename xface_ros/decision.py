"""What the node decides, without ROS: input checks, which start to predict, the verdict.

Imports no rclpy and no message package (plain Python and :mod:`xface_core` only), so every
rule here is tested where ROS is not installed (tests/ros/test_decision.py proves it in a
subprocess that cannot import rclpy). The node converts a received message to a
:class:`PoseInput` (plain values) and hands it over; what comes back is a :class:`Verdict`:

* :class:`Rejected`: the pose is not predicted; ``code`` (a key of :data:`INPUT_ERRORS`)
  and ``detail`` say why. The node publishes an ERROR status and nothing else.
* :class:`Predicted`: the simulation ran; ``decision`` says whether it counts as accepted
  (it seats with the required margin) and why, ``seated_pose`` is the seat or None.

What ``/diagnostics`` counts of the verdicts is :mod:`xface_ros.stats`. Units: lengths in
metres, angles in radians, stamps and clocks in nanoseconds, durations in seconds unless a
name ends in ``_ms``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import ClassVar

from xface_core.atlas.approach import suggest_approach
from xface_core.atlas.build import AcceptanceAtlas
from xface_core.atlas.probability import seat_probability
from xface_core.codes import Outcome
from xface_core.errors import XfaceError
from xface_core.frames import (
    AbsurdDistanceError,
    DockStart,
    NonPlanarOrientationError,
    NonUnitQuaternionError,
    NotFacingError,
    PlanarPose,
    check_distance,
    check_facing,
    moving_pose,
    planar_yaw,
    relative_pose_to_start,
)
from xface_core.predict import predict
from xface_core.result import Margins, Prediction
from xface_ros.config import NodeConfig, normalise_frame_id

__all__ = [
    "ANSWERS",
    "INPUT_ERRORS",
    "Decision",
    "InputRejected",
    "PoseInput",
    "Predicted",
    "Rejected",
    "Verdict",
    "answer",
    "check_pose",
    "combined_margin",
    "decide",
    "evaluate",
    "evaluate_dock_query",
    "evaluate_query",
    "evaluate_streamed",
    "required_margin_m",
    "simulate",
]

#: How the node's seat probabilities decide poses near a boundary: from the straight
#: boundaries between its atlas's edge flips (the node builds it with every flip), which
#: keeps the covariance stream at sensor rate (docs/atlas.md, "Seat probability").
SEAT_BOUNDARY = "atlas"

#: Input error codes (the ``input_error`` value of an ERROR status), with what they mean.
INPUT_ERRORS: dict[str, str] = {
    "non_finite": "a position or quaternion component is NaN or infinite",
    "wrong_frame": "header.frame_id is not the base_frame parameter",
    "stale_stamp": "the stamp is older than input_timeout_s",
    "future_stamp": "the stamp lies more than input_timeout_s in the future",
    "unnormalised_quaternion": "the quaternion's norm is not 1",
    "non_planar": "the orientation rolls or pitches beyond max_tilt_rad",
    "absurd_distance": "|x| or |y| is beyond max_distance_widths face widths",
    "not_facing": "|theta0| > pi/2: the faces do not face each other (yaw 0 is back to back)",
    "no_pose": "no pose has been received yet (service: empty start frame id)",
    "bad_tolerance": "the query's tolerance is negative or not finite",
    "bad_required_margin": "the predict_dock request's required_margin is negative or not finite",
    "bad_required_probability": "the predict_dock request's required_probability is not in [0, 1]",
    "bad_covariance": "the pose's (x, yaw) covariance is not finite, symmetric and positive "
    "semi-definite",
    "invalid_input": "the simulator refused the start (e.g. the parts interpenetrate)",
    "internal_error": "the simulator failed unexpectedly (a bug: the message has the details)",
}


class InputRejected(Exception):
    """An input pose that is not predicted; ``code`` is a key of :data:`INPUT_ERRORS`."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(f"{code}: {detail}")
        self.code = code
        self.detail = detail


@dataclass(frozen=True)
class PoseInput:
    """A received ``geometry_msgs/PoseStamped`` as plain values.

    ``position`` (x, y, z) in metres, ``orientation`` the quaternion (x, y, z, w),
    ``stamp_ns`` the header stamp in nanoseconds, ``frame_id`` the header's frame.
    """

    frame_id: str
    stamp_ns: int
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    covariance: tuple[float, float, float, float] | None = None
    """The (x, yaw) block of a ``PoseWithCovarianceStamped`` covariance, row-major
    (m^2, m rad, rad m, rad^2): the covariance of (x0, theta0). None: the pose is exact."""


# --- input checks, in the documented order: frame, finiteness, stamp, quaternion, distance,
# --- facing ----------------------------------------------------------------------------------


def _check_frame(pose: PoseInput, base_frame: str) -> None:
    if normalise_frame_id(pose.frame_id) != base_frame:
        raise InputRejected(
            "wrong_frame", f"frame_id {pose.frame_id!r} is not the base frame {base_frame!r}"
        )


def _check_finite(pose: PoseInput) -> None:
    if not all(math.isfinite(v) for v in (*pose.position, *pose.orientation)):
        raise InputRejected(
            "non_finite", f"position {pose.position}, quaternion {pose.orientation}"
        )


def _check_stamp(stamp_ns: int, now_ns: int, timeout_s: float) -> None:
    """Stale or future stamps, judged against ``now_ns``; ``timeout_s`` 0 disables."""
    if timeout_s <= 0.0:
        return
    if stamp_ns == 0:  # "1.7e9 s old" would hide what happened: the sender never set it
        raise InputRejected("stale_stamp", "zero stamp: header.stamp was never set")
    age_s = (now_ns - stamp_ns) * 1e-9
    if age_s > timeout_s:
        raise InputRejected(
            "stale_stamp",
            f"pose is {age_s:.3f} s old, input_timeout_s {timeout_s:g}: a late pose, or clock "
            "skew (the sender's clock behind the node's; use_sim_time on one side only?)",
        )
    if -age_s > timeout_s:
        # Nothing arrives before it is sent: a stamp from the future is always clock skew.
        raise InputRejected(
            "future_stamp",
            f"clock skew: the stamp is {-age_s:.3f} s ahead of the node's clock "
            f"(input_timeout_s {timeout_s:g})",
        )


def _planar_pose(pose: PoseInput, config: NodeConfig) -> PlanarPose:
    """x, y (m) and yaw (rad) of a finite pose; z is ignored (the model is planar)."""
    x, y, _z = pose.position
    try:
        yaw = planar_yaw(*pose.orientation, max_tilt_rad=config.max_tilt_rad)
        check_distance(x, y, width=config.width_m, max_widths=config.max_distance_widths)
    except NonUnitQuaternionError as exc:
        raise InputRejected("unnormalised_quaternion", str(exc)) from exc
    except NonPlanarOrientationError as exc:
        raise InputRejected("non_planar", str(exc)) from exc
    except AbsurdDistanceError as exc:
        raise InputRejected("absurd_distance", str(exc)) from exc
    except XfaceError as exc:  # non-finite after all (cannot happen after _check_finite)
        raise InputRejected("non_finite", str(exc)) from exc
    return PlanarPose(float(x), float(y), yaw)


def check_pose(pose: PoseInput, config: NodeConfig, *, now_ns: int | None) -> DockStart:
    """Check an input pose and convert it to the simulator's start (x0, theta0, y_start).

    ``now_ns`` is the node clock (ns) to judge the stamp by; None skips the stamp check
    (planner queries about hypothetical poses).

    Raises
    ------
    InputRejected
        The first failed check, in the order frame, finiteness, stamp, quaternion, distance,
        facing (``|theta0| <= pi/2`` after the conversion).
    """
    _check_frame(pose, config.base_frame)
    _check_finite(pose)
    if now_ns is not None:
        _check_stamp(pose.stamp_ns, now_ns, config.input_timeout_s)
    start = relative_pose_to_start(_planar_pose(pose, config))
    try:
        check_facing(start.theta0)
    except NotFacingError as exc:
        raise InputRejected("not_facing", str(exc)) from exc
    return start


# --- acceptance -----------------------------------------------------------------------------


def combined_margin(margins: Margins, width: float) -> float:
    """One margin in metres: the smaller of the lateral margin and D times the angle margin.

    The paper's acceptance maps have axes x0 / D and theta0 (rad); measuring both in those
    units and scaling by D (``width``, m) gives a length: the distance, along either axis of
    the map, to the nearest pose with another outcome.
    """
    return min(margins.lateral, margins.angle * width)


@dataclass(frozen=True)
class Decision:
    """Whether a prediction counts as accepted, and why."""

    accepted: bool
    margin_m: float | None
    """Combined margin (m), None when margins were not computed."""
    required_m: float
    """The margin (m) asked for."""
    why: str
    seat_probability: float | None = None
    """P(seat) under the pose's covariance, None for an exact pose (or no atlas yet)."""
    suggestion: tuple[float, float] | None = None
    """(dx m, dtheta rad) that brings P(seat) to the required probability, when not accepted
    for want of it and a correction was found."""
    required_probability: float = 0.0
    """The P(seat) asked for of a pose with a covariance (``min_seat_probability``, or a
    ``predict_dock`` request's); 0: none."""


def decide(prediction: Prediction, *, required_margin_m: float) -> Decision:
    """Accepted = it seats and (when a margin, in m, is required) the combined margin suffices."""
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


def required_margin_m(tolerance_m: float, config: NodeConfig) -> float:
    """The margin (m) a query asks for: its tolerance when > 0, else (0) ``min_margin``.

    A negative or non-finite tolerance never gets here: :func:`evaluate_query` rejects it.
    """
    return tolerance_m if tolerance_m > 0.0 else config.min_margin


def _check_covariance(cov: tuple[float, float, float, float]) -> None:
    """Finite, symmetric (to round-off) and positive semi-definite, else ``bad_covariance``."""
    xx, xt, tx, tt = cov
    scale = max(abs(xx), abs(tt), 1e-300)
    if not all(math.isfinite(v) for v in cov):
        raise InputRejected("bad_covariance", f"covariance {cov!r} is not finite")
    if abs(xt - tx) > 1e-9 * scale:
        raise InputRejected("bad_covariance", f"covariance {cov!r} is not symmetric")
    if xx < 0.0 or tt < 0.0 or xx * tt - xt * tx < -1e-9 * scale * scale:
        raise InputRejected("bad_covariance", f"covariance {cov!r} is not positive semi-definite")


def _with_probability(
    decision: Decision,
    start: DockStart,
    cov: tuple[float, float, float, float],
    config: NodeConfig,
    atlas: AcceptanceAtlas | None,
) -> Decision:
    """The decision with P(seat) under the pose's covariance (read from the atlas: without a
    ready atlas it is not computed, since building one takes seconds) and, when the required
    probability (``decision.required_probability``) asks for more, not accepted with a
    suggested correction."""
    level = decision.required_probability
    if atlas is None:
        if level > 0.0 and decision.accepted:
            why = "seat probability not available yet (the atlas is being built)"
            return replace(decision, accepted=False, why=why)
        return decision
    matrix = ((cov[0], cov[1]), (cov[2], cov[3]))
    p = float(
        seat_probability(
            config.design,
            start.x0,
            start.theta0,
            matrix,
            physics=config.physics,
            atlas=atlas,
            boundary=SEAT_BOUNDARY,
        )
    )
    decision = replace(decision, seat_probability=p)
    if level <= 0.0 or p >= level:
        return decision
    suggestion = None
    if level < 1.0:
        s = suggest_approach(
            config.design, start.x0, start.theta0, matrix, level=level,
            physics=config.physics, atlas=atlas, probability=p, boundary=SEAT_BOUNDARY,
        )  # fmt: skip
        if s.reached:
            suggestion = (s.dx, s.dtheta)
    asked = "min_seat_probability" if level == config.min_seat_probability else "required"
    why = f"seat probability {p:.3g} < {asked} {level:.3g}"
    return replace(decision, accepted=False, why=why, suggestion=suggestion)


# --- verdicts -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Rejected:
    """A pose that is not predicted: publish an ERROR status with ``code`` and ``detail``."""

    stamp_ns: int
    """The input's stamp (ns), 0 when there was no input."""
    code: str
    """A key of :data:`INPUT_ERRORS`."""
    detail: str

    accepted = False
    seated_pose: ClassVar[PlanarPose | None] = None
    """A rejected pose has no seat (as :attr:`Predicted.seated_pose` when it does not seat)."""


@dataclass(frozen=True)
class Predicted:
    """A simulated pose: the prediction, whether it is accepted and how long it took."""

    stamp_ns: int
    """The input's stamp (ns)."""
    start: DockStart
    prediction: Prediction
    decision: Decision
    compute_s: float
    """Wall time of the simulation, margins included (s)."""

    @property
    def accepted(self) -> bool:
        """It seats (with the required margin)."""
        return self.decision.accepted

    @property
    def final_pose(self) -> PlanarPose:
        """The final pose of the moving pivot frame in the base frame at the start."""
        p = self.prediction
        return moving_pose(p.pivot_m[0], p.pivot_m[1], p.phi_m)

    @property
    def seated_pose(self) -> PlanarPose | None:
        """The pose it seats at (published, latched), or None when it does not seat."""
        return self.final_pose if self.prediction.seated else None


Verdict = Rejected | Predicted


#: The answer a planner reads first (the ``answer`` value of ``predict_status``), with what it
#: means; the reason and margins come with it.
ANSWERS: dict[str, str] = {
    "no_pose": "no pose has been received yet",
    "stale": "the latest pose is older than input_timeout_s",
    "invalid": "the pose was rejected (input_error says which check failed)",
    "will_not_seat": "simulated: it will not seat (outcome and reason say how it ends)",
    "seats_without_margin": "simulated: it seats, with less than the required margin",
    "seats": "simulated: it seats (with the required margin)",
}

#: Rejections with an answer of their own; every other input error answers "invalid".
_REJECTION_ANSWERS = {"no_pose": "no_pose", "stale_stamp": "stale"}


def answer(verdict: Verdict) -> str:
    """The key of :data:`ANSWERS` for a verdict."""
    if isinstance(verdict, Rejected):
        return _REJECTION_ANSWERS.get(verdict.code, "invalid")
    if verdict.accepted:
        return "seats"
    return "seats_without_margin" if verdict.prediction.seated else "will_not_seat"


def simulate(
    config: NodeConfig,
    start: DockStart,
    *,
    path: bool,
    margins: bool,
    atlas: AcceptanceAtlas | None = None,
) -> tuple[Prediction, float]:
    """Predict one start with the config's design and physics (margins from ``atlas`` when
    one is given: the same margins, searched with fewer simulations); the prediction and its
    wall time (s). Raises what :func:`xface_core.predict.predict` raises."""
    t0 = time.perf_counter()
    prediction = predict(
        config.design,
        start.x0,
        start.theta0,
        y_start=start.y_start,
        physics=config.physics,
        path=path,
        margins=margins,
        atlas=atlas if margins else None,
        margin_threads=config.margin_threads,
    )
    return prediction, time.perf_counter() - t0


def evaluate(
    pose: PoseInput,
    config: NodeConfig,
    *,
    now_ns: int | None,
    required_margin_m: float,
    path: bool,
    margins: bool,
    atlas: AcceptanceAtlas | None = None,
    required_probability: float | None = None,
) -> Verdict:
    """Check, simulate and decide one pose; never raises for a bad pose or a failed simulation.

    ``now_ns`` is the clock for the stamp check (None: no check), ``required_margin_m`` the
    combined margin (m) a seat needs, ``path`` / ``margins`` what the simulation computes,
    ``required_probability`` the P(seat) a pose with a covariance needs (None:
    ``min_seat_probability``).
    """
    try:
        start = check_pose(pose, config, now_ns=now_ns)
        if pose.covariance is not None:
            _check_covariance(pose.covariance)
    except InputRejected as exc:
        return Rejected(pose.stamp_ns, exc.code, exc.detail)
    try:
        prediction, compute_s = simulate(config, start, path=path, margins=margins, atlas=atlas)
    except XfaceError as exc:
        return Rejected(pose.stamp_ns, "invalid_input", str(exc))
    except Exception as exc:  # a bug in the simulator must not take the node down
        return Rejected(pose.stamp_ns, "internal_error", repr(exc))
    if prediction.outcome is Outcome.INVALID_INPUT:
        return Rejected(pose.stamp_ns, "invalid_input", prediction.reason)
    level = config.min_seat_probability if required_probability is None else required_probability
    decision = replace(
        decide(prediction, required_margin_m=required_margin_m), required_probability=level
    )
    if pose.covariance is not None:
        decision = _with_probability(decision, start, pose.covariance, config, atlas)
    return Predicted(pose.stamp_ns, start, prediction, decision, compute_s)


def evaluate_streamed(
    pose: PoseInput,
    config: NodeConfig,
    *,
    receive_ns: int,
    path: bool,
    atlas: AcceptanceAtlas | None = None,
) -> Verdict:
    """A streamed pose: the stamp is judged at arrival (``receive_ns``: waiting for the worker
    is the node's delay, not the input's), margins as configured, ``min_margin`` required."""
    return evaluate(
        pose,
        config,
        now_ns=receive_ns,
        required_margin_m=config.min_margin,
        path=path,
        margins=config.need_margins,
        atlas=atlas,
    )


def evaluate_query(
    requested: PoseInput,
    latest: PoseInput | None,
    config: NodeConfig,
    *,
    tolerance_m: float,
    now_ns: int,
    atlas: AcceptanceAtlas | None = None,
) -> Verdict:
    """A planner query (GetPlan): which start to predict, then the verdict, always with a path.

    An empty ``requested.frame_id`` means the latest streamed pose, subject to
    ``input_timeout_s`` against ``now_ns``; an explicit start is not checked for staleness
    (planners ask about hypothetical poses). ``tolerance_m`` > 0 is the required combined
    margin; 0 uses ``min_margin``; a negative or non-finite one is rejected (``bad_tolerance``).
    """
    if not (math.isfinite(tolerance_m) and tolerance_m >= 0.0):
        return Rejected(
            requested.stamp_ns,
            "bad_tolerance",
            f"tolerance {tolerance_m!r} m: a required margin is finite and >= 0 (0: min_margin)",
        )
    return _evaluate_start(
        requested, latest, config, tolerance_m=tolerance_m, now_ns=now_ns, atlas=atlas
    )


def evaluate_dock_query(
    requested: PoseInput,
    latest: PoseInput | None,
    config: NodeConfig,
    *,
    required_margin: float,
    required_probability: float,
    now_ns: int,
    atlas: AcceptanceAtlas | None = None,
) -> Verdict:
    """A ``predict_dock`` (PredictDock) query: as :func:`evaluate_query`, and a required P(seat).

    ``required_margin`` (m) > 0 is the required combined margin, 0 uses ``min_margin``;
    ``required_probability`` in (0, 1] the P(seat) a pose with a covariance needs, 0 uses
    ``min_seat_probability``. A negative or non-finite margin is rejected
    (``bad_required_margin``), a probability outside [0, 1] (``bad_required_probability``).
    ``requested.covariance``, when given, also applies to the latest pose (empty frame id);
    without one the latest pose keeps the covariance it came with, if any.
    """
    if not (math.isfinite(required_margin) and required_margin >= 0.0):
        return Rejected(
            requested.stamp_ns,
            "bad_required_margin",
            f"required_margin {required_margin!r} m: it is finite and >= 0 (0: min_margin)",
        )
    if not (math.isfinite(required_probability) and 0.0 <= required_probability <= 1.0):
        return Rejected(
            requested.stamp_ns,
            "bad_required_probability",
            f"required_probability {required_probability!r}: it is in [0, 1] "
            "(0: min_seat_probability)",
        )
    return _evaluate_start(
        requested,
        latest,
        config,
        tolerance_m=required_margin,
        now_ns=now_ns,
        atlas=atlas,
        required_probability=required_probability if required_probability > 0.0 else None,
    )


def _evaluate_start(
    requested: PoseInput,
    latest: PoseInput | None,
    config: NodeConfig,
    *,
    tolerance_m: float,
    now_ns: int,
    atlas: AcceptanceAtlas | None,
    required_probability: float | None = None,
) -> Verdict:
    """A query's verdict once its requirements are checked: the requested start or (empty
    frame id) the latest streamed pose, always with a path."""
    check_now_ns: int | None = None
    pose = requested
    if not requested.frame_id:
        if latest is None:
            return Rejected(0, "no_pose", "no pose received yet")
        pose, check_now_ns = latest, now_ns
        if requested.covariance is not None:
            pose = replace(pose, covariance=requested.covariance)
    required = required_margin_m(tolerance_m, config)
    return evaluate(
        pose,
        config,
        now_ns=check_now_ns,
        required_margin_m=required,
        path=True,
        margins=config.need_margins or required > 0.0,
        atlas=atlas,
        required_probability=required_probability,
    )
