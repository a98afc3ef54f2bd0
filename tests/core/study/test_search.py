"""Design search: the paper's box on a small pose grid finds the best cell of the M table,
refinement only improves on it, and the criteria rank what they say."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import xface_core as xf
from xface_core.study.noise import PoseNoise
from xface_core.study.run import read_study
from xface_core.study.search import box_nodes, search_designs

#: The documented smaller grid of the check against ``xface table --face X``: 11 x 11 poses
#: per design instead of 41 x 41 (the full-size check is run by hand, docs/study.md).
SMALL_GRID = 11


@pytest.fixture(scope="module")
def table() -> xf.MTable:
    return xf.m_table("X", grid=SMALL_GRID, workers=1)


def test_coarse_nodes_of_the_default_box_are_the_paper_s_axes() -> None:
    assert box_nodes(0.0625, 16.0, 11, geometric=True) == xf.PAPER_H_OVER_D
    assert box_nodes(0.0, 10.0, 11, geometric=False) == xf.PAPER_R_P


def test_the_paper_box_finds_the_best_cell_of_the_m_table(table: xf.MTable) -> None:
    found = search_designs("X", refine=0, grid=SMALL_GRID, workers=1)
    i, j = np.unravel_index(int(np.argmax(table.M)), table.M.shape)
    assert (found.best["h_over_d"], found.best["r_p"]) == (table.h_over_d[i], table.r_p[j])
    assert found.best["M"] == table.M.max()
    assert np.array_equal(found.coarse, table.M)


def test_refinement_keeps_or_beats_the_coarse_best(table: xf.MTable) -> None:
    found = search_designs("X", refine=1, grid=SMALL_GRID, workers=1)
    assert found.coarse_best["M"] == table.M.max()
    assert found.best["M"] >= found.coarse_best["M"]
    assert len(found.ranked) > table.M.size  # the refinement simulated new designs


@pytest.mark.parametrize(
    ("criterion", "column", "noise"),
    [
        ("guaranteed", "guaranteed_cells", None),
        ("centred", "centred_cells", None),
        ("seat_probability", "seat_probability", PoseNoise(0.1, 0.1, samples=4)),
    ],
)
def test_a_criterion_ranks_by_its_column(
    criterion: str, column: str, noise: PoseNoise | None
) -> None:
    found = search_designs(
        "V",
        h_over_d=(0.25, 1.0),
        r_p=(0.0, 2.0),
        steps=3,
        refine=0,
        criterion=criterion,
        noise=noise,
        grid=7,
        workers=1,
    )
    values = [r[column] for r in found.ranked]
    assert values == sorted(values, reverse=True)
    assert found.coarse.max() == values[0]


def test_a_search_with_an_output_resumes_from_it(tmp_path: Path) -> None:
    kw = {"h_over_d": (0.25, 1.0), "r_p": (0.0, 2.0), "steps": 3, "grid": 7, "workers": 1}
    first = search_designs("S", refine=1, out=tmp_path / "s.parquet", **kw)  # type: ignore[arg-type]
    rows = read_study(tmp_path / "s.parquet").num_rows
    again = search_designs("S", refine=1, out=tmp_path / "s.parquet", **kw)  # type: ignore[arg-type]
    assert again.ranked == first.ranked
    assert read_study(tmp_path / "s.parquet").num_rows == rows


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"criterion": "area"}, "criterion"),
        ({"steps": 1}, "steps"),
        ({"refine": 99}, "refine"),
        ({"refine_steps": 4}, "refine steps"),
        ({"h_over_d": (1.0, 0.5)}, "box"),
        ({"r_p": (0.0, float("inf"))}, "box"),
    ],
)
def test_bad_search_settings_are_refused(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(xf.XfaceValueError, match=message):
        search_designs("X", grid=5, workers=1, **kwargs)  # type: ignore[arg-type]


def test_the_seat_probability_criterion_needs_a_pose_noise() -> None:
    with pytest.raises(xf.XfaceValueError, match="needs a pose noise"):
        search_designs("X", criterion="seat_probability", grid=5, workers=1)
