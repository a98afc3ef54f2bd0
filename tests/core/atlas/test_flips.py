"""Grid-line flips: bisected lazily or all after the build, bracketed to the resolution, kept
in the atlas."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core.atlas import flips as atlas_flips
from xface_core.atlas.build import build_atlas
from xface_core.atlas.flips import (
    LINE_RESOLUTION,
    FlipKey,
    bisect_every_flip,
    boundary_segments,
    grid_flips,
)

COARSE = {"lateral_step": 1 / 32, "angle_step": math.pi / 128}
RESOLUTION = (1e-4, 1e-5)


@pytest.fixture(scope="module")
def x_atlas() -> xf.AcceptanceAtlas:
    return build_atlas(xf.x_face(0.25, 1.0), **COARSE)


def _flip_segments(atlas: xf.AcceptanceAtlas, axis: int, count: int) -> list[FlipKey]:
    """The first ``count`` segments with a flip on grid lines of ``axis`` near the centre."""
    out = atlas.outcomes
    keys: list[FlipKey] = []
    if axis == 0:  # columns: along x0
        for line in range(out.shape[1] // 2, out.shape[1]):
            for node in np.flatnonzero(out[:-1, line] != out[1:, line]):
                keys.append((0, line, int(node)))
    else:
        for line in range(out.shape[0] // 2, out.shape[0]):
            for node in np.flatnonzero(out[line, :-1] != out[line, 1:]):
                keys.append((1, line, int(node)))
    return keys[:count]


def _pose(atlas: xf.AcceptanceAtlas, key: FlipKey, at: float) -> tuple[float, float]:
    axis, line, _ = key
    return (at, float(atlas.theta0[line])) if axis == 0 else (float(atlas.x0[line]), at)


@pytest.mark.parametrize("axis", [0, 1])
def test_bracket_is_resolution_wide_with_the_node_outcome_on_its_lo_side(
    x_atlas: xf.AcceptanceAtlas, axis: int
) -> None:
    keys = _flip_segments(x_atlas, axis, 3)
    assert keys
    for key, (lo, hi) in zip(keys, grid_flips(x_atlas, keys, RESOLUTION), strict=True):
        assert 0.0 < hi - lo <= RESOLUTION[axis]
        _, line, node = key
        node_code = x_atlas.outcomes[node, line] if axis == 0 else x_atlas.outcomes[line, node]
        xs, ts = zip(_pose(x_atlas, key, lo), _pose(x_atlas, key, hi), strict=True)
        codes = xf.predict_batch(x_atlas.design, xs, ts).outcome
        assert codes[0] == node_code
        assert codes[1] != node_code


def test_known_flips_are_not_simulated_again(
    x_atlas: xf.AcceptanceAtlas, monkeypatch: pytest.MonkeyPatch
) -> None:
    keys = _flip_segments(x_atlas, 0, 2)
    first = grid_flips(x_atlas, keys, RESOLUTION)

    def no_simulation(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated a known flip again")

    monkeypatch.setattr(atlas_flips, "outcomes_at", no_simulation)
    assert grid_flips(x_atlas, keys, RESOLUTION) == first


def test_copies_of_the_atlas_for_another_width_share_the_flips(
    x_atlas: xf.AcceptanceAtlas,
) -> None:
    keys = _flip_segments(x_atlas, 1, 1)
    grid_flips(x_atlas, keys, RESOLUTION)
    wide = x_atlas.bound_to(xf.x_face(0.25, 1.0, width=0.05), x_atlas.physics)
    assert wide.flips.get(keys[0]) == x_atlas.flips.get(keys[0])


def test_a_segment_without_a_flip_is_refused(x_atlas: xf.AcceptanceAtlas) -> None:
    out = x_atlas.outcomes
    line = out.shape[1] // 2
    node = int(np.flatnonzero(out[:-1, line] == out[1:, line])[0])
    with pytest.raises(ValueError, match="no flip"):
        grid_flips(x_atlas, [(0, line, node)], RESOLUTION)


def test_an_atlas_pickles_with_its_flips(x_atlas: xf.AcceptanceAtlas) -> None:
    # Process pools send the atlas by pickle; the store's lock stays behind, its flips go.
    import pickle

    keys = _flip_segments(x_atlas, 0, 1)
    grid_flips(x_atlas, keys, RESOLUTION)
    copy = pickle.loads(pickle.dumps(x_atlas))
    assert copy.flips.get(keys[0]) == x_atlas.flips.get(keys[0])
    assert np.array_equal(copy.outcomes, x_atlas.outcomes)


def test_boundary_segments_are_the_grid_segments_whose_nodes_differ() -> None:
    outcomes = np.array([[3, 3, 4], [3, 4, 4]], dtype=np.int8)  # (x0 node, theta0 node)
    # Along x0 (axis 0, line = theta0 index): column 1 differs between x0 nodes 0 and 1.
    # Along theta0 (axis 1, line = x0 index): row 0 flips after node 1, row 1 after node 0.
    assert sorted(boundary_segments(outcomes)) == [(0, 1, 0), (1, 0, 1), (1, 1, 0)]


@pytest.fixture(scope="module")
def every_flip_atlas() -> xf.AcceptanceAtlas:
    return build_atlas(xf.v_face(0.5, 1.0), **COARSE, every_flip=True)


def test_an_atlas_built_with_every_flip_knows_the_flip_of_each_boundary_segment(
    every_flip_atlas: xf.AcceptanceAtlas,
) -> None:
    keys = boundary_segments(every_flip_atlas.outcomes)
    assert len(keys) > 100
    assert len(every_flip_atlas.flips) == len(keys)
    for key in keys:
        lo, hi = every_flip_atlas.flips.get(key)  # type: ignore[misc]
        assert 0.0 < hi - lo <= LINE_RESOLUTION[key[0]]


def test_every_flip_brackets_a_real_flip(every_flip_atlas: xf.AcceptanceAtlas) -> None:
    # A sample of the brackets simulated at both ends: the node's outcome at lo, another at hi.
    keys = boundary_segments(every_flip_atlas.outcomes)[::97]
    poses = []
    for key in keys:
        lo, hi = every_flip_atlas.flips.get(key)  # type: ignore[misc]
        poses += [_pose(every_flip_atlas, key, lo), _pose(every_flip_atlas, key, hi)]
    xs, ts = zip(*poses, strict=True)
    codes = xf.predict_batch(every_flip_atlas.design, xs, ts).outcome
    for n, (axis, line, node) in enumerate(keys):
        out = every_flip_atlas.outcomes
        node_code = out[node, line] if axis == 0 else out[line, node]
        assert codes[2 * n] == node_code
        assert codes[2 * n + 1] != node_code


def test_bisecting_every_flip_again_simulates_nothing(
    every_flip_atlas: xf.AcceptanceAtlas, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_simulation(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated a known flip again")

    monkeypatch.setattr(atlas_flips, "outcomes_at", no_simulation)
    assert bisect_every_flip(every_flip_atlas) == 0


def test_every_flip_completes_the_flips_a_query_left(x_atlas: xf.AcceptanceAtlas) -> None:
    # The lazily found ones are kept; the rest are bisected: one flip per segment in the end.
    import pickle

    atlas = pickle.loads(pickle.dumps(x_atlas))  # its own store
    keys = boundary_segments(atlas.outcomes)
    known = len(atlas.flips)
    assert bisect_every_flip(atlas) == len(keys) - known
    assert len(atlas.flips) == len(keys)
