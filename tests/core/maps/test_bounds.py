"""Tests of xface_core.maps.bounds: the paper's closed-form "best case" bounds (Tables III, IV)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xface_core.errors import XfaceValueError
from xface_core.maps.bounds import (
    S_RULE,
    S_RULE_ANALOGUE,
    V_RULE,
    bound_m,
    bound_map,
    bound_table,
    lever_bound_table,
)
from xface_core.maps.grids import PAPER_H_OVER_D, PAPER_R_P, theta_grid, x0_grid
from xface_core.maps.paper import paper_table

#: Documented in docs/bounds.md: cells of Table IV the S rule matches, and its sum of |dM|.
S_RULE_MATCHED_CELLS = 34
S_RULE_SUM_ABS_DM = 294
S_RULE_ANALOGUE_MATCHED_CELLS = 16


def mismatches(computed: np.ndarray, printed: np.ndarray) -> list[tuple[float, float, int, int]]:
    """(H/D, r_p, computed, printed) of every printed cell that differs."""
    return [
        (PAPER_H_OVER_D[i], PAPER_R_P[j], int(computed[i, j]), int(printed[i, j]))
        for i, j in zip(*np.nonzero(np.isfinite(printed) & (computed != printed)), strict=True)
    ]


def test_v_bound_reproduces_table_three_in_all_121_cells() -> None:
    printed = paper_table("V").M
    assert mismatches(bound_table("V"), printed) == []


def test_v_bound_needs_the_papers_theta_grid() -> None:
    printed = paper_table("V").M
    assert len(mismatches(bound_table("V", theta_grid="symmetric"), printed)) > 20


def test_s_rule_matches_the_documented_number_of_table_four_cells() -> None:
    printed = paper_table("S").M
    computed = bound_table("S")
    known = np.isfinite(printed)
    assert int((computed[known] == printed[known]).sum()) == S_RULE_MATCHED_CELLS
    assert int(np.abs(computed[known] - printed[known]).sum()) == S_RULE_SUM_ABS_DM


def test_s_analogue_of_the_v_rule_matches_fewer_cells() -> None:
    printed = paper_table("S").M
    known = np.isfinite(printed)
    computed = lever_bound_table(S_RULE_ANALOGUE)
    assert int((computed[known] == printed[known]).sum()) == S_RULE_ANALOGUE_MATCHED_CELLS


def test_s_rule_matches_every_cell_its_cut_and_reach_decide() -> None:
    """r_p = 0 and H/D <= 0.32988: only x0 near 0 is in reach, the tip band does not bind."""
    printed = paper_table("S").M
    assert bound_table("S")[:4, 0].tolist() == printed[:4, 0].tolist()


def test_s_rule_gives_26_or_27_in_the_missing_rows() -> None:
    """Only theta0 = 0 and pi/80 pass the cut there: 13 nodes plus 13 or 14."""
    tall = bound_table("S")[9:]
    assert set(tall.ravel().tolist()) <= {26, 27}


@pytest.mark.parametrize("face", ["V", "S"])
@pytest.mark.parametrize("grid", ["paper", "symmetric"])
def test_table_cells_equal_single_design_counts(face: str, grid: str) -> None:
    table = bound_table(face, theta_grid=grid)  # type: ignore[arg-type]
    single = np.array(
        [
            [bound_m(face, h, r, theta_grid=grid) for r in PAPER_R_P]  # type: ignore[arg-type]
            for h in PAPER_H_OVER_D
        ]
    )
    assert (table == single).all()


@pytest.mark.parametrize("face", ["V", "S"])
def test_bound_map_has_rows_x0_and_columns_theta0(face: str) -> None:
    m = bound_map(face, 1.0, 3.0, n=21)  # type: ignore[arg-type]
    assert m.shape == (21, 21)
    assert m.dtype == np.bool_
    # the aligned start (x0 = 0, theta0 = 0) passes; the ends of the theta axis never do
    assert m[10, 10]
    assert not m[:, 0].any()


def test_v_bound_on_the_symmetric_grid_is_mirror_symmetric() -> None:
    for h in PAPER_H_OVER_D:
        for r in PAPER_R_P:
            m = bound_map("V", h, r, theta_grid="symmetric")
            assert (m == m[::-1, ::-1]).all(), (h, r)


@pytest.mark.parametrize("face", ["V", "S"])
def test_angle_cut_shrinks_as_the_profile_gets_taller(face: str) -> None:
    theta = theta_grid(kind="paper")
    for r in PAPER_R_P:
        widest = [
            float(np.abs(theta[bound_map(face, h, r).any(axis=0)]).max())  # type: ignore[arg-type]
            for h in PAPER_H_OVER_D
        ]
        assert widest == sorted(widest, reverse=True), r


@pytest.mark.parametrize(("face", "rule"), [("V", V_RULE), ("S", S_RULE)])
def test_no_node_passes_beyond_the_angle_cut(face: str, rule: object) -> None:
    theta = theta_grid(kind="paper")
    for h in PAPER_H_OVER_D:
        cut = math.pi / 2 - math.atan(rule.edge_slope * h)  # type: ignore[attr-defined]
        m = bound_map(face, h, 5.0)  # type: ignore[arg-type]
        assert not m[:, np.abs(theta) >= cut].any()


@pytest.mark.parametrize("face", ["V", "S"])
def test_reach_limits_x0_when_the_pivot_is_on_the_profile(face: str) -> None:
    x0 = x0_grid()
    for h in PAPER_H_OVER_D[:6]:
        m = bound_map(face, h, 0.0)  # type: ignore[arg-type]
        assert not m[np.abs(x0) >= h / 2].any()


@pytest.mark.parametrize(("face", "band_nodes"), [("V", 19), ("S", 13)])
def test_aligned_column_is_the_capture_band(face: str, band_nodes: int) -> None:
    """At theta0 = 0 the tip lands in the mate for |x0| < D/2 (V) or D/3 (S)."""
    for h in PAPER_H_OVER_D:
        m = bound_map(face, h, 10.0)  # type: ignore[arg-type]
        assert int(m[:, 20].sum()) == band_nodes


def test_longer_lever_passes_fewer_nodes_far_from_the_pivot() -> None:
    """Large r_p: the tilted tip lands far off; M falls monotonically from r_p = 2 on."""
    table = bound_table("V")
    assert (np.diff(table[:6, 1:], axis=1) <= 0).all()


@pytest.mark.parametrize("bad", [-0.1, 0.0, math.nan, math.inf, 1e5])
def test_bad_h_over_d_is_rejected(bad: float) -> None:
    with pytest.raises(XfaceValueError, match="h_over_d"):
        bound_map("V", bad, 1.0)


@pytest.mark.parametrize("bad", [-1.0, math.nan, -math.inf])
def test_bad_r_p_is_rejected(bad: float) -> None:
    with pytest.raises(XfaceValueError, match="r_p"):
        bound_m("S", 1.0, bad)


def test_non_numeric_design_is_rejected() -> None:
    with pytest.raises(XfaceValueError, match="real number"):
        bound_map("V", "tall", 1.0)  # type: ignore[arg-type]


def test_bad_value_in_a_table_axis_is_rejected() -> None:
    with pytest.raises(XfaceValueError, match="h_over_d"):
        bound_table("V", h_over_d=[1.0, -2.0])


@pytest.mark.parametrize("face", ["X", "custom", "v", ""])
def test_faces_without_a_closed_form_bound_are_rejected(face: str) -> None:
    with pytest.raises(XfaceValueError, match="face"):
        bound_map(face, 1.0, 1.0)  # type: ignore[arg-type]


def test_bad_grid_arguments_are_rejected() -> None:
    with pytest.raises(XfaceValueError, match="odd integer"):
        bound_map("V", 1.0, 1.0, n=40)
    with pytest.raises(XfaceValueError, match="kind"):
        bound_table("S", theta_grid="fine")  # type: ignore[arg-type]
