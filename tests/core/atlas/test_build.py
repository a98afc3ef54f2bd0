"""The acceptance atlas: outcomes on a grid, built by refinement, cached on disk."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import xface_core as xf
from xface_core.atlas.build import AtlasCacheWarning, build_atlas
from xface_core.atlas.cache import checksum
from xface_core.atlas.flips import bisect_every_flip
from xface_core.errors import Cancelled

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
