"""The design search's heat map: one cell per design, values readable, best outlined."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import xface_core as xf
from xface_core.viz.heatmap import CELL_PX, ramp_colors, save_heatmap_png


def test_the_ramp_runs_from_dark_to_light() -> None:
    rgb = ramp_colors([0.0, 0.5, 1.0]).astype(float)
    luma = rgb @ np.array([0.299, 0.587, 0.114])
    assert luma[0] < luma[1] < luma[2]


@pytest.mark.parametrize("values", [[[1, 2, 3], [4, 5, 6]], [[0.125, 0.5, 0.25], [0.0, 1.0, 0.75]]])
def test_a_heat_map_has_a_cell_per_design(tmp_path: Path, values: list[list[float]]) -> None:
    path = save_heatmap_png(values, [0.5, 1.0], [0.0, 1.0, 2.0], tmp_path / "h.png", best=(1, 2))
    width, height = Image.open(path).size
    assert width > 3 * CELL_PX
    assert height > 2 * CELL_PX


def test_the_best_cell_is_outlined(tmp_path: Path) -> None:
    def picture(best: tuple[int, int] | None) -> np.ndarray:
        path = save_heatmap_png(
            [[1, 2], [3, 4]], [0.5, 1.0], [0.0, 1.0], tmp_path / "h.png", best=best
        )
        return np.asarray(Image.open(path))

    assert not np.array_equal(picture((1, 1)), picture(None))


def test_values_of_another_shape_are_refused(tmp_path: Path) -> None:
    with pytest.raises(xf.XfaceValueError, match="values must be"):
        save_heatmap_png([[1, 2]], [0.5, 1.0], [0.0, 1.0], tmp_path / "h.png")


def test_the_same_values_give_the_same_file(tmp_path: Path) -> None:
    first = save_heatmap_png([[1, 2]], [0.5], [0.0, 1.0], tmp_path / "a.png", best=(0, 1))
    second = save_heatmap_png([[1, 2]], [0.5], [0.0, 1.0], tmp_path / "b.png", best=(0, 1))
    assert first.read_bytes() == second.read_bytes()
