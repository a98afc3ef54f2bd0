"""Margins from the atlas: the exact margin search's answer with a few simulations.

:func:`~xface_core.atlas.margins.outcome_margins` scans each of the four half-axes from the query
in steps of D/40 or pi/160 until an outcome differs, then bisects. Here the scan is read from
the atlas instead: along the query's line, the outcome at each atlas grid line it crosses is
the common outcome of the two atlas nodes either side of it (the line runs between two grid
rows or columns); the first crossing whose outcome differs from the query's (or is unknown:
the two nodes disagree) is confirmed by simulating it and the crossing before it, and the
bracket is then bisected exactly to the same resolution as the exact search, the four
half-axes in one batch per bisection step. Where the line leaves the atlas before a flip,
the exact scan takes over from the atlas's edge (or from its last grid line before the end
of the search range), so the answer never depends on the atlas's extent, only on its
spacing (a flip and flip back between two grid lines is missed, as the exact scan misses
one between two of its nodes).
"""

from __future__ import annotations

import bisect
import itertools
import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.physics import Physics
from xface_core.result import Margins
from xface_core.runner import (
    DEFAULT_THREADS,
    check_pose,
    clear_start_height,
    outcomes_at,
    thread_count,
)

from .build import AcceptanceAtlas
from .flips import LINE_FLIP_REFINEMENT, FlipKey, grid_flips
from .margins import (
    ANGLE_RESOLUTION,
    ANGLE_STEP,
    LATERAL_RESOLUTION,
    LATERAL_STEP,
    HalfAxisSearch,
    flip_distances,
    moved_along,
    outcome_margins,
    reach_margins,
    search_physics,
)

__all__ = ["margins_from_atlas"]

#: Half-width of the confirmed bracket around an interpolated flip, in units of the
#: resolution: just under half, so the bracket is narrower than the exact search's.
CONFIRM_HALF_WIDTH = 0.45
#: A bracket that did not confirm is followed by GALLOP_PROBES probes at GALLOP_FIRST,
#: 2 GALLOP_FIRST, 4 GALLOP_FIRST, ... resolutions past its far side (one batch): the
#: interpolation is usually off by a few resolutions where the boundary curves.
GALLOP_FIRST = 0.9
GALLOP_PROBES = 6


@dataclass
class _HalfAxis:
    """One half-axis search: offsets (D or rad) from the query, outcomes known so far."""

    axis: int  # 0: x0, 1: theta0
    direction: float
    offsets: npt.NDArray[np.float64]  # the atlas grid lines crossed, nearest first
    first: int  # grid index of the first crossing along the axis (none when offsets is empty)
    limit: float
    lines: tuple[int, int]  # the two grid lines either side of the query's line
    weight: float  # where the query's line lies between them (0: on the first, 1: second)
    lo: float = 0.0  # largest offset known to have the query's outcome
    hi: float = math.inf  # smallest offset known to differ (inf: none yet)
    cursor: int = 0  # next crossing to read from the atlas

    @property
    def step(self) -> int:
        """+1 or -1: the grid index's direction along the half-axis."""
        return 1 if self.direction > 0.0 else -1

    @property
    def last(self) -> int:
        """Grid index of the last crossing within the search (``first`` less one step when
        there is none)."""
        return self.first + self.step * (self.offsets.size - 1)

    def predicted(self, atlas: AcceptanceAtlas) -> npt.NDArray[np.int8]:
        """The atlas's outcome at each crossing: the common outcome of the two grid lines'
        nodes either side of the query's line, -1 where they disagree. Read only by the
        walk of :func:`_confirm` (most queries never need it)."""
        n, step = self.offsets.size, self.step
        nodes = np.arange(self.first, self.first + step * n, step)
        out = atlas.outcomes
        a, b = (out[nodes, self.lines[0]], out[nodes, self.lines[1]]) if self.axis == 0 else (
            out[self.lines[0], nodes], out[self.lines[1], nodes]
        )  # fmt: skip
        return np.where(a == b, a, -1).astype(np.int8)


class _Sims(NamedTuple):
    """How the simulations that confirm and bisect the query's flips run."""

    physics: Physics
    threads: int


def _sims_for(atlas: AcceptanceAtlas, q: int, threads: int) -> _Sims:
    """The physics of the confirmations (:func:`~xface_core.atlas.margins.search_physics`: a
    query that never touches is decided by its approach alone) and their threads. The atlas
    path always starts clear of the base (a lower start takes the exact search)."""
    return _Sims(search_physics(atlas.design, atlas.physics, q, None), threads)


def _half_axes(
    atlas: AcceptanceAtlas, x_d: float, theta0: float, limit_x: float
) -> list[_HalfAxis]:
    """The four half-axis searches: the atlas grid lines each crosses within its limit."""
    # atlas.cell_index for one pose, without its array conversions (about 20 us).
    i = math.floor((x_d - atlas.x0[0]) / atlas.lateral_step)
    k = math.floor((theta0 - atlas.theta0[0]) / atlas.angle_step)
    i, k = min(max(i, 0), atlas.x0.size - 2), min(max(k, 0), atlas.theta0.size - 2)
    w_theta = (theta0 - atlas.theta0[k]) / atlas.angle_step
    w_x = (x_d - atlas.x0[i]) / atlas.lateral_step
    axes = []
    for axis, coords, value, limit, lines, weight in (
        (0, atlas.x0, x_d, limit_x, (k, k + 1), w_theta),
        (1, atlas.theta0, theta0, math.pi, (i, i + 1), w_x),
    ):
        # The grid lines strictly ahead, nearest first (the coordinates ascend), up to the
        # search's limit. Ahead downwards, value - c is exactly -(c - value).
        right = int(np.searchsorted(coords, value, side="right"))
        left = int(np.searchsorted(coords, value, side="left"))
        for direction, first, off in (
            (-1.0, left - 1, value - coords[left - 1 :: -1] if left else coords[:0]),
            (1.0, right, coords[right:] - value),
        ):
            n = int(np.searchsorted(off, limit, side="right"))
            axes.append(_HalfAxis(axis, direction, off[:n], first, limit, lines, float(weight)))
    return axes


def _exact(
    atlas: AcceptanceAtlas,
    x_d: float,
    theta0: float,
    h: _HalfAxis,
    offsets: npt.ArrayLike,
    sims: _Sims,
) -> npt.NDArray[np.int8]:
    """Exact outcomes at offsets along one half-axis (one batch)."""
    xs, ts = moved_along(x_d, theta0, h.axis, h.direction, offsets)
    return _outcomes(atlas, xs, ts, sims.physics, None)


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def _pool() -> ThreadPoolExecutor:
    """One long-lived helper thread per extra core (a pool per call would cost more than a
    confirmation batch saves)."""
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(
                max(1, DEFAULT_THREADS - 1), thread_name_prefix="xface-confirm"
            )
        return _POOL


def _forget_pool_in_child() -> None:
    """A forked child (a process pool's worker) inherits the pool object but not its thread:
    submitting to it would wait forever, so the child makes its own on first use."""
    global _POOL, _POOL_LOCK
    _POOL, _POOL_LOCK = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_pool_in_child)


def _outcomes_split(
    atlas: AcceptanceAtlas,
    x_d: npt.NDArray[np.float64],
    theta0: npt.NDArray[np.float64],
    sims: _Sims,
) -> npt.NDArray[np.int8]:
    """Exact outcomes of a few poses (x0 in D) split over the cores: confirmation poses lie
    on boundaries, where a simulation costs several times a typical one, so even eight of
    them are worth a second thread (``predict_batch`` splits only large batches).

    The poses come in pairs either side of a flip, the query's side first, and the two
    sides cost differently (on X 0.25/1: 0.19 ms a simulation on the seated side, 0.08 ms
    past the flip): taking every other pose, one thread got all of one side. They are dealt
    out back and forth (0, 1, 1, 0, 0, 1, ... for two threads), so each gets both."""
    parts = min(sims.threads, x_d.size)
    if parts <= 1:
        return _outcomes(atlas, x_d, theta0, sims.physics)
    chunks = _snake_chunks(x_d.size, parts)
    futures = [
        _pool().submit(_outcomes, atlas, x_d[c], theta0[c], sims.physics) for c in chunks[1:]
    ]
    out = np.empty(x_d.size, dtype=np.int8)
    out[chunks[0]] = _outcomes(atlas, x_d[chunks[0]], theta0[chunks[0]], sims.physics)
    for c, future in zip(chunks[1:], futures, strict=True):
        out[c] = future.result()
    return out


def _outcomes(
    atlas: AcceptanceAtlas,
    x_d: npt.NDArray[np.float64],
    theta0: npt.NDArray[np.float64],
    physics: Physics,
    threads: int | None = 1,
) -> npt.NDArray[np.int8]:
    """Exact outcomes of poses (x0 in D) on ``threads`` (None: the runner's split of a large
    batch)."""
    return outcomes_at(atlas.design, x_d, theta0, physics, threads=threads)


def _snake_chunks(n: int, parts: int) -> list[npt.NDArray[np.intp]]:
    """Indices 0..n-1 dealt to ``parts`` chunks back and forth: 0, 1, .., parts-1,
    parts-1, .., 0, 0, 1, ..."""
    k = np.arange(n) % (2 * parts)
    owner = np.where(k < parts, k, 2 * parts - 1 - k)
    return [np.flatnonzero(owner == p) for p in range(parts)]


#: Where the outcome changes along each grid line of an atlas, per axis (0: along x0, the
#: first index; 1: along theta0): ``changes[axis][line]`` lists, ascending, each node ``j``
#: of the line whose next node ``j + 1`` has another outcome. A boundary crosses few nodes
#: of a line, so the lists are short (a few thousand entries for the node's atlas). Plain
#: lists, searched with ``bisect``: a query's eight lookups took 19 us, against 36 us with
#: ``np.searchsorted`` on slices of arrays.
_Changes = tuple[list[list[int]], list[list[int]]]


def _changes_along(out: npt.NDArray[np.int8]) -> list[list[int]]:
    """The lists of :data:`_Changes` along the first axis of ``out``."""
    lines, after = np.nonzero((out[1:] != out[:-1]).T)  # by line, then along it
    starts = np.searchsorted(lines, np.arange(out.shape[1] + 1)).tolist()
    flat = after.tolist()
    return [flat[starts[n] : starts[n + 1]] for n in range(out.shape[1])]


def _nearest_change(changes: _Changes, axis: int, line: int, node: int, step: int) -> int | None:
    """The nearest node past ``node`` (``step`` +1: above it, -1: below) on grid line
    ``line`` along ``axis`` whose outcome differs from ``node``'s (None: no such node)."""
    on_line = changes[axis][line]
    # The changes at or above node; the nearest below it is the one before those.
    k = bisect.bisect_left(on_line, node)
    if step > 0:
        return on_line[k] + 1 if k < len(on_line) else None
    return on_line[k - 1] if k > 0 else None


_CHANGES: dict[int, tuple[npt.NDArray[np.int8], _Changes]] = {}
_CHANGES_SIZE = 8
_CHANGES_LOCK = threading.Lock()


def _changes(atlas: AcceptanceAtlas) -> _Changes:
    """The atlas's :data:`_Changes`, made once per outcome array (shared by the atlas's
    copies): a grid line's first flip ahead of the query is then looked up, not searched."""
    out = atlas.outcomes
    with _CHANGES_LOCK:
        hit = _CHANGES.get(id(out))
        if hit is not None and hit[0] is out:
            return hit[1]
    made = (_changes_along(out), _changes_along(out.T))
    with _CHANGES_LOCK:
        if len(_CHANGES) >= _CHANGES_SIZE:
            _CHANGES.clear()
        _CHANGES[id(out)] = (out, made)
    return made


def _line_flip(atlas: AcceptanceAtlas, h: _HalfAxis, line: int, q: int) -> FlipKey | None:
    """The grid segment where ``line`` first flips from ``q`` along the half-axis, or None
    when the line does not have ``q`` at the node before its first node ahead of the query,
    or never leaves ``q`` within the search."""
    if h.offsets.size == 0:
        return None
    step = h.step
    before = h.first - step
    size = atlas.outcomes.shape[h.axis]
    if not 0 <= before < size:
        return None
    at = (before, line) if h.axis == 0 else (line, before)
    if int(atlas.outcomes[at]) != q:
        return None
    # The node before has q, so the first node ahead without q is its nearest change.
    node = _nearest_change(_changes(atlas), h.axis, line, before, step)
    if node is None or (node - h.last) * step > 0:  # none within the search
        return None
    return (h.axis, line, min(node, node - step))


def _interpolate(
    atlas: AcceptanceAtlas,
    x_d: float,
    theta0: float,
    q: int,
    axes: list[_HalfAxis],
    resolution: tuple[float, float],
    sims: _Sims,
) -> None:
    """Bracket each half-axis's first flip from the first flips of the two grid lines either
    side of it, where both start with the query's outcome: the flip is interpolated between
    theirs and the bracket ``[g - delta, g + delta]`` (``2 delta``
    just under the resolution) confirmed by two exact simulations, all half-axes in one
    batch. A half-axis left with ``hi = inf`` takes the full search (:func:`_confirm`)."""
    plans: list[tuple[_HalfAxis, FlipKey, FlipKey]] = []
    for h in axes:
        first, second = (_line_flip(atlas, h, line, q) for line in h.lines)
        if first is None or second is None:
            continue
        if atlas.flips.worth_finding([first, second]):
            plans.append((h, first, second))
    if not plans:
        return
    line_res = (resolution[0] / LINE_FLIP_REFINEMENT, resolution[1] / LINE_FLIP_REFINEMENT)
    brackets = grid_flips(atlas, [key for _, *pair in plans for key in pair], line_res)
    guesses = []
    for n, (h, _, _) in enumerate(plans):
        (lo1, hi1), (lo2, hi2) = brackets[2 * n], brackets[2 * n + 1]
        flip = (1.0 - h.weight) * 0.5 * (lo1 + hi1) + h.weight * 0.5 * (lo2 + hi2)
        value = x_d if h.axis == 0 else theta0
        guesses.append((flip - value) * h.direction)
    tries = []
    for (h, _, _), g in zip(plans, guesses, strict=True):
        delta = CONFIRM_HALF_WIDTH * resolution[h.axis]
        if g - delta > 0.0:
            tries.append((h, np.array([g - delta, g + delta])))
    missed = []
    for (h, offsets), codes in zip(tries, _probe(atlas, x_d, theta0, tries, sims), strict=True):
        if codes[0] == q and codes[1] != q:
            h.lo, h.hi = float(offsets[0]), float(offsets[1])
        elif codes[0] == q or codes[1] != q:  # beyond the bracket, or before it
            missed.append((h, offsets, codes[0] == q))
    _gallop(atlas, x_d, theta0, q, missed, resolution, sims)


def _probe(
    atlas: AcceptanceAtlas,
    x_d: float,
    theta0: float,
    tries: list[tuple[_HalfAxis, npt.NDArray[np.float64]]],
    sims: _Sims,
) -> list[npt.NDArray[np.int8]]:
    """Exact outcomes at offsets along several half-axes: one batch, split over threads."""
    if not tries:
        return []
    ends = list(itertools.accumulate(off.size for _, off in tries))
    spans = list(zip([0, *ends[:-1]], ends, strict=True))
    xs, ts = np.empty(ends[-1]), np.empty(ends[-1])
    for (h, off), (start, end) in zip(tries, spans, strict=True):
        xs[start:end], ts[start:end] = moved_along(x_d, theta0, h.axis, h.direction, off)
    codes = _outcomes_split(atlas, xs, ts, sims)
    return [codes[start:end] for start, end in spans]


def _gallop(
    atlas: AcceptanceAtlas,
    x_d: float,
    theta0: float,
    q: int,
    missed: list[tuple[_HalfAxis, npt.NDArray[np.float64], bool]],
    resolution: tuple[float, float],
    sims: _Sims,
) -> None:
    """Second round for brackets that did not confirm: the flip lies beyond (``ahead``) or
    before the confirmed bracket, usually within a few resolutions (the boundary curves
    between the grid lines). Probe at 0.9, 1.8, 3.6, ... resolutions from the bracket's side
    in one batch; the first probe that changes outcome closes a bracket (``_bisect_all``
    narrows it). A half-axis whose flip lies further keeps ``hi = inf`` (the full search)."""
    tries = []
    for h, offsets, ahead in missed:
        steps = GALLOP_FIRST * resolution[h.axis] * 2.0 ** np.arange(GALLOP_PROBES)
        probes = offsets[1] + steps if ahead else offsets[0] - steps
        tries.append((h, probes[probes > 0.0]))
    for (h, probes), codes, (_, offsets, ahead) in zip(
        tries, _probe(atlas, x_d, theta0, tries, sims), missed, strict=True
    ):
        if ahead:  # outcome q up to offsets[1]: the first probe that differs closes it
            differ = np.flatnonzero(codes != q)
            if differ.size:
                j = int(differ[0])
                h.lo = float(probes[j - 1]) if j else float(offsets[1])
                h.hi = float(probes[j])
        else:  # another outcome from offsets[0] on: the first probe (going back) with q
            same = np.flatnonzero(codes == q)
            if same.size:
                j = int(same[0])
                h.lo = float(probes[j])
                h.hi = float(probes[j - 1]) if j else float(offsets[0])


def _confirm(
    atlas: AcceptanceAtlas, x_d: float, theta0: float, q: int, h: _HalfAxis, sims: _Sims
) -> None:
    """Walk one half-axis on the atlas to its first flip and confirm it exactly: sets
    ``h.lo`` and ``h.hi`` to a simulated bracket (``hi`` stays inf: no flip on the atlas,
    ``lo`` is then the last crossing inside it)."""
    predicted = h.predicted(atlas)
    while True:
        ahead = np.flatnonzero(predicted[h.cursor :] != q)
        if ahead.size == 0:
            if h.offsets.size:
                h.lo = max(h.lo, float(h.offsets[-1]))
            return
        c = h.cursor + int(ahead[0])
        # The suspected flip and the crossing before it, unless that one is confirmed.
        window = h.offsets[max(h.cursor, c - 1) : c + 1]
        codes = _exact(atlas, x_d, theta0, h, window, sims)
        if window.size == 2 and codes[0] != q:
            # The atlas missed a flip before the suspected one: simulate the crossings
            # between the last confirmed pose and it (the exact scan, over a short stretch).
            back = h.offsets[h.cursor : c - 1]
            early = _exact(atlas, x_d, theta0, h, back, sims) if back.size else codes[:0]
            window = np.concatenate((back, window[:1]))
            codes = np.concatenate((early, codes[:1]))
        differ = np.flatnonzero(codes != q)
        if differ.size:
            j = int(differ[0])
            h.lo = float(window[j - 1]) if j else h.lo
            h.hi = float(window[j])
            return
        h.lo = float(window[-1])
        h.cursor = c + 1


def _bisect_all(
    atlas: AcceptanceAtlas,
    x_d: float,
    theta0: float,
    q: int,
    axes: list[_HalfAxis],
    resolution: tuple[float, float],
    sims: _Sims,
) -> None:
    """Bisect every bracket to its axis's resolution, all half-axes in one batch per step."""
    while True:
        active = [h for h in axes if math.isfinite(h.hi) and h.hi - h.lo > resolution[h.axis]]
        if not active:
            return
        xs = np.empty(len(active))
        ts = np.empty(len(active))
        for n, h in enumerate(active):
            x, t = moved_along(x_d, theta0, h.axis, h.direction, [0.5 * (h.lo + h.hi)])
            xs[n], ts[n] = x[0], t[0]
        codes = _outcomes(atlas, xs, ts, sims.physics, None)
        for h, code in zip(active, codes, strict=True):
            mid = 0.5 * (h.lo + h.hi)
            if code == q:
                h.lo = mid
            else:
                h.hi = mid


def _scan_past_atlas(h: _HalfAxis, resolution: float) -> HalfAxisSearch | None:
    """The exact scan from the last atlas crossing (``h.lo``) to the end of the exact
    search's range (None: nothing left): its last node is ``ceil(limit / step) * step``, so
    the stretch between the atlas's last crossing and that node is checked too (a flip there
    was missed once)."""
    step = LATERAL_STEP if h.axis == 0 else ANGLE_STEP
    last = math.ceil(h.limit / step - 1e-12) * step
    remaining = last - h.lo
    if remaining <= 0.0:
        return None
    return HalfAxisSearch(h.axis, h.direction, last, min(step, remaining), resolution, h.lo)


def margins_from_atlas(
    atlas: AcceptanceAtlas,
    x0: float,
    theta0: float,
    outcome: Outcome,
    *,
    y_start: float | None = None,
    resolution: tuple[float, float] = (LATERAL_RESOLUTION, ANGLE_RESOLUTION),
    threads: int | None = None,
) -> Margins:
    """Distances from (x0, theta0) to the nearest outcome flip along x0 and theta0: the same
    result and meaning as :func:`~xface_core.atlas.margins.outcome_margins` (each bisected to
    1e-4 D and 1e-5 rad, searched over |dx0| <= 2 L and |dtheta0| <= pi), read from the
    atlas and confirmed by exact simulations.

    Parameters
    ----------
    atlas : AcceptanceAtlas
        Built for the query's design and physics (``atlas.design``, ``atlas.physics``).
    x0 : float
        Lateral offset (the design's length unit).
    theta0 : float
        Angle (rad).
    outcome : Outcome
        The query's own exact outcome (from :func:`~xface_core.predict`).
    y_start : float, optional
        The query's start height (length). The atlas was built at the default start; a start
        clear of the base at every angle (:func:`~xface_core.runner.clear_start_height`)
        has the same neighbours, and a lower one is searched exactly at its own height
        (:func:`outcome_margins` at that start).
    resolution : (float, float)
        Bisection resolution, lateral (D) and angular (rad); default the exact search's
        (1e-4 D, 1e-5 rad). Each factor 2 coarser saves one sequential simulation per
        half-axis: a caller that needs an answer sooner than exact can trade it here.
    threads : int, optional
        Threads that share a batch of confirmation simulations (default: one per core). Where
        other busy threads share the cores, fewer are faster: in the ROS node (its executor,
        DDS and a client on two cores) one thread gave a median latency of 2.25-2.47 ms
        against 2.96-3.19 ms with two (docs/notes/2026-11-23-one-margin-thread.md).

    Examples
    --------
    >>> from xface_core import predict, v_face
    >>> from xface_core.atlas.build import build_atlas
    >>> d = v_face(0.5, 1.0)
    >>> atlas = build_atlas(d, lateral_step=1 / 16, angle_step=0.05)
    >>> m = margins_from_atlas(atlas, 0.1, 0.05, predict(d, 0.1, 0.05).outcome)
    >>> exact = predict(d, 0.1, 0.05, margins=True).margins
    >>> abs(m.angle_minus - exact.angle_minus) <= 1e-5
    True
    """
    design, physics = atlas.design, atlas.physics
    check_pose(design, x0, theta0, y_start)
    lateral_res, angle_res = (float(r) for r in resolution)
    if not (0.0 < lateral_res < math.inf and 0.0 < angle_res < math.inf):
        raise XfaceValueError(f"resolution must be two finite values > 0, got {resolution!r}")
    n_threads = thread_count(threads)
    x_d = x0 / design.width
    # The atlas ran every pose from just clear of the base for its angle. A start at least
    # clear of the base at every angle (runner.clear_start_height) only translates further to
    # the same first contact, so its neighbours' outcomes are the atlas's; a lower start is
    # searched exactly at its own height.
    known = reach_margins(design, x0, theta0, outcome)
    if known is not None:
        return known
    low_start = y_start is not None and y_start / design.width < clear_start_height(design)
    if low_start or not bool(atlas.covers(x_d, theta0)):
        return outcome_margins(design, x0, theta0, outcome, physics=physics, y_start=y_start)
    q = int(outcome)
    limit_x = 2.0 * design.mated_distance
    axes = _half_axes(atlas, x_d, theta0, limit_x)
    sims = _sims_for(atlas, q, n_threads)
    _interpolate(atlas, x_d, theta0, q, axes, (lateral_res, angle_res), sims)
    for h in axes:
        if math.isinf(h.hi):
            _confirm(atlas, x_d, theta0, q, h, sims)
    _bisect_all(atlas, x_d, theta0, q, axes, (lateral_res, angle_res), sims)
    found = [h.hi * (design.width if h.axis == 0 else 1.0) for h in axes]
    # Half-axes with no flip on the atlas: the exact scan past it, all in lockstep.
    beyond = [
        (n, _scan_past_atlas(h, lateral_res if h.axis == 0 else angle_res))
        for n, h in enumerate(axes)
        if math.isinf(h.hi)
    ]
    scans = [(n, search) for n, search in beyond if search is not None]
    distances = flip_distances(
        design, x0, theta0, outcome, [search for _, search in scans], physics=sims.physics
    )
    for (n, _), distance in zip(scans, distances, strict=True):
        found[n] = distance
    return Margins(
        lateral_minus=found[0],
        lateral_plus=found[1],
        angle_minus=found[2],
        angle_plus=found[3],
    )
