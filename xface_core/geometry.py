"""Face geometry: the X-, V- and S-Face profiles and user-defined layered faces.

Every part has a body frame with its pivot (rotation point) at the origin and its profile
facing +y; the profile's base line lies at ``y = r_p * D`` and rises at most ``H`` above it.
The base part sits at the world origin; the moving part is the same kind of part turned
180 degrees in the plane, so a body point ``v`` of it is at ``P_M - R(phi_M) v`` in the world.

A design holds, per layer, one closed polygon (counter-clockwise) for the base part and one
for the moving part, both in their own body frames and in units of the face width D (the
simulator works in units of D; :attr:`FaceDesign.width` only scales inputs and outputs).
Contacts only occur between equal layers.

Below the profile each body extends down to ``y = -body_depth`` (default one width below the
pivot, ``body_depth = 1``), so the pivot lies inside the body and the side walls are long
enough that contacts happen on the profile and the walls, never on the bottom.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

import numpy as np
import numpy.typing as npt
import shapely

from .errors import GeometryError, XfaceValueError

__all__ = [
    "FaceDesign",
    "FaceKind",
    "custom_face",
    "is_mirror_symmetric",
    "make_face",
    "s_face",
    "v_face",
    "x_face",
]

FaceKind = Literal["X", "V", "S", "custom"]
FloatArray = npt.NDArray[np.float64]

#: Largest accepted H/D and r_p: the range the engine is verified over (docs/model.md,
#: "Range"). A seeded random probe of the built-in faces (scripts/evidence/range_probe.py)
#: found no interpenetration, UNRESOLVED, mirror or symmetry-filling disagreement up to H/D 100
#: (3000 runs at 10-100, 1538 at 50-100), and 24 in 16 of 1462 runs at 100-200 (issue 37's
#: reproducers start at 102); 50 keeps a factor 2 below that. The paper's metric "plateaus"
#: long before (Section IV-A).
MAX_DESIGN_RATIO = 50.0

#: Largest accepted vertex coordinate of a custom face (D): r_p + H of the largest built-in
#: design, whose outlines reach that far from their pivots.
MAX_CUSTOM_COORDINATE = 2.0 * MAX_DESIGN_RATIO

#: Largest accepted mated distance L of a custom face (D): 2 r_p + H of the largest built-in.
MAX_MATED_DISTANCE = 3.0 * MAX_DESIGN_RATIO

#: Largest accepted width D (the caller's length unit): the width only scales poses in and
#: out (the engine works in D), so it is not part of the verified range; 1e4 is far beyond any
#: connector in metres or millimetres.
MAX_WIDTH = 1.0e4

#: Where the limits above come from, named in every refusal.
_RANGE_WHY = "the range the engine is verified over; docs/model.md, Range"

#: Shortest accepted polygon edge (D): a repeated vertex makes an edge without a direction.
MIN_EDGE_LENGTH = 1e-9


def _check_ratio(
    name: str, value: float, *, allow_zero: bool, limit: float = MAX_DESIGN_RATIO
) -> float:
    """``value`` as a float, refused unless finite, positive (or zero) and at most ``limit``."""
    value = float(value)
    if not math.isfinite(value):
        raise XfaceValueError(f"{name} must be finite, got {value!r}")
    if value < 0.0 or (value == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise XfaceValueError(f"{name} must be {bound}, got {value!r}")
    if value > limit:
        why = "far beyond any connector" if limit == MAX_WIDTH else _RANGE_WHY
        raise XfaceValueError(f"{name} must be <= {limit:g} ({why}), got {value!r}")
    return value


@dataclass(frozen=True, eq=False)
class FaceDesign:
    """A connector design: one polygon per layer for each part, in units of the width D.

    Build one with :func:`x_face`, :func:`v_face`, :func:`s_face` or :func:`custom_face`
    rather than directly.

    Attributes
    ----------
    kind : {"X", "V", "S", "custom"}
    h_over_d : float
        Profile height H over width D (dimensionless).
    r_p : float
        Distance from the pivot to the profile's base line, in widths D.
    width : float
        The face width D in the caller's length unit (metres in the ROS node); only used to
        scale poses in and out.
    mated_distance : float
        Pivot-to-pivot distance L when seated, in widths D (``2 r_p + H/D`` for the built-in
        faces).
    base_layers, moving_layers : tuple of (n, 2) float arrays
        Closed counter-clockwise polygons, body frames, units of D.
    mirror_symmetric : bool
        True when mirroring x -> -x maps the design onto itself, so that the outcome at
        (x0, theta0) equals the outcome at (-x0, -theta0): the maps and atlases then simulate
        half of their poses and mirror the rest. :func:`custom_face` checks the claim.
    name : str or None
        What the design is called in text, titles and tables: a face file's ``name:``
        (:func:`~xface_core.facefile.load_face`); None for a design built in Python, which
        is then called by its kind (:attr:`display_name`). Never part of the geometry.
    """

    kind: FaceKind
    h_over_d: float
    r_p: float
    width: float
    mated_distance: float
    base_layers: tuple[FloatArray, ...] = field(repr=False)
    moving_layers: tuple[FloatArray, ...] = field(repr=False)
    mirror_symmetric: bool = False
    body_depth: float = 1.0
    name: str | None = None

    @property
    def display_name(self) -> str:
        """The design's name for people: its :attr:`name` if it has one, else ``custom face``
        or ``X-Face`` (``V-Face``, ``S-Face``)."""
        if self.name:
            return self.name
        return "custom face" if self.kind == "custom" else f"{self.kind}-Face"

    @property
    def height(self) -> float:
        """Profile height H in the caller's length unit."""
        return self.h_over_d * self.width

    @property
    def n_layers(self) -> int:
        """Number of layers (2 for the X-Face, 1 for V and S)."""
        return len(self.base_layers)

    @cached_property
    def cache_key(self) -> tuple[object, ...]:
        """A hashable key that identifies the geometry (not the width); computed once."""
        return (
            self.kind,
            self.mated_distance,
            tuple(tuple(map(float, p.ravel())) for p in self.base_layers),
            tuple(tuple(map(float, p.ravel())) for p in self.moving_layers),
        )

    def with_width(self, width: float) -> FaceDesign:
        """The same design at another width D (lengths in the caller's unit)."""
        width = _check_ratio("width", width, allow_zero=False, limit=MAX_WIDTH)
        return FaceDesign(
            kind=self.kind,
            h_over_d=self.h_over_d,
            r_p=self.r_p,
            width=width,
            mated_distance=self.mated_distance,
            base_layers=self.base_layers,
            moving_layers=self.moving_layers,
            mirror_symmetric=self.mirror_symmetric,
            body_depth=self.body_depth,
            name=self.name,
        )

    def seated_angle(self, x0: float) -> float:
        """The common angle phi (rad) at which the parts seat for lateral offset ``x0``.

        ``x0`` is in the caller's unit; raises when ``|x0| > L`` (no seat exists).
        """
        ratio = -x0 / (self.mated_distance * self.width)
        if not abs(ratio) <= 1.0:
            raise XfaceValueError(f"|x0| = {abs(x0):g} exceeds the mated distance: no seat")
        return math.asin(ratio)

    def moving_outline_world(self, layer: int, x0: float, y_m: float, phi_m: float) -> FloatArray:
        """The moving part's polygon of ``layer`` in the world (units of D)."""
        return _moving_to_world(self.moving_layers[layer], x0, y_m, phi_m)

    def base_outline_world(self, layer: int, phi_b: float) -> FloatArray:
        """The base part's polygon of ``layer`` in the world (units of D)."""
        c, s = math.cos(phi_b), math.sin(phi_b)
        poly = self.base_layers[layer]
        return np.column_stack((c * poly[:, 0] - s * poly[:, 1], s * poly[:, 0] + c * poly[:, 1]))

    def base_outline_path(self, layer: int, phi_b: npt.ArrayLike) -> FloatArray:
        """The base part's polygon of ``layer`` at every angle of ``phi_b`` (n,): (n, v, 2),
        in the world (units of D); :meth:`base_outline_world` for a whole path at once.

        Examples
        --------
        >>> d = x_face(0.25, 2.0)
        >>> outlines = d.base_outline_path(0, [0.0, 0.3])
        >>> outlines.shape
        (2, 4, 2)
        >>> np.allclose(outlines[1], d.base_outline_world(0, 0.3))
        True
        """
        phi = np.asarray(phi_b, dtype=np.float64)
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        poly = self.base_layers[layer]
        px, py = poly[None, :, 0], poly[None, :, 1]
        return np.stack((c * px - s * py, s * px + c * py), axis=-1)

    def moving_outline_path(
        self, layer: int, x0: float, y_m: npt.ArrayLike, phi_m: npt.ArrayLike
    ) -> FloatArray:
        """The moving part's polygon of ``layer`` at every sample of a path: pivot at
        ``(x0, y_m[i])``, angle ``phi_m[i]``; (n, v, 2) in the world (units of D), what
        :meth:`moving_outline_world` gives per sample.

        Examples
        --------
        >>> d = x_face(0.25, 2.0)
        >>> outlines = d.moving_outline_path(1, 0.1, [4.5, 4.25], [0.2, 0.0])
        >>> outlines.shape
        (2, 4, 2)
        >>> np.allclose(outlines[0], d.moving_outline_world(1, 0.1, 4.5, 0.2))
        True
        """
        phi = np.asarray(phi_m, dtype=np.float64)
        y = np.asarray(y_m, dtype=np.float64)
        c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
        poly = self.moving_layers[layer]
        px, py = poly[None, :, 0], poly[None, :, 1]
        return np.stack((x0 - (c * px - s * py), y[:, None] - (s * px + c * py)), axis=-1)


def _moving_to_world(poly: FloatArray, x0: float, y_m: float, phi_m: float) -> FloatArray:
    c, s = math.cos(phi_m), math.sin(phi_m)
    return np.column_stack(
        (x0 - (c * poly[:, 0] - s * poly[:, 1]), y_m - (s * poly[:, 0] + c * poly[:, 1]))
    )


def _strip(profile: Sequence[tuple[float, float]], depth: float) -> FloatArray:
    """Close a profile polyline (left to right) into a CCW polygon reaching down to -depth."""
    pts = [(0.5, -depth), *reversed(profile), (-0.5, -depth)]
    # reversed profile runs right to left along the top, which is CCW with the bottom first.
    return np.asarray(pts, dtype=np.float64)


def _design(
    kind: FaceKind,
    h_over_d: float,
    r_p: float,
    width: float,
    base_profiles: Sequence[Sequence[tuple[float, float]]],
    moving_profiles: Sequence[Sequence[tuple[float, float]]],
    *,
    mirror_symmetric: bool,
    body_depth: float,
) -> FaceDesign:
    depth = _check_ratio("body_depth", body_depth, allow_zero=True)
    base = tuple(_strip(p, depth) for p in base_profiles)
    moving = tuple(_strip(p, depth) for p in moving_profiles)
    return FaceDesign(
        kind=kind,
        h_over_d=h_over_d,
        r_p=r_p,
        width=width,
        mated_distance=2.0 * r_p + h_over_d,
        base_layers=base,
        moving_layers=moving,
        mirror_symmetric=mirror_symmetric,
        body_depth=depth,
    )


def _common(h_over_d: float, r_p: float, width: float) -> tuple[float, float, float]:
    return (
        _check_ratio("h_over_d", h_over_d, allow_zero=False),
        _check_ratio("r_p", r_p, allow_zero=True),
        _check_ratio("width", width, allow_zero=False, limit=MAX_WIDTH),
    )


def x_face(
    h_over_d: float, r_p: float, *, width: float = 1.0, body_depth: float = 1.0
) -> FaceDesign:
    """The two-layer X-Face: two mirrored sawtooth strips acting on the same rigid parts.

    Layer 1's top edge runs from (-D/2, r_p D) up to (+D/2, r_p D + H) with a wall at
    x = +D/2; layer 2 is its mirror image. Each layer is its own complement when the part is
    turned 180 degrees, so the face is genderless.

    Examples
    --------
    >>> d = x_face(0.25, 2.0)
    >>> d.n_layers, d.mated_distance
    (2, 4.25)
    """
    h, rp, w = _common(h_over_d, r_p, width)
    layer1 = [(-0.5, rp), (0.5, rp + h)]
    layer2 = [(-0.5, rp + h), (0.5, rp)]
    return _design(
        "X",
        h,
        rp,
        w,
        [layer1, layer2],
        [layer1, layer2],
        mirror_symmetric=True,
        body_depth=body_depth,
    )


def v_face(
    h_over_d: float, r_p: float, *, width: float = 1.0, body_depth: float = 1.0
) -> FaceDesign:
    """The gendered V-Face: the base carries the male isosceles triangle (base D, height H),
    the moving part the complementary notch.

    Examples
    --------
    >>> v_face(1.0, 0.0).mated_distance
    1.0
    """
    h, rp, w = _common(h_over_d, r_p, width)
    male = [(-0.5, rp), (0.0, rp + h), (0.5, rp)]
    female = [(-0.5, rp + h), (0.0, rp), (0.5, rp + h)]
    return _design("V", h, rp, w, [male], [female], mirror_symmetric=True, body_depth=body_depth)


def s_face(
    h_over_d: float, r_p: float, *, width: float = 1.0, body_depth: float = 1.0
) -> FaceDesign:
    """The genderless S-Face zig-zag with vertices at x = -D/2, -D/6, +D/6, +D/2.

    The ends lie on the mid line ``r_p D + H/2``; the inner vertices are H/2 above and below
    it (H is peak to trough). The profile is point-symmetric, hence its own complement.
    """
    h, rp, w = _common(h_over_d, r_p, width)
    mid = rp + 0.5 * h
    zig = [(-0.5, mid), (-1.0 / 6.0, rp + h), (1.0 / 6.0, rp), (0.5, mid)]
    return _design("S", h, rp, w, [zig], [zig], mirror_symmetric=False, body_depth=body_depth)


_FACTORIES = {"X": x_face, "V": v_face, "S": s_face}


def make_face(
    kind: str, h_over_d: float, r_p: float, *, width: float = 1.0, body_depth: float = 1.0
) -> FaceDesign:
    """Build a built-in face by its letter ("X", "V" or "S", case-insensitive).

    Examples
    --------
    >>> make_face("s", 0.5, 1.0).kind
    'S'
    """
    try:
        factory = _FACTORIES[kind.upper()]
    except (KeyError, AttributeError):
        raise XfaceValueError(f"face must be one of X, V, S; got {kind!r}") from None
    return factory(h_over_d, r_p, width=width, body_depth=body_depth)


#: Most vertex-edge pairs a design may have (a 400-vertex outline against another: 320 000
#: pairs, a 51 MB pair table built in 0.2 s and about 0.2 s per prediction).
MAX_CONTACT_PAIRS = 500_000


def custom_face(
    base_layers: Sequence[npt.ArrayLike],
    moving_layers: Sequence[npt.ArrayLike],
    *,
    mated_distance: float,
    width: float = 1.0,
    mirror_symmetric: bool = False,
) -> FaceDesign:
    """A user-defined face: one simple polygon per layer for each part, in units of D.

    Polygons are given in each part's body frame (pivot at the origin, profile facing +y)
    and may be convex or simple non-convex; they are validated with shapely and oriented
    counter-clockwise. ``mated_distance`` is the pivot-to-pivot distance L (in D) at which
    the parts are seated at equal angles; the mated parts must not overlap.

    ``mirror_symmetric=True`` claims that mirroring x -> -x maps every layer's pair of
    polygons onto a layer's pair (the X-Face's two layers swap, the V-Face's one maps onto
    itself), so that the outcome at (x0, theta0) equals the one at (-x0, -theta0); the maps
    then simulate only half of their poses. The claim is checked, vertex by vertex
    (:func:`is_mirror_symmetric`): a false one would copy wrong outcomes into every map.

    Raises
    ------
    GeometryError
        Layer counts differ, a polygon is not simple, has fewer than three vertices or a
        coordinate beyond +-:data:`MAX_CUSTOM_COORDINATE` D, the mated parts overlap, or
        ``mirror_symmetric`` is claimed for a design that is not.

    Examples
    --------
    >>> sq = [(-0.5, -1.0), (0.5, -1.0), (0.5, 0.5), (-0.5, 0.5)]
    >>> custom_face([sq], [sq], mated_distance=1.0).n_layers
    1
    >>> custom_face([sq], [sq], mated_distance=0.5)
    Traceback (most recent call last):
    ...
    xface_core.errors.GeometryError: layer 0: the mated parts overlap (area 0.5 D^2)
    """
    if len(base_layers) != len(moving_layers) or not base_layers:
        raise GeometryError("base and moving parts need the same number (>= 1) of layers")
    L = _check_ratio("mated_distance", mated_distance, allow_zero=False, limit=MAX_MATED_DISTANCE)
    w = _check_ratio("width", width, allow_zero=False, limit=MAX_WIDTH)
    base = tuple(_validated_polygon(p, f"base layer {i}") for i, p in enumerate(base_layers))
    moving = tuple(_validated_polygon(p, f"moving layer {i}") for i, p in enumerate(moving_layers))
    n_pairs = sum(2 * len(b) * len(m) for b, m in zip(base, moving, strict=True))
    if n_pairs > MAX_CONTACT_PAIRS:
        raise GeometryError(
            f"{n_pairs} vertex-edge pairs (2 x base vertices x moving vertices per layer) is "
            f"more than {MAX_CONTACT_PAIRS}: every prediction checks each pair at every step. "
            "Simplify the outlines (for example shapely.simplify(polygon, tolerance)) to a "
            "few hundred vertices per part"
        )
    for i, (b, m) in enumerate(zip(base, moving, strict=True)):
        overlap = (
            shapely.Polygon(b).intersection(shapely.Polygon(_moving_to_world(m, 0.0, L, 0.0))).area
        )
        if overlap > 1e-9:
            raise GeometryError(f"layer {i}: the mated parts overlap (area {overlap:.3g} D^2)")
    if mirror_symmetric and not is_mirror_symmetric(base, moving):
        raise GeometryError(
            "mirror_symmetric is claimed but the design is not mirror-symmetric: mirroring "
            "x -> -x does not map each layer's base and moving polygons onto a layer's (within "
            f"{MIN_EDGE_LENGTH:g} D per vertex); the maps would copy wrong outcomes. Leave "
            "mirror_symmetric false"
        )
    return FaceDesign(
        kind="custom",
        h_over_d=float("nan"),
        r_p=float("nan"),
        width=w,
        mated_distance=L,
        base_layers=base,
        moving_layers=moving,
        mirror_symmetric=bool(mirror_symmetric),
        body_depth=-min(float(p[:, 1].min()) for p in base),
    )


def _validated_polygon(points: npt.ArrayLike, name: str) -> FloatArray:
    try:
        arr = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int beyond a float
        raise GeometryError(
            f"{name}: vertices must be numbers in an (n, 2) array (ragged or non-numeric input)"
        ) from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 3:
        raise GeometryError(f"{name}: need an (n >= 3, 2) array of vertices, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise GeometryError(f"{name}: vertices must be finite")
    if np.any(np.abs(arr) > MAX_CUSTOM_COORDINATE):
        raise GeometryError(
            f"{name}: a vertex coordinate of {float(np.abs(arr).max()):.3g} D is beyond "
            f"+-{MAX_CUSTOM_COORDINATE:g} D (MAX_CUSTOM_COORDINATE, r_p + H of the largest "
            f"built-in design: {_RANGE_WHY})"
        )
    if arr.shape[0] > 3 and np.array_equal(arr[0], arr[-1]):
        # A closed ring (the first vertex repeated last) describes the same polygon.
        arr = arr[:-1]
    step = np.hypot(*(np.roll(arr, -1, axis=0) - arr).T)
    if np.any(step <= MIN_EDGE_LENGTH):
        k = int(np.argmax(step <= MIN_EDGE_LENGTH))
        raise GeometryError(
            f"{name}: vertices {k} and {(k + 1) % len(arr)} coincide (an edge of length "
            f"{step[k]:.3g} D); remove the repeated vertex"
        )
    poly = shapely.Polygon(arr)
    if not poly.is_valid or poly.area <= 0.0:
        reason = shapely.is_valid_reason(poly)
        raise GeometryError(f"{name}: not a simple polygon ({reason})")
    if not shapely.is_ccw(poly.exterior):
        arr = arr[::-1].copy()
    return np.ascontiguousarray(arr)


def _same_ring(a: FloatArray, b: FloatArray, tol: float) -> bool:
    """True when the rings ``a`` and ``b`` (same orientation) have the same vertices in the
    same cyclic order, each within ``tol`` (D) of its partner, from any starting vertex."""
    if a.shape != b.shape:
        return False
    starts = np.flatnonzero(np.max(np.abs(b - a[0]), axis=1) <= tol)
    return any(np.max(np.abs(np.roll(b, -int(k), axis=0) - a)) <= tol for k in starts)


def is_mirror_symmetric(
    base_layers: Sequence[FloatArray], moving_layers: Sequence[FloatArray]
) -> bool:
    """Whether mirroring x -> -x maps the design onto itself: each layer's (base, moving)
    pair of counter-clockwise polygons (body frames, D), mirrored, is the pair of one layer,
    each layer used once, vertex for vertex within :data:`MIN_EDGE_LENGTH` (closer vertices
    are one point, as for edges). Then the outcome at (x0, theta0) is the one at
    (-x0, -theta0): in the world, x -> -x turns a pose (x0, theta0) into (-x0, -theta0)
    and each part's body frame into its own mirror image.

    Examples
    --------
    >>> d = x_face(0.25, 2.0)
    >>> is_mirror_symmetric(d.base_layers, d.moving_layers)  # its two layers swap
    True
    >>> d = s_face(0.25, 2.0)
    >>> is_mirror_symmetric(d.base_layers, d.moving_layers)  # point-, not mirror-symmetric
    False
    """
    unmatched = list(range(len(base_layers)))
    for base, moving in zip(base_layers, moving_layers, strict=True):
        # Mirroring reverses a ring's orientation: reverse the order to keep it CCW.
        mirrored = (base[::-1] * (-1.0, 1.0), moving[::-1] * (-1.0, 1.0))
        match = next(
            (
                j
                for j in unmatched
                if _same_ring(mirrored[0], base_layers[j], MIN_EDGE_LENGTH)
                and _same_ring(mirrored[1], moving_layers[j], MIN_EDGE_LENGTH)
            ),
            None,
        )
        if match is None:
            return False
        unmatched.remove(match)
    return True
