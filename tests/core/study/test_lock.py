"""One writer per study: a second run into the same output is refused with the holder's pid,
by real processes, and the lock dies with its holder (forked workers do not keep it)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

import xface_core as xf
from xface_core.study.run import read_study, run_study
from xface_core.study.space import DesignSpace

ROOT = Path(__file__).resolve().parents[3]

#: Four designs on a 5 x 5 pose grid.
SPACE = DesignSpace(faces=("X", "V"), h_over_d=(0.25,), r_p=(1.0, 2.0))
SWEEP = ["sweep", "--face", "X,V", "--h-over-d", "0.25", "--rp", "1,2", "--grid", "5"]
SWEEP += ["--workers", "1", "--quiet", "--json"]

#: A process that holds the lock of the study at argv[1] by the documented protocol (flock on
#: ``<table>.lock``, its pid and host in it), says so, and waits to be killed.
HOLD = """
import fcntl, os, socket, sys, time
fd = os.open(sys.argv[1] + ".lock", os.O_RDWR | os.O_CREAT)
fcntl.flock(fd, fcntl.LOCK_EX)
os.write(fd, f"{os.getpid()} {socket.gethostname()}\\n".encode())
print("held", flush=True)
time.sleep(600)
"""

#: A sweep (the command line's own main) whose first design waits for the file argv[1]: it
#: holds the study's lock, with a part still to write, until the test lets it go.
PAUSED_SWEEP = """
import sys, time
from pathlib import Path
from xface_core.study import run
real, go = run.evaluate_design, Path(sys.argv[1])
def paused(job):
    Path(str(go) + ".waiting").touch()
    while not go.exists():
        time.sleep(0.01)
    return real(job)
run.evaluate_design = paused
from xface_core.cli import main
sys.exit(main(sys.argv[2:]))
"""


def _python(*argv: str, **kwargs: Any) -> subprocess.Popen[str]:
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return subprocess.Popen(
        [sys.executable, *argv],
        env={**os.environ, "PYTHONPATH": path},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def _wait_for(path: Path, proc: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + 120  # a guard against a hang, not a measurement
    while not path.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.01)


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> Any:
    out = tmp_path_factory.mktemp("clean") / "study.parquet"
    run_study(SPACE, out, grid=5, workers=1)
    return read_study(out, timing=False)


def test_a_study_locked_by_another_process_is_refused_until_that_process_dies(
    tmp_path: Path, clean: Any
) -> None:
    out = tmp_path / "study.parquet"
    holder = _python("-c", HOLD, str(out))
    try:
        assert holder.stdout is not None
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(xf.XfaceValueError) as err:
            run_study(SPACE, out, grid=5, workers=1)
        assert f"another sweep is writing this study (pid {holder.pid})" in str(err.value)
        assert not out.exists()  # refused before anything was written
    finally:
        holder.kill()  # SIGKILL: no clean-up of its own; the kernel drops the lock
        holder.communicate()
    assert run_study(SPACE, out, grid=5, workers=1).computed == len(SPACE)
    assert read_study(out, timing=False).equals(clean)
    assert not out.with_name(out.name + ".lock").exists()  # removed by the run that held it


def test_a_forked_worker_of_a_killed_sweep_does_not_keep_its_lock(tmp_path: Path) -> None:
    out = tmp_path / "study.parquet"
    script = """
import os, signal, sys, time
from xface_core.study.lock import StudyLock
StudyLock(sys.argv[1]).acquire()
child = os.fork()
if child == 0:  # a worker, as a local pool forks them (the test's pipes closed)
    null = os.open(os.devnull, os.O_RDWR)
    os.dup2(null, 1)
    os.dup2(null, 2)
    time.sleep(600)
    os._exit(0)
print(child, flush=True)
os.kill(os.getpid(), signal.SIGKILL)  # the sweep dies; its worker lives on
"""
    sweep = _python("-c", script, str(out))
    stdout, stderr = sweep.communicate(timeout=120)
    assert stdout.strip().isdigit(), stderr
    worker = int(stdout)
    try:
        os.kill(worker, 0)  # still alive
        assert run_study(SPACE, out, grid=5, workers=1).computed == len(SPACE)
    finally:
        os.kill(worker, signal.SIGKILL)


def test_two_sweeps_into_one_out_at_once_one_is_refused_and_the_other_finishes(
    tmp_path: Path, clean: Any
) -> None:
    out, go = tmp_path / "study.parquet", tmp_path / "go"
    first = _python("-c", PAUSED_SWEEP, str(go), *SWEEP, "--out", str(out))
    try:
        _wait_for(Path(f"{go}.waiting"), first)  # inside its first design, the study locked
        second = _python("-m", "xface_core.cli", *SWEEP, "--out", str(out))
        _, err = second.communicate(timeout=120)
        assert second.returncode == 2
        assert err.startswith("xface: error: "), err
        assert err.count("\n") == 1, err
        assert f"another sweep is writing this study (pid {first.pid})" in err
    finally:
        go.touch()
        stdout, stderr = first.communicate(timeout=120)
    assert first.returncode == 0, stderr
    assert json.loads(stdout)["computed"] == len(SPACE)
    assert read_study(out, timing=False).equals(clean)
