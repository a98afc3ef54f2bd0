"""The README's first command: ``python -m xface_ros.demo`` waits for the node to be ready,
shows every kind of answer and the planner's, and leaves a recording that verifies.

The end-to-end run is the short form of ``scripts/evidence/demo_fresh_clone.py`` (which runs ``make
demo`` on a fresh clone beside two busy processes); the waiting is tested against a fake
status source, without a node.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from xface_ros import demo
from xface_ros.demo import EVERY_KIND, wait_until_ready

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
RERUN = Path(sys.executable).with_name("rerun")


def test_demo_shows_every_kind_of_answer_and_the_planners_and_its_recording_verifies(
    ros_domain_id: int, tmp_path: Path
) -> None:
    rrd = tmp_path / "demo.rrd"
    env = dict(
        os.environ, ROS_DOMAIN_ID=str(ros_domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    run = subprocess.run(
        [sys.executable, "-m", "xface_ros.demo", "--rate", "4", "--duration", "60",
         "--record", str(rrd)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    out = run.stdout + run.stderr
    assert run.returncode == 0, out
    assert f"ROS_DOMAIN_ID={ros_domain_id}" in out
    # The answers' clock starts once the node is ready: no answer before that line.
    ready = out.index("node ready after")
    first_answer = re.search(r"-> [A-Z_]+ +(accepted|will not seat)", out)
    assert first_answer is not None, out
    assert ready < first_answer.start(), out
    assert re.search(r"-> SEATED +accepted", out), out
    for outcome in ("BAD_MATE", "OUT_OF_REACH", "NO_CONTACT"):
        assert re.search(rf"-> {outcome} +will not seat", out), out
    assert re.search(r" invalid +INVALID_INPUT: not_facing", out), out
    kinds = re.search(r"every kind of answer: (.*)", out)
    assert kinds is not None, out
    for name in EVERY_KIND.values():
        assert re.search(rf"{name} [1-9]", kinds[1]), out
    assert "missing" not in kinds[1], out
    assert "planner answer: a plan of" in out
    assert "node exited with code 0" in out
    assert re.search(rf"recording {re.escape(str(rrd))} \(\d+ bytes\): verified", out), out
    assert run.stdout.rstrip().endswith("xface demo: OK"), out
    verify = subprocess.run(
        [str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120,
        check=False,
    )  # fmt: skip
    assert verify.returncode == 0, verify.stdout + verify.stderr


class FakeNode:
    """A status source on a fake clock: ``messages[i]`` is the node's predictor message from
    second ``i`` on (None: no /diagnostics yet); the node exits at ``exits_at`` seconds."""

    def __init__(self, messages: list[str | None], exits_at: float = float("inf")) -> None:
        self.messages, self.exits_at = messages, exits_at
        self.now = 0.0
        self.said: list[str] = []

    def message(self) -> str | None:
        return self.messages[min(int(self.now), len(self.messages) - 1)]

    def running(self) -> bool:
        return self.now < self.exits_at

    def sleep(self, seconds: float) -> None:
        self.now += seconds

    def wait(self, timeout_s: float = 600.0) -> str | None:
        return wait_until_ready(
            self.message, self.running, timeout_s=timeout_s, say=self.said.append,
            every_s=5.0, clock=lambda: self.now, sleep=self.sleep,
        )  # fmt: skip


def compiling(done: int, seconds: int) -> str:
    return f"warming up: compiling the simulator ({done}/7, {seconds} s)"


def test_the_demo_waits_while_the_node_warms_up_and_says_how_far_it_has_come() -> None:
    # Its service exists from the first second; ready only once /diagnostics stops warming up.
    node = FakeNode([None, *(compiling(3, s) for s in range(1, 12)), "predicting: last none"])
    assert node.wait() is None
    assert 12.0 <= node.now < 13.0
    assert node.said == [
        f"xface demo:   5 s, the node is {compiling(3, 5)}",
        f"xface demo:  10 s, the node is {compiling(3, 10)}",
    ]


def test_the_demo_stops_waiting_when_the_node_exits() -> None:
    node = FakeNode([None, compiling(1, 1)], exits_at=3.0)
    assert node.wait() == "the node exited before it was ready"


def test_the_demo_gives_up_after_its_bound_and_says_where_the_node_was() -> None:
    node = FakeNode([None, compiling(3, 1)])
    problem = node.wait(timeout_s=30.0)
    assert problem is not None
    assert problem.startswith("the node was not ready within 30 s (warming up: compiling")


#: A stand-in for a node that never exits on SIGINT (ended by SIGKILL after 60 s at most).
IGNORES_SIGINT = """
import signal, time
signal.signal(signal.SIGINT, signal.SIG_IGN)
print("ready", flush=True)
time.sleep(60)
"""


def test_a_node_that_ignores_sigint_is_killed_only_after_the_wait_and_said_to_be(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(demo, "STOP_TIMEOUT_S", 1.0)
    stubborn = subprocess.Popen([sys.executable, "-c", IGNORES_SIGINT], stdout=subprocess.PIPE)
    assert stubborn.stdout is not None
    assert stubborn.stdout.readline() == b"ready\n"  # SIGINT is ignored from here on
    assert demo._stop(stubborn) == (-signal.SIGKILL, True)
    assert "did not exit within 1 s of SIGINT: killing it" in capsys.readouterr().err


def test_a_recording_that_does_not_verify_is_not_presented_as_good(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rrd = tmp_path / "cut.rrd"
    rrd.write_bytes(b"RRF2 and then nothing")  # what a node killed mid-write leaves
    assert demo._check_recording(rrd, killed=True) == ["recording does not verify"]
    out = capsys.readouterr().out
    assert "is NOT good: the node was killed, so it is unfinished; rerun rrd verify failed" in out
    assert "view it with" not in out
