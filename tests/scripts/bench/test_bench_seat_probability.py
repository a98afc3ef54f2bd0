"""scripts/bench/bench_seat_probability.py: the seat probability's run time against error.

Timings and errors are never asserted (they are the script's findings, docs/atlas.md); the
tests check that the queries straddle, that the counters count and are taken out again, and
that a small run prints a row for every setting.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

import xface_core as xf
from xface_core.atlas import probability
from xface_core.atlas.build import build_atlas

ROOT = Path(__file__).resolve().parents[3]


sys.path.insert(0, str(ROOT / "scripts" / "bench"))
bench = importlib.import_module("bench_seat_probability")


def test_queries_lie_near_seated_nodes_with_valid_covariances() -> None:
    atlas = build_atlas(xf.v_face(0.5, 1.0), lateral_step=1 / 16, angle_step=0.05)
    rng = np.random.default_rng(1)
    for x0, theta0, cov in bench.straddling_queries(atlas, 5, rng):
        assert np.allclose(cov, cov.T)
        assert np.all(np.linalg.eigvalsh(cov) >= 0.0)
        i = int(np.argmin(np.abs(atlas.x0 - x0)))
        k = int(np.argmin(np.abs(atlas.theta0 - theta0)))
        near = atlas.outcomes[max(i - 4, 0) : i + 5, max(k - 4, 0) : k + 5]
        assert (near == xf.Outcome.SEATED).any()


def test_counting_counts_rays() -> None:
    counter = bench.Counting()
    design = xf.v_face(0.5, 1.0)
    atlas = build_atlas(design, lateral_step=1 / 16, angle_step=0.05)
    counter.masses(atlas, (0.0, 0.0), np.eye(2) * 0.01, True, np.zeros(4), 8, 2, "exact")
    assert counter.rays == 4


@pytest.mark.slow
def test_a_small_run_prints_every_setting_and_restores_the_module(
    capsys: pytest.CaptureFixture[str],
) -> None:
    before = probability._ray_masses
    assert bench.main(["--queries", "1"]) == 0
    out = capsys.readouterr().out
    assert probability._ray_masses is before
    rows = [line for line in out.splitlines() if line.startswith("| ") and "even" in line]
    assert len(rows) == len(bench.RAYS) * len(bench.STEPS)
    adaptive = [line for line in out.splitlines() if line.startswith("| adaptive")]
    assert sum("| exact |" in line for line in adaptive) == len(bench.RAY_TOLS)
    assert sum("| atlas |" in line for line in adaptive) == len(bench.RAY_TOLS) * len(
        bench.ATLAS_STEPS
    )
    assert f"largest error at {bench.DEFAULT}" in out
    assert f"largest error at {bench.NODE}" in out


@pytest.mark.slow
def test_suggest_prints_one_line_per_design(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(bench, "DESIGNS", [("V", 0.5, 1.0)])
    assert bench.main(["--suggest", "--queries", "3", "--seed", "2"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("V 0.5/1: suggest_approach over 3 queries: median ")
