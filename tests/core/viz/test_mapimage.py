"""Acceptance-map pictures: cell colours, orientation (theta0 across, x0 up), PNG layout."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from PIL import Image

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import s_face, v_face
from xface_core.maps.acceptance import AcceptanceMap, acceptance_map
from xface_core.viz.mapimage import (
    GUARANTEED_OUTLINE,
    guaranteed_cells,
    map_to_rgb,
    outcome_colors,
    save_map_png,
)

SEATED, BAD, PASSED = int(Outcome.SEATED), int(Outcome.BAD_MATE), int(Outcome.PASSED)


def make_map(grid: Any, *, guaranteed: object = None, m: int | None = None) -> SimpleNamespace:
    grid = np.asarray(grid, dtype=np.int64)
    n, k = grid.shape
    return SimpleNamespace(
        x0=np.linspace(-1.0, 1.0, n),
        theta0=np.linspace(-math.pi / 2, math.pi / 2, k),
        outcomes=grid,
        M=int(np.count_nonzero(grid == SEATED)) if m is None else m,
        design=s_face(0.5, 1.0),
        guaranteed=guaranteed,
    )


@pytest.fixture
def amap() -> SimpleNamespace:
    """5 rows (x0) x 7 columns (theta0): a seated block, one PASSED corner cell."""
    grid = np.full((5, 7), BAD)
    grid[1:4, 2:5] = SEATED
    grid[4, 6] = PASSED  # largest x0, largest theta0
    return make_map(grid, guaranteed=(slice(1, 4), slice(2, 5)))


# --- colours and the raw picture ----------------------------------------------------------------


def test_every_outcome_has_its_own_colour() -> None:
    colors = outcome_colors()
    assert set(colors) == set(Outcome)
    assert len(set(colors.values())) == len(Outcome)


def test_rgb_has_scale_pixels_per_cell(amap: SimpleNamespace) -> None:
    assert map_to_rgb(amap, scale=3).shape == (5 * 3, 7 * 3, 3)


def test_largest_x0_and_theta0_is_the_top_right_cell(amap: SimpleNamespace) -> None:
    rgb = map_to_rgb(amap, scale=4)
    top_right = rgb[:4, -4:].reshape(-1, 3)
    assert {tuple(int(c) for c in px) for px in top_right} == {outcome_colors()[Outcome.PASSED]}


@given(
    grid=hnp.arrays(
        np.int64,
        hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=9),
        elements=st.sampled_from([int(o) for o in Outcome]),
    ),
    scale=st.integers(1, 5),
)
def test_every_cell_has_its_outcome_colour(grid: np.ndarray, scale: int) -> None:
    rgb = map_to_rgb(make_map(grid), scale=scale)
    n = grid.shape[0]
    colors = outcome_colors()
    for (i, j), value in np.ndenumerate(grid):
        row = (n - 1 - i) * scale  # x0 grows upwards: grid row i is picture row n - 1 - i
        cell = rgb[row : row + scale, j * scale : (j + 1) * scale]
        assert (cell == colors[Outcome(value)]).all()


# --- the PNG ------------------------------------------------------------------------------------


def test_png_file_has_the_reported_size(tmp_path: Path, amap: SimpleNamespace) -> None:
    picture = save_map_png(amap, tmp_path / "m.png")
    with Image.open(picture.path) as image:
        assert image.size == picture.size


def test_png_cell_box_is_n_by_m_cells(tmp_path: Path, amap: SimpleNamespace) -> None:
    left, top, right, bottom = save_map_png(amap, tmp_path / "m.png", scale=6).cells
    assert (right - left, bottom - top) == (7 * 6, 5 * 6)


def test_png_known_cell_has_its_colour(tmp_path: Path, amap: SimpleNamespace) -> None:
    scale = 8
    picture = save_map_png(amap, tmp_path / "m.png", scale=scale)
    left, top, _, _ = picture.cells
    with Image.open(picture.path) as image:
        # the PASSED cell: grid row 4 (largest x0) is the top row, column 6 the last one
        centre = (left + 6 * scale + scale // 2, top + 0 * scale + scale // 2)
        assert image.convert("RGB").getpixel(centre) == outcome_colors()[Outcome.PASSED]


def test_png_outlines_the_guaranteed_rectangle(tmp_path: Path, amap: SimpleNamespace) -> None:
    scale = 8
    picture = save_map_png(amap, tmp_path / "m.png", scale=scale)
    left, top, _, _ = picture.cells
    # rectangle rows 1:4, columns 2:5; its top edge is the top of grid row 3 = picture row 1
    edge = (left + 3 * scale + scale // 2, top + 1 * scale)
    with Image.open(picture.path) as image:
        assert image.convert("RGB").getpixel(edge) == GUARANTEED_OUTLINE


def test_png_without_rectangle_keeps_the_cell_colour(tmp_path: Path, amap: SimpleNamespace) -> None:
    amap.guaranteed = None
    scale = 8
    picture = save_map_png(amap, tmp_path / "m.png", scale=scale)
    left, top, _, _ = picture.cells
    edge = (left + 3 * scale + scale // 2, top + 1 * scale)
    with Image.open(picture.path) as image:
        assert image.convert("RGB").getpixel(edge) == outcome_colors()[Outcome.SEATED]


def test_png_refuses_a_wrong_m(tmp_path: Path, amap: SimpleNamespace) -> None:
    amap.M = 10
    with pytest.raises(XfaceValueError, match="M = 10"):
        save_map_png(amap, tmp_path / "m.png")


# --- the guaranteed rectangle's forms -----------------------------------------------------------


@pytest.mark.parametrize(
    "form",
    [(slice(1, 4), slice(2, 5)), (range(1, 4), range(2, 5)), ((1, 4), (2, 5)), [[1, 4], [2, 5]]],
)
def test_rectangle_forms_read_half_open(amap: SimpleNamespace, form: object) -> None:
    amap.guaranteed = form
    assert guaranteed_cells(amap) == (1, 4, 2, 5)


@pytest.mark.parametrize(
    "form",
    [(slice(0, 2), slice(2, 5)), ((1, 6), (2, 5)), ((3, 3), (2, 5)), ((1.0, 4.0), (2, 5)), "all"],
)
def test_bad_rectangles_are_refused(amap: SimpleNamespace, form: object) -> None:
    amap.guaranteed = form
    with pytest.raises(XfaceValueError):
        guaranteed_cells(amap)


# --- malformed maps -----------------------------------------------------------------------------


def test_unknown_outcome_value_is_refused(amap: SimpleNamespace) -> None:
    amap.outcomes[0, 0] = 42
    with pytest.raises(XfaceValueError, match="42"):
        map_to_rgb(amap)


def test_outcome_shape_must_match_the_axes(amap: SimpleNamespace) -> None:
    amap.theta0 = amap.theta0[:-1]
    with pytest.raises(XfaceValueError, match="shape"):
        map_to_rgb(amap)


def test_axes_must_increase(amap: SimpleNamespace) -> None:
    amap.x0 = amap.x0[::-1]
    with pytest.raises(XfaceValueError, match="increasing"):
        map_to_rgb(amap)


@pytest.mark.parametrize("scale", [0, 65, 1.5, True])
def test_scale_must_be_a_small_positive_integer(amap: SimpleNamespace, scale: Any) -> None:
    with pytest.raises(XfaceValueError, match="scale"):
        map_to_rgb(amap, scale=scale)


# --- a real acceptance map ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def real_map() -> AcceptanceMap:
    amap = acceptance_map(v_face(1.0, 1.0), grid=11)
    assert amap.guaranteed is not None
    return amap


def test_real_map_cells_have_their_colours(real_map: AcceptanceMap) -> None:
    rgb = map_to_rgb(real_map, scale=1)
    colors = outcome_colors()
    expected = np.array([[colors[Outcome(v)] for v in row] for row in real_map.outcomes[::-1]])
    np.testing.assert_array_equal(rgb, expected)


def test_real_map_rectangle_centre_is_seated_in_the_png(
    tmp_path: Path, real_map: AcceptanceMap
) -> None:
    scale = 8
    picture = save_map_png(real_map, tmp_path / "real.png", scale=scale)
    cells = guaranteed_cells(real_map)
    assert cells is not None
    r0, r1, c0, c1 = cells
    n = real_map.outcomes.shape[0]
    i, j = (r0 + r1 - 1) // 2, (c0 + c1 - 1) // 2  # a cell inside the rectangle
    left, top, _, _ = picture.cells
    centre = (left + j * scale + scale // 2, top + (n - 1 - i) * scale + scale // 2)
    with Image.open(picture.path) as image:
        assert image.convert("RGB").getpixel(centre) == outcome_colors()[Outcome.SEATED]
