"""Every reproducer of issue 37's range probe (``../shared/repro/engine_range.py``) as a test.

Outside the verified range (H/D or r_p above :data:`~xface_core.geometry.MAX_DESIGN_RATIO`) the
design is now refused with an error that states the limit; inside it each run must pass the
issue's bar (no interpenetration beyond 1e-6 D along the path, no UNRESOLVED, a mirror-symmetric
design's mirror pair equal, a map filled by symmetry equal to its simulation), checked by the
probe's own code (scripts/evidence/range_probe.py). Reproducers inside the range that still fail
are engine defects, marked ``xfail(strict=True)``: fixing the engine turns them into failures
that say to drop the mark. The seeded probe itself runs small here, within the accepted range.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from xface_core import Outcome
from xface_core.cli import main
from xface_core.errors import XfaceValueError
from xface_core.geometry import MAX_DESIGN_RATIO

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
range_probe = importlib.import_module("range_probe")
Run: Any = range_probe.Run

ENGINE_DEFECT = "engine defect inside the verified range (issue 37): "

#: Why each reproducer inside the range still fails, by its "defect" key in the data file.
DEFECTS: dict[str, str] = {}


def _reproducers(group: str) -> list[Any]:
    """The runs of ``range_reproducers.json`` in ``group`` ("refused": beyond the range, built-in
    designs whose H/D is above 50; "inside": within it), engine defects marked xfail."""
    params = []
    for row in json.loads(DATA.read_text()):
        if row["group"] != group:
            continue
        run = Run(**{k: math.inf if v == "inf" else v for k, v in row["run"].items()})
        marks = []
        if row["defect"]:
            reason = ENGINE_DEFECT + DEFECTS[row["defect"]]
            marks.append(pytest.mark.xfail(strict=True, reason=reason))
        params.append(pytest.param(run, id=row["id"], marks=marks))
    return params


#: Each reproducer with where it was found: issue 37's engine_range.py (ids "N-class-kind"),
#: then runs the probe found inside the range when run over the old one (seed 1 at 1b73aaf) and
#: over the new one (seeds 2, 4 and 5, and 7 with custom faces only), ids
#: "probe-N-class-kind".
DATA = Path(__file__).with_name("range_reproducers.json")
REFUSED = _reproducers("refused")
INSIDE = _reproducers("inside")


@pytest.mark.parametrize("run", REFUSED)
def test_a_reproducer_beyond_the_verified_range_is_refused_with_its_limit(run: Any) -> None:
    with pytest.raises(XfaceValueError, match=r"h_over_d must be <= 50 \(the range the engine"):
        run.design()


@pytest.mark.parametrize("run", INSIDE)
def test_a_reproducer_inside_the_verified_range_passes_the_bar(run: Any) -> None:
    assert range_probe.check_run(run) == []


def test_the_seeded_probe_over_the_accepted_range_is_clean(tmp_path: Path) -> None:
    """200 seeded runs over everything FaceDesign and Physics accept (the CI-sized probe)."""
    out = tmp_path / "findings.json"
    args = ["--runs", "200", "--seed", "37", "--timeout", "120", "--json", str(out)]
    assert range_probe.main(args) == 0
    assert json.loads(out.read_text()) == []


def test_the_probe_exits_1_and_writes_each_finding_with_its_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The probe can fail: one run with a finding makes it exit 1 and write that run."""

    def one_finding(run: Any) -> list[tuple[str, str]]:
        return [("overlap", "planted")] if run.index == 1 else []

    monkeypatch.setattr(range_probe, "check_run", one_finding)  # forked workers inherit it
    out = tmp_path / "findings.json"
    assert range_probe.main(["--runs", "3", "--seed", "0", "--json", str(out)]) == 1
    (row,) = json.loads(out.read_text())
    assert row["run"]["index"] == 1
    assert row["findings"] == [["overlap", "planted"]]


def test_the_overlap_depth_is_the_deepest_vertex_or_the_crossing_thickness() -> None:
    square = np.array([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)])
    pushed_in = square / 2 + np.array([0.25, 0.9])  # two vertices 0.1 inside the square
    assert range_probe.overlap_depth(square, pushed_in) == pytest.approx(0.1)
    touching = square / 2 + np.array([0.25, 1.0])
    assert range_probe.overlap_depth(square, touching) == 0.0
    # A plus sign: no vertex of either bar inside the other, a 0.2 x 0.2 overlap.
    bar = np.array([(-1.0, -0.1), (1.0, -0.1), (1.0, 0.1), (-1.0, 0.1)])
    assert range_probe.overlap_depth(bar, bar[:, ::-1]) == pytest.approx(0.1, rel=0.02)


def test_predict_answers_at_the_largest_accepted_design(capsys: pytest.CaptureFixture[str]) -> None:
    limit = f"{MAX_DESIGN_RATIO:g}"
    argv = ["predict", "--face", "X", "--h-over-d", limit, "--rp", limit]
    assert main([*argv, "--x0", "0.5", "--theta0", "0.3", "--json"]) == 0
    outcome = json.loads(capsys.readouterr().out)["outcome"]
    assert outcome in {o.name for o in Outcome} - {"UNRESOLVED"}


def test_predict_beyond_the_largest_accepted_design_is_refused_with_its_limit(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["predict", "--face", "X", "--h-over-d", "10000", "--rp", "10000"]
    assert main([*argv, "--x0", "0.5", "--theta0", "0.3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    expected = (
        "xface: error: h_over_d must be <= 50 (the range the engine is verified over; "
        "docs/model.md, Range), got 10000.0"
    )
    assert err == [expected]
