"""Margins: how far a query pose is from the nearest pose with a different outcome."""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import replace
from typing import NamedTuple, cast

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics, SolverSettings
from xface_core.result import Margins
from xface_core.runner import clear_start_height, outcomes_at

__all__ = [
    "HalfAxisSearch",
    "flip_distance",
    "flip_distances",
    "outcome_margins",
    "reach_margins",
]

#: Coarse scan steps before bisection: D/40 laterally, pi/160 in angle.
LATERAL_STEP = 1.0 / 40.0
ANGLE_STEP = math.pi / 160.0
#: Scan nodes simulated per batch (most flips are within the first batch).
SCAN_BATCH = 16
#: Bisection resolution: 1e-4 D laterally, 1e-5 rad in angle.
LATERAL_RESOLUTION = 1e-4
ANGLE_RESOLUTION = 1e-5


class HalfAxisSearch(NamedTuple):
    """One half-axis of an exact margin search (:func:`flip_distances`): the axis (0: x0 in
    D, 1: theta0), its direction (+1 or -1), the scan's last offset, step and bisection
    resolution (D or rad), and ``first``, the offset up to which it is known flip-free."""

    axis: int
    direction: float
    limit: float
    step: float
    resolution: float
    first: float = 0.0


def moved_along(
    x0: float,
    theta0: float,
    axis: int,
    direction: float,
    offsets: npt.ArrayLike,
    scale: float = 1.0,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The pose (x0, theta0) moved by each of ``offsets`` along a half-axis (axis 0: x0, the
    offsets in units of D times ``scale``, the length of D in x0's unit; 1: theta0, rad):
    arrays of x0 and theta0."""
    off = np.asarray(offsets, dtype=np.float64)
    if axis == 0:
        return x0 + direction * off * scale, np.full(off.shape, theta0)
    return np.full(off.shape, x0), theta0 + direction * off


class _Search:
    """The state of one :class:`HalfAxisSearch`: scanning batch by batch until a node's
    outcome differs, then bisecting the step before it; ``result`` once done."""

    def __init__(self, half: HalfAxisSearch, scale: float) -> None:
        self.half, self.scale = half, scale
        n = max(1, math.ceil((half.limit - half.first) / half.step))
        self.offsets = half.first + np.arange(1, n + 1, dtype=np.float64) * half.step
        self.start = 0  # the next scan batch's first node
        self.lo = self.hi = math.nan  # the bracket, once the scan found a flip
        self.result: float | None = None

    def probes(self) -> npt.NDArray[np.float64]:
        """The offsets this search simulates next."""
        if math.isnan(self.hi):
            return self.offsets[self.start : self.start + SCAN_BATCH]
        return np.array([0.5 * (self.lo + self.hi)])

    def poses(
        self, x0: float, theta0: float, probes: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The query moved by ``probes`` along this half-axis: (x0 (length), theta0)."""
        return moved_along(x0, theta0, self.half.axis, self.half.direction, probes, self.scale)

    def take(self, probes: npt.NDArray[np.float64], codes: npt.NDArray[np.int8], q: int) -> None:
        """Advance by the outcomes ``codes`` of ``probes``."""
        if math.isnan(self.hi):
            found = np.flatnonzero(codes != q)
            if not found.size:
                self.start += SCAN_BATCH
                if self.start >= self.offsets.size:
                    self.result = math.inf
                return
            self.hi = float(self.offsets[self.start + int(found[0])])
            self.lo = self.hi - self.half.step
        elif codes[0] == q:
            self.lo = float(probes[0])
        else:
            self.hi = float(probes[0])
        if not self.hi - self.lo > self.half.resolution:
            self.result = self.hi * self.scale


def flip_distances(
    design: FaceDesign,
    x0: float,
    theta0: float,
    outcome: Outcome,
    searches: Sequence[HalfAxisSearch],
    *,
    physics: Physics,
    y_start: float | None = None,
) -> list[float]:
    """:func:`flip_distance` along several half-axes of one query, in lockstep: each round
    simulates every unfinished search's next scan batch or bisection midpoint in one engine
    call, so a query's four half-axes take about as many calls as its longest one, not their
    sum (a seat's exact search made 48 one-pose calls, each about 16 us in the runner
    besides its simulations). Every search simulates the same poses and decides as it would
    alone, so each distance is the same bit for bit."""
    pending = [_Search(half, design.width if half.axis == 0 else 1.0) for half in searches]
    states = list(pending)
    q = int(outcome)
    w = design.width  # the searches run in the design's length unit, the engine in D
    ys = None if y_start is None else y_start / w
    while pending:
        probes = [search.probes() for search in pending]
        poses = [s.poses(x0, theta0, p) for s, p in zip(pending, probes, strict=True)]
        xs = np.concatenate([x for x, _ in poses])
        ts = np.concatenate([t for _, t in poses])
        codes = outcomes_at(design, xs / w, ts, physics, y_start=ys)
        at = 0
        for search, p in zip(pending, probes, strict=True):
            search.take(p, codes[at : at + p.size], q)
            at += p.size
        pending = [search for search in pending if search.result is None]
    return [cast(float, search.result) for search in states]


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
    half = HalfAxisSearch(axis, direction, limit, step, resolution, first)
    return flip_distances(design, x0, theta0, outcome, [half], physics=physics, y_start=y_start)[0]


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
    found = flip_distances(
        design,
        x0,
        theta0,
        outcome,
        [
            HalfAxisSearch(0, -1.0, lateral_limit, LATERAL_STEP, LATERAL_RESOLUTION),
            HalfAxisSearch(0, 1.0, lateral_limit, LATERAL_STEP, LATERAL_RESOLUTION),
            HalfAxisSearch(1, -1.0, math.pi, ANGLE_STEP, ANGLE_RESOLUTION),
            HalfAxisSearch(1, 1.0, math.pi, ANGLE_STEP, ANGLE_RESOLUTION),
        ],
        physics=phys,
        y_start=y_start,
    )
    return Margins(
        lateral_minus=found[0], lateral_plus=found[1], angle_minus=found[2], angle_plus=found[3]
    )
