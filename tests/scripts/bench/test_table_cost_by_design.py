"""scripts/bench/table_cost_by_design.py: each design's map time and the shares of a table.

Timings are never asserted (they are the script's findings); the tests check that the shares
add up to the designs' times, that M and the step counts are the maps' own, and that bad
arguments end in one usage error.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import xface_core as xf

ROOT = Path(__file__).resolve().parents[3]

sys.path.insert(0, str(ROOT / "scripts" / "bench"))
bench = importlib.import_module("table_cost_by_design")


def _costs() -> list[object]:
    return [bench.Cost("S", 1.0, 0.0, 0.3, 10), bench.Cost("S", 0.5, 1.0, 0.1, 7),
            bench.Cost("X", 1.0, 0.0, 0.6, 20)]  # fmt: skip


def test_the_shares_of_each_group_add_up_to_its_designs_times() -> None:
    by_rp = bench.shares(_costs(), "r_p")
    found = [(v, round(s, 12), round(f, 12)) for v, s, f in by_rp]
    assert found == [(0.0, 0.9, 0.9), (1.0, 0.1, 0.1)]
    by_face = bench.shares(_costs(), "face")
    assert [v for v, _, _ in by_face] == ["S", "X"]
    assert sum(f for _, _, f in by_face) == pytest.approx(1.0)


def test_a_designs_m_is_its_acceptance_maps() -> None:
    cost = bench.map_cost("V", 0.5, 1.0, 9, 1)
    assert cost.m == xf.acceptance_map(xf.v_face(0.5, 1.0), grid=9, threads=1).M
    assert cost.seconds > 0.0


def test_the_step_counts_are_those_of_the_cells_that_touched() -> None:
    cost = bench.Cost("S", 0.5, 1.0, 0.0, 0)
    steps, rejected = bench.steps_per_touching_cell(cost, 9)
    X, T = np.meshgrid(xf.x0_grid(9), xf.theta_grid(9), indexing="ij")
    whole = xf.predict_batch(xf.s_face(0.5, 1.0), X.ravel(), T.ravel(), threads=1)
    touched = whole.events > 0  # a cell that touched has located its first contact
    assert steps == pytest.approx(whole.steps[touched].mean())
    assert rejected >= 0.0


def test_a_run_prints_the_shares_and_the_costliest_designs(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["--faces", "S", "--h-over-d", "0.5", "--r-p", "0,1", "--grid", "7",
            "--repeats", "1", "--top", "2"]  # fmt: skip
    assert bench.main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith("2 designs, 7 x 7 maps, one thread:")
    rows = [line for line in out.splitlines() if line.startswith("| S 0.5/")]
    assert sorted(row.split("|")[1].strip() for row in rows) == ["S 0.5/0", "S 0.5/1"]
    times = [float(row.split("|")[2]) for row in rows]
    assert times == sorted(times, reverse=True)


@pytest.mark.parametrize(
    "argv",
    [["--grid", "2"], ["--repeats", "0"], ["--faces", "Q"], ["--r-p", "a,b"],
     ["--faces", "X", "--h-over-d", "-1", "--r-p", "1"]],
)  # fmt: skip
def test_bad_arguments_end_in_one_usage_error(
    argv: list[str], usage_error: Callable[..., str]
) -> None:
    usage_error(bench.main, argv)
