"""scripts/evidence/face_search_check.py scores a search's best face and the X-Face on grids the
search never saw (a finer one and the paper's theta grid)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from xface_core.cli import main

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "evidence" / "face_search_check.py"


def test_the_check_scores_both_faces_on_three_grids(tmp_path: Path) -> None:
    out = tmp_path / "search"
    small = ["--grid", "7", "--budget", "6", "--popsize", "6", "--workers", "1"]
    assert main(["optimize", *small, "--out", str(out), "--no-crosscheck", "--quiet"]) == 0
    run = subprocess.run(
        [sys.executable, str(SCRIPT), str(out)], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0].startswith(f"{out}: optimized profile")
    assert [line.split(":")[0].strip() for line in lines[1:]] == [
        "7 x 7 (symmetric)",
        "81 x 81 (symmetric)",
        "41 x 41 (paper)",
    ]
    assert all("X-Face" in line and "gain" in line for line in lines[1:])
