"""scripts/evidence/demo_fresh_clone.py's pieces: what a good demo run shows, the busy processes it
always ends, and the venv it never installs into (the whole run takes minutes: the script
itself, docs/ros.md gives its numbers)."""

from __future__ import annotations

import importlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts" / "evidence"))
fresh = importlib.import_module("demo_fresh_clone")

#: The demo's lines of a good run (make demo on a fresh clone; node log lines left out).
GOOD_RUN = """\
xface demo: node ready after 244.3 s (simulator: compiles)
   0.7    +0.0000   +0.000 -> SEATED       accepted        0.0244    160.7
   1.6    +0.0450   +0.800 -> BAD_MATE     will not seat              81.0  descended below
   2.5    +0.1250   +0.000 -> OUT_OF_REACH will not seat               0.2  |x0| exceeds
   3.5    +0.0750   +0.300 -> NO_CONTACT   will not seat               1.4  the faces never
   4.0                        -            invalid       INVALID_INPUT: not_facing: |theta0|
xface demo: planner answer: a plan of 26 poses to the seat
xface demo: node exited with code 0
xface demo: OK
"""


def test_a_good_run_passes_and_each_missing_answer_is_named() -> None:
    assert fresh.check_demo_output(GOOD_RUN) == []
    no_miss = "".join(line for line in GOOD_RUN.splitlines(True) if "NO_CONTACT" not in line)
    assert fresh.check_demo_output(no_miss) == ["no answer showing a miss"]
    no_planner = GOOD_RUN.replace("planner answer: a plan of 26 poses", "planner answer: none")
    assert fresh.check_demo_output(no_planner) == ["no planner answer"]
    failed = GOOD_RUN.replace("xface demo: OK", "xface demo: FAILED: recording does not verify")
    assert fresh.check_demo_output(failed) == ["xface demo: FAILED: recording does not verify"]


def test_the_busy_processes_are_ended_even_when_the_run_fails() -> None:
    started: list[subprocess.Popen[bytes]] = []

    def failing_run() -> None:
        with fresh.busy_processes(2) as busy:
            started.extend(busy)
            assert all(process.poll() is None for process in busy)  # running meanwhile
            raise RuntimeError("make failed")

    with pytest.raises(RuntimeError, match="make failed"):
        failing_run()
    assert [process.returncode for process in started] == [-signal.SIGKILL] * 2  # and reaped


def test_a_venv_make_did_not_install_is_refused_and_an_installed_one_is_left_alone(
    tmp_path: Path,
) -> None:
    clone, venv = tmp_path / "clone", tmp_path / "venv"
    clone.mkdir()
    venv.mkdir()
    (clone / "pyproject.toml").write_text("[project]\n", encoding="utf-8")
    with pytest.raises(ValueError, match="would install into it"):
        fresh.make_arguments(venv, clone)
    (venv / fresh.INSTALL_STAMP).touch()
    assert fresh.make_arguments(venv, clone) == ["make", "demo", f"VENV={venv}"]
    # make compares the two: a pyproject.toml newer than the stamp would reinstall.
    stamp_mtime = os.stat(venv / fresh.INSTALL_STAMP).st_mtime
    assert os.stat(clone / "pyproject.toml").st_mtime < stamp_mtime
    assert fresh.make_arguments(None, clone) == ["make", "demo"]
