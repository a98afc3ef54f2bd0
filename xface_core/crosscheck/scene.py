"""One docking run in Chipmunk2D (pymunk): the independent engine behind ``xface crosscheck``.

The scene is xface's model built from rigid bodies, joints and contacts, with none of
xface's contact logic:

- the **base body** is hinged at the world origin (a ``PivotJoint`` to the static body) and
  starts at angle 0; with an infinite damping ratio its polygons sit on the static body;
- the **moving body** has its pivot held on the line ``x = x0`` (a ``GrooveJoint`` along y
  on the static body) and starts at angle theta0 at xface's start height
  (:func:`xface_core.runner.start_height`); its polygons are the design's moving layers with
  every vertex negated, since a moving body point ``v`` sits at ``P_M - R(phi_M) v``;
- **collision shapes** are the design's polygons per layer, split into convex pieces; layer
  ``k`` gets the shape-filter category ``1 << k`` and collides only with that category, so
  each layer meets only its twin; the polygons already reach down to ``-body_depth``;
- **contacts** have zero restitution and the friction coefficient of :class:`Physics`
  (every shape gets ``sqrt(mu)``; Chipmunk multiplies the two).

**The drive, overdamped.** Before every step the bodies get their free velocity: the moving
pivot ``V = 1 D/s`` down (a constant push balanced by a linear damper) and no rotation (a
rotational damper with no inertia left over). The step's solver then applies the contact
and joint impulses, which project that velocity onto the admissible set in the metric of
the mass matrix (Gauss's least constraint); positions follow. This is the overdamped limit
taken once per step (Moreau's sweeping process), the quasi-static model of xface: with the
moments of inertia in the ratio ``I_B / I_M = c_B / c_M`` the projection minimises the same
dissipation ``c_B w_B^2 + c_M w_M^2`` at every descent rate, and because the constraints are
homogeneous in the velocities the rotation per unit descent is that of the least-dissipation
rate whatever the translational mass. The pivot slows down where the parts must turn fast
per unit descent and stops where no admissible motion descends: a jam is a stall.

The moments are ``I = l^2`` (times ``max(1, 1/ratio)`` and the ratio) with ``l`` the farthest
polygon vertex from its pivot, so that the M-metric step bound (no point of the moving part
moves more than about one free step per step) holds for rotations as well.

**Artefacts and their controls (defaults of** :class:`EngineSettings` **and why).** The
evidence is a study on the two flattest paper designs (V and S, H/D 0.0625, r_p 1, 21 x 21
cells, sharp and rounded runs), tabulated in ``docs/crosscheck.md``.

- *Step size* ``step = 1e-4 D`` of free descent per step (``dt = step / V``). New contacts are
  found after they happen (Chipmunk has no speculative contacts), so a step lets a vertex
  enter by up to about one step: kept twenty times below the rounding radius. Halving it to
  5e-5 D changed no cell of the V design and only 4 cells' sharp runs of the S design (each a
  vertex meeting a vertex; the rounded runs changed nowhere). The ``converged`` option of
  :func:`xface_core.crosscheck.crosscheck` halves it, with the slop, until the map stops
  changing: what matters is the ratio of the two (below).
- *Collision slop* ``slop = 1e-6 D`` (Chipmunk's default is 0.1 length units, a tenth of a
  face here): the overlap left uncorrected. It matters more than the step: a vertex sliding
  on an edge sits one slop deep, and near flush edges or at the end of an edge that depth is
  enough to catch the neighbouring edge and jam. At 1e-4 D, 9-11 sharp cells per design
  flipped with every halving of the step and 10 V cells jammed that seat at 1e-6; at 1e-6 and
  1e-7 D the maps agree but for one vertex-on-vertex cell. The step must stay well above the
  slop too: at 1e-6 D slop, a step of 1.25e-5 D let a sharp corner one slop deep catch where
  its edge ends at a concave vertex, and the runs checked jammed (at xface's jam pose) where
  the same step at 1e-7 D slop seats; hence ``step / slop = 100``.
- *Penetration and joint correction* ``correction = 0.2``: the fraction of the overlap beyond
  the slop (and of the joints' drift) removed per step (Box2D's Baumgarte factor; Chipmunk's
  default removes 10 % per 1/60 s, which at this step would be about 0.06 % per step). 0.05 and 0.5
  change at most one sharp cell.
- *Solver iterations* ``iterations = 40`` (Chipmunk's default is 10): multi-contact
  projections need them to converge; 10 and 100 change at most one sharp cell.
- *Corner rounding* ``corner_radius = 0`` (sharp). :func:`~xface_core.crosscheck.crosscheck`
  runs every cell twice, sharp and with ``0.002 D`` rounding (morphological opening then
  closing of each polygon, arcs of 16 facets per quarter turn, so the flat edges stay where
  they are), and reports the cell AMBIGUOUS when the two disagree: a vertex meeting a vertex
  is decided by which side of the corner the contact normal falls, and 0.002 D of rounding,
  far below any machining tolerance, is enough to flip it. Sharp runs carry one more
  artefact: a non-convex polygon is a union of convex pieces, and where a piece's seam meets
  a concave vertex (the bottom of a V notch) a corner of the other part can be pushed by the
  piece's own corner instead of the notch's flank. The rounded runs are the robust ones: no
  setting above changed a rounded cell's seating.
- *Travel budget*: a run ends on its own terms (stall, below the seat, passed), not after a
  fixed time. The descent is bounded by the seat floor; the stall test compares the mean
  state of two consecutive windows (so that a solver limit cycle at a jam, contacts taking
  turns every few steps, counts as a stall) and allows creeps down to ``stall_speed = 1e-3``
  of the free speed in the metric above (at r_p = 0 the parts may turn 1 rad for 0.02 D of
  descent: that creep moves at about 1/50 of the free speed). The time budget ``max_travel =
  500 D`` of free descent (5 million steps) is a safety net; a run that hits it is UNRESOLVED
  (``hit_budget``) and counted as ambiguous, never as "slipped".
- *Free flight* (no contact, angles frozen, pure translation) is jumped over exactly: the
  vertical gap to the next contact is computed from the polygons and the moving body is
  moved to a few steps above it. The same gap test decides PASSED and NO_CONTACT.

**Classification** (:func:`classify`), tolerances far above the engine's slop and step:
SEATED when the run stalled with ``|phi_B - phi_M| <= angle_tol = 1e-2 rad`` and the pivot
within ``position_tol * max(1, L) = 1e-2 D`` of the mated position; BAD_MATE when it stalled
elsewhere, when the pivot fell below the seat height by more than the position tolerance, or
a part turned past pi; PASSED (NO_CONTACT before any contact) when no contact lies ahead;
OUT_OF_REACH for ``|x0| > L`` and INVALID_INPUT for non-finite or overlapping starts, as in
xface; UNRESOLVED when the budget ran out.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import pymunk
import shapely
from pymunk import autogeometry

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics
from xface_core.runner import start_height

__all__ = [
    "DEFAULT_ENGINE",
    "EngineRun",
    "EngineSettings",
    "classify",
    "convex_pieces",
    "rounded_polygon",
    "run_cell",
    "vertical_gap",
]

FloatArray = npt.NDArray[np.float64]

#: Free descent speed of the moving pivot (D per second): time is measured in D of free descent.
SPEED = 1.0

#: Facets per quarter turn of a rounded corner.
ROUND_SEGMENTS = 16

#: Rounding radius of the second run of every cell (D).
DEFAULT_ROUNDING = 2e-3


@dataclass(frozen=True)
class EngineSettings:
    """Settings of one Chipmunk2D run (lengths in units of D; see the module docstring)."""

    step: float = 1e-4
    """Free descent per step (D); the time step is ``step / SPEED``."""
    slop: float = 1e-6
    """Chipmunk's collision slop (D): overlap left uncorrected."""
    correction: float = 0.2
    """Fraction of the overlap beyond the slop, and of the joints' drift, removed per step."""
    iterations: int = 40
    """Solver iterations per step."""
    corner_radius: float = 0.0
    """Rounding of every polygon corner (D); 0 keeps the corners sharp."""
    angle_tol: float = 1e-2
    """SEATED needs ``|phi_B - phi_M|`` within this (rad)."""
    position_tol: float = 1e-2
    """SEATED needs the pivot within this (D, per D of L when L > 1) of the mated position;
    a pivot this far below the seat height ends the run as BAD_MATE."""
    stall_window: float = 0.05
    """Window of the stall test, in D of free descent."""
    stall_speed: float = 1e-3
    """A run stalls when its mean state over the last window lies closer than this fraction
    of one window's free descent to its mean state over the window before (in the metric of
    the moments: D for the pivot, l rad for the angles)."""
    check_every: int = 25
    """Steps between two checks (stall, seat floor, free flight)."""
    max_travel: float = 500.0
    """Time budget in D of free descent; past it the run is UNRESOLVED."""

    def __post_init__(self) -> None:
        for name in ("step", "slop", "stall_window", "stall_speed", "max_travel"):
            value = getattr(self, name)
            if not (isinstance(value, float | int) and 0.0 < value < math.inf):
                raise XfaceValueError(
                    f"EngineSettings.{name} must be finite and > 0, got {value!r}"
                )
        if not 0.0 < self.correction <= 1.0:
            raise XfaceValueError(
                f"EngineSettings.correction must be in (0, 1], got {self.correction}"
            )
        if not 0.0 <= self.corner_radius < 0.1:
            raise XfaceValueError(
                f"EngineSettings.corner_radius must be in [0, 0.1), got {self.corner_radius}"
            )
        if self.iterations < 1 or self.check_every < 1:
            raise XfaceValueError("EngineSettings.iterations and check_every must be >= 1")

    def with_step(self, step: float) -> EngineSettings:
        """The same settings at another step size."""
        return replace(self, step=step)

    def rounded(self, radius: float = DEFAULT_ROUNDING) -> EngineSettings:
        """The same settings with rounded corners."""
        return replace(self, corner_radius=radius)


DEFAULT_ENGINE = EngineSettings()


@dataclass(frozen=True)
class EngineRun:
    """How one engine run ended (lengths in units of D, angles in rad)."""

    outcome: Outcome
    reason: str
    phi_b: float
    phi_m: float
    y_m: float
    """Final height of the moving pivot."""
    x_drift: float
    """Final distance of the moving pivot from the line x = x0 (the groove joint's error)."""
    y_start: float
    descent: float
    """How far the pivot travelled down, ``y_start - y_m``."""
    steps: int
    hit_budget: bool
    """True when the time budget ran out (outcome UNRESOLVED)."""


# --------------------------------------------------------------------------------------------
# Geometry: rounding, convex pieces, the vertical gap
# --------------------------------------------------------------------------------------------


def rounded_polygon(poly: FloatArray, radius: float) -> FloatArray:
    """``poly`` with every corner rounded to ``radius`` (opening then closing), edges in place;
    counter-clockwise, not closed. ``radius = 0`` returns the polygon unchanged."""
    if radius <= 0.0:
        return np.asarray(poly, dtype=np.float64)
    shape = shapely.Polygon(poly)
    opened = shape.buffer(-radius, quad_segs=ROUND_SEGMENTS).buffer(
        radius, quad_segs=ROUND_SEGMENTS
    )
    closed = opened.buffer(radius, quad_segs=ROUND_SEGMENTS).buffer(
        -radius, quad_segs=ROUND_SEGMENTS
    )
    if not isinstance(closed, shapely.Polygon) or closed.is_empty:
        raise ValueError(f"rounding by {radius} D splits or erases a polygon")
    ring = shapely.orient_polygons(closed).exterior
    pts = np.asarray(ring.coords, dtype=np.float64)[:-1]
    return np.asarray(shapely.Polygon(pts).simplify(radius * 1e-4).exterior.coords)[:-1]


def convex_pieces(poly: FloatArray) -> list[FloatArray]:
    """Convex pieces whose union is ``poly`` (Chipmunk's decomposition, checked by area;
    constrained Delaunay triangles if the check fails)."""
    shape = shapely.Polygon(poly)
    closed = [(float(x), float(y)) for x, y in poly] + [(float(poly[0, 0]), float(poly[0, 1]))]
    hulls = autogeometry.convex_decomposition(closed, 0.0)
    pieces = [np.array([(v.x, v.y) for v in h[:-1]], dtype=np.float64) for h in hulls]
    union = shapely.union_all([shapely.Polygon(p) for p in pieces if len(p) >= 3])
    if abs(union.area - shape.area) <= 1e-9 * max(1.0, shape.area) and (
        union.symmetric_difference(shape).area <= 1e-9 * max(1.0, shape.area)
    ):
        return [p for p in pieces if len(p) >= 3]
    tris = shapely.constrained_delaunay_triangles(shape)
    return [np.asarray(t.exterior.coords, dtype=np.float64)[:-1] for t in tris.geoms]


def _edges(poly: FloatArray) -> tuple[FloatArray, FloatArray]:
    return poly, np.roll(poly, -1, axis=0)


def _drop_onto(top: FloatArray, bottom: FloatArray, margin: float) -> float:
    """Least downward translation of the vertices of ``top`` onto the edges of ``bottom``
    (>= -margin; inf if none lies below)."""
    a, b = _edges(bottom)
    dx = b[:, 0] - a[:, 0]
    steep = np.abs(dx) > 1e-15
    a, b, dx = a[steep], b[:, :][steep], dx[steep]
    px, py = top[:, 0:1], top[:, 1:2]
    lo, hi = np.minimum(a[:, 0], b[:, 0]), np.maximum(a[:, 0], b[:, 0])
    inside = (px >= lo - 1e-12) & (px <= hi + 1e-12)
    t = np.clip((px - a[:, 0]) / dx, 0.0, 1.0)
    y_edge = a[:, 1] + t * (b[:, 1] - a[:, 1])
    d = py - y_edge
    ok = inside & (d >= -margin)
    return float(d[ok].min()) if ok.any() else math.inf


def vertical_gap(moving: FloatArray, base: FloatArray, margin: float = 0.0) -> float:
    """How far ``moving`` (world polygon) can translate straight down before it touches
    ``base`` (world polygon): the least vertex-onto-edge distance either way round, counting
    pairs already touching or overlapping by up to ``margin``; inf if it never touches."""
    down = _drop_onto(moving, base, margin)
    # A base vertex under a moving edge: the moving part drops by (edge height - vertex height).
    up = _drop_onto(-base, -moving, margin)
    return min(down, up)


# --------------------------------------------------------------------------------------------
# Classification
# --------------------------------------------------------------------------------------------


def seat_height(x0: float, L: float) -> float:
    """Height of the moving pivot in the mated pose (D)."""
    return math.sqrt(max(L * L - x0 * x0, 0.0))


def is_seated_pose(
    phi_b: float, phi_m: float, x_m: float, y_m: float, L: float, settings: EngineSettings
) -> bool:
    """Equal angles and the pivot at the mated position, to the settings' tolerances."""
    phi = 0.5 * (phi_b + phi_m)
    tol = settings.position_tol * max(1.0, L)
    return (
        abs(phi_b - phi_m) <= settings.angle_tol
        and math.hypot(x_m + L * math.sin(phi), y_m - L * math.cos(phi)) <= tol
    )


#: The reason of a run that stalled away from the mated pose.
JAM_REASON = "jammed: stopped away from the mated pose"


def classify(
    *,
    phi_b: float,
    phi_m: float,
    x_m: float,
    y_m: float,
    x0: float,
    L: float,
    stalled: bool,
    clear_ahead: bool,
    had_contact: bool,
    settings: EngineSettings = DEFAULT_ENGINE,
) -> tuple[Outcome, str] | None:
    """The outcome of an engine state, or None while the run must go on.

    ``stalled``: the mean state moved less than the stall speed allows between two windows;
    ``clear_ahead``: no contact lies ahead along a straight descent; ``had_contact``: the
    parts have touched. Lengths in D, angles in rad.

    Examples
    --------
    >>> import math
    >>> L = 4.25
    >>> classify(
    ...     phi_b=0.0,
    ...     phi_m=0.0,
    ...     x_m=0.0,
    ...     y_m=L,
    ...     x0=0.0,
    ...     L=L,
    ...     stalled=True,
    ...     clear_ahead=False,
    ...     had_contact=True,
    ... )
    (<Outcome.SEATED: 3>, 'seated: stopped at the mated pose')
    """
    if clear_ahead:
        if had_contact:
            return Outcome.PASSED, "passed: no contact ahead along the descent"
        return Outcome.NO_CONTACT, "no contact along the descent"
    if abs(phi_b) > math.pi or abs(phi_m) > math.pi:
        return Outcome.BAD_MATE, "a part turned past pi"
    if y_m < seat_height(x0, L) - settings.position_tol * max(1.0, L):
        return Outcome.BAD_MATE, "below the seat height"
    if stalled:
        if is_seated_pose(phi_b, phi_m, x_m, y_m, L, settings):
            return Outcome.SEATED, "seated: stopped at the mated pose"
        return Outcome.BAD_MATE, JAM_REASON
    return None


# --------------------------------------------------------------------------------------------
# The scene
# --------------------------------------------------------------------------------------------


@dataclass
class _Scene:
    space: pymunk.Space
    base: pymunk.Body | None
    moving: pymunk.Body
    base_polys: list[FloatArray]
    moving_polys: list[FloatArray]
    metric: tuple[float, float]
    """I_B / m and I_M / m: the stall test's metric (D^2)."""


def _moments(design: FaceDesign, ratio: float) -> tuple[float, float]:
    reach = max(float(np.hypot(p[:, 0], p[:, 1]).max()) for p in design.base_layers)
    reach = max(reach, *(float(np.hypot(p[:, 0], p[:, 1]).max()) for p in design.moving_layers))
    if not math.isfinite(ratio):
        return 0.0, reach * reach  # the base is static: its moment never enters
    i_m = reach * reach * max(1.0, 1.0 / ratio)
    return ratio * i_m, i_m


def _add_layers(
    space: pymunk.Space,
    body: pymunk.Body,
    polys: list[FloatArray],
    sign: float,
    friction: float,
    slop_filter: list[pymunk.ShapeFilter],
) -> None:
    for k, poly in enumerate(polys):
        for piece in convex_pieces(poly):
            shape = pymunk.Poly(body, [(sign * x, sign * y) for x, y in piece])
            shape.friction = math.sqrt(friction)
            shape.elasticity = 0.0
            shape.filter = slop_filter[k]
            space.add(shape)


def build_scene(
    design: FaceDesign,
    x0: float,
    theta0: float,
    y_start: float,
    physics: Physics,
    settings: EngineSettings,
) -> _Scene:
    """The Chipmunk2D space of one run at its start pose (lengths in D)."""
    dt = settings.step / SPEED
    space = pymunk.Space()
    space.iterations = settings.iterations
    space.collision_slop = settings.slop
    space.collision_bias = (1.0 - settings.correction) ** (1.0 / dt)
    # The overdamped drive, applied by Chipmunk's own velocity update before the solver:
    # v <- v * damping**dt + gravity * dt, so no velocity survives a step and the free
    # velocity is V down for every dynamic body (the base's hinge takes its share).
    space.damping = 0.0
    space.gravity = (0.0, -SPEED / dt)
    r = settings.corner_radius
    base_polys = [rounded_polygon(p, r) for p in design.base_layers]
    moving_polys = [rounded_polygon(p, r) for p in design.moving_layers]
    filters = [pymunk.ShapeFilter(categories=1 << k, mask=1 << k) for k in range(len(base_polys))]
    i_b, i_m = _moments(design, physics.damping_ratio)
    joint_bias = (1.0 - settings.correction) ** (1.0 / dt)
    base: pymunk.Body | None
    if physics.base_fixed:
        base = None
        _add_layers(space, space.static_body, base_polys, 1.0, physics.friction, filters)
    else:
        base = pymunk.Body(1.0, i_b)
        base.position = (0.0, 0.0)
        base.angle = 0.0
        hinge = pymunk.PivotJoint(space.static_body, base, (0.0, 0.0), (0.0, 0.0))
        hinge.error_bias = joint_bias
        space.add(base, hinge)
        _add_layers(space, base, base_polys, 1.0, physics.friction, filters)
    moving = pymunk.Body(1.0, i_m)
    moving.position = (x0, y_start)
    moving.angle = theta0
    reach = 10.0 * (design.mated_distance + design.body_depth + 1.0) + abs(y_start)
    groove = pymunk.GrooveJoint(space.static_body, moving, (x0, -reach), (x0, reach), (0.0, 0.0))
    groove.error_bias = joint_bias
    space.add(moving, groove)
    _add_layers(space, moving, moving_polys, -1.0, physics.friction, filters)
    return _Scene(space, base, moving, base_polys, moving_polys, (i_b, i_m))


def _world(scene: _Scene) -> tuple[list[FloatArray], list[FloatArray]]:
    """The layers' polygons in the world at the current pose."""
    phi_b = 0.0 if scene.base is None else scene.base.angle
    c, s = math.cos(phi_b), math.sin(phi_b)
    rot_b = np.array([[c, s], [-s, c]])
    base = [p @ rot_b for p in scene.base_polys]
    m = scene.moving
    c, s = math.cos(m.angle), math.sin(m.angle)
    rot_m = np.array([[c, s], [-s, c]])
    px, py = m.position
    moving = [np.array([px, py]) - p @ rot_m for p in scene.moving_polys]
    return base, moving


def _gap(scene: _Scene, margin: float) -> float:
    base, moving = _world(scene)
    return min(vertical_gap(m, b, margin) for m, b in zip(moving, base, strict=True))


def _overlap_area(scene: _Scene) -> float:
    base, moving = _world(scene)
    return sum(
        float(shapely.Polygon(b).intersection(shapely.Polygon(m)).area)
        for b, m in zip(base, moving, strict=True)
    )


def _state(scene: _Scene) -> tuple[float, float, float, float]:
    phi_b = 0.0 if scene.base is None else float(scene.base.angle)
    x, y = scene.moving.position
    return phi_b, float(scene.moving.angle), float(x), float(y)


def _start_check(design: FaceDesign, x0: float, theta0: float) -> tuple[Outcome, str] | None:
    if not (math.isfinite(x0) and math.isfinite(theta0)) or abs(theta0) > 2.0 * math.pi:
        return Outcome.INVALID_INPUT, "non-finite or absurd input"
    if abs(x0) > design.mated_distance:
        return Outcome.OUT_OF_REACH, "|x0| exceeds the mated pivot distance L"
    return None


def _ended(outcome: Outcome, reason: str, y_start: float, phi_m: float = 0.0) -> EngineRun:
    return EngineRun(outcome, reason, 0.0, phi_m, y_start, 0.0, y_start, 0.0, 0, False)


def run_cell(
    design: FaceDesign,
    x0: float,
    theta0: float,
    *,
    physics: Physics | None = None,
    settings: EngineSettings = DEFAULT_ENGINE,
    y_start: float | None = None,
) -> EngineRun:
    """Run one start pose in Chipmunk2D to its end.

    ``x0`` and ``y_start`` in units of D (default start: xface's start height for theta0),
    ``theta0`` in rad. Never raises for a pose: bad input gives INVALID_INPUT.

    Examples
    --------
    >>> from xface_core import x_face
    >>> run_cell(x_face(0.25, 2.0), 0.0, 0.0).outcome.name
    'SEATED'
    """
    phys = Physics() if physics is None else physics
    early = _start_check(design, x0, theta0)
    if early is not None:
        return _ended(*early, math.nan, theta0)
    y0 = start_height(design, theta0) if y_start is None else float(y_start)
    if not math.isfinite(y0):
        return _ended(Outcome.INVALID_INPUT, "non-finite start height", y0, theta0)
    scene = build_scene(design, x0, theta0, y0, phys, settings)
    if _overlap_area(scene) > 1e-12:
        return _ended(Outcome.INVALID_INPUT, "the start pose interpenetrates the parts", y0, theta0)
    return _simulate(scene, design.mated_distance, x0, y0, settings)


def _touching(scene: _Scene) -> bool:
    """True while the moving body has a contact (an arbiter with contact points)."""
    found: list[int] = []
    scene.moving.each_arbiter(lambda arb: found.append(len(arb.contact_point_set.points)))
    return any(found)


class _StallWindow:
    """The states (y_M, phi_B, phi_M) of the last ``2 * half`` checks, oldest first, in one
    array: the stall test compares the mean state of its two halves. A creep moves the
    mean, a limit cycle of the solver (contacts taking turns, seen with periods of a few
    checks at a jam) does not. Kept in place, not rebuilt from a queue at every check (that
    took 53 us a check, against 137 us for the check's 25 steps); the means are numpy's over
    the same rows, so a stall is found at the same step."""

    def __init__(self, half: int) -> None:
        self.half = half
        self.states = np.zeros((2 * half, 3))
        self.count = 0

    def clear(self) -> None:
        """Forget every state (the moving part jumped)."""
        self.count = 0

    def push(self, y_m: float, phi_b: float, phi_m: float) -> None:
        """Add the newest state, dropping the oldest once full."""
        states = self.states
        states[:-1] = states[1:]
        states[-1] = (y_m, phi_b, phi_m)
        self.count = min(self.count + 1, states.shape[0])

    @property
    def full(self) -> bool:
        return self.count == self.states.shape[0]

    def moved(self, metric: tuple[float, float]) -> float:
        """Metric distance between the mean states of the two halves (D; ``metric``: the
        moments, D^2 per rad^2, that weigh the angles)."""
        half = self.half
        dy, db, dm = self.states[half:].mean(axis=0) - self.states[:half].mean(axis=0)
        return math.sqrt(dy * dy + metric[0] * db * db + metric[1] * dm * dm)


def _stepper(space: pymunk.Space) -> Callable[[float, int], None]:
    """``step(dt, n)``: ``n`` steps of ``space``, the first through ``Space.step`` and the
    rest through Chipmunk's own ``cpSpaceStep``.

    ``Space.step`` wraps the C step in Python (checks of bodies added since the last step,
    a lock for callbacks that add or remove, their deferred work, post-step callbacks): six
    cells at 5e-5 D took 0.79 s through it and 0.74 s through the C step. A scene adds and removes
    nothing once built and its one callback only counts, so after the first step of a batch
    that work is empty and the C step alone does the same (the same runs to the last bit,
    tests/core/crosscheck/test_scene.py). pymunk's own handles (``pymunk._chipmunk.lib``,
    ``Space._space``); a pymunk without them steps through ``Space.step`` only."""
    try:
        from pymunk._chipmunk import lib  # private: looked for here, not assumed

        c_step, handle = lib.cpSpaceStep, space._space
    except (ImportError, AttributeError):

        def step_each(dt: float, n: int) -> None:
            for _ in range(n):
                space.step(dt)

        return step_each

    def step_many(dt: float, n: int) -> None:
        space.step(dt)
        for _ in range(n - 1):
            c_step(handle, dt)

    return step_many


def _simulate(scene: _Scene, L: float, x0: float, y0: float, settings: EngineSettings) -> EngineRun:
    """Step the scene until :func:`classify` decides or the budget runs out."""
    dt = settings.step / SPEED
    i_b, i_m = scene.metric
    window = max(2, round(settings.stall_window / (settings.step * settings.check_every)))
    history = _StallWindow(window)
    max_steps = math.ceil(settings.max_travel / settings.step)
    # Pairs overlapping by less than this count as touching in the gap tests: deeper than
    # any overlap the engine leaves (one step of travel before a contact is found, the slop).
    margin = 2.0 * settings.step + 10.0 * settings.slop
    jump_at = 40.0 * settings.step
    space, moving = scene.space, scene.moving
    step_space = _stepper(space)
    begun = {"contacts": 0}
    space.on_collision(
        begin=lambda arb, sp, data: data.update(contacts=data["contacts"] + 1), data=begun
    )
    steps = 0
    verdict: tuple[Outcome, str] | None = None
    touching = _touching(scene)  # then as left by the last check: nothing moves in between
    while verdict is None and steps < max_steps:
        if not touching:
            # Free flight (angles frozen, pure translation): jump to a few steps above the
            # next contact.
            gap = _gap(scene, margin)
            if jump_at < gap < math.inf:
                x, y = moving.position
                moving.position = (x, y - (gap - 4.0 * settings.step))
                space.reindex_shapes_for_body(moving)
                history.clear()
        step_space(dt, settings.check_every)
        steps += settings.check_every
        phi_b, phi_m, x_m, y_m = _state(scene)
        history.push(y_m, phi_b, phi_m)
        stalled = history.full and history.moved((i_b, i_m)) < (
            settings.stall_speed * settings.stall_window
        )
        touching = _touching(scene)
        verdict = classify(
            phi_b=phi_b,
            phi_m=phi_m,
            x_m=x_m,
            y_m=y_m,
            x0=x0,
            L=L,
            stalled=stalled,
            clear_ahead=not touching and not math.isfinite(_gap(scene, margin)),
            had_contact=begun["contacts"] > 0,
            settings=settings,
        )
    phi_b, phi_m, x_m, y_m = _state(scene)
    outcome, reason = verdict or (Outcome.UNRESOLVED, "time budget ran out")
    return EngineRun(
        outcome=outcome,
        reason=reason,
        phi_b=phi_b,
        phi_m=phi_m,
        y_m=y_m,
        x_drift=x_m - x0,
        y_start=y0,
        descent=y0 - y_m,
        steps=steps,
        hit_budget=verdict is None,
    )
