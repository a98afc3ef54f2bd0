"""scripts/evidence/pymunk_sampling.py: the pymunk scene's map timed cell by cell (the numbers are
timings, never asserted; the tests check what the script counts)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
sampling = importlib.import_module("pymunk_sampling")


def test_every_cell_is_run_and_split_by_outcome_and_sign() -> None:
    pytest.importorskip("pymunk")
    r = sampling.sample("X", 0.25, 2.0, 5)
    assert r["design"] == "X 0.25/2"
    assert r["map_s"] > 0.0
    assert r["diagonal_estimate_s"] > 0.0
    assert set(r["cell_ms_by_outcome"]) <= {"SEATED", "BAD_MATE", "NO_CONTACT", "OUT_OF_REACH"}
    assert "SEATED" in r["cell_ms_by_outcome"]  # (0, 0) seats
    assert "map / estimate" in sampling.line(r)


def test_the_summary_of_a_hand_made_map() -> None:
    import numpy as np

    x0s, thetas = np.array([-1.0, 0.0, 1.0]), np.array([-0.5, 0.0, 0.5])
    seconds = np.array([[0.001, 0.002, 0.010], [0.002, 0.002, 0.002], [0.010, 0.002, 0.001]])
    outcomes = np.array([["A", "A", "B"], ["A", "A", "A"], ["B", "A", "A"]], dtype=object)
    r = sampling.summarise(seconds, outcomes, x0s, thetas)
    assert r["map_s"] == pytest.approx(0.032)
    assert r["diagonal_estimate_s"] == pytest.approx((0.001 + 0.002 + 0.001) / 3 * 9)
    assert r["cell_ms_by_outcome"] == pytest.approx({"A": 12.0 / 7, "B": 10.0})
    assert r["cell_ms_same_sign"] == pytest.approx(1.0)  # the corners (-,-) and (+,+)
    assert r["cell_ms_opposite_sign"] == pytest.approx(10.0)


def test_an_even_grid_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        sampling.main(["--grid", "4"])
    assert exc.value.code == 2
    assert "--grid must be an odd integer" in capsys.readouterr().err
