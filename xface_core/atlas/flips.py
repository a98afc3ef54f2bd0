"""Flips on the atlas's grid lines, bisected lazily and kept in the atlas's :class:`FlipStore`.

The margins of a query are distances to the nearest flip along its own lines, which run
between the atlas's grid lines. Where the two grid lines either side of a query's line both
flip between the same two nodes, the query's flip lies close to the straight line between
theirs: interpolating it and confirming the interpolated bracket with two exact simulations
replaces a bisection of ten sequential steps. The grid lines' own flips are bisected once,
the second time a query needs them (a one-off query is cheaper searched along its own line),
and kept: a robot holding or slowly changing its pose keeps asking about the same few
boundaries. Or all of them at once, after the build (:func:`bisect_every_flip`,
``build_atlas(..., every_flip=True)``, as the ROS node does): then the first query near a
boundary is as cheap as the next.

A grid-line flip is bisected from the atlas's two node outcomes (the node's own outcome on the
``lo`` side); the nodes either side of a boundary are always simulated ones (the atlas's
refinement simulates every block whose corners disagree), never filled.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt

from xface_core.errors import Cancelled
from xface_core.geometry import FaceDesign
from xface_core.physics import Physics
from xface_core.runner import outcomes_at

from .margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION

__all__ = [
    "LINE_FLIP_REFINEMENT",
    "LINE_RESOLUTION",
    "FlipKey",
    "bisect_every_flip",
    "boundary_segments",
    "grid_flips",
]

#: (axis, line, node): axis 0 is the column ``theta0[line]`` searched along x0 between
#: ``x0[node]`` and ``x0[node + 1]``; axis 1 the row ``x0[line]`` searched along theta0.
FlipKey = tuple[int, int, int]

#: The grid lines' own flips are bisected this much finer than the margins' resolution, so
#: the interpolation between them is limited by the boundary's curvature, not by them.
LINE_FLIP_REFINEMENT = 4.0
#: The grid-line flips' resolution for the margins' default one: (D along x0, rad along theta0).
LINE_RESOLUTION = (
    LATERAL_RESOLUTION / LINE_FLIP_REFINEMENT,
    ANGLE_RESOLUTION / LINE_FLIP_REFINEMENT,
)


class _Store(Protocol):
    def get(self, key: FlipKey) -> tuple[float, float] | None: ...

    def put(self, key: FlipKey, bracket: tuple[float, float]) -> None: ...


class GridAtlas(Protocol):
    """What the bisection reads of an :class:`~xface_core.atlas.build.AcceptanceAtlas` (which
    builds with it, so this module does not import that one)."""

    @property
    def design(self) -> FaceDesign: ...

    @property
    def physics(self) -> Physics: ...

    @property
    def x0(self) -> npt.NDArray[np.float64]: ...

    @property
    def theta0(self) -> npt.NDArray[np.float64]: ...

    @property
    def outcomes(self) -> npt.NDArray[np.int8]: ...

    @property
    def flips(self) -> _Store: ...


def _ends(atlas: GridAtlas, key: FlipKey) -> tuple[float, float, float, int]:
    """(lo, hi, fixed coordinate, outcome at lo) of a grid-line segment."""
    axis, line, node = key
    if axis == 0:
        return (
            float(atlas.x0[node]),
            float(atlas.x0[node + 1]),
            float(atlas.theta0[line]),
            int(atlas.outcomes[node, line]),
        )
    return (
        float(atlas.theta0[node]),
        float(atlas.theta0[node + 1]),
        float(atlas.x0[line]),
        int(atlas.outcomes[line, node]),
    )


def grid_flips(
    atlas: GridAtlas,
    keys: Sequence[FlipKey],
    resolution: tuple[float, float],
    threads: int | None = None,
    cancel: Callable[[], bool] | None = None,
) -> list[tuple[float, float]]:
    """Brackets ``(lo, hi)`` of the flips on grid-line segments (D along x0, rad along
    theta0), each at most ``resolution[axis]`` wide; ``lo`` has the outcome of the segment's
    first node. Known ones come from ``atlas.flips``; the others are bisected together (one
    batch of simulations per bisection step) and stored there.

    A segment whose two nodes have the same outcome has no flip to find: asking for one is a
    programming error (``ValueError``). ``threads``: of each batch (default one per core).
    ``cancel``: asked before each batch; True stops with :class:`~.errors.Cancelled` (the
    flips finished so far are kept).
    """
    store = atlas.flips
    found: dict[FlipKey, tuple[float, float]] = {}
    todo: list[tuple[FlipKey, float, float, float, int]] = []
    for key in dict.fromkeys(keys):  # unique, in order
        known = store.get(key)
        if known is not None:
            found[key] = known
            continue
        lo, hi, fixed, code = _ends(atlas, key)
        axis, line, node = key
        other = atlas.outcomes[node + 1, line] if axis == 0 else atlas.outcomes[line, node + 1]
        if int(other) == code:
            raise ValueError(f"grid segment {key} has no flip: both nodes are {code}")
        todo.append((key, lo, hi, fixed, code))
    design = atlas.design
    while todo:
        check_cancel(cancel)
        n = len(todo)
        xs, ts = np.empty(n), np.empty(n)
        for j, (key, lo, hi, fixed, _) in enumerate(todo):
            mid = 0.5 * (lo + hi)
            xs[j], ts[j] = (mid, fixed) if key[0] == 0 else (fixed, mid)
        codes = outcomes_at(design, xs, ts, atlas.physics, threads=threads)
        pending = []
        for (key, lo, hi, fixed, code), got in zip(todo, codes, strict=True):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if int(got) == code else (lo, mid)
            if hi - lo <= resolution[key[0]]:
                store.put(key, (lo, hi))
                found[key] = (lo, hi)
            else:
                pending.append((key, lo, hi, fixed, code))
        todo = pending
    return [found[key] for key in keys]


def boundary_segments(outcomes: npt.NDArray[np.int8]) -> list[FlipKey]:
    """Every grid-line segment whose two nodes have different outcomes: the keys of all
    the flips an atlas with these node ``outcomes`` (n, m) has on its grid lines."""
    along_x0 = np.argwhere(outcomes[:-1, :] != outcomes[1:, :])  # (node, line)
    along_theta0 = np.argwhere(outcomes[:, :-1] != outcomes[:, 1:])  # (line, node)
    return [(0, int(line), int(node)) for node, line in along_x0] + [
        (1, int(line), int(node)) for line, node in along_theta0
    ]


def bisect_every_flip(
    atlas: GridAtlas,
    resolution: tuple[float, float] = LINE_RESOLUTION,
    threads: int | None = None,
    cancel: Callable[[], bool] | None = None,
) -> int:
    """Bisect the flip of every boundary segment of the atlas's grid lines not known yet
    (:func:`boundary_segments`), all in one batch per bisection step, into ``atlas.flips``;
    how many were bisected. ``cancel`` as for :func:`grid_flips`.

    Then every margins query on the atlas interpolates its flips and confirms them with
    eight simulations, the first query near a boundary too, instead of searching along its
    own line (34 simulations in 15-16 sequential batches, 1.7-1.9 ms on the bench's designs)
    or, the second time, bisecting the grid lines around it (59-70 simulations in 16
    batches, 2.6-3.4 ms). On the default grids of the bench's X, V and S: 4192-4490
    segments, 0.26-0.41 s on two cores (``scripts/bench/bench_atlas.py --every-flip``,
    docs/atlas.md).
    """
    todo = [key for key in boundary_segments(atlas.outcomes) if atlas.flips.get(key) is None]
    if todo:
        grid_flips(atlas, todo, resolution, threads, cancel)
    return len(todo)


def check_cancel(cancel: Callable[[], bool] | None) -> None:
    """Raise :class:`~.errors.Cancelled` when ``cancel`` is given and says so (between two
    batches of a long computation)."""
    if cancel is not None and cancel():
        raise Cancelled("cancelled by the caller")
