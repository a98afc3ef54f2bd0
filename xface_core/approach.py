"""A robust approach: the smallest pose correction that makes a dock likely (or safe).

For a planner that can still correct before the faces touch. Two questions, one function:

- with a covariance: the smallest change (dx, dtheta) of the estimate, measured as a
  Mahalanobis distance under that covariance (how many standard deviations the correction
  is), after which :func:`~xface_core.probability.seat_probability` reaches ``level``;
- without one: the smallest change, measured as ``sqrt((dx / D)^2 + dtheta^2)`` (D-and-radian
  norm), after which the pose seats with margins at least ``min_lateral`` and ``min_angle``
  on both sides.

Candidates come from the atlas (the seated indicator smoothed by the Gaussian, or the
seated runs along rows and columns), nearest first; each is confirmed exactly (probability
or margins at that pose) and the correction is then shortened by bisection along the
straight line from the estimate while the requirement still holds. The result is a pose
that meets the requirement by exact computation; it is the smallest one among the tried
candidates' segments, not a proven global minimum.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .atlas import AcceptanceAtlas, build_atlas
from .atlas_margins import margins_from_atlas
from .codes import Outcome
from .errors import XfaceValueError
from .geometry import FaceDesign
from .physics import Physics
from .probability import checked_covariances, seat_probability
from .result import Margins
from .runner import check_pose, predict_batch

__all__ = ["ApproachSuggestion", "suggest_approach"]

FloatArray = npt.NDArray[np.float64]

#: Default margins required without a covariance: 0.05 D and 0.05 rad (about 3 degrees).
DEFAULT_MIN_LATERAL = 0.05
DEFAULT_MIN_ANGLE = 0.05
#: Candidates confirmed before giving up, and bisection steps along the segment.
MAX_CANDIDATES = 6
LINE_STEPS = 6


@dataclass(frozen=True)
class ApproachSuggestion:
    """A correction of the estimated pose and what it achieves."""

    dx: float
    """Lateral correction (the design's length unit)."""
    dtheta: float
    """Angle correction (rad)."""
    distance: float
    """Size of the correction in ``metric``."""
    metric: str
    """``"mahalanobis"`` (standard deviations under the covariance) or ``"scaled"``
    (``sqrt((dx / D)^2 + dtheta^2)``)."""
    reached: bool
    """True when the corrected pose meets the requirement (False: none of the candidates
    did; ``dx = dtheta = 0`` then)."""
    seat_probability: float | None = None
    """Seat probability at the corrected pose (with a covariance)."""
    margins: Margins | None = None
    """Margins at the corrected pose (without a covariance)."""


def _smoothed_seated(atlas: AcceptanceAtlas, cov_d: FloatArray) -> FloatArray:
    """The seated indicator of the atlas convolved with the Gaussian (sampled on the grid,
    by FFT): an estimate of the seat probability at every node."""
    seated = (atlas.outcomes == Outcome.SEATED).astype(np.float64)
    g = cov_d / np.outer(
        [atlas.lateral_step, atlas.angle_step], [atlas.lateral_step, atlas.angle_step]
    )
    half = [min(math.ceil(4.0 * math.sqrt(g[a, a])), seated.shape[a] - 1) for a in (0, 1)]
    if half[0] == 0 and half[1] == 0:
        return np.asarray(seated, dtype=np.float64)
    i = np.arange(-half[0], half[0] + 1)[:, None].astype(np.float64)
    k = np.arange(-half[1], half[1] + 1)[None, :].astype(np.float64)
    # A regularised inverse: a singular covariance smooths along one direction only.
    inv = np.linalg.inv(g + 1e-6 * np.eye(2))
    kernel = np.exp(-0.5 * (inv[0, 0] * i * i + 2 * inv[0, 1] * i * k + inv[1, 1] * k * k))
    kernel /= kernel.sum()
    shape = [seated.shape[a] + kernel.shape[a] - 1 for a in (0, 1)]
    full = np.fft.irfft2(np.fft.rfft2(seated, shape) * np.fft.rfft2(kernel, shape), shape)
    return np.asarray(
        full[half[0] : half[0] + seated.shape[0], half[1] : half[1] + seated.shape[1]]
    )


def _runs(mask: npt.NDArray[np.bool_], axis: int, reverse: bool) -> npt.NDArray[np.int64]:
    """Per node: how many True nodes follow it along ``axis`` (towards smaller indices
    when ``reverse``) before the first False one."""
    m = np.moveaxis(mask, axis, 0)
    out = np.zeros(m.shape, dtype=np.int64)
    order = range(1, m.shape[0]) if reverse else range(m.shape[0] - 2, -1, -1)
    for j in order:
        prev = j - 1 if reverse else j + 1
        out[j] = np.where(m[prev], out[prev] + 1, 0)
    return np.moveaxis(out, 0, axis)


def _safe_nodes(
    atlas: AcceptanceAtlas, min_lateral_d: float, min_angle: float
) -> npt.NDArray[np.bool_]:
    """Nodes that seat with at least the required run of seated nodes either side (in whole
    steps, so an under-estimate of the margins there)."""
    seated = atlas.outcomes == Outcome.SEATED
    need_x = math.ceil(min_lateral_d / atlas.lateral_step)
    need_t = math.ceil(min_angle / atlas.angle_step)
    return np.asarray(
        seated
        & (_runs(seated, 0, False) >= need_x)
        & (_runs(seated, 0, True) >= need_x)
        & (_runs(seated, 1, False) >= need_t)
        & (_runs(seated, 1, True) >= need_t)
    )


def _shortest(
    start: FloatArray,
    candidates: FloatArray,
    meets: Callable[[FloatArray], tuple[bool, object]],
) -> tuple[FloatArray, object] | None:
    """The first candidate (nearest first) meeting the requirement, pulled back towards
    ``start`` by bisection while it still holds; None if none of them does."""
    for target in candidates[:MAX_CANDIDATES]:
        ok, info = meets(target)
        if not ok:
            continue
        lo, hi, best = 0.0, 1.0, (target, info)
        for _ in range(LINE_STEPS):
            mid = 0.5 * (lo + hi)
            pose = start + mid * (target - start)
            ok, found = meets(pose)
            if ok:
                hi, best = mid, (pose, found)
            else:
                lo = mid
        return best
    return None


def suggest_approach(
    design: FaceDesign,
    x0: float,
    theta0: float,
    cov: npt.ArrayLike | None = None,
    *,
    level: float = 0.9,
    min_lateral: float | None = None,
    min_angle: float = DEFAULT_MIN_ANGLE,
    physics: Physics | None = None,
    atlas: AcceptanceAtlas | None = None,
) -> ApproachSuggestion:
    """The smallest correction of (x0, theta0) after which the dock is likely or safe.

    Parameters
    ----------
    design : FaceDesign
    x0, theta0 : float
        The estimated pose (length, rad).
    cov : (2, 2) array, optional
        Covariance of (x0, theta0) (length^2, length rad, rad^2). Given: the requirement is
        a seat probability of at least ``level`` and the metric the Mahalanobis distance of
        the correction under ``cov`` (regularised by 1e-6 of a squared atlas step, so a
        singular covariance still has one). None: the requirement is a seat with margins
        ``>= min_lateral`` and ``>= min_angle`` on both sides, the metric
        ``sqrt((dx / D)^2 + dtheta^2)``.
    level : float
        Required seat probability, in (0, 1).
    min_lateral : float, optional
        Required lateral margin (length; default 0.05 D).
    min_angle : float
        Required angular margin (rad; default 0.05).
    physics : Physics, optional
    atlas : AcceptanceAtlas, optional
        Built for this design and physics (default: one is built).

    Returns
    -------
    ApproachSuggestion
        ``dx = dtheta = 0`` with ``reached`` True when the estimate already meets the
        requirement.

    Examples
    --------
    The aligned pose of an X-Face already seats with margins of 0.05 D and 0.05 rad:

    >>> import xface_core as xf
    >>> design = xf.x_face(0.5, 1.0)
    >>> coarse = xf.build_atlas(design, lateral_step=0.125, angle_step=0.1, angle_range=1.7)
    >>> suggestion = suggest_approach(design, 0.0, 0.0, atlas=coarse)
    >>> suggestion.reached, suggestion.dx, suggestion.dtheta, suggestion.metric
    (True, 0.0, 0.0, 'scaled')
    """
    phys = Physics() if physics is None else physics
    check_pose(design, x0, theta0, None)
    at = build_atlas(design, physics=phys) if atlas is None else atlas
    at = at.bound_to(design, phys)
    w = design.width
    start = np.array([x0 / w, theta0])
    nodes = np.stack(np.meshgrid(at.x0, at.theta0, indexing="ij"), axis=-1)
    if cov is not None:
        if not 0.0 < level < 1.0:
            raise XfaceValueError(f"level must be in (0, 1), got {level!r}")
        c = checked_covariances(cov, 1)[0]
        cov_d = c / np.outer([w, 1.0], [w, 1.0])
        reg = cov_d + 1e-6 * np.diag([at.lateral_step**2, at.angle_step**2])
        inv = np.linalg.inv(reg)
        good = _smoothed_seated(at, cov_d) >= level
        metric = "mahalanobis"

        def measure(delta: FloatArray) -> FloatArray:
            return np.asarray(np.sqrt(np.einsum("...i,ij,...j->...", delta, inv, delta)))

        def meets(pose: FloatArray) -> tuple[bool, object]:
            p = float(seat_probability(design, pose[0] * w, pose[1], c, physics=phys, atlas=at))
            return p >= level, p

    else:
        lat = DEFAULT_MIN_LATERAL * w if min_lateral is None else float(min_lateral)
        if not (math.isfinite(lat) and lat >= 0 and math.isfinite(min_angle) and min_angle >= 0):
            raise XfaceValueError("min_lateral and min_angle must be finite and >= 0")
        good = _safe_nodes(at, lat / w, min_angle)
        metric = "scaled"

        def measure(delta: FloatArray) -> FloatArray:
            return np.asarray(np.hypot(delta[..., 0], delta[..., 1]))

        def meets(pose: FloatArray) -> tuple[bool, object]:
            code = Outcome(
                int(predict_batch(design, [pose[0] * w], [pose[1]], physics=phys).outcome[0])
            )
            if code is not Outcome.SEATED:
                return False, None
            m = margins_from_atlas(at, pose[0] * w, pose[1], code)
            return m.lateral >= lat and m.angle >= min_angle, m

    ok, info = meets(start)
    if ok:
        return _suggestion(start, start, measure, metric, True, info, w)
    candidates = nodes[good]
    order = np.argsort(measure(candidates - start))
    found = _shortest(start, candidates[order], meets)
    if found is None:
        return _suggestion(start, start, measure, metric, False, info, w)
    return _suggestion(start, found[0], measure, metric, True, found[1], w)


def _suggestion(
    start: FloatArray,
    pose: FloatArray,
    measure: Callable[[FloatArray], FloatArray],
    metric: str,
    reached: bool,
    info: object,
    width: float,
) -> ApproachSuggestion:
    delta = pose - start
    return ApproachSuggestion(
        dx=float(delta[0] * width),
        dtheta=float(delta[1]),
        distance=float(measure(delta)),
        metric=metric,
        reached=reached,
        seat_probability=info if isinstance(info, float) else None,
        margins=info if isinstance(info, Margins) else None,
    )
