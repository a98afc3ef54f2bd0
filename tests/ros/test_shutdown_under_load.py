"""SIGINT and SIGTERM while a 1 kHz pose stream runs: exit code 0, a finished recording.

Each round starts a recording node, streams poses at 1 kHz from a client thread until the
node has predicted some of them, signals it mid-stream and checks its exit code and that
``rerun rrd verify`` accepts the recording. A signal that lands while the executor waits, takes
a message or runs a callback must all end the same way.
"""

from __future__ import annotations

import random
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]

WIDTH = 0.05
ROUNDS = 12  # half SIGINT, half SIGTERM
RATE_HZ = 1000.0


def rerun_cli() -> str:
    """The ``rerun`` CLI of this environment (it ships in the rerun-sdk wheel)."""
    beside = Path(sys.executable).with_name("rerun")
    found = str(beside) if beside.exists() else shutil.which("rerun")
    if found is None:
        pytest.skip("the rerun CLI (rerun-sdk, viz extra) is not installed")
    return found


class Stream:
    """Publishes fresh poses at ``RATE_HZ`` from its own thread until stopped."""

    def __init__(self, client: Any) -> None:
        self._client = client
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.sent = 0

    def _run(self) -> None:
        period = 1.0 / RATE_HZ
        next_t = time.perf_counter()
        while not self._stop.is_set():
            self._client.pose_pub.publish(self._client.pose_msg(0.3 * WIDTH, 3 * WIDTH, 3.34))
            self.sent += 1
            next_t += period
            delay = next_t - time.perf_counter()
            if delay > 0:
                time.sleep(delay)

    def __enter__(self) -> Stream:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=10.0)


@pytest.mark.parametrize("round_", range(ROUNDS))
def test_signal_under_a_1khz_stream_exits_zero_with_a_valid_recording(
    launch: Any, tmp_path: Path, round_: int
) -> None:
    sig = signal.SIGINT if round_ % 2 == 0 else signal.SIGTERM
    rrd = tmp_path / "run.rrd"
    running = launch(record=True, record_path=str(rrd))
    c = running.client
    with Stream(c):
        # Wait until the node is busy predicting the stream (statuses come back).
        c.status.wait_for(lambda s: c.values(s).get("outcome") == "SEATED")
        # Signal at a different phase of the executor's work each round (seeded: reproducible).
        time.sleep(random.Random(round_).uniform(0.0, 0.5))
        code = running.node.stop(sig)
    assert code == 0, running.node.log()
    verify = subprocess.run(
        [rerun_cli(), "rrd", "verify", str(rrd)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert verify.returncode == 0, verify.stdout + verify.stderr
