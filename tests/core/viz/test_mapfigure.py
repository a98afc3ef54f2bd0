"""Acceptance-map figures (matplotlib): formats, reproducible files, what the legend says."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from xface_core.cli import main
from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import x_face
from xface_core.viz.mapimage import map_figure, save_map_picture

SEATED, BAD, REACH = int(Outcome.SEATED), int(Outcome.BAD_MATE), int(Outcome.OUT_OF_REACH)


@pytest.fixture
def amap() -> SimpleNamespace:
    """9 x 9 nodes over [-D, D] x [-90, 90] deg; X 0.25/0.25 has L = 0.75 D."""
    grid = np.full((9, 9), BAD)
    grid[0, :] = grid[-1, :] = REACH
    grid[3:6, 2:7] = SEATED
    return SimpleNamespace(
        x0=np.linspace(-1.0, 1.0, 9),
        theta0=np.linspace(-math.pi / 2, math.pi / 2, 9),
        outcomes=grid,
        M=15,
        design=x_face(0.25, 0.25),
        guaranteed=(slice(3, 6), slice(2, 7)),
        centred=(slice(3, 6), slice(2, 7)),
    )


def _labels(amap: SimpleNamespace) -> list[str]:
    fig, _ = map_figure(amap)
    legend = fig.axes[0].get_legend()
    assert legend is not None
    return [t.get_text() for t in legend.get_texts()]


def test_legend_gives_the_guaranteed_extents(amap: SimpleNamespace) -> None:
    text = "\n".join(_labels(amap))
    # rows 3..5: x0 -0.25..0.25; columns 2..6: theta0 -45..45 deg
    assert "[-0.25, 0.25] D" in text
    assert "[-45, 45] deg" in text


def test_legend_counts_each_outcome_present(amap: SimpleNamespace) -> None:
    labels = _labels(amap)
    assert "seated (15)" in labels
    assert "out of reach (18)" in labels
    assert not any(label.startswith("passed") for label in labels)


def test_reach_limit_is_marked_inside_the_range(amap: SimpleNamespace) -> None:
    assert any("L = 0.75 D" in label for label in _labels(amap))


def test_reach_limit_outside_the_range_is_not_marked(amap: SimpleNamespace) -> None:
    amap.design = x_face(0.25, 1.0)  # L = 2.25 D, beyond |x0| <= D
    assert not any("reach limit" in label for label in _labels(amap))


def test_title_names_the_design_and_m(amap: SimpleNamespace) -> None:
    fig, _ = map_figure(amap)
    title = fig.axes[0].get_title()
    assert "X-Face" in title
    assert "M = 15 of 81" in title


def test_axes_are_in_degrees_and_d(amap: SimpleNamespace) -> None:
    fig, _ = map_figure(amap)
    ax = fig.axes[0]
    assert ax.get_xlim() == pytest.approx((-101.25, 101.25))
    assert ax.get_ylim() == pytest.approx((-1.125, 1.125))


def test_svg_is_written_and_reproducible(tmp_path: Path, amap: SimpleNamespace) -> None:
    first = save_map_picture(amap, tmp_path / "a.svg").path.read_bytes()
    second = save_map_picture(amap, tmp_path / "b.svg").path.read_bytes()
    assert first.lstrip().startswith(b"<?xml")
    assert first == second


def test_png_is_reproducible(tmp_path: Path, amap: SimpleNamespace) -> None:
    first = save_map_picture(amap, tmp_path / "a.png").path.read_bytes()
    second = save_map_picture(amap, tmp_path / "b.png").path.read_bytes()
    assert first[:8] == b"\x89PNG\r\n\x1a\n"
    assert first == second


def test_unknown_suffix_is_refused(tmp_path: Path, amap: SimpleNamespace) -> None:
    with pytest.raises(XfaceValueError, match=r"\.png or \.svg"):
        save_map_picture(amap, tmp_path / "map.jpg")


def test_a_centred_region_with_unseated_cells_is_refused(amap: SimpleNamespace) -> None:
    amap.centred = (slice(2, 6), slice(2, 7))
    with pytest.raises(XfaceValueError, match="centred"):
        map_figure(amap)


def test_x0_is_in_the_length_unit_when_d_is_not_1(amap: SimpleNamespace) -> None:
    amap.design = x_face(0.25, 0.25, width=0.05)
    amap.x0 = amap.x0 * 0.05
    fig, _ = map_figure(amap)
    assert "D = 0.05" in fig.axes[0].get_ylabel()


def test_cli_map_writes_svg_and_png(tmp_path: Path) -> None:
    svg, png = tmp_path / "m.svg", tmp_path / "m.png"
    argv = ["map", "--face", "V", "--grid", "11", "--svg", str(svg), "--png", str(png)]
    assert main(argv) == 0
    assert svg.read_bytes().lstrip().startswith(b"<?xml")
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_cli_map_png_to_a_missing_folder_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["map", "--grid", "11", "--svg", str(tmp_path / "no" / "m.svg")]) == 2
    assert capsys.readouterr().err.startswith("xface: error:")


def test_a_large_grid_gets_smaller_cells() -> None:
    grid = np.full((161, 161), BAD)
    big = SimpleNamespace(
        x0=np.linspace(-1.0, 1.0, 161),
        theta0=np.linspace(-math.pi / 2, math.pi / 2, 161),
        outcomes=grid,
        M=0,
        design=x_face(0.25, 1.0),
        guaranteed=None,
    )
    _, box = map_figure(big)
    assert (box.right - box.left, box.bottom - box.top) == (161 * 4, 161 * 4)
