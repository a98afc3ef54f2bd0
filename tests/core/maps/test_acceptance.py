"""Acceptance maps and M tables."""

from __future__ import annotations

import numpy as np
import pytest

import xface_core as xf
from xface_core import Outcome
from xface_core.maps import acceptance
from xface_core.maps.paper import paper_table


@pytest.mark.parametrize(("h", "rp"), [(0.0625, 1.0), (0.5, 2.0), (3.0314, 0.0), (16.0, 5.0)])
def test_x_face_map_is_mirror_symmetric_without_using_symmetry(h: float, rp: float) -> None:
    o = xf.acceptance_map(xf.x_face(h, rp), use_symmetry=False).outcomes
    assert np.array_equal(o, o[::-1, ::-1])


@pytest.mark.parametrize(("h", "rp"), [(0.5, 1.0), (1.0, 3.0), (5.278, 0.0)])
def test_v_face_map_is_mirror_symmetric_without_using_symmetry(h: float, rp: float) -> None:
    o = xf.acceptance_map(xf.v_face(h, rp), use_symmetry=False).outcomes
    assert np.array_equal(o, o[::-1, ::-1])


def test_symmetry_shortcut_gives_the_full_map() -> None:
    design = xf.x_face(0.32988, 1.0)
    fast = xf.acceptance_map(design)
    full = xf.acceptance_map(design, use_symmetry=False)
    assert np.array_equal(fast.outcomes, full.outcomes)


def test_s_face_is_not_treated_as_mirror_symmetric() -> None:
    o = xf.acceptance_map(xf.s_face(0.5, 1.0)).outcomes
    assert not np.array_equal(o, o[::-1, ::-1])


def test_maps_do_not_depend_on_the_unit() -> None:
    maps = [xf.acceptance_map(xf.v_face(0.5, 1.0, width=w)).outcomes for w in (1e-3, 1.0, 1e3)]
    assert np.array_equal(maps[0], maps[1])
    assert np.array_equal(maps[1], maps[2])


def test_map_axes_follow_the_paper_layout() -> None:
    amap = xf.acceptance_map(xf.x_face(0.25, 1.0, width=2.0))
    assert amap.outcomes.shape == (41, 41)
    assert amap.x0[0] == -2.0
    assert amap.x0[-1] == 2.0
    assert amap.theta0[0] == pytest.approx(-np.pi / 2)
    assert amap.theta0[20] == 0.0


def test_m_counts_seated_cells() -> None:
    amap = xf.acceptance_map(xf.s_face(1.0, 2.0))
    assert int((amap.outcomes == Outcome.SEATED).sum()) == amap.M
    assert sum(amap.counts().values()) == 41 * 41


def test_guaranteed_rectangle_is_all_seated_and_maximal_in_area() -> None:
    amap = xf.acceptance_map(xf.x_face(0.5, 1.0))
    rows, cols = amap.guaranteed
    assert (amap.outcomes[rows.start : rows.stop, cols.start : cols.stop] == Outcome.SEATED).all()
    assert len(rows) * len(cols) >= 1
    crow, ccol = amap.centred
    assert crow.start + crow.stop - 1 == 40
    assert ccol.start + ccol.stop - 1 == 40
    assert len(rows) * len(cols) >= len(crow) * len(ccol)


def test_v_bound_table_reproduces_table_iii() -> None:
    t = xf.m_table("V", method="bound", theta_kind="paper")
    assert np.array_equal(t.M, paper_table("V").M.astype(int))


def test_table_does_not_depend_on_worker_count() -> None:
    kw = {"h_over_d": (0.25, 2.0), "r_p": (0.0, 1.0, 4.0), "grid": 21}
    serial = xf.m_table("S", workers=1, **kw)  # type: ignore[arg-type]
    parallel = xf.m_table("S", workers=2, **kw)  # type: ignore[arg-type]
    assert np.array_equal(serial.M, parallel.M)


def test_a_table_starts_no_more_processes_than_designs(monkeypatch: pytest.MonkeyPatch) -> None:
    started: list[int] = []

    class CountedPool(acceptance.ProcessPoolExecutor):
        def __init__(self, max_workers: int, **kw: object) -> None:
            started.append(max_workers)
            super().__init__(max_workers, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(acceptance, "ProcessPoolExecutor", CountedPool)
    kw = {"h_over_d": (0.25, 2.0), "r_p": (1.0,), "grid": 5}
    table = xf.m_table("V", workers=64, **kw)  # type: ignore[arg-type]
    assert started == [2]
    assert np.array_equal(table.M, xf.m_table("V", workers=1, **kw).M)  # type: ignore[arg-type]


@pytest.mark.parametrize("workers", [0, 100_000])
def test_a_table_refuses_a_worker_count_out_of_range(workers: int) -> None:
    with pytest.raises(xf.XfaceValueError, match="workers must be in"):
        xf.m_table("V", h_over_d=(0.25,), r_p=(1.0,), grid=5, workers=workers)


def test_bound_for_x_face_is_refused() -> None:
    with pytest.raises(xf.XfaceValueError):
        xf.m_table("X", method="bound")


@pytest.mark.slow
@pytest.mark.parametrize("face", ["X", "V", "S"])
def test_every_run_of_a_full_table_ends_in_a_decided_outcome(face: str) -> None:
    decided = {
        Outcome.SEATED,
        Outcome.BAD_MATE,
        Outcome.PASSED,
        Outcome.NO_CONTACT,
        Outcome.OUT_OF_REACH,
    }
    for h in xf.PAPER_H_OVER_D:
        for rp in xf.PAPER_R_P:
            amap = xf.acceptance_map(xf.make_face(face, h, rp))
            assert set(np.unique(amap.outcomes).tolist()) <= decided, (face, h, rp)


def test_refined_map_fills_agreeing_cells_and_keeps_coarse_nodes() -> None:
    design = xf.x_face(0.25, 2.0)
    full = xf.acceptance_map(design, grid=81)
    refined = xf.acceptance_map(design, grid=81, coarse=21)
    assert np.array_equal(refined.outcomes[::4, ::4], xf.acceptance_map(design, grid=21).outcomes)
    assert np.array_equal(full.outcomes, refined.outcomes)


@pytest.mark.parametrize("coarse", [2, 4, 41, 13])
def test_refinement_needs_a_dividing_odd_coarse_grid(coarse: int) -> None:
    with pytest.raises(xf.XfaceValueError, match="coarse"):
        xf.acceptance_map(xf.x_face(0.25, 2.0), grid=41, coarse=coarse)


def test_a_map_reports_its_progress_and_the_same_outcomes() -> None:
    design = xf.v_face(0.5, 1.0)
    calls: list[tuple[int, int]] = []
    with_progress = xf.acceptance_map(design, grid=21, progress=lambda d, t: calls.append((d, t)))
    assert np.array_equal(with_progress.outcomes, xf.acceptance_map(design, grid=21).outcomes)
    assert calls[-1][0] == calls[-1][1] > 0


def test_a_table_reports_each_design() -> None:
    calls: list[tuple[int, int]] = []
    xf.m_table("V", h_over_d=[0.25, 0.5], r_p=[1.0], grid=5, workers=1,
               progress=lambda d, t: calls.append((d, t)))  # fmt: skip
    assert calls == [(1, 2), (2, 2)]
