"""scripts/bench/bench_optimize.py times the face search on 1 and 2 workers and checks that both
find the same faces (a bench of a search that did not reproduce would time two searches)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "bench" / "bench_optimize.py"


def test_the_bench_reports_the_speed_up_of_two_workers() -> None:
    args = ["--grid", "7", "--budget", "12", "--repeats", "1", "--vertices", "2"]
    run = subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr
    assert "speed-up of 2 workers:" in run.stdout
    assert "faces simulated per run" in run.stdout
