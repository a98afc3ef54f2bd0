"""The acceptance atlas: one design's outcomes on a fine (x0, theta0) grid, built once.

A robot asks many questions *around* the pose it holds (how far is the next flip, how likely
is a seat under this covariance); each would cost dozens to thousands of simulations. The
atlas answers the "where are the boundaries" part once per design and physics, so those
questions need only a few exact simulations at the boundaries they touch. It never replaces
the simulation of a queried pose itself.

Grid: ``x0 = i * lateral_step`` (units of D) over ``|x0| <= lateral_range`` (default: the mated
distance L plus two steps, since beyond L every pose is OUT_OF_REACH) and
``theta0 = k * angle_step`` (rad) over ``|theta0| <= angle_range`` (default 3 pi/2: the
paper's pi/2 plus the margin search's pi), built from
integers so mirrored nodes are exact negatives. Every pose starts at the default height just
clear of the base for its angle (:func:`~xface_core.runner.start_heights`), as
:func:`~xface_core.predict` does without ``y_start``; queries with an explicit ``y_start`` do
not use the atlas.

Build: the nodes at every ``coarse_stride``-th grid line are simulated; then, halving the
stride down to 1, only the blocks whose four corners disagree, and their eight neighbours,
get their midpoints simulated; the nodes of the other blocks take the common outcome of
their corners. A region of another outcome that fits inside one coarse block (and its
neighbours) without touching a simulated node is missed: see ``docs/atlas.md``.
"""

from __future__ import annotations

import hashlib
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError, is_integer_in
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics, SolverSettings
from xface_core.runner import START_CLEARANCE, outcomes_at

from .cache import (
    ATLAS_FORMAT,
    AtlasCacheWarning,
    UnusableAtlasFile,
    cache_path,
    is_directory,
    read_atlas_file,
    warn_cache,
    write_atlas_file,
)
from .flips import bisect_every_flip, check_cancel

__all__ = [
    "ATLAS_FORMAT",
    "DEFAULT_ANGLE_STEP",
    "DEFAULT_COARSE_STRIDE",
    "DEFAULT_LATERAL_STEP",
    "MAX_ATLAS_NODES",
    "AcceptanceAtlas",
    "AtlasCacheWarning",
    "atlas_key",
    "build_atlas",
]

FloatArray = npt.NDArray[np.float64]
Int8Array = npt.NDArray[np.int8]

#: Default node spacing: D/64 laterally and pi/256 in angle, finer than the exact margin
#: search's scan (D/40, pi/160), so the atlas sees every feature that search sees.
DEFAULT_LATERAL_STEP = 1.0 / 64.0
DEFAULT_ANGLE_STEP = math.pi / 256.0
#: Default half-width in angle: pi/2 (the paper's range) plus the exact margin search's pi, so
#: the angle search from any query in [-pi/2, pi/2] stays on the atlas. The outcome is uniform
#: over most of the extra range, so it costs little: the refinement only follows boundaries.
DEFAULT_ANGLE_RANGE = 1.5 * math.pi
#: Nodes between the simulated lines of the first pass (a power of two).
DEFAULT_COARSE_STRIDE = 8
#: Where a boundary cell's chord is checked, in cell coordinates (fractions of the steps):
#: the centre and the four quarter points. With the centre alone 3 % of the poses in X
#: 0.25/1's boundary cells stayed on the wrong side of their chord, with these five 0.5 %.
CHORD_CHECK_POINTS = ((0.5, 0.5), (0.25, 0.25), (0.75, 0.75), (0.25, 0.75), (0.75, 0.25))
#: Largest grid accepted (int8 outcomes: 4 MB; about 5 minutes to build on a loaded
#: 2-core machine if every node had to be simulated).
MAX_ATLAS_NODES = 4_000_000


class FlipStore:
    """Flip positions on an atlas's grid lines, found lazily and kept (thread-safe).

    Key ``(axis, line, node)``: the flip on grid line ``line`` (axis 0: the column
    ``theta0[line]``, searched along x0; axis 1: the row ``x0[line]``, searched along theta0)
    between nodes ``node`` and ``node + 1``. Value ``(lo, hi)``: a bracket of it in the
    line's coordinate (D or rad), ``lo`` with the outcome of node ``node``, ``hi`` with
    another one. Shared by every copy of the atlas (:meth:`AcceptanceAtlas.bound_to`): the
    flips are in units of D, the same for any width.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._known: dict[tuple[int, int, int], tuple[float, float]] = {}
        self._asked: set[tuple[int, int, int]] = set()
        self._version = 0  # counts the changes, so the dense arrays know when to renew
        self._dense: tuple[int, tuple[int, int], FloatArray, FloatArray] | None = None
        self._chords: tuple[int, npt.NDArray[np.bool_]] | None = None

    def worth_finding(self, keys: list[tuple[int, int, int]]) -> bool:
        """True when every key is known or was asked for before (then bisecting the unknown
        ones pays: a second query came by); records the ask. A one-off query is cheaper
        with a search along its own line than with the bisection of two grid lines."""
        with self._lock:
            again = all(k in self._known or k in self._asked for k in keys)
            self._asked.update(keys)
            return again

    def get(self, key: tuple[int, int, int]) -> tuple[float, float] | None:
        with self._lock:
            return self._known.get(key)

    def put(self, key: tuple[int, int, int], bracket: tuple[float, float]) -> None:
        with self._lock:
            self._known[key] = bracket
            self._version += 1

    def __len__(self) -> int:
        with self._lock:
            return len(self._known)

    def arrays(self) -> tuple[npt.NDArray[np.int64], FloatArray]:
        """The known flips as arrays: keys (n, 3) and brackets (n, 2), for saving."""
        with self._lock:
            items = sorted(self._known.items())
        keys = np.array([k for k, _ in items], dtype=np.int64).reshape(-1, 3)
        brackets = np.array([b for _, b in items], dtype=np.float64).reshape(-1, 2)
        return keys, brackets

    def dense(self, shape: tuple[int, int]) -> tuple[FloatArray, FloatArray]:
        """The known flips as two grids of positions (the middle of each bracket), NaN
        where none is known, for a grid of ``shape`` (nodes along x0, along theta0):
        ``along_x0[i, k]`` (D) between nodes (i, k) and (i + 1, k), ``along_theta0[i, k]``
        (rad) between (i, k) and (i, k + 1). Kept until a flip is added (read-only)."""
        with self._lock:
            cached = self._dense
            if cached is not None and cached[0] == self._version and cached[1] == shape:
                return cached[2], cached[3]
            version = self._version
        keys, brackets = self.arrays()
        along_x0 = np.full((shape[0] - 1, shape[1]), np.nan)
        along_theta0 = np.full((shape[0], shape[1] - 1), np.nan)
        middle = brackets.mean(axis=1)
        on_column = keys[:, 0] == 0
        along_x0[keys[on_column, 2], keys[on_column, 1]] = middle[on_column]
        along_theta0[keys[~on_column, 1], keys[~on_column, 2]] = middle[~on_column]
        along_x0.flags.writeable = False
        along_theta0.flags.writeable = False
        with self._lock:
            self._dense = (version, shape, along_x0, along_theta0)
        return along_x0, along_theta0

    def checked_chords(self) -> npt.NDArray[np.bool_] | None:
        """The cells whose chords passed their check
        (:meth:`AcceptanceAtlas.checked_chords`), while no flip has changed since; None
        before a check or after a change."""
        with self._lock:
            kept = self._chords
            return kept[1] if kept is not None and kept[0] == self._version else None

    def keep_checked_chords(self, version: int, trusted: npt.NDArray[np.bool_]) -> None:
        """Keep a chord check made on the flips of ``version`` (:attr:`version`)."""
        with self._lock:
            self._chords = (version, trusted)

    @property
    def version(self) -> int:
        """Counts the changes to the known flips."""
        with self._lock:
            return self._version

    def add_arrays(
        self, keys: npt.ArrayLike, brackets: npt.ArrayLike, shape: tuple[int, int]
    ) -> None:
        """Know the flips of :meth:`arrays` again (a saved atlas loaded). Raises
        ``ValueError`` for arrays that cannot be an atlas's flips on a grid of ``shape``
        (nodes along x0, along theta0): a foreign or damaged file is rebuilt, not trusted."""
        k = np.asarray(keys)
        b = np.asarray(brackets, dtype=np.float64)
        if k.ndim != 2 or k.shape[1] != 3 or b.shape != (k.shape[0], 2):
            raise ValueError("flip arrays of the wrong shape")
        if k.shape[0] == 0:
            return
        if not np.issubdtype(k.dtype, np.integer):
            raise ValueError("flip keys must be integers")
        axis, line, node = k[:, 0], k[:, 1], k[:, 2]
        # axis 0: line indexes theta0, node indexes x0; axis 1 the other way round.
        n_line = np.where(axis == 0, shape[1], shape[0])
        n_node = np.where(axis == 0, shape[0], shape[1])
        ok = (
            np.isin(axis, (0, 1))
            & (line >= 0) & (line < n_line) & (node >= 0) & (node < n_node - 1)
            & np.all(np.isfinite(b), axis=1) & (b[:, 0] < b[:, 1])
        )  # fmt: skip
        if not bool(np.all(ok)):
            raise ValueError("flip arrays that do not fit the grid")
        with self._lock:
            for key, bracket in zip(k.tolist(), b.tolist(), strict=True):
                self._known[(key[0], key[1], key[2])] = (bracket[0], bracket[1])
            self._version += 1

    def __getstate__(self) -> dict[str, object]:
        # An atlas goes to process-pool workers by pickle: the flips go with it, a lock cannot.
        with self._lock:
            return {"known": dict(self._known), "asked": set(self._asked)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._lock = threading.Lock()
        self._known = state["known"]
        self._asked = state["asked"]
        self._version = 0
        self._dense = None
        self._chords = None


@dataclass(frozen=True, eq=False)
class AcceptanceAtlas:
    """Outcomes of one design and physics on a regular (x0, theta0) grid.

    Attributes
    ----------
    design : FaceDesign
        The design it was built for (any width: the atlas is in units of D).
    physics : Physics
    key : str
        Hex digest of the geometry, physics, settings, grid and start height: equal keys
        mean interchangeable atlases (it names the cache file).
    x0 : (n,) float
        Lateral offsets of the nodes, in units of D.
    theta0 : (m,) float
        Angles of the nodes (rad).
    outcomes : (n, m) int8
        :class:`~xface_core.codes.Outcome` value per node (simulated or filled).
    simulated : (n, m) bool
        True where the node was simulated (False: filled from agreeing block corners).
    start_clearance : float
        Every node started this far (D) above the lowest clear height for its angle: the
        default start of :func:`~xface_core.predict`.
    build_seconds : float
        Wall time of the build, with the flips' bisection when built with ``every_flip``
        (0 when loaded from the cache).
    flips : FlipStore
        Flips on the grid lines bisected so far (:mod:`xface_core.atlas.flips`): all of
        them when built with ``every_flip``, else they grow as queries touch boundaries;
        saved with the atlas (:meth:`save`).
    """

    design: FaceDesign
    physics: Physics
    key: str
    x0: FloatArray
    theta0: FloatArray
    outcomes: Int8Array
    simulated: npt.NDArray[np.bool_]
    start_clearance: float = START_CLEARANCE
    build_seconds: float = 0.0
    flips: FlipStore = field(default_factory=FlipStore, repr=False)

    def __post_init__(self) -> None:
        # Read-only arrays: one atlas is shared by every query (and thread) that uses it.
        for array in (self.x0, self.theta0, self.outcomes, self.simulated):
            array.flags.writeable = False

    @property
    def lateral_step(self) -> float:
        """Node spacing along x0 (D)."""
        return float(self.x0[1] - self.x0[0])

    @property
    def angle_step(self) -> float:
        """Node spacing along theta0 (rad)."""
        return float(self.theta0[1] - self.theta0[0])

    @property
    def simulations(self) -> int:
        """Nodes simulated to build the atlas."""
        return int(np.count_nonzero(self.simulated))

    def covers(self, x0_d: npt.ArrayLike, theta0: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """True where a pose (x0 in D, theta0 in rad) lies inside the grid."""
        x, t = np.asarray(x0_d, dtype=np.float64), np.asarray(theta0, dtype=np.float64)
        return np.asarray(
            (x >= self.x0[0]) & (x <= self.x0[-1]) & (t >= self.theta0[0]) & (t <= self.theta0[-1])
        )

    def cell_index(
        self, x0_d: npt.ArrayLike, theta0: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
        """Lower-left node (i, k) of the grid cell holding each pose (clipped to the grid)."""
        x, t = np.asarray(x0_d, dtype=np.float64), np.asarray(theta0, dtype=np.float64)
        i = np.floor((np.nan_to_num(x) - self.x0[0]) / self.lateral_step).astype(np.intp)
        k = np.floor((np.nan_to_num(t) - self.theta0[0]) / self.angle_step).astype(np.intp)
        return np.clip(i, 0, self.x0.size - 2), np.clip(k, 0, self.theta0.size - 2)

    @cached_property
    def _seated_nodes(self) -> npt.NDArray[np.int8]:
        # 1 where a node seats, else 0: read by every sample of every probability query
        # (comparing the whole grid per call cost more than the query's own work).
        seated: npt.NDArray[np.int8] = (self.outcomes == Outcome.SEATED).astype(np.int8)
        seated.flags.writeable = False
        return seated

    def _corner_verdicts(
        self, x: FloatArray, t: FloatArray
    ) -> tuple[
        npt.NDArray[np.int8], npt.NDArray[np.intp], npt.NDArray[np.intp], npt.NDArray[np.bool_]
    ]:
        """:meth:`seated_in_cell` of poses (D, rad), with their cells' lower-left nodes and
        whether they lie inside the grid."""
        i, k = self.cell_index(x, t)
        inside = self.covers(x, t)
        s = self._seated_nodes
        corners = s[i, k] + s[i + 1, k] + s[i, k + 1] + s[i + 1, k + 1]
        out = np.where(corners == 4, 1, np.where(corners == 0, 0, -1)).astype(np.int8)
        out[~inside] = -1
        return out, i, k, inside

    def seated_in_cell(self, x0_d: npt.ArrayLike, theta0: npt.ArrayLike) -> npt.NDArray[np.int8]:
        """Per pose: 1 when its cell's four corners all seat, 0 when none does, -1 when they
        disagree or the pose lies outside the grid (an exact simulation must decide)."""
        return self._corner_verdicts(
            np.asarray(x0_d, dtype=np.float64), np.asarray(theta0, dtype=np.float64)
        )[0]

    def seated_by_flips(self, x0_d: npt.ArrayLike, theta0: npt.ArrayLike) -> npt.NDArray[np.int8]:
        """As :meth:`seated_in_cell`, and in a cell whose corners disagree the side of the
        chord drawn between the flips known on its two edges that change (marching squares:
        1 on the seated corners' side, 0 on the other), where that cell's chord passed its
        check (:meth:`checked_chords`, made on first use). -1 still where no chord can be
        drawn (the two seated corners opposite, a flip not known yet), where the check
        found it wrong, and outside the grid: an exact simulation must decide those.

        The chord is exact only where the boundary is straight across the cell: a curved
        one is off by about its curvature times the cell size squared over 8, and
        structure finer than a cell that the check's five points miss is not seen. What
        that costs a seat probability is measured in docs/atlas.md."""
        x = np.asarray(x0_d, dtype=np.float64)
        t = np.asarray(theta0, dtype=np.float64)
        out, i, k, inside = self._corner_verdicts(x, t)
        flat = out.reshape(-1)
        mixed = np.nonzero((flat < 0) & inside.reshape(-1))[0]
        if mixed.size == 0:
            return out
        i, k = i.reshape(-1)[mixed], k.reshape(-1)[mixed]
        side = self._chord_side(x.reshape(-1)[mixed], t.reshape(-1)[mixed], i, k)
        flat[mixed] = np.where(self.checked_chords()[i, k], side, -1)
        return out

    def checked_chords(self, threads: int | None = None) -> npt.NDArray[np.bool_]:
        """Per cell (n - 1, m - 1): False where the chord of :meth:`seated_by_flips` put one
        of five points (the centre and the four quarter points) on the wrong side of the
        boundary by an exact simulation, True elsewhere. Made once (five simulations per
        cell whose corners disagree on seating; 0.1-0.7 s on the default grids, ``threads``
        as for :func:`~xface_core.runner.outcomes_at`) and kept until a flip changes.

        Where outcomes interleave within a cell (SEATED and BAD_MATE bands on X 0.25/1 near
        |theta0| = 0.6-0.7 rad) the chord is wrong for 8 % of the poses in boundary cells;
        after this check, for 0.5 %, the rest simulated (docs/atlas.md)."""
        kept = self.flips.checked_chords()
        if kept is not None:
            return kept
        version = self.flips.version
        s = self._seated_nodes
        corners = s[:-1, :-1] + s[1:, :-1] + s[:-1, 1:] + s[1:, 1:]
        cells = np.argwhere((corners > 0) & (corners < 4))
        trusted = np.ones(corners.shape, dtype=bool)
        if cells.size:
            i = np.repeat(cells[:, 0], len(CHORD_CHECK_POINTS))
            k = np.repeat(cells[:, 1], len(CHORD_CHECK_POINTS))
            fraction = np.tile(np.array(CHORD_CHECK_POINTS), (len(cells), 1))
            x = self.x0[i] + fraction[:, 0] * self.lateral_step
            t = self.theta0[k] + fraction[:, 1] * self.angle_step
            side = self._chord_side(x, t, i, k)
            asked = side >= 0
            exact = outcomes_at(self.design, x[asked], t[asked], self.physics, threads=threads)
            wrong = np.zeros(side.shape, dtype=bool)
            wrong[asked] = side[asked] != (exact == Outcome.SEATED)
            trusted[i[wrong], k[wrong]] = False
        trusted.flags.writeable = False
        self.flips.keep_checked_chords(version, trusted)
        return trusted

    def _chord_side(
        self,
        x: FloatArray,
        t: FloatArray,
        i: npt.NDArray[np.intp],
        k: npt.NDArray[np.intp],
    ) -> npt.NDArray[np.int8]:
        """For poses (D, rad) in cells (i, k) whose corners disagree: 1 on the seated side of
        the chord between the flips on the cell's two changing edges, 0 on the other, -1
        where there is no chord (opposite seated corners, a flip unknown, both flips at one
        corner)."""
        s = self._seated_nodes
        c00, c10, c01, c11 = s[i, k], s[i + 1, k], s[i, k + 1], s[i + 1, k + 1]
        along_x0, along_theta0 = self.flips.dense(self.outcomes.shape)
        dx, dt = self.lateral_step, self.angle_step
        u = (x - self.x0[i]) / dx  # the pose in cell coordinates (0..1 both ways)
        v = (t - self.theta0[k]) / dt
        # The crossing on each edge in cell coordinates: bottom (b, 0), right (1, r),
        # top (p, 1), left (0, q); an edge whose ends agree has none.
        bottom = (along_x0[i, k] - self.x0[i]) / dx
        right = (along_theta0[i + 1, k] - self.theta0[k]) / dt
        top = (along_x0[i, k + 1] - self.x0[i]) / dx
        left = (along_theta0[i, k] - self.theta0[k]) / dt
        edge_u = np.column_stack((bottom, np.ones_like(u), top, np.zeros_like(u)))
        edge_v = np.column_stack((np.zeros_like(u), right, np.ones_like(u), left))
        changes = np.column_stack((c00 != c10, c10 != c11, c01 != c11, c00 != c01))
        first, second = np.argsort(~changes, axis=1, kind="stable")[:, :2].T
        rows = np.arange(u.size)
        pu, pv = edge_u[rows, first], edge_v[rows, first]
        eu, ev = edge_u[rows, second] - pu, edge_v[rows, second] - pv
        # The side of the chord: of the pose, and of a seated corner (the first one: c00,
        # c10, c01 then c11).
        seated_u = np.where(c00 == 1, 0.0, np.where(c10 == 1, 1.0, np.where(c01 == 1, 0.0, 1.0)))
        seated_v = np.where((c00 == 1) | (c10 == 1), 0.0, 1.0)
        pose_side = eu * (v - pv) - ev * (u - pu)
        seated_side = eu * (seated_v - pv) - ev * (seated_u - pu)
        # A chord needs two distinct crossings (both at one corner: a boundary through a node).
        drawn = (
            (changes.sum(axis=1) == 2)
            & np.isfinite(pose_side * seated_side)
            & (eu * eu + ev * ev > 1e-12)
        )
        return np.where(drawn, pose_side * seated_side > 0.0, -1).astype(np.int8)

    def bound_to(self, design: FaceDesign, physics: Physics) -> AcceptanceAtlas:
        """This atlas for ``design`` (same geometry, any width: the atlas is in units of D, and
        the returned one reads queries in ``design``'s length unit) and ``physics``.

        Raises :class:`XfaceValueError` unless it was built for this geometry and physics,
        so it cannot silently answer for another connector.
        """
        if design.cache_key != self.design.cache_key:
            raise XfaceValueError("the atlas was built for another design geometry")
        if physics != self.physics:
            raise XfaceValueError(f"the atlas was built for {self.physics!r}, not for {physics!r}")
        if design is self.design:
            return self
        bound = replace(self, design=design)
        if "_seated_nodes" in self.__dict__:  # the same nodes: not compared again
            bound.__dict__["_seated_nodes"] = self.__dict__["_seated_nodes"]
        return bound

    def save(self, path: str | Path) -> Path:
        """Write the atlas to an ``.npz`` file (``build_atlas(..., cache_dir=...)`` reads it
        back for the same design, physics and grid; the design itself is not stored), with
        the grid-line flips found so far (saved again later, a restart also keeps those) and
        a checksum (:mod:`xface_core.atlas.cache`). The file is replaced atomically: a reader
        never sees half a file, and two processes may save the same atlas at once. Raises
        ``OSError`` when the folder cannot be written."""
        flip_keys, flip_brackets = self.flips.arrays()
        arrays: dict[str, npt.NDArray[Any]] = {
            "key": np.array(self.key),
            "format": np.array(ATLAS_FORMAT, dtype=np.int64),
            "x0": self.x0,
            "theta0": self.theta0,
            "outcomes": self.outcomes,
            "simulated": self.simulated,
            "start_clearance": np.array(self.start_clearance, dtype=np.float64),
            "flip_keys": flip_keys,
            "flip_brackets": flip_brackets,
        }
        return write_atlas_file(Path(path), arrays)


def _settings_tuple(settings: SolverSettings) -> tuple[object, ...]:
    return tuple(getattr(settings, f.name) for f in fields(settings))


def atlas_key(
    design: FaceDesign,
    physics: Physics,
    *,
    lateral_step: float,
    angle_step: float,
    lateral_range: float,
    angle_range: float,
    coarse_stride: int,
) -> str:
    """Digest of everything an atlas's outcomes depend on (geometry in D, physics, solver
    settings, grid, refinement stride, start height and the format): the cache file name."""
    parts = (
        ATLAS_FORMAT,
        design.cache_key,
        physics.damping_ratio,
        physics.friction,
        _settings_tuple(physics.settings),
        lateral_step,
        angle_step,
        lateral_range,
        angle_range,
        coarse_stride,
        START_CLEARANCE,
    )
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:24]


def _half_nodes(extent: float, step: float, stride: int) -> int:
    """Steps from the centre to the edge: covers ``extent`` and is a multiple of ``stride``."""
    return stride * math.ceil(extent / step / stride - 1e-9)


def _check_positive(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise XfaceValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _grid_size(
    x_range: float, dx: float, t_range: float, dt: float, coarse_stride: int, max_nodes: int
) -> tuple[int, int]:
    """Nodes either side of zero along x0 and theta0 (:func:`build_atlas`'s grid), after
    checking the stride and the grid's size."""
    if not is_integer_in(coarse_stride, 1) or coarse_stride & (coarse_stride - 1):
        raise XfaceValueError(f"coarse_stride must be a power of two >= 1, got {coarse_stride!r}")
    nx = _half_nodes(x_range, dx, coarse_stride)
    nt = _half_nodes(t_range, dt, coarse_stride)
    if nt * dt > 2.0 * math.pi:  # the engine takes |theta0| <= 2 pi
        raise XfaceValueError("angle_range rounded up to the coarse stride exceeds 2 pi")
    nodes = (2 * nx + 1) * (2 * nt + 1)
    if nodes > max_nodes:
        raise XfaceValueError(
            f"an atlas of {2 * nx + 1} x {2 * nt + 1} = {nodes:,} nodes exceeds max_nodes="
            f"{max_nodes:,} (about {nodes * 1e-4:.0f} s if every node were simulated at "
            "100 us each); raise the steps or narrow the ranges"
        )
    return nx, nt


def build_atlas(
    design: FaceDesign,
    *,
    physics: Physics | None = None,
    lateral_step: float = DEFAULT_LATERAL_STEP,
    angle_step: float = DEFAULT_ANGLE_STEP,
    lateral_range: float | None = None,
    angle_range: float = DEFAULT_ANGLE_RANGE,
    coarse_stride: int = DEFAULT_COARSE_STRIDE,
    max_nodes: int = MAX_ATLAS_NODES,
    cache_dir: str | Path | None = None,
    threads: int | None = None,
    every_flip: bool = False,
    cancel: Callable[[], bool] | None = None,
    on_cache_problem: Callable[[str], object] | None = None,
) -> AcceptanceAtlas:
    """Build (or load from ``cache_dir``) the acceptance atlas of a design and physics.

    Parameters
    ----------
    design : FaceDesign
    physics : Physics, optional
        Default ``Physics()``.
    lateral_step : float
        Node spacing along x0, in units of D (default D/64).
    angle_step : float
        Node spacing along theta0, rad (default pi/256).
    lateral_range : float, optional
        Half-width of the grid along x0, in D (default: L + 2 steps; beyond L no seat exists).
    angle_range : float
        Half-width of the grid along theta0, rad (default 3 pi/2; at most 2 pi).
    coarse_stride : int
        Grid lines between the simulated lines of the first pass (a power of two >= 1;
        1 simulates every node).
    max_nodes : int
        Size guard: a grid with more nodes raises :class:`XfaceValueError` with the estimate.
    cache_dir : path, optional
        Directory of ``atlas-<key>.npz`` files (``~`` expanded, created if absent): an atlas
        with the same key is loaded instead of built, and a built one is saved there. A file
        that fails a check (:mod:`xface_core.atlas.cache`) is rebuilt and replaced, and a
        folder that cannot be written keeps nothing; each is one
        :class:`~xface_core.atlas.cache.AtlasCacheWarning` (the atlas is returned all the
        same). Nothing is cached unless a directory is given.
    threads : int, optional
        Threads of the batch simulations (default: one per core).
    every_flip : bool
        Also bisect the flip of every boundary segment of the grid lines
        (:func:`~xface_core.atlas.flips.bisect_every_flip`: 0.26-0.41 s more on the default
        grids, 3-5 times the build), so that the margins of a query near a boundary no one
        asked about before are interpolated and confirmed with eight simulations instead of
        searched (docs/atlas.md). A cached atlas that lacks some is completed and saved
        again. Default False: the flips are then bisected lazily, as queries come by (seat
        probabilities never need them).
    cancel : callable, optional
        Asked before each batch of simulations (the build's longest is a fraction of a
        second); when it returns True the build stops with :class:`~.errors.Cancelled` and
        nothing is saved. For a caller that may stop wanting the atlas (the ROS node at
        shutdown or after a design change).
    on_cache_problem : callable, optional
        Told, in one sentence naming the file and the reason, of a cache file not used or
        not written, instead of an :class:`~xface_core.atlas.cache.AtlasCacheWarning`: for a
        caller with a logger of its own (the ROS node).

    Examples
    --------
    >>> from xface_core import v_face
    >>> a = build_atlas(v_face(0.5, 1.0), lateral_step=0.125, angle_step=0.2, angle_range=1.6)
    >>> a.outcomes.shape
    (49, 17)
    """
    phys = Physics() if physics is None else physics
    if not isinstance(phys, Physics):
        raise XfaceValueError(f"physics must be a Physics, got {phys!r}")
    dx = _check_positive("lateral_step", lateral_step)
    dt = _check_positive("angle_step", angle_step)
    x_range = (
        design.mated_distance + 2.0 * dx
        if lateral_range is None
        else _check_positive("lateral_range", lateral_range)
    )
    t_range = _check_positive("angle_range", angle_range)
    if t_range > 2.0 * math.pi:
        raise XfaceValueError(f"angle_range must be <= 2 pi, got {angle_range!r}")
    nx, nt = _grid_size(x_range, dx, t_range, dt, coarse_stride, max_nodes)
    key = atlas_key(
        design, phys, lateral_step=dx, angle_step=dt, lateral_range=x_range,
        angle_range=t_range, coarse_stride=coarse_stride,
    )  # fmt: skip
    # Integer multiples: mirrored nodes are exact negatives (the mirror fill relies on it).
    x_d = np.arange(-nx, nx + 1).astype(np.float64) * dx
    th = np.arange(-nt, nt + 1).astype(np.float64) * dt
    path = None if cache_dir is None else cache_path(cache_dir, key)
    if path is not None:
        loaded = _load_or_warn(path, design, phys, key, x_d, th, on_cache_problem)
        if loaded is not None:
            if every_flip and bisect_every_flip(loaded, threads=threads, cancel=cancel):
                _save_or_warn(loaded, path, on_cache_problem)
            return loaded

    t0 = time.perf_counter()
    outcomes, simulated = _refine(design, x_d, th, coarse_stride, phys, threads, cancel)
    atlas = AcceptanceAtlas(
        design=design,
        physics=phys,
        key=key,
        x0=x_d,
        theta0=th,
        outcomes=outcomes,
        simulated=simulated,
        build_seconds=time.perf_counter() - t0,
    )
    if every_flip:
        bisect_every_flip(atlas, threads=threads, cancel=cancel)
        atlas = replace(atlas, build_seconds=time.perf_counter() - t0)  # the flips as well
    if path is not None:
        _save_or_warn(atlas, path, on_cache_problem)
    return atlas


def _load_or_warn(
    path: Path,
    design: FaceDesign,
    physics: Physics,
    key: str,
    x_d: FloatArray,
    th: FloatArray,
    report: Callable[[str], object] | None,
) -> AcceptanceAtlas | None:
    """The cached atlas at ``path`` for ``key`` on the grid ``x_d`` x ``th``, or None: when
    there is no file, or when the file fails a check of
    :func:`~xface_core.atlas.cache.read_atlas_file` or holds flips that do not fit the grid
    (then with one :class:`AtlasCacheWarning` naming the file and the reason, or that
    sentence to ``report``). The caller rebuilds it and replaces the file."""
    try:
        data = read_atlas_file(path, key=key, x0=x_d, theta0=th, start_clearance=START_CLEARANCE)
        atlas = AcceptanceAtlas(
            design=design,
            physics=physics,
            key=key,
            x0=x_d,
            theta0=th,
            outcomes=np.asarray(data["outcomes"], dtype=np.int8),
            simulated=np.asarray(data["simulated"], dtype=np.bool_),
            start_clearance=START_CLEARANCE,
        )
        try:
            atlas.flips.add_arrays(data["flip_keys"], data["flip_brackets"], atlas.outcomes.shape)
        except ValueError as exc:
            raise UnusableAtlasFile(str(exc)) from exc
    except (FileNotFoundError, NotADirectoryError):
        return None  # nothing cached yet (the folder may not exist, or be a file: the save says)
    except UnusableAtlasFile as exc:
        then = "built, not cached" if is_directory(path) else "rebuilt and replaced"
        warn_cache(f"atlas cache file {path} not used: {exc}; the atlas is {then}", report)
        return None
    return atlas


def _save_or_warn(
    atlas: AcceptanceAtlas, path: Path, report: Callable[[str], object] | None
) -> None:
    """Save ``atlas`` to ``path``; a folder that cannot be written is one
    :class:`AtlasCacheWarning` or sentence to ``report`` (the atlas is still there for the
    caller, the next run builds it again). A directory there is left alone (warned when read)."""
    if is_directory(path):
        return
    try:
        atlas.save(path)
    except OSError as exc:
        warn_cache(f"atlas cache file {path} not written ({exc}); the atlas is not kept", report)


def _simulate(
    design: FaceDesign,
    x_d: FloatArray,
    th: FloatArray,
    todo: npt.NDArray[np.bool_],
    out: Int8Array,
    physics: Physics,
    threads: int | None,
) -> None:
    """Simulate the nodes marked in ``todo`` into ``out`` (mirrored when the design allows)."""
    if design.mirror_symmetric:
        # outcome(x0, theta0) == outcome(-x0, -theta0) exactly for such designs, and the
        # grid is built from integers, so node (i, k) mirrors onto (n-1-i, m-1-k).
        todo = todo | todo[::-1, ::-1]
        flat = np.flatnonzero(todo.ravel())
        half = flat[flat <= (todo.size - 1) // 2]
    else:
        half = np.flatnonzero(todo.ravel())
    i, k = np.unravel_index(half, todo.shape)
    codes = outcomes_at(design, x_d[i], th[k], physics, threads=threads)
    out[i, k] = codes
    if design.mirror_symmetric:
        out[todo.shape[0] - 1 - i, todo.shape[1] - 1 - k] = codes


def _refine(
    design: FaceDesign,
    x_d: FloatArray,
    th: FloatArray,
    stride: int,
    physics: Physics,
    threads: int | None,
    cancel: Callable[[], bool] | None = None,
) -> tuple[Int8Array, npt.NDArray[np.bool_]]:
    """Outcomes on the grid by boundary-following refinement (see the module docstring);
    ``cancel`` is asked before each batch (:func:`~.atlas_flips.check_cancel`)."""
    shape = (x_d.size, th.size)
    out = np.full(shape, -1, dtype=np.int8)
    todo = np.zeros(shape, dtype=bool)
    todo[::stride, ::stride] = True
    simulated = todo.copy()
    check_cancel(cancel)
    _simulate(design, x_d, th, todo, out, physics, threads)
    s = stride
    while s > 1:
        c = out[::s, ::s]
        ref = c[:-1, :-1]
        mixed = (ref != c[1:, :-1]) | (ref != c[:-1, 1:]) | (ref != c[1:, 1:])
        # Neighbours too: a boundary can cross a block's edge between two agreeing corners.
        grown = mixed.copy()
        grown[1:, :] |= mixed[:-1, :]
        grown[:-1, :] |= mixed[1:, :]
        grown[:, 1:] |= grown[:, :-1].copy()
        grown[:, :-1] |= grown[:, 1:].copy()
        fine = np.repeat(np.repeat(grown, s, axis=0), s, axis=1)
        near = np.zeros(shape, dtype=bool)  # nodes touching a refined block
        near[:-1, :-1] |= fine
        near[1:, :-1] |= fine
        near[:-1, 1:] |= fine
        near[1:, 1:] |= fine
        half = s // 2
        todo = np.zeros(shape, dtype=bool)
        todo[::half, ::half] = True
        todo &= near & (out < 0)
        check_cancel(cancel)
        _simulate(design, x_d, th, todo, out, physics, threads)
        simulated |= todo
        # Nodes of untouched blocks take their block's common corner outcome.
        fill = (out < 0) & ~near
        i, k = np.nonzero(fill)
        bi = np.minimum(i // s, c.shape[0] - 2)
        bk = np.minimum(k // s, c.shape[1] - 2)
        out[i, k] = c[bi, bk]
        s = half
    return out, simulated
