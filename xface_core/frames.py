r"""Frames: 3D orientations to planar yaw, and relative poses to the simulator's start.

The ROS node (and any other caller with a pose estimate) gives the **relative pose**: the pose
of the moving part's pivot frame expressed in the base part's pivot frame, each frame with its
+y axis pointing out of its own face and +z normal to the docking plane::

        x_m <----+      moving pivot M at (x, y); at yaw = pi its +y_m points down,
                 |      out of the moving face, and its x_m points along -x_b
                 v +y_m
              /\/\/\/\    moving face  (the gap closes along -y_b: the approach)
              \/\/\/\/    base face
                 ^ +y_b
                 |
                 +----> +x_b    base pivot B at the origin

When seated at zero lateral offset the moving pivot is at ``(0, L)`` with ``yaw = pi``
(the two +y axes point at each other), where L is the mated pivot-to-pivot distance. The
approach runs along the base frame's -y. The simulator's start is then

    ``x0 = x``, ``theta0 = wrap(yaw - pi)``, ``y_start = y``.

Paths and final states come back in the same frame (the base frame as it was at the start):
a moving pivot at ``(px, py)`` with simulator angle ``phi_m`` is the pose
``(px, py, wrap(phi_m + pi))``.

Lengths are in the caller's unit (metres in the ROS node), angles in radians. Everything
here is pure math (no ROS import).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from .errors import InputError, XfaceValueError
from .geometry import FaceDesign

__all__ = [
    "DEFAULT_MAX_DISTANCE_WIDTHS",
    "DEFAULT_MAX_TILT_RAD",
    "MAX_FACING_ANGLE_RAD",
    "QUATERNION_NORM_TOL",
    "AbsurdDistanceError",
    "DockStart",
    "NonFiniteInputError",
    "NonPlanarOrientationError",
    "NonUnitQuaternionError",
    "NotFacingError",
    "PlanarPose",
    "check_distance",
    "check_facing",
    "mated_pose",
    "moving_pose",
    "path_poses",
    "planar_yaw",
    "relative_pose_to_start",
    "start_to_relative_pose",
    "wrap_angle",
    "yaw_to_quaternion",
]

FloatArray = npt.NDArray[np.float64]

#: Largest accepted | |q| - 1 |. Poses from float64 sources are normalised to ~1e-15 and from
#: float32 sources to ~1e-7; anything beyond 1e-3 is a bug upstream, not rounding.
QUATERNION_NORM_TOL = 1.0e-3

#: Default largest tilt (rad) of the moving frame's z axis away from the base frame's z axis.
#: The model is planar: a tilted connector meets the other at a different profile.
DEFAULT_MAX_TILT_RAD = 0.05

#: Default largest |x| or |y| in face widths before a pose is called absurd (a metre-scale
#: connector reported kilometres away is a unit or frame error, not a docking attempt).
DEFAULT_MAX_DISTANCE_WIDTHS = 1000.0

#: Largest |theta0| (rad) at which the faces still face each other. Beyond it the moving face
#: points away from the base (theta0 = pi, relative yaw 0 = the identity quaternion, is back to
#: back): the model has no docking to predict there.
MAX_FACING_ANGLE_RAD = math.pi / 2


class NonFiniteInputError(InputError):
    """A coordinate or quaternion component is NaN or infinite."""


class NonUnitQuaternionError(InputError):
    """The orientation quaternion is not normalised (beyond :data:`QUATERNION_NORM_TOL`)."""


class NonPlanarOrientationError(InputError):
    """The orientation rolls or pitches out of the docking plane beyond the tolerance."""


class AbsurdDistanceError(InputError):
    """The relative position is absurdly far for the connector's size."""


class NotFacingError(InputError):
    """The faces do not face each other: |theta0| > :data:`MAX_FACING_ANGLE_RAD`."""


class PlanarPose(NamedTuple):
    """A pose in the docking plane: position (length) and yaw (rad, about +z)."""

    x: float
    y: float
    yaw: float


class DockStart(NamedTuple):
    """The simulator's initial condition (see :func:`xface_core.predict`)."""

    x0: float
    """Lateral offset of the moving pivot (length)."""
    theta0: float
    """Moving part angle relative to the mated orientation, wrapped to (-pi, pi] (rad)."""
    y_start: float
    """Height of the moving pivot above the base pivot (length)."""


def wrap_angle(angle: float) -> float:
    """Wrap an angle (rad) to the half-open interval (-pi, pi].

    Examples
    --------
    >>> wrap_angle(3 * math.pi / 2)
    -1.5707963267948966
    >>> wrap_angle(-math.pi)
    3.141592653589793
    >>> wrap_angle(0.25)
    0.25
    """
    if not math.isfinite(angle):
        raise NonFiniteInputError(f"angle must be finite, got {angle!r}")
    wrapped = math.remainder(angle, 2.0 * math.pi)  # exact, in [-pi, pi]
    return math.pi if wrapped <= -math.pi else wrapped


def planar_yaw(
    qx: float,
    qy: float,
    qz: float,
    qw: float,
    *,
    max_tilt_rad: float = DEFAULT_MAX_TILT_RAD,
    norm_tol: float = QUATERNION_NORM_TOL,
) -> float:
    """The yaw (rad, in (-pi, pi]) of a unit quaternion that (nearly) rotates about +z only.

    Parameters
    ----------
    qx, qy, qz, qw : float
        The quaternion (ROS order x, y, z, w).
    max_tilt_rad : float
        Largest accepted angle (rad) between the rotated z axis and +z, i.e. the combined
        roll and pitch.
    norm_tol : float
        Largest accepted deviation of the quaternion's norm from 1.

    Raises
    ------
    NonFiniteInputError
        A component is NaN or infinite.
    NonUnitQuaternionError
        ``| |q| - 1 | > norm_tol``.
    NonPlanarOrientationError
        The tilt exceeds ``max_tilt_rad``.

    Examples
    --------
    >>> s = math.sin(0.3)
    >>> round(planar_yaw(0.0, 0.0, s, math.cos(0.3)), 12)
    0.6
    >>> planar_yaw(0.0, 0.0, 0.0, 2.0)
    Traceback (most recent call last):
    ...
    xface_core.frames.NonUnitQuaternionError: quaternion norm 2 is not 1 (tolerance 0.001)
    >>> planar_yaw(math.sin(0.1), 0.0, 0.0, math.cos(0.1))
    Traceback (most recent call last):
    ...
    xface_core.frames.NonPlanarOrientationError: orientation tilts 0.2 rad out of the plane ...
    """
    components = (qx, qy, qz, qw)
    if not all(math.isfinite(c) for c in components):
        raise NonFiniteInputError(f"quaternion has a non-finite component: {components!r}")
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not abs(norm - 1.0) <= norm_tol:
        raise NonUnitQuaternionError(
            f"quaternion norm {norm:.6g} is not 1 (tolerance {norm_tol:g})"
        )
    qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
    # z component of R(q) e_z; the tilt is the angle between the rotated z axis and +z. The
    # half-angle form keeps it accurate for small tilts (acos near 1 loses half the digits).
    tilt = 2.0 * math.atan2(math.hypot(qx, qy), math.hypot(qz, qw))
    if not tilt <= max_tilt_rad:
        raise NonPlanarOrientationError(
            f"orientation tilts {tilt:.3g} rad out of the plane (roll/pitch), "
            f"tolerance {max_tilt_rad:g} rad"
        )
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return wrap_angle(yaw)


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """The unit quaternion (x, y, z, w) of a rotation by ``yaw`` (rad) about +z.

    Examples
    --------
    >>> yaw_to_quaternion(math.pi)
    (0.0, 0.0, 1.0, 6.123233995736766e-17)
    >>> round(planar_yaw(*yaw_to_quaternion(-2.0)), 12)
    -2.0
    """
    half = 0.5 * yaw
    return (0.0, 0.0, math.sin(half), math.cos(half))


def check_distance(
    x: float, y: float, *, width: float, max_widths: float = DEFAULT_MAX_DISTANCE_WIDTHS
) -> None:
    """Raise unless ``x`` and ``y`` are finite and within ``max_widths`` face widths.

    Raises
    ------
    NonFiniteInputError, AbsurdDistanceError

    Examples
    --------
    >>> check_distance(0.01, 0.2, width=0.05)
    >>> check_distance(0.0, 80.0, width=0.05)
    Traceback (most recent call last):
    ...
    xface_core.frames.AbsurdDistanceError: |y| = 80 is 1600 face widths, more than 1000
    """
    if not (math.isfinite(x) and math.isfinite(y)):
        raise NonFiniteInputError(f"position must be finite, got x={x!r}, y={y!r}")
    if not (math.isfinite(width) and width > 0.0):
        raise XfaceValueError(f"width must be finite and > 0, got {width!r}")
    for name, value in (("x", x), ("y", y)):
        if abs(value) > max_widths * width:
            raise AbsurdDistanceError(
                f"|{name}| = {abs(value):g} is {abs(value) / width:.4g} face widths, "
                f"more than {max_widths:g}"
            )


def check_facing(theta0: float) -> None:
    """Raise unless the faces face each other, ``|theta0| <= pi/2`` (NaN is left to the
    finiteness checks).

    Raises
    ------
    NotFacingError

    Examples
    --------
    >>> check_facing(0.3)
    >>> check_facing(math.pi)
    Traceback (most recent call last):
    ...
    xface_core.frames.NotFacingError: |theta0| = 3.142 rad > pi/2: the faces do not face ...
    """
    if abs(theta0) > MAX_FACING_ANGLE_RAD:
        raise NotFacingError(
            f"|theta0| = {abs(theta0):.4g} rad > pi/2: the faces do not face each other "
            "(theta0 = 0, relative yaw pi, is aligned; relative yaw 0, the identity "
            "quaternion, is back to back)"
        )


def relative_pose_to_start(pose: PlanarPose) -> DockStart:
    """The simulator's start from the relative pose of the moving pivot frame.

    Examples
    --------
    >>> relative_pose_to_start(PlanarPose(0.01, 0.3, math.pi - 0.2))
    DockStart(x0=0.01, theta0=-0.2..., y_start=0.3)
    """
    return DockStart(x0=pose.x, theta0=wrap_angle(pose.yaw - math.pi), y_start=pose.y)


def start_to_relative_pose(start: DockStart) -> PlanarPose:
    """The inverse of :func:`relative_pose_to_start`.

    Examples
    --------
    >>> start_to_relative_pose(DockStart(0.01, 0.0, 0.3))
    PlanarPose(x=0.01, y=0.3, yaw=3.141592653589793)
    """
    return moving_pose(start.x0, start.y_start, start.theta0)


def moving_pose(pivot_x: float, pivot_y: float, phi_m: float) -> PlanarPose:
    """The relative pose of the moving pivot frame for a simulator state.

    ``pivot_x, pivot_y`` is the moving pivot (length) and ``phi_m`` the moving part's
    simulator angle (rad), both in the base frame as it was at the start.
    """
    return PlanarPose(float(pivot_x), float(pivot_y), wrap_angle(phi_m + math.pi))


def mated_pose(design: FaceDesign, x0: float) -> PlanarPose:
    """The relative pose in which the parts seat for lateral offset ``x0`` (length).

    Both parts end at the common angle phi with ``sin phi = -x0 / L`` (MODEL.md, "Mated
    pose"); the moving pivot keeps ``x = x0`` and sits at ``y = L cos phi``.

    Raises
    ------
    XfaceValueError
        ``|x0| > L``: no seated pose exists.

    Examples
    --------
    >>> from xface_core.geometry import x_face
    >>> mated_pose(x_face(0.25, 2.0, width=0.05), 0.0)
    PlanarPose(x=0.0, y=0.2125, yaw=3.141592653589793)
    """
    phi = design.seated_angle(x0)
    length = design.mated_distance * design.width
    return moving_pose(-length * math.sin(phi), length * math.cos(phi), phi)


def path_poses(pivot_m: npt.ArrayLike, phi_m: npt.ArrayLike) -> FloatArray:
    """Relative poses along a path: an (n, 3) array of x, y (length) and yaw (rad).

    ``pivot_m`` is (n, 2) and ``phi_m`` (n,), as in :class:`xface_core.result.AlignmentPath`.

    Examples
    --------
    >>> path_poses([[0.0, 1.0], [0.0, 0.5]], [0.0, -0.1])
    array([[0.        , 1.        , 3.14159265],
           [0.        , 0.5       , 3.04159265]])
    """
    pivots = np.asarray(pivot_m, dtype=np.float64).reshape(-1, 2)
    angles = np.asarray(phi_m, dtype=np.float64).reshape(-1)
    if pivots.shape[0] != angles.shape[0]:
        raise XfaceValueError(
            f"pivot_m has {pivots.shape[0]} rows but phi_m has {angles.shape[0]} entries"
        )
    if not (np.all(np.isfinite(pivots)) and np.all(np.isfinite(angles))):
        raise NonFiniteInputError("path has non-finite entries")
    yaw = np.remainder(angles + math.pi, 2.0 * math.pi)  # phi + pi, in [0, 2 pi)
    yaw = np.where(yaw > math.pi, yaw - 2.0 * math.pi, yaw)  # (-pi, pi]
    return np.column_stack((pivots, yaw))
