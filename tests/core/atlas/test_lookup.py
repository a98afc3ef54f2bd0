"""Margins from the atlas equal the exact margin search within its resolution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core.atlas import lookup as atlas_margins
from xface_core.atlas.build import build_atlas
from xface_core.atlas.margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION
from xface_core.errors import XfaceValueError
from xface_core.runner import clear_start_height

#: Coarser than the default atlas, over its full default range (the angle search from
#: |theta0| <= pi/2 reaches 3 pi/2); the full-size check is scripts/evidence/check_atlas.py.
COARSE = {"lateral_step": 1 / 32, "angle_step": math.pi / 128}


@pytest.fixture(scope="module")
def v_atlas() -> xf.AcceptanceAtlas:
    return build_atlas(xf.v_face(0.5, 1.0), **COARSE)


def _as_array(m: xf.Margins) -> np.ndarray:
    return np.array([m.lateral_minus, m.lateral_plus, m.angle_minus, m.angle_plus])


def _agree(a: xf.Margins, b: xf.Margins, width: float) -> bool:
    tol = np.array([LATERAL_RESOLUTION * width] * 2 + [ANGLE_RESOLUTION] * 2) * (1 + 1e-9)
    x, y = _as_array(a), _as_array(b)
    same = x == y  # both inf (no flip found) compare equal; inf - inf would be nan
    diff = np.subtract(x, y, out=np.zeros(4), where=~same)
    return bool(np.all(same | (np.abs(diff) <= tol)))


@settings(max_examples=6)
@given(x0=st.floats(-0.9, 0.9), theta0=st.floats(-1.5, 1.5))
def test_atlas_margins_equal_exact_search(
    v_atlas: xf.AcceptanceAtlas, x0: float, theta0: float
) -> None:
    design = v_atlas.design
    outcome = xf.predict(design, x0, theta0, path=False).outcome
    exact = xf.outcome_margins(design, x0, theta0, outcome)
    assert _agree(xf.margins_from_atlas(v_atlas, x0, theta0, outcome), exact, design.width)


def test_width_scales_margins() -> None:
    design = xf.v_face(0.5, 1.0, width=0.03)
    atlas = build_atlas(design, **COARSE)
    outcome = xf.predict(design, 0.003, 0.1, path=False).outcome
    exact = xf.outcome_margins(design, 0.003, 0.1, outcome)
    assert _agree(xf.margins_from_atlas(atlas, 0.003, 0.1, outcome), exact, design.width)


def test_predict_with_atlas_gives_the_exact_margins(v_atlas: xf.AcceptanceAtlas) -> None:
    # The atlas was built in widths; the query comes in metres (D = 3 cm).
    design = xf.v_face(0.5, 1.0, width=0.03)
    fast = xf.predict(design, 0.006, -0.3, path=False, margins=True, atlas=v_atlas).margins
    exact = xf.predict(design, 0.006, -0.3, path=False, margins=True).margins
    assert fast is not None
    assert exact is not None
    assert _agree(fast, exact, design.width)


def test_explicit_start_height_is_searched_at_that_height(v_atlas: xf.AcceptanceAtlas) -> None:
    design = v_atlas.design
    outcome = xf.predict(design, 0.1, 0.1, y_start=-5.0, path=False).outcome
    got = xf.margins_from_atlas(v_atlas, 0.1, 0.1, outcome, y_start=-5.0)
    assert got == xf.outcome_margins(design, 0.1, 0.1, outcome, y_start=-5.0)


def test_query_off_the_atlas_falls_back_to_exact_search(v_atlas: xf.AcceptanceAtlas) -> None:
    design = v_atlas.design
    outcome = xf.predict(design, 0.1, 1.8 * math.pi, path=False).outcome
    got = xf.margins_from_atlas(v_atlas, 0.1, 1.8 * math.pi, outcome)
    assert got == xf.outcome_margins(design, 0.1, 1.8 * math.pi, outcome)


def test_non_finite_query_is_refused(v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.InputError):
        xf.margins_from_atlas(v_atlas, math.nan, 0.0, xf.Outcome.SEATED)


def test_coarser_resolution_brackets_the_exact_flip(v_atlas: xf.AcceptanceAtlas) -> None:
    design = v_atlas.design
    outcome = xf.predict(design, 0.2, -0.3, path=False).outcome
    exact = _as_array(xf.outcome_margins(design, 0.2, -0.3, outcome))
    coarse = _as_array(xf.margins_from_atlas(v_atlas, 0.2, -0.3, outcome, resolution=(1e-2, 1e-3)))
    finite = np.isfinite(exact)
    tol = np.array([1e-2, 1e-2, 1e-3, 1e-3])[finite] + 1e-4
    assert np.all(np.abs(coarse[finite] - exact[finite]) <= tol)
    assert np.array_equal(np.isfinite(coarse), finite)


def test_bad_resolution_is_refused(v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.XfaceValueError, match="resolution"):
        xf.margins_from_atlas(v_atlas, 0.0, 0.0, xf.Outcome.SEATED, resolution=(0.0, 1e-5))


def test_flip_between_last_grid_line_and_search_end_is_found() -> None:
    # Found by scripts/evidence/check_atlas.py: this flip lies 3.1343 rad up, past the last atlas
    # grid line within the pi searched and before the exact scan's last node at pi.
    design = xf.s_face(0.25, 3.0)
    atlas = build_atlas(design)
    x0, theta0 = 1.6861043121347752, 0.23280522327235342
    outcome = xf.predict(design, x0, theta0, path=False).outcome
    got = xf.margins_from_atlas(atlas, x0, theta0, outcome)
    assert got.angle_plus == pytest.approx(3.1343, abs=1e-4)


def test_a_start_clear_of_the_base_at_every_angle_is_read_from_the_atlas(
    v_atlas: xf.AcceptanceAtlas, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A robot's stream starts well above the base: the approach then only translates
    # further to the same first contact, so the atlas answers (no exact search runs).
    design = v_atlas.design
    y_start = (clear_start_height(design) + 0.5) * design.width
    exact = xf.outcome_margins(
        design, 0.1, 0.1, xf.predict(design, 0.1, 0.1).outcome, y_start=y_start
    )

    def no_exact_search(*args: object, **kwargs: object) -> None:
        raise AssertionError("searched exactly")

    monkeypatch.setattr(atlas_margins, "outcome_margins", no_exact_search)
    outcome = xf.predict(design, 0.1, 0.1, y_start=y_start, path=False).outcome
    got = xf.margins_from_atlas(v_atlas, 0.1, 0.1, outcome, y_start=y_start)
    assert _agree(got, exact, design.width)


def _count_simulations(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The poses of every batch the atlas's margins send to the engine from now on."""
    calls: list[int] = []
    counted = atlas_margins.outcomes_at

    def counting(design: xf.FaceDesign, x0: np.ndarray, *args: object, **kw: object) -> object:
        calls.append(len(x0))
        return counted(design, x0, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(atlas_margins, "outcomes_at", counting)
    return calls


def test_with_the_grid_flips_known_a_query_takes_eight_simulations(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A robot holding its pose: the boundaries around it are known after the first query,
    # so the next query's four flips are interpolated and confirmed with two simulations each.
    atlas = build_atlas(xf.x_face(0.25, 1.0), **COARSE)
    design = atlas.design
    outcome = xf.predict(design, 0.05, 0.1, path=False).outcome
    for _ in range(2):  # the second query near a boundary bisects its grid lines
        xf.margins_from_atlas(atlas, 0.05, 0.1, outcome)
    calls = _count_simulations(monkeypatch)
    got = xf.margins_from_atlas(atlas, 0.05 + 1e-4, 0.1 + 1e-4, outcome)
    exact = xf.outcome_margins(design, 0.05 + 1e-4, 0.1 + 1e-4, outcome)
    assert sum(calls) == 8
    assert _agree(got, exact, design.width)


def test_with_every_flip_the_first_query_near_a_boundary_takes_eight_simulations(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # build_atlas(every_flip=True), as in the node: no query has been near these boundaries,
    # yet the four flips are interpolated and confirmed, not searched.
    atlas = build_atlas(xf.x_face(0.25, 1.0), **COARSE, every_flip=True)
    design = atlas.design
    outcome = xf.predict(design, 0.05, 0.1, path=False).outcome
    calls = _count_simulations(monkeypatch)
    got = xf.margins_from_atlas(atlas, 0.05, 0.1, outcome)
    exact = xf.outcome_margins(design, 0.05, 0.1, outcome)
    assert sum(calls) == 8
    assert _agree(got, exact, design.width)


def test_a_wrong_interpolated_flip_is_caught_by_its_confirmation(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    atlas = build_atlas(xf.x_face(0.25, 1.0), **COARSE)
    design = atlas.design
    real = atlas_margins.grid_flips
    used: list[int] = []

    def shifted(*args: object, **kwargs: object) -> list[tuple[float, float]]:
        # Every grid-line flip reported 0.1 (D or rad) too far: no bracket confirms, and the
        # probes past it (up to 29 resolutions) cannot close one either.
        found = real(*args, **kwargs)  # type: ignore[arg-type]
        used.append(len(found))
        return [(lo + 0.1, hi + 0.1) for lo, hi in found]

    monkeypatch.setattr(atlas_margins, "grid_flips", shifted)
    outcome = xf.predict(design, 0.05, 0.1, path=False).outcome
    for _ in range(2):  # the second query interpolates
        got = xf.margins_from_atlas(atlas, 0.05, 0.1, outcome)
    assert used
    assert _agree(got, xf.outcome_margins(design, 0.05, 0.1, outcome), design.width)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_confirmation_poses_split_over_threads_give_the_batch_outcomes(threads: int) -> None:
    atlas = build_atlas(xf.x_face(0.25, 1.0), **COARSE)
    rng = np.random.default_rng(3)
    xs, ts = rng.uniform(-1.0, 1.0, 9), rng.uniform(-1.0, 1.0, 9)
    sims = atlas_margins._Sims(atlas.physics, threads)
    split = atlas_margins._outcomes_split(atlas, xs, ts, sims)
    assert np.array_equal(split, xf.predict_batch(atlas.design, xs, ts).outcome)


def test_margins_are_the_same_with_any_number_of_threads() -> None:
    # Each on an atlas of its own: the grid-line flips an atlas keeps change which searches
    # the next query takes (and its answer, within the resolution).
    design = xf.x_face(0.25, 1.0)
    outcome = xf.predict(design, 0.05, 0.1).outcome
    found = []
    for threads in (1, 2):
        atlas = build_atlas(design, **COARSE)
        for _ in range(2):  # the second query reads the grid-line flips the first found
            found.append(xf.margins_from_atlas(atlas, 0.05, 0.1, outcome, threads=threads))
    assert found[:2] == found[2:]


@pytest.mark.parametrize("threads", [0, -1, 1.5, True, "2"])
def test_a_thread_count_that_is_not_a_positive_integer_is_refused(threads: object) -> None:
    design = xf.x_face(0.25, 1.0)
    atlas = build_atlas(design, **COARSE)
    with pytest.raises(XfaceValueError, match="threads must be an integer >= 1"):
        xf.margins_from_atlas(atlas, 0.05, 0.1, xf.Outcome.SEATED, threads=threads)  # type: ignore[arg-type]


def test_a_one_off_query_does_not_bisect_grid_lines(monkeypatch: pytest.MonkeyPatch) -> None:
    # A planner's single question: searching its own line is cheaper than bisecting the two
    # grid lines either side, which only pays when another query comes by.
    atlas = build_atlas(xf.x_face(0.25, 1.0), **COARSE)
    design = atlas.design

    def no_grid_flips(*args: object, **kwargs: object) -> None:
        raise AssertionError("bisected grid lines for a one-off query")

    monkeypatch.setattr(atlas_margins, "grid_flips", no_grid_flips)
    outcome = xf.predict(design, 0.05, 0.1, path=False).outcome
    got = xf.margins_from_atlas(atlas, 0.05, 0.1, outcome)
    assert _agree(got, xf.outcome_margins(design, 0.05, 0.1, outcome), design.width)


def test_a_forked_child_confirms_with_a_pool_of_its_own() -> None:
    # A process pool forks its workers: the parent's helper thread does not exist there.
    import multiprocessing

    atlas = build_atlas(xf.x_face(0.25, 1.0), **COARSE)
    xs, ts = np.array([0.0, 0.1, 0.2]), np.array([0.0, 0.1, -0.1])
    sims = atlas_margins._Sims(atlas.physics, 2)
    parent = atlas_margins._outcomes_split(atlas, xs, ts, sims)  # the parent's pool now exists
    with multiprocessing.get_context("fork").Pool(1) as pool:
        child = pool.apply_async(atlas_margins._outcomes_split, (atlas, xs, ts, sims)).get(
            timeout=120
        )
    assert np.array_equal(child, parent)


def test_confirmation_pairs_are_dealt_so_each_thread_gets_both_sides() -> None:
    # Poses come as (query side, far side) pairs: every other pose would give one thread
    # all of one side, whose simulations cost twice the other's.
    chunks = atlas_margins._snake_chunks(8, 2)
    assert [c.tolist() for c in chunks] == [[0, 3, 4, 7], [1, 2, 5, 6]]
    assert all(len({k % 2 for k in c.tolist()}) == 2 for c in chunks)


@given(st.integers(1, 40), st.integers(1, 6))
def test_snake_chunks_deal_every_pose_once(n: int, parts: int) -> None:
    chunks = atlas_margins._snake_chunks(n, parts)
    assert sorted(np.concatenate(chunks).tolist()) == list(range(n))
    sizes = [c.size for c in chunks]
    assert max(sizes) - min(sizes) <= 2


def test_a_miss_is_confirmed_by_its_approach_alone_with_the_same_margins(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A query that never touches flips where the parts start to touch: one event (the
    # first contact) decides it. Same margins as with the full simulation, each on an atlas
    # of its own (the flips an atlas keeps steer the next query's search).
    design = xf.x_face(0.25, 1.0)
    rng = np.random.default_rng(11)
    queries = [(1.5 + rng.normal(0.0, 0.01), 0.3 + rng.normal(0.0, 0.005)) for _ in range(4)]
    queries += [(-1.6, -0.2), (1.7, 0.0)]
    outcomes = [xf.predict(design, x, t, path=False).outcome for x, t in queries]
    assert set(outcomes) == {xf.Outcome.NO_CONTACT}
    asked: list[int] = []
    real_batch = atlas_margins.outcomes_at

    def spy(
        design: xf.FaceDesign, xs: np.ndarray, ts: np.ndarray, physics: xf.Physics, **kw: object
    ) -> object:
        asked.append(physics.settings.max_events)
        return real_batch(design, xs, ts, physics, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(atlas_margins, "outcomes_at", spy)
    one_event = build_atlas(design, **COARSE)
    fast = [
        xf.margins_from_atlas(one_event, x, t, o)
        for (x, t), o in zip(queries, outcomes, strict=True)
    ]
    assert set(asked) == {1}  # and not empty: every simulation stopped at its first contact
    monkeypatch.setattr(
        atlas_margins,
        "_sims_for",
        lambda atlas, q, threads: atlas_margins._Sims(atlas.physics, threads),
    )
    full = build_atlas(design, **COARSE)
    slow = [
        xf.margins_from_atlas(full, x, t, o) for (x, t), o in zip(queries, outcomes, strict=True)
    ]
    assert fast == slow


@settings(max_examples=40)
@given(
    st.integers(2, 9), st.integers(2, 9), st.integers(1, 3), st.integers(0, 2**32 - 1)
)  # fmt: skip
def test_the_nearest_change_is_the_nearest_other_outcome_along_each_axis(
    rows: int, cols: int, kinds: int, seed: int
) -> None:
    out = np.random.default_rng(seed).integers(0, kinds + 1, (rows, cols)).astype(np.int8)
    changes = (atlas_margins._changes_along(out), atlas_margins._changes_along(out.T))
    for i in range(rows):
        for k in range(cols):
            for axis, line, node, along in ((0, k, i, out[:, k]), (1, i, k, out[i, :])):
                later = [j for j in range(node + 1, along.size) if along[j] != along[node]]
                earlier = [j for j in range(node) if along[j] != along[node]]
                up = atlas_margins._nearest_change(changes, axis, line, node, 1)
                down = atlas_margins._nearest_change(changes, axis, line, node, -1)
                assert up == (later[0] if later else None)
                assert down == (earlier[-1] if earlier else None)


def _scan_line_flip(
    atlas: xf.AcceptanceAtlas, h: atlas_margins._HalfAxis, line: int, q: int
) -> tuple[int, int, int] | None:
    """The definition of a grid line's first flip: walk the line node by node."""
    along = atlas.outcomes[:, line] if h.axis == 0 else atlas.outcomes[line, :]
    nodes = [h.first + h.step * n for n in range(h.offsets.size)]
    before = h.first - h.step
    if not nodes or not 0 <= before < along.size or along[before] != q:
        return None
    node = next((n for n in nodes if along[n] != q), None)
    return None if node is None else (h.axis, line, min(node, node - h.step))


@settings(max_examples=25)
@given(x0=st.floats(-2.4, 2.4), theta0=st.floats(-1.6, 1.6), limit=st.floats(0.05, 4.5))
def test_a_line_flip_read_from_the_changes_is_the_first_one_a_walk_finds(
    v_atlas: xf.AcceptanceAtlas, x0: float, theta0: float, limit: float
) -> None:
    for h in atlas_margins._half_axes(v_atlas, x0, theta0, limit):
        for line in h.lines:
            for q in (int(xf.Outcome.SEATED), int(xf.Outcome.BAD_MATE)):
                expected = _scan_line_flip(v_atlas, h, line, q)
                assert atlas_margins._line_flip(v_atlas, h, line, q) == expected


def test_half_axes_cross_the_grid_lines_ahead_within_the_limit(
    v_atlas: xf.AcceptanceAtlas,
) -> None:
    x0, theta0, limit = 0.11, -0.3, 0.2
    minus_x, plus_x, minus_t, plus_t = atlas_margins._half_axes(v_atlas, x0, theta0, limit)
    ahead = v_atlas.x0[(v_atlas.x0 > x0) & (v_atlas.x0 - x0 <= limit)]
    behind = v_atlas.x0[(v_atlas.x0 < x0) & (x0 - v_atlas.x0 <= limit)][::-1]
    assert np.array_equal(plus_x.offsets, ahead - x0)
    assert np.array_equal(minus_x.offsets, x0 - behind)
    assert v_atlas.x0[plus_x.first] == ahead[0]
    assert v_atlas.x0[minus_x.first] == behind[0]
    assert minus_t.offsets[-1] <= math.pi
    assert plus_t.offsets[-1] <= math.pi
    # The atlas's outcome at each crossing: the two grid rows either side agree, or -1.
    k0, k1 = plus_x.lines
    nodes = plus_x.first + np.arange(plus_x.offsets.size)
    a, b = v_atlas.outcomes[nodes, k0], v_atlas.outcomes[nodes, k1]
    assert np.array_equal(plus_x.predicted(v_atlas), np.where(a == b, a, -1))
