"""scripts/bench/map_cost_by_outcome.py: a map's cost per cell by outcome and event count.

Timings are never asserted (they are the script's findings); the tests check that the groups
are the map's own, that every cell of the map is in the printed table, and that bad arguments
end in one usage error.
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
bench = importlib.import_module("map_cost_by_outcome")


def _cells(row: str) -> tuple[str, int, int]:
    fields = [f.strip() for f in row.strip("|").split("|")]
    return fields[0], int(fields[1]), int(fields[2])


def test_groups_are_the_maps_outcomes_and_event_counts() -> None:
    design = xf.v_face(0.5, 1.0)
    table, _ = bench.rows(design, 9, 1, 1, 1)
    X, T = np.meshgrid(xf.x0_grid(9), xf.theta_grid(9), indexing="ij")
    whole = xf.predict_batch(design, X.ravel() * design.width, T.ravel(), threads=1)
    expected = {
        (xf.Outcome(int(o)).name, int(e)): int(((whole.outcome == o) & (whole.events == e)).sum())
        for o, e in zip(whole.outcome.ravel(), whole.events.ravel(), strict=True)
    }
    found = {(name, events): cells for name, events, cells in map(_cells, table)}
    assert found == expected


def test_small_groups_are_left_out() -> None:
    table, _ = bench.rows(xf.v_face(0.5, 1.0), 9, 1, 1, 1_000)
    assert table == []


def test_a_run_prints_every_cell_of_the_map_in_the_table(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["--face", "S", "--h-over-d", "0.5", "--grid", "7", "--repeats", "1", "--tile", "1"]
    assert bench.main([*argv, "--min-cells", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("S 0.5/1, 7 x 7 map:")
    assert tuple(lines[1:3]) == bench.HEADER
    assert sum(_cells(row)[2] for row in lines[3:]) == 49
    shares = [float(row.strip("|").split("|")[-1]) for row in lines[3:]]
    assert all(share >= 0.0 for share in shares)


@pytest.mark.parametrize(
    "argv", [["--grid", "0"], ["--tile", "1000"], ["--h-over-d", "nan"], ["--face", "Q"]]
)
def test_bad_arguments_end_in_one_usage_error(
    argv: list[str], usage_error: Callable[..., str]
) -> None:
    usage_error(bench.main, argv)
