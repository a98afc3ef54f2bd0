"""A robust approach: the smallest pose correction that makes a dock likely (or safe).

For a planner that can still correct before the faces touch. Two questions, one function:

- with a covariance: the smallest change (dx, dtheta) of the estimate, measured as a
  Mahalanobis distance under that covariance (how many standard deviations the correction
  is), after which :func:`~xface_core.atlas.probability.seat_probability` reaches ``level``;
- without one: the smallest change, measured as ``sqrt((dx / D)^2 + dtheta^2)`` (D-and-radian
  norm), after which the pose seats with margins at least ``min_lateral`` and ``min_angle``
  on both sides.

Candidates come from the atlas (the seated indicator smoothed by the Gaussian, in windows
around the estimate growing to the whole grid; or the seated runs along rows and columns),
nearest first; each is confirmed exactly (probability or margins at that pose) and the
correction is then shortened along the straight line from the estimate while the
requirement still holds (the probability's crossing by regula falsi on its probit, the
margins' by bisection), to 1/64 of the segment. The result is a pose that meets the
requirement by exact computation; it is the smallest one among the tried candidates'
segments, not a proven global minimum.
"""

from __future__ import annotations

import itertools
import math
import statistics
import threading
import weakref
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics
from xface_core.result import Margins
from xface_core.runner import check_pose, outcomes_at

from .build import AcceptanceAtlas, build_atlas
from .lookup import margins_from_atlas
from .probability import checked_covariances, seat_probability

__all__ = ["ApproachSuggestion", "suggest_approach"]

FloatArray = npt.NDArray[np.float64]

#: Default margins required without a covariance: 0.05 D and 0.05 rad (about 3 degrees).
DEFAULT_MIN_LATERAL = 0.05
DEFAULT_MIN_ANGLE = 0.05
#: Candidates confirmed before giving up, and bisection steps along the segment (its
#: resolution: 1/64 of the segment; the probability's secant stops at the same width).
MAX_CANDIDATES = 6
LINE_STEPS = 6
#: Radii (standard deviations) of the windows around the estimate in which candidates are
#: looked for before the whole atlas is smoothed.
WINDOW_RADII = (8.0, 32.0)


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


def _smoothed_seated(
    atlas: AcceptanceAtlas, cov_d: FloatArray, rows: slice, cols: slice
) -> FloatArray:
    """The seated indicator of the atlas convolved with the Gaussian (sampled on the grid,
    by FFT) at the nodes ``[rows, cols]``: an estimate of the seat probability there.

    Only the window and a kernel's half-width around it enter the convolution (outside the
    grid counts as not seated, as over the whole grid), so a window costs what its size does:
    the whole node atlas took 25-60 ms, a window of a few sigma well under a millisecond."""
    g = cov_d / np.outer(
        [atlas.lateral_step, atlas.angle_step], [atlas.lateral_step, atlas.angle_step]
    )
    shape_all = atlas.outcomes.shape
    half = [min(math.ceil(4.0 * math.sqrt(g[a, a])), shape_all[a] - 1) for a in (0, 1)]
    lo = [max(w.start - h, 0) for w, h in zip((rows, cols), half, strict=True)]
    hi = [min(w.stop + h, n) for w, h, n in zip((rows, cols), half, shape_all, strict=True)]
    seated = (atlas.outcomes[lo[0] : hi[0], lo[1] : hi[1]] == Outcome.SEATED).astype(np.float64)
    # Where the window starts inside the block that was convolved.
    i0, k0 = rows.start - lo[0], cols.start - lo[1]
    n0, n1 = rows.stop - rows.start, cols.stop - cols.start
    if half[0] == 0 and half[1] == 0:
        return np.asarray(seated[i0 : i0 + n0, k0 : k0 + n1])
    i = np.arange(-half[0], half[0] + 1)[:, None].astype(np.float64)
    k = np.arange(-half[1], half[1] + 1)[None, :].astype(np.float64)
    # A regularised inverse: a singular covariance smooths along one direction only.
    inv = np.linalg.inv(g + 1e-6 * np.eye(2))
    kernel = np.exp(-0.5 * (inv[0, 0] * i * i + 2 * inv[0, 1] * i * k + inv[1, 1] * k * k))
    kernel /= kernel.sum()
    shape = [seated.shape[a] + kernel.shape[a] - 1 for a in (0, 1)]
    full = np.fft.irfft2(np.fft.rfft2(seated, shape) * np.fft.rfft2(kernel, shape), shape)
    return np.asarray(full[half[0] + i0 : half[0] + i0 + n0, half[1] + k0 : half[1] + k0 + n1])


class _KeptPerAtlas:
    """Arrays computed from an atlas, kept for the last ``kept`` keys of each atlas (weakly:
    an atlas dropped by its owner takes its arrays with it). Thread-safe; a value computed
    twice at once by two threads is kept once."""

    def __init__(self, kept: int) -> None:
        self._kept = kept
        self._store: weakref.WeakKeyDictionary[AcceptanceAtlas, dict[object, FloatArray]] = (
            weakref.WeakKeyDictionary()
        )
        self._lock = threading.Lock()

    def get(
        self, atlas: AcceptanceAtlas, key: object, make: Callable[[], FloatArray]
    ) -> FloatArray:
        """The array kept for ``key``, or ``make()``'s, then kept."""
        with self._lock:
            found = self._store.setdefault(atlas, {}).get(key)
        if found is None:
            found = make()
            with self._lock:
                kept = self._store.setdefault(atlas, {})
                if len(kept) >= self._kept:
                    del kept[next(iter(kept))]
                kept[key] = found
        return found


#: Whole-grid smoothings kept per atlas (a stream's covariance is often the same from pose
#: to pose, and one that no correction can satisfy asks for the whole grid every time).
WHOLE_KEPT = 4
_WHOLE = _KeptPerAtlas(WHOLE_KEPT)


def _smoothed(atlas: AcceptanceAtlas, cov_d: FloatArray, rows: slice, cols: slice) -> FloatArray:
    """:func:`_smoothed_seated`, with the whole grid's kept for the last WHOLE_KEPT
    covariances of each atlas."""
    if (rows.start, rows.stop, cols.start, cols.stop) != (0, atlas.x0.size, 0, atlas.theta0.size):
        return _smoothed_seated(atlas, cov_d, rows, cols)
    return _WHOLE.get(atlas, cov_d.tobytes(), lambda: _smoothed_seated(atlas, cov_d, rows, cols))


def _likely_nodes(
    atlas: AcceptanceAtlas,
    start: FloatArray,
    cov_d: FloatArray,
    reg: FloatArray,
    level: float,
    measure: Callable[[FloatArray], FloatArray],
) -> Iterator[FloatArray]:
    """Atlas nodes whose smoothed seat estimate reaches ``level``, nearest first in the
    Mahalanobis metric, found in windows of growing radius around ``start`` (D, rad).

    A window reaching ``radius`` standard deviations (of ``reg``) from ``start`` along both
    axes holds every node nearer than that: its nodes nearer than ``radius`` come in order
    before any node of the next, wider window. The last round is the whole grid."""
    steps = np.array([atlas.lateral_step, atlas.angle_step])
    origin = np.array([atlas.x0[0], atlas.theta0[0]])
    shape = atlas.outcomes.shape
    centre = (start - origin) / steps
    done = -1.0  # nodes nearer than this came in an earlier round (none before the first)
    for radius in (*WINDOW_RADII, math.inf):
        if math.isfinite(radius):
            reach = radius * np.sqrt(np.diag(reg)) / steps
            lo = np.maximum(np.floor(centre - reach).astype(np.int64), 0)
            hi = np.minimum(np.ceil(centre + reach).astype(np.int64) + 1, shape)
            if np.any(lo >= hi):
                continue  # the window lies off the grid
            rows, cols = slice(int(lo[0]), int(hi[0])), slice(int(lo[1]), int(hi[1]))
        else:
            rows, cols = slice(0, shape[0]), slice(0, shape[1])
        good = _smoothed(atlas, cov_d, rows, cols) >= level
        nodes = np.stack(np.meshgrid(atlas.x0[rows], atlas.theta0[cols], indexing="ij"), axis=-1)[
            good
        ]
        dist = measure(nodes - start)
        band = (dist > done) & (dist <= radius)
        for j in np.flatnonzero(band)[np.argsort(dist[band], kind="stable")]:
            yield nodes[j]
        done = radius


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


def _safe_nodes(atlas: AcceptanceAtlas, need_x: int, need_t: int) -> npt.NDArray[np.bool_]:
    """Nodes that seat with at least ``need_x`` seated nodes either side along x0 and
    ``need_t`` along theta0 (:func:`_required_runs`)."""
    seated = atlas.outcomes == Outcome.SEATED
    return np.asarray(
        seated
        & (_runs(seated, 0, False) >= need_x)
        & (_runs(seated, 0, True) >= need_x)
        & (_runs(seated, 1, False) >= need_t)
        & (_runs(seated, 1, True) >= need_t)
    )


def _nearest(dist: FloatArray, k: int) -> npt.NDArray[np.intp]:
    """Indices of the ``k`` smallest distances, nearest first, ties in index order: the
    first ``k`` of a stable argsort, without sorting them all (a node atlas has some 10^4
    candidate nodes, and at most MAX_CANDIDATES are tried)."""
    if dist.size <= k:
        return np.argsort(dist, kind="stable")
    kth = np.partition(dist, k - 1)[k - 1]
    within = np.flatnonzero(dist <= kth)  # k or more (ties), in index order
    return within[np.argsort(dist[within], kind="stable")][:k]


#: Safe nodes' coordinates kept per atlas, for the last SAFE_KEPT margin requirements (a
#: planner asks with the same ones every time; finding them takes about 10 ms).
SAFE_KEPT = 4
_SAFE = _KeptPerAtlas(SAFE_KEPT)


def _required_runs(
    atlas: AcceptanceAtlas, min_lateral_d: float, min_angle: float
) -> tuple[int, int]:
    """The margins (D, rad) in whole atlas steps along x0 and theta0, rounded up (so the safe
    nodes under-estimate the margins there)."""
    return math.ceil(min_lateral_d / atlas.lateral_step), math.ceil(min_angle / atlas.angle_step)


def _safe_coordinates(atlas: AcceptanceAtlas, min_lateral_d: float, min_angle: float) -> FloatArray:
    """(x0 in D, theta0) of :func:`_safe_nodes`, an (n, 2) array, kept per atlas for the
    last SAFE_KEPT requirements (in whole atlas steps, which is all the nodes depend on)."""
    key = _required_runs(atlas, min_lateral_d, min_angle)

    def make() -> FloatArray:
        good = _safe_nodes(atlas, *key)
        nodes = np.stack(np.meshgrid(atlas.x0, atlas.theta0, indexing="ij"), axis=-1)[good]
        return np.asarray(nodes)

    return _SAFE.get(atlas, key, make)


def _first_meeting(
    candidates: Iterable[FloatArray], meets: Callable[[FloatArray], tuple[bool, object]]
) -> tuple[FloatArray, object] | None:
    """The first of at most MAX_CANDIDATES candidates (nearest first) that meets the
    requirement exactly, with what ``meets`` found there; None if none of them does."""
    for target in itertools.islice(candidates, MAX_CANDIDATES):
        ok, info = meets(target)
        if ok:
            return target, info
    return None


def _bisect_back(
    start: FloatArray,
    target: FloatArray,
    info: object,
    meets: Callable[[FloatArray], tuple[bool, object]],
) -> tuple[FloatArray, object]:
    """``target`` pulled back towards ``start`` along the straight line by LINE_STEPS
    bisection steps while the requirement (a yes or no: margins) still holds."""
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


_NORMAL = statistics.NormalDist()


def _probit(p: float) -> float:
    """The standard normal quantile of ``p`` (clipped to 1e-12 from 0 and 1): across a
    straight boundary the seat probability is the normal CDF of a linear function of the
    position, so its probit is linear along a line."""
    return _NORMAL.inv_cdf(min(max(p, 1e-12), 1.0 - 1e-12))


def _secant_back(
    start: FloatArray,
    target: FloatArray,
    p_start: float,
    p_target: float,
    probability_at: Callable[[FloatArray], float],
    level: float,
) -> tuple[FloatArray, float]:
    """``target`` pulled back towards ``start`` to where the seat probability falls to
    ``level``, to the same width as LINE_STEPS bisection steps (1/64 of the segment).

    The probability is the Gaussian's mass over the seated region, smooth along the line,
    and across a straight boundary the normal CDF of a linear function of the position: so
    the crossing is found by regula falsi on its probit (:func:`_probit`), with the Illinois
    rule (the retained end's value halved when the same end is kept twice), instead of
    bisection: typically two or three exact evaluations instead of six. Each point tried
    stays at least half the width inside the bracket, so an estimate that lands next to one
    end closes the bracket with the next evaluation. The end kept as the answer always has
    an exact probability >= ``level``; at most LINE_STEPS evaluations."""
    width = 0.5**LINE_STEPS
    lo, hi = 0.0, 1.0
    z_level = _probit(level)
    v_lo, v_hi = _probit(p_start) - z_level, _probit(p_target) - z_level
    best = (target, p_target)
    kept = 0  # +1: the last step moved hi, -1: lo
    for _ in range(LINE_STEPS):
        if hi - lo <= width:
            break
        f = hi - v_hi * (hi - lo) / (v_hi - v_lo) if v_hi > v_lo else 0.5 * (lo + hi)
        f = min(max(f, lo + 0.5 * width), hi - 0.5 * width)
        pose = start + f * (target - start)
        p = probability_at(pose)
        if p >= level:
            hi, v_hi, best = f, _probit(p) - z_level, (pose, p)
            if kept > 0:
                v_lo *= 0.5
            kept = 1
        else:
            lo, v_lo = f, _probit(p) - z_level
            if kept < 0:
                v_hi *= 0.5
            kept = -1
    return best


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
    probability: float | None = None,
    boundary: str = "exact",
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
    probability : float, optional
        With ``cov``: the seat probability at (x0, theta0) when the caller has computed it
        already (:func:`~xface_core.atlas.probability.seat_probability` with this atlas, as the
        ROS node has): spares that evaluation. In [0, 1].
    boundary : {"exact", "atlas"}
        With ``cov``: how each seat probability decides the poses near a boundary
        (:func:`~xface_core.atlas.probability.seat_probability`'s ``boundary``).

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
    start = np.array([x0 / design.width, theta0])
    if cov is not None:
        return _by_probability(at, start, cov, level, probability, boundary)
    return _by_margins(at, start, min_lateral, min_angle)


def _by_probability(
    at: AcceptanceAtlas,
    start: FloatArray,
    cov: npt.ArrayLike,
    level: float,
    probability: float | None,
    boundary: str,
) -> ApproachSuggestion:
    """:func:`suggest_approach` with a covariance (``start`` in D and rad)."""
    if not 0.0 < level < 1.0:
        raise XfaceValueError(f"level must be in (0, 1), got {level!r}")
    if probability is not None and not 0.0 <= probability <= 1.0:
        raise XfaceValueError(f"probability must be in [0, 1], got {probability!r}")
    design, w = at.design, at.design.width
    c = checked_covariances(cov, 1)[0]
    cov_d = c / np.outer([w, 1.0], [w, 1.0])
    reg = cov_d + 1e-6 * np.diag([at.lateral_step**2, at.angle_step**2])
    inv = np.linalg.inv(reg)

    def measure(delta: FloatArray) -> FloatArray:
        return np.asarray(np.sqrt(np.einsum("...i,ij,...j->...", delta, inv, delta)))

    def probability_at(pose: FloatArray) -> float:
        p = seat_probability(
            design, pose[0] * w, pose[1], c, physics=at.physics, atlas=at, boundary=boundary
        )
        return float(p)

    def meets(pose: FloatArray) -> tuple[bool, object]:
        p = probability_at(pose)
        return p >= level, p

    p_start = probability_at(start) if probability is None else float(probability)
    if p_start >= level:
        return _suggestion(start, start, measure, "mahalanobis", True, p_start, w)
    found = _first_meeting(_likely_nodes(at, start, cov_d, reg, level, measure), meets)
    if found is None:
        return _suggestion(start, start, measure, "mahalanobis", False, p_start, w)
    target, p_target = found
    assert isinstance(p_target, float)
    pose, p = _secant_back(start, target, p_start, p_target, probability_at, level)
    return _suggestion(start, pose, measure, "mahalanobis", True, p, w)


def _by_margins(
    at: AcceptanceAtlas, start: FloatArray, min_lateral: float | None, min_angle: float
) -> ApproachSuggestion:
    """:func:`suggest_approach` without a covariance (``start`` in D and rad)."""
    design, w = at.design, at.design.width
    lat = DEFAULT_MIN_LATERAL * w if min_lateral is None else float(min_lateral)
    if not (math.isfinite(lat) and lat >= 0 and math.isfinite(min_angle) and min_angle >= 0):
        raise XfaceValueError("min_lateral and min_angle must be finite and >= 0")

    def measure(delta: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(delta[..., 0], delta[..., 1]))

    def meets(pose: FloatArray) -> tuple[bool, object]:
        code = Outcome(int(outcomes_at(design, pose[0], pose[1], at.physics)))
        if code is not Outcome.SEATED:
            return False, None
        m = margins_from_atlas(at, pose[0] * w, pose[1], code)
        return m.lateral >= lat and m.angle >= min_angle, m

    ok, info = meets(start)
    if ok:
        return _suggestion(start, start, measure, "scaled", True, info, w)
    nodes = _safe_coordinates(at, lat / w, min_angle)
    found = _first_meeting(nodes[_nearest(measure(nodes - start), MAX_CANDIDATES)], meets)
    if found is None:
        return _suggestion(start, start, measure, "scaled", False, info, w)
    pose, info = _bisect_back(start, found[0], found[1], meets)
    return _suggestion(start, pose, measure, "scaled", True, info, w)


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
