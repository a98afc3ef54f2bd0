"""Margins: how far a query pose is from the nearest pose with a different outcome."""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from .geometry import FaceDesign
from .outcome import Outcome
from .physics import Physics, SolverSettings
from .result import Margins
from .runner import clear_start_height, run_flat_lengths

__all__ = ["flip_distance", "outcome_margins", "reach_margins"]

#: Coarse scan steps before bisection: D/40 laterally, pi/160 in angle.
LATERAL_STEP = 1.0 / 40.0
ANGLE_STEP = math.pi / 160.0
#: Scan nodes simulated per batch (most flips are within the first batch).
SCAN_BATCH = 16
#: Bisection resolution: 1e-4 D laterally, 1e-5 rad in angle.
LATERAL_RESOLUTION = 1e-4
ANGLE_RESOLUTION = 1e-5


def flip_distance(
    design: FaceDesign,
    x0: float,
    theta0: float,
    outcome: Outcome,
    *,
    axis: int,
    direction: float,
    limit: float,
    step: float,
    resolution: float,
    physics: Physics,
    y_start: float | None = None,
    first: float = 0.0,
) -> float:
    """Distance along one axis (0: x0 in D, 1: theta0) to the first node whose outcome
    differs from ``outcome``, scanned coarsely (in batches, nearest first, stopping at the
    first batch with a flip) then bisected; inf if none.

    The scan nodes are ``first + k step`` (k >= 1, offsets in D or rad) up to ``limit``:
    ``first`` > 0 continues a search known to be flip-free up to ``first`` (the atlas hands
    over at its edge). Every pose starts at ``y_start`` (length) when given, else at the
    default height for its angle, as the query itself was simulated.
    """
    offsets = first + np.arange(1, max(1, math.ceil((limit - first) / step)) + 1) * step
    scale = design.width if axis == 0 else 1.0
    flip = -1
    for start in range(0, offsets.size, SCAN_BATCH):
        chunk = offsets[start : start + SCAN_BATCH]
        xs = np.full(chunk.shape, x0)
        ts = np.full(chunk.shape, theta0)
        (xs if axis == 0 else ts)[:] += direction * chunk * scale
        codes = _outcomes(design, xs, ts, physics, y_start)
        found = np.flatnonzero(codes != outcome)
        if found.size:
            flip = start + int(found[0])
            break
    if flip < 0:
        return math.inf
    hi = float(offsets[flip])
    lo = hi - step
    while hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        x, t = (
            (x0 + direction * mid * scale, theta0) if axis == 0 else (x0, theta0 + direction * mid)
        )
        code = _outcomes(design, np.array([x]), np.array([t]), physics, y_start)[0]
        if code == outcome:
            lo = mid
        else:
            hi = mid
    return hi * scale


def _outcomes(
    design: FaceDesign,
    x0: npt.NDArray[np.float64],
    theta0: npt.NDArray[np.float64],
    physics: Physics,
    y_start: float | None,
) -> npt.NDArray[np.void]:
    """``predict_batch(design, x0, theta0, physics=physics, y_start=y_start).outcome`` for
    flat arrays of poses (length, rad) and one start height (length) or None."""
    ys = None if y_start is None else np.full(x0.shape, y_start, dtype=np.float64)
    return run_flat_lengths(design, x0, theta0, physics, None, ys)["outcome"]


def reach_margins(design: FaceDesign, x0: float, theta0: float, outcome: Outcome) -> Margins | None:
    """The margins of an OUT_OF_REACH pose without a simulation, else None.

    Beyond the mated distance (|x0| > L) every pose ends OUT_OF_REACH whatever its angle and
    start, and at |x0| = L none does (the engine's first test): the nearest flip lies at
    |x0| - L towards the middle, nowhere outwards or in angle. What the exact scan would
    find, within its resolution, with no simulation. Only for |theta0| <= pi: beyond, the
    angle search reaches the engine's |theta0| <= 2 pi limit, where poses are refused.
    """
    length = design.mated_distance * design.width
    if outcome != Outcome.OUT_OF_REACH or not abs(theta0) <= math.pi or not abs(x0) > length:
        return None
    inward = abs(x0) - length
    if inward > 2.0 * length:  # beyond the lateral search range
        inward = math.inf
    minus, plus = (inward, math.inf) if x0 > 0.0 else (math.inf, inward)
    return Margins(
        lateral_minus=minus, lateral_plus=plus, angle_minus=math.inf, angle_plus=math.inf
    )


def search_physics(
    design: FaceDesign, physics: Physics, outcome: Outcome | int, y_start: float | None
) -> Physics:
    """The physics a margin search simulates the query's neighbours with.

    A query that never touches (NO_CONTACT) flips where the parts start to touch (or go out
    of reach), and the approach alone decides that: a pure translation to the first contact,
    no integration. With one event allowed a run stops at its first contact (UNRESOLVED, or
    BAD_MATE below the seat) and ends NO_CONTACT exactly when the full run does (the same on
    80000 random poses of four designs), so the search runs with ``max_events = 1``: a miss's
    boundary simulations then cost about as much as one. This holds for a start clear of
    the base (the default start, or ``y_start`` at least :func:`clear_start_height`); a lower
    start may touch at once, and is searched with ``physics`` itself.
    """
    if int(outcome) != int(Outcome.NO_CONTACT):
        return physics
    if y_start is not None and not y_start / design.width >= clear_start_height(design):
        return physics
    return _one_event(physics)


@functools.lru_cache(maxsize=16)
def _one_event(physics: Physics) -> Physics:
    """``physics`` with one event allowed (cached: every miss's margins ask, and two
    ``dataclasses.replace`` cost about 15 us)."""
    return replace(physics, settings=replace(physics.settings, max_events=1))


def outcome_margins(
    design: FaceDesign,
    x0: float,
    theta0: float,
    outcome: Outcome,
    *,
    physics: Physics | None = None,
    damping_ratio: float | None = None,
    friction: float | None = None,
    settings: SolverSettings | None = None,
    y_start: float | None = None,
) -> Margins:
    """Distances from (x0, theta0) to the nearest outcome flip, along x0 and along theta0.

    The search scans |x0 - x0'| up to 2 L (beyond L no seat exists, so a SEATED query always
    flips) and |theta0 - theta0'| up to pi, then bisects to 1e-4 D and 1e-5 rad. A flip
    between two scan nodes that flips back before the next one is not seen; the scan steps
    (D/40, pi/160) bound the width of such islands.

    Every neighbour is simulated from the query's own start: ``y_start`` (length) when
    given, as :func:`~xface_core.predict` took it, else the default height for its angle.
    (Searching at the default start for a query started elsewhere compared two different
    experiments: a start below the base, INVALID_INPUT, "flipped" at the first scan node and
    gave margins of +-9.8e-5 D.)

    Examples
    --------
    >>> from xface_core import predict, x_face
    >>> d = x_face(0.25, 2.0)
    >>> m = outcome_margins(d, 0.0, 0.0, predict(d, 0.0, 0.0).outcome)
    >>> 0.0 < m.lateral < 2 * d.mated_distance and 0.0 < m.angle < math.pi
    True
    """
    phys = Physics.resolve(
        physics, damping_ratio=damping_ratio, friction=friction, settings=settings
    )
    known = reach_margins(design, x0, theta0, outcome)
    if known is not None:
        return known
    phys = search_physics(design, phys, outcome, y_start)
    lateral_limit = 2.0 * design.mated_distance
    lat = [
        flip_distance(
            design,
            x0,
            theta0,
            outcome,
            axis=0,
            direction=s,
            limit=lateral_limit,
            step=LATERAL_STEP,
            resolution=LATERAL_RESOLUTION,
            physics=phys,
            y_start=y_start,
        )
        for s in (-1.0, 1.0)
    ]
    ang = [
        flip_distance(
            design,
            x0,
            theta0,
            outcome,
            axis=1,
            direction=s,
            limit=math.pi,
            step=ANGLE_STEP,
            resolution=ANGLE_RESOLUTION,
            physics=phys,
            y_start=y_start,
        )
        for s in (-1.0, 1.0)
    ]
    return Margins(lateral_minus=lat[0], lateral_plus=lat[1], angle_minus=ang[0], angle_plus=ang[1])
