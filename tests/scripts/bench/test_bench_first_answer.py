"""scripts/bench/bench_first_answer.py times ``xface predict`` from fresh interpreters, as
installed and with numba's full context refresh first, and reports both side by side."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "bench" / "bench_first_answer.py"


def _bench(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300
    )


def test_the_report_gives_both_variants_for_each_design(tmp_path: Path) -> None:
    out = tmp_path / "first.md"
    run = _bench("--repeats", "1", "--out", str(out))
    assert run.returncode == 0, run.stdout + run.stderr
    rows = [line for line in out.read_text().splitlines() if line.startswith("| largest")]
    rows += [line for line in out.read_text().splitlines() if line.startswith("| small")]
    assert len(rows) == 2
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        lean, refreshed, ratio = (float(c.split()[0]) for c in cells[1:])
        assert lean > 0.0
        assert refreshed > 0.0
        assert abs(ratio - lean / refreshed) < 5e-3  # the medians are printed to 1 ms
    assert out.read_text() == run.stdout


def test_an_unwritable_out_is_one_line_and_exit_1(tmp_path: Path) -> None:
    run = _bench("--repeats", "1", "--out", str(tmp_path / "no" / "such" / "dir" / "f.md"))
    assert run.returncode == 1
    assert "bench_first_answer: cannot write" in run.stdout
    assert "Traceback" not in run.stdout + run.stderr


def test_no_repeats_is_a_usage_error() -> None:
    run = _bench("--repeats", "0")
    assert run.returncode == 2
    assert "--repeats must be at least 1" in run.stderr
