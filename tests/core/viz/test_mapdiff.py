"""Two maps compared cell by cell: the counts, and maps that do not share a grid."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from xface_core.codes import Outcome
from xface_core.errors import XfaceValueError
from xface_core.geometry import x_face
from xface_core.viz.comparefig import save_comparison
from xface_core.viz.mapdiff import SeatedIn, map_difference

S, B, P = int(Outcome.SEATED), int(Outcome.BAD_MATE), int(Outcome.PASSED)


def make_map(grid: list[list[int]]) -> SimpleNamespace:
    g = np.asarray(grid, dtype=np.int64)
    return SimpleNamespace(
        x0=np.linspace(-1.0, 1.0, g.shape[0]),
        theta0=np.linspace(-math.pi / 2, math.pi / 2, g.shape[1]),
        outcomes=g,
        M=int(np.count_nonzero(g == S)),
        design=x_face(0.25, 1.0),
        guaranteed=None,
    )


A = make_map([[S, S, B], [S, B, B]])
B_MAP = make_map([[S, B, S], [P, B, B]])


def test_counts_of_a_hand_made_pair() -> None:
    diff = map_difference(A, B_MAP)
    assert diff.counts() == {
        SeatedIn.BOTH: 1,
        SeatedIn.ONLY_A: 2,
        SeatedIn.ONLY_B: 1,
        SeatedIn.NEITHER: 2,
    }


def test_same_outcome_counts_failures_too() -> None:
    assert map_difference(A, B_MAP).same_outcome == 3  # (0,0) seated, (1,1) and (1,2) bad


def test_maps_on_different_grids_are_refused() -> None:
    other = make_map([[S, S], [S, B]])
    with pytest.raises(XfaceValueError, match="share their grid"):
        map_difference(A, other)


def test_picture_returns_the_counts_it_draws(tmp_path: Path) -> None:
    diff = save_comparison(A, B_MAP, tmp_path / "cmp.svg")
    assert (tmp_path / "cmp.svg").read_bytes().lstrip().startswith(b"<?xml")
    assert diff.count(SeatedIn.ONLY_A) == 2
