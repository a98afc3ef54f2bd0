"""The README's first command: ``python -m xface_ros.demo`` shows predictions and exits 0."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def test_demo_shows_accepted_and_rejected_predictions_and_records(
    ros_domain_id: int, tmp_path: Path
) -> None:
    rrd = tmp_path / "demo.rrd"
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id))
    run = subprocess.run(
        [sys.executable, "-m", "xface_ros.demo", "--duration", "5", "--record", str(rrd)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    out = run.stdout + run.stderr
    assert run.returncode == 0, out
    assert f"ROS_DOMAIN_ID={ros_domain_id}" in out
    assert re.search(r"-> SEATED +accepted", out), out
    assert re.search(r"-> (BAD_MATE|OUT_OF_REACH|NO_CONTACT) +will not seat", out), out
    assert re.search(r" invalid +INVALID_INPUT: not_facing", out), out
    assert "planner answer: a plan of" in out
    summary = re.search(r"(\d+) predictions \((\d+) accepted, (\d+) will not seat\)", out)
    assert summary is not None, out
    assert int(summary[2]) > 0
    assert int(summary[3]) > 0
    assert "node exited with code 0" in out
    assert rrd.stat().st_size > 0
