"""Flips on the atlas's grid lines, bisected lazily and kept in the atlas's :class:`FlipStore`.

The margins of a query are distances to the nearest flip along its own lines, which run
between the atlas's grid lines. Where the two grid lines either side of a query's line both
flip between the same two nodes, the query's flip lies close to the straight line between
theirs: interpolating it and confirming the interpolated bracket with two exact simulations
replaces a bisection of ten sequential steps. The grid lines' own flips are bisected once,
the second time a query needs them (a one-off query is cheaper searched along its own line),
and kept: a robot holding or slowly changing its pose keeps asking about the same few
boundaries.

A grid-line flip is bisected from the atlas's two node outcomes (the node's own outcome on the
``lo`` side); the nodes either side of a boundary are always simulated ones (the atlas's
refinement simulates every block whose corners disagree), never filled.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .atlas import AcceptanceAtlas
from .runner import run_flat

__all__ = ["FlipKey", "grid_flips"]

#: (axis, line, node): axis 0 is the column ``theta0[line]`` searched along x0 between
#: ``x0[node]`` and ``x0[node + 1]``; axis 1 the row ``x0[line]`` searched along theta0.
FlipKey = tuple[int, int, int]


def _ends(atlas: AcceptanceAtlas, key: FlipKey) -> tuple[float, float, float, int]:
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
    atlas: AcceptanceAtlas, keys: Sequence[FlipKey], resolution: tuple[float, float]
) -> list[tuple[float, float]]:
    """Brackets ``(lo, hi)`` of the flips on grid-line segments (D along x0, rad along
    theta0), each at most ``resolution[axis]`` wide; ``lo`` has the outcome of the segment's
    first node. Known ones come from ``atlas.flips``; the others are bisected together (one
    batch of simulations per bisection step) and stored there.

    A segment whose two nodes have the same outcome has no flip to find: asking for one is a
    programming error (``ValueError``).
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
        n = len(todo)
        xs, ts = np.empty(n), np.empty(n)
        for j, (key, lo, hi, fixed, _) in enumerate(todo):
            mid = 0.5 * (lo + hi)
            xs[j], ts[j] = (mid, fixed) if key[0] == 0 else (fixed, mid)
        # The engine's flat entry, in units of D: predict_batch's conversions cost about
        # 25 us a call, as much as several of these simulations, once per bisection step.
        codes = run_flat(design, xs, ts, atlas.physics)["outcome"]
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
