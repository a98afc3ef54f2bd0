"""The acceptance atlas: outcomes on a grid, built by refinement, cached on disk."""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import xface_core as xf
from xface_core.atlas.build import AtlasCacheWarning, build_atlas
from xface_core.atlas.cache import checksum
from xface_core.atlas.flips import bisect_every_flip, boundary_segments
from xface_core.errors import Cancelled
from xface_core.runner import count_engine_calls

#: Small grids for the cache tests (the shared coarse atlas is the coarse_v_atlas fixture).
SMALL = {"lateral_step": 1 / 16, "angle_step": math.pi / 32, "angle_range": math.pi / 2}


def test_refined_atlas_equals_full_simulation_on_its_nodes(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    design = coarse_v_atlas.design
    x, t = np.meshgrid(coarse_v_atlas.x0, coarse_v_atlas.theta0, indexing="ij")
    full = xf.predict_batch(design, x * design.width, t).outcome
    assert coarse_v_atlas.simulations < full.size  # the refinement skipped uniform blocks
    assert np.array_equal(coarse_v_atlas.outcomes, full)


def test_asymmetric_design_is_not_mirrored() -> None:
    # The S-Face is not mirror-symmetric: every simulated node is simulated as itself.
    design = xf.s_face(1.0, 1.0)
    atlas = build_atlas(design, lateral_step=1 / 16, angle_step=math.pi / 32, angle_range=1.6)
    x, t = np.meshgrid(atlas.x0, atlas.theta0, indexing="ij")
    full = xf.predict_batch(design, x, t).outcome
    assert np.array_equal(atlas.outcomes, full)


def test_grid_is_mirror_exact(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    assert np.array_equal(coarse_v_atlas.x0[::-1], -coarse_v_atlas.x0)
    assert np.array_equal(coarse_v_atlas.theta0[::-1], -coarse_v_atlas.theta0)


def test_default_ranges_cover_reach_and_margin_search() -> None:
    design = xf.v_face(0.5, 1.0)
    atlas = build_atlas(design, lateral_step=1 / 8, angle_step=0.1)
    assert atlas.x0[-1] >= design.mated_distance
    assert atlas.theta0[-1] >= 1.5 * math.pi


def test_cache_round_trip_skips_the_build(tmp_path: Path) -> None:
    design = xf.v_face(0.5, 1.0)
    built = build_atlas(design, cache_dir=tmp_path, **SMALL)
    files = list(tmp_path.glob("atlas-*.npz"))
    assert [f.name for f in files] == [f"atlas-{built.key}.npz"]
    loaded = build_atlas(design, cache_dir=tmp_path, **SMALL)
    assert loaded.build_seconds == 0.0
    assert np.array_equal(loaded.outcomes, built.outcomes)


def test_unreadable_cache_file_is_rebuilt(tmp_path: Path) -> None:
    design = xf.v_face(0.5, 1.0)
    built = build_atlas(design, cache_dir=tmp_path, **SMALL)
    (tmp_path / f"atlas-{built.key}.npz").write_bytes(b"truncated")
    with pytest.warns(AtlasCacheWarning, match="not an .npz"):
        again = build_atlas(design, cache_dir=tmp_path, **SMALL)
    assert again.build_seconds > 0.0
    assert np.array_equal(again.outcomes, built.outcomes)
    assert build_atlas(design, cache_dir=tmp_path, **SMALL).build_seconds == 0.0


def test_cache_key_depends_on_physics_and_grid(tmp_path: Path) -> None:
    design = xf.v_face(0.5, 1.0)
    a = build_atlas(design, cache_dir=tmp_path, **SMALL)
    b = build_atlas(design, physics=xf.Physics(friction=0.1), cache_dir=tmp_path, **SMALL)
    c = build_atlas(design, cache_dir=tmp_path, **{**SMALL, "lateral_step": 1 / 8})
    assert len({a.key, b.key, c.key}) == 3


def test_size_guard_names_the_estimate() -> None:
    with pytest.raises(xf.XfaceValueError, match="nodes exceeds max_nodes"):
        build_atlas(xf.x_face(0.25, 10.0), lateral_step=1e-4)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"lateral_step": 0.0},
        {"angle_step": math.nan},
        {"angle_range": 7.0},
        {"coarse_stride": 3},
        {"lateral_range": -1.0},
    ],
)
def test_bad_grid_is_refused(kwargs: dict[str, float]) -> None:
    with pytest.raises(xf.XfaceValueError):
        build_atlas(xf.v_face(0.5, 1.0), **kwargs)


def test_atlas_for_other_physics_is_refused(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.XfaceValueError, match="built for"):
        coarse_v_atlas.bound_to(coarse_v_atlas.design, xf.Physics(friction=0.2))
    with pytest.raises(xf.XfaceValueError, match="another design"):
        coarse_v_atlas.bound_to(xf.x_face(0.5, 1.0), coarse_v_atlas.physics)


def test_cell_classification_marks_outside_as_unknown(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    out = coarse_v_atlas.seated_in_cell([0.0, 0.0, 50.0], [0.0, 1.5, 0.0])
    assert out.tolist() == [1, 0, -1]


def test_atlas_binds_to_the_same_geometry_at_another_width(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    metric = xf.v_face(0.5, 1.0, width=0.03)
    bound = coarse_v_atlas.bound_to(metric, coarse_v_atlas.physics)
    assert bound.design is metric
    assert bound.outcomes is coarse_v_atlas.outcomes


def test_atlas_arrays_are_read_only(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(ValueError, match="read-only"):
        coarse_v_atlas.outcomes[0, 0] = 0


def test_saved_atlas_keeps_the_grid_line_flips_found_so_far(tmp_path: Path) -> None:
    # A restart (build_atlas with the cache) knows the flips the last run bisected: its first
    # margins near them take the interpolated confirmations at once.
    design = xf.x_face(0.25, 1.0)
    built = build_atlas(design, cache_dir=tmp_path, **SMALL)
    outcome = xf.predict(design, 0.05, 0.1).outcome
    for _ in range(2):  # the second query bisects the grid lines around it
        xf.margins_from_atlas(built, 0.05, 0.1, outcome)
    assert len(built.flips) > 0
    built.save(tmp_path / f"atlas-{built.key}.npz")
    loaded = build_atlas(design, cache_dir=tmp_path, **SMALL)
    assert loaded.build_seconds == 0.0
    assert loaded.flips.arrays()[0].tolist() == built.flips.arrays()[0].tolist()
    assert np.array_equal(loaded.flips.arrays()[1], built.flips.arrays()[1])
    assert xf.margins_from_atlas(loaded, 0.05, 0.1, outcome) == xf.margins_from_atlas(
        built, 0.05, 0.1, outcome
    )


@pytest.mark.parametrize(
    ("keys", "brackets"),
    [
        ([[2, 0, 0]], [[0.0, 0.1]]),  # no such axis
        ([[0, 10_000, 0]], [[0.0, 0.1]]),  # off the grid
        ([[0, 0, 0]], [[0.1, 0.0]]),  # an empty bracket
        ([[0, 0, 0]], [[0.0, float("nan")]]),
        ([[0.5, 0, 0]], [[0.0, 0.1]]),  # not an integer key
        ([[0, 0]], [[0.0, 0.1]]),  # wrong shape
    ],
)
def test_flips_that_do_not_fit_the_grid_are_refused(keys: list, brackets: list) -> None:
    atlas = build_atlas(xf.v_face(0.5, 1.0), **SMALL)
    with pytest.raises(ValueError, match="flip"):
        atlas.flips.add_arrays(np.array(keys), np.array(brackets), atlas.outcomes.shape)
    assert len(atlas.flips) == 0


def test_a_cache_file_with_damaged_flips_is_rebuilt(tmp_path: Path) -> None:
    design = xf.v_face(0.5, 1.0)
    built = build_atlas(design, cache_dir=tmp_path, **SMALL)
    path = tmp_path / f"atlas-{built.key}.npz"
    with np.load(path) as data:
        arrays = dict(data)
    arrays["flip_keys"] = np.array([[0, -1, 0]])
    arrays["flip_brackets"] = np.array([[0.0, 0.1]])
    del arrays["checksum"]  # signed again: the flips' own check must refuse them
    np.savez_compressed(path, **arrays, checksum=np.array(checksum(arrays)))
    with pytest.warns(AtlasCacheWarning, match="flip arrays that do not fit the grid"):
        again = build_atlas(design, cache_dir=tmp_path, **SMALL)
    assert again.build_seconds > 0.0
    assert np.array_equal(again.outcomes, built.outcomes)


def test_a_cached_atlas_without_every_flip_is_completed_and_saved_again(tmp_path: Path) -> None:
    from xface_core.atlas.flips import boundary_segments

    design = xf.v_face(0.5, 1.0)
    lazy = build_atlas(design, cache_dir=tmp_path, **SMALL)
    assert len(lazy.flips) == 0
    completed = build_atlas(design, cache_dir=tmp_path, **SMALL, every_flip=True)
    segments = len(boundary_segments(completed.outcomes))
    assert segments > 0
    assert len(completed.flips) == segments
    again = build_atlas(design, cache_dir=tmp_path, **SMALL)  # read from the file
    assert again.build_seconds == 0.0
    assert len(again.flips) == segments


def test_build_seconds_include_the_flips_when_every_flip_is_bisected(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The bisection is made to last at least 0.3 s: a build time without it would be the
    # refinement's alone (milliseconds on this grid).
    from xface_core.atlas import build as atlas_module

    real = atlas_module.bisect_every_flip

    def slow(*args: Any, **kwargs: Any) -> int:
        time.sleep(0.3)
        return real(*args, **kwargs)

    monkeypatch.setattr(atlas_module, "bisect_every_flip", slow)
    atlas = build_atlas(xf.v_face(0.5, 1.0), **SMALL, every_flip=True)
    assert atlas.build_seconds >= 0.3
    assert len(atlas.flips) > 0


def test_a_cancelled_build_stops_between_batches_and_saves_nothing(tmp_path: Path) -> None:
    asked: list[int] = []

    def cancel() -> bool:
        asked.append(1)
        return len(asked) > 2  # two batches run, the third is not started

    with pytest.raises(Cancelled):
        build_atlas(
            xf.v_face(0.5, 1.0), lateral_step=1 / 16, angle_step=0.05, cache_dir=tmp_path,
            every_flip=True, cancel=cancel,
        )  # fmt: skip
    assert len(asked) == 3
    assert list(tmp_path.iterdir()) == []


def test_a_build_never_cancelled_is_the_same_atlas() -> None:
    d = xf.v_face(0.5, 1.0)
    plain = build_atlas(d, lateral_step=1 / 16, angle_step=0.05, every_flip=True)
    asked = build_atlas(
        d, lateral_step=1 / 16, angle_step=0.05, every_flip=True, cancel=lambda: False
    )
    assert np.array_equal(plain.outcomes, asked.outcomes)
    assert len(plain.flips) == len(asked.flips)


def test_cancelled_flip_bisection_keeps_no_partial_flips() -> None:
    atlas = build_atlas(xf.v_face(0.5, 1.0), lateral_step=1 / 16, angle_step=0.05)
    before = len(atlas.flips)
    with pytest.raises(Cancelled):
        bisect_every_flip(atlas, cancel=lambda: True)
    assert len(atlas.flips) == before


# --- the straight boundary between a cell's edge flips (seated_by_flips) -------------------


def _half_plane_atlas(slope: float, offset: float) -> xf.AcceptanceAtlas:
    """An atlas of a made-up 'design' that seats exactly below the line theta0 = slope x0 +
    offset (D, rad), with every grid-line flip at that line's exact crossing."""
    from xface_core.atlas.build import AcceptanceAtlas, FlipStore

    x0 = np.linspace(-1.0, 1.0, 9)
    theta0 = np.linspace(-0.5, 0.5, 9)
    below = theta0[None, :] < slope * x0[:, None] + offset
    outcomes = np.where(below, xf.Outcome.SEATED, xf.Outcome.BAD_MATE).astype(np.int8)
    store = FlipStore()
    for axis, line, node in boundary_segments(outcomes):
        if axis == 0:  # along x0 on the column theta0[line]
            at, ends = (theta0[line] - offset) / slope, x0[node : node + 2]
        else:  # along theta0 on the row x0[line]
            at, ends = slope * x0[line] + offset, theta0[node : node + 2]
        # Inside the segment, as a bisection's bracket always is (a line through a node
        # ends a hair beyond it).
        width = 1e-6 * (ends[1] - ends[0])
        at = min(max(at, ends[0] + width), ends[1] - width)
        store.put((axis, line, node), (at - 0.5 * width, at + 0.5 * width))
    atlas = AcceptanceAtlas(
        design=xf.v_face(0.5, 1.0), physics=xf.Physics(), key="half-plane", x0=x0,
        theta0=theta0, outcomes=outcomes, simulated=np.ones_like(outcomes, dtype=bool),
        flips=store,
    )  # fmt: skip
    # Every chord passes (the design's own outcomes are not these: no simulation checks them).
    store.keep_checked_chords(store.version, np.ones((8, 8), dtype=bool))
    return atlas


@settings(max_examples=40, deadline=None)
@given(
    slope=st.floats(0.2, 3.0) | st.floats(-3.0, -0.2),
    offset=st.floats(-0.2, 0.2),
    seed=st.integers(0, 2**31),
)
def test_a_straight_boundary_is_drawn_exactly(slope: float, offset: float, seed: int) -> None:
    atlas = _half_plane_atlas(slope, offset)
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, 400)
    t = rng.uniform(-0.5, 0.5, 400)
    truth = (t < slope * x + offset).astype(np.int8)
    clear = np.abs(t - (slope * x + offset)) > 1e-4  # not on the line itself
    got = atlas.seated_by_flips(x, t)
    # Every cell has its line or agreeing corners, but for a line through a node (both
    # crossings at one corner): that cell is left to simulation.
    drawn = got >= 0
    assert drawn.mean() > 0.9
    assert np.array_equal(got[clear & drawn], truth[clear & drawn])


def test_a_cell_with_opposite_seated_corners_is_left_to_simulation() -> None:
    atlas = _half_plane_atlas(1.0, 0.0)
    saddle = atlas.outcomes.copy()
    saddle[4, 4], saddle[5, 5], saddle[5, 4], saddle[4, 5] = 3, 3, 4, 4
    odd = replace(atlas, outcomes=saddle, key="saddle")
    middle = (0.5 * (odd.x0[4] + odd.x0[5]), 0.5 * (odd.theta0[4] + odd.theta0[5]))
    assert odd.seated_by_flips([middle[0]], [middle[1]]).tolist() == [-1]


def test_a_cell_without_its_flips_is_left_to_simulation() -> None:
    from xface_core.atlas.build import FlipStore

    store = FlipStore()
    store.keep_checked_chords(store.version, np.ones((8, 8), dtype=bool))
    atlas = replace(_half_plane_atlas(1.0, 0.0), flips=store, key="no flips")
    x = np.linspace(-0.9, 0.9, 50)
    got = atlas.seated_by_flips(x, x + 0.01)  # just above the line: in mixed cells
    assert (got[atlas.seated_in_cell(x, x + 0.01) < 0] == -1).all()
    assert (got == -1).any()


def test_a_new_flip_renews_the_dense_flips() -> None:
    atlas = _half_plane_atlas(1.0, 0.0)
    key = boundary_segments(atlas.outcomes)[0]
    before = atlas.flips.dense(atlas.outcomes.shape)[key[0]].copy()
    lo, hi = atlas.flips.get(key) or (0.0, 0.0)
    atlas.flips.put(key, (lo - 0.01, hi - 0.01))
    after = atlas.flips.dense(atlas.outcomes.shape)[key[0]]
    changed = np.flatnonzero(np.nan_to_num(before) != np.nan_to_num(after))
    assert changed.size == 1


def test_flips_on_a_real_atlas_decide_most_boundary_cells_right() -> None:
    # The V-Face's boundaries are smooth across most cells: the straight line between a
    # cell's flips decides nearly every pose in a mixed cell as the simulation does.
    atlas = build_atlas(xf.v_face(0.5, 1.0), every_flip=True, **SMALL)
    got, exact = _chords_against_simulation(atlas, 600, seed=3)
    drawn = got >= 0
    assert drawn.mean() > 0.9
    assert (got[drawn] == exact[drawn]).mean() > 0.97


def _chords_against_simulation(
    atlas: xf.AcceptanceAtlas, n: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """``seated_by_flips`` and the simulated seating of ``n`` random poses in boundary cells
    (cells whose corners disagree on seating)."""
    rng = np.random.default_rng(seed)
    s = atlas.outcomes == xf.Outcome.SEATED
    corners = s[:-1, :-1].astype(int) + s[1:, :-1] + s[:-1, 1:] + s[1:, 1:]
    cells = np.argwhere((corners > 0) & (corners < 4))
    pick = cells[rng.integers(0, len(cells), n)]
    x = atlas.x0[pick[:, 0]] + rng.random(n) * atlas.lateral_step
    t = atlas.theta0[pick[:, 1]] + rng.random(n) * atlas.angle_step
    exact = (xf.predict_batch(atlas.design, x, t).outcome == xf.Outcome.SEATED).astype(np.int8)
    return atlas.seated_by_flips(x, t), exact


@pytest.fixture(scope="module")
def interleaved_atlas() -> xf.AcceptanceAtlas:
    """X 0.25/1 on the default grid with every flip: SEATED and BAD_MATE bands interleave
    within cells near |theta0| = 0.6-0.7 rad, where chords go wrong."""
    return build_atlas(xf.x_face(0.25, 1.0), every_flip=True)


def test_the_chord_check_sets_aside_the_cells_where_a_chord_is_wrong(
    interleaved_atlas: xf.AcceptanceAtlas,
) -> None:
    from xface_core.atlas.build import CHORD_CHECK_POINTS

    atlas = interleaved_atlas
    trusted = atlas.checked_chords()
    assert 0 < np.count_nonzero(~trusted) < trusted.size
    # A cell set aside put one of its check points on the wrong side: its poses simulate.
    i, k = (int(v) for v in np.argwhere(~trusted)[0])
    x = atlas.x0[i] + np.array([f[0] for f in CHORD_CHECK_POINTS]) * atlas.lateral_step
    t = atlas.theta0[k] + np.array([f[1] for f in CHORD_CHECK_POINTS]) * atlas.angle_step
    assert (atlas.seated_by_flips(x, t) == -1).all()
    # The rest is right for nearly every pose in a boundary cell (8 % wrong unchecked).
    got, exact = _chords_against_simulation(atlas, 2000, seed=5)
    drawn = got >= 0
    assert (got[drawn] != exact[drawn]).mean() < 0.02


def test_the_chord_check_is_made_once_and_renewed_by_a_new_flip(
    interleaved_atlas: xf.AcceptanceAtlas,
) -> None:
    atlas = interleaved_atlas
    first = atlas.checked_chords()
    with count_engine_calls() as calls:
        again = atlas.checked_chords()
    assert again is first
    assert calls.poses == 0
    key = boundary_segments(atlas.outcomes)[0]
    atlas.flips.put(key, atlas.flips.get(key) or (0.0, 1.0))  # the same flip, put again
    with count_engine_calls() as calls:
        renewed = atlas.checked_chords()
    assert calls.poses > 0
    assert np.array_equal(renewed, first)
