"""docs/ros.md's Python examples work when pasted: run against a node, they print answers."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from xface_core.codes import Outcome
from xface_ros.conversions import typed_interface_problem
from xface_ros.decision import ANSWERS

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def example_blocks() -> list[str]:
    """The ```python blocks of the Examples section, in order (they build on each other)."""
    text = (ROOT / "docs" / "ros.md").read_text(encoding="utf-8")
    section = text.split("\n## Examples\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.DOTALL)


def test_examples_print_a_prediction_a_plan_and_its_reason(launch: Any) -> None:
    # Pasted right after starting the node, as a user would. A generous input timeout: on a
    # loaded machine the example's pose reached the node 0.67 s after its stamp, and the
    # node's default 0.5 s then (rightly) called it stale; the docs' examples are what is
    # under test here, not the staleness rule (tests/ros/test_decision.py).
    running = launch(wait=False, input_timeout_s=30.0)
    blocks = example_blocks()
    assert len(blocks) == 3
    typed = typed_interface_problem() is None  # the last example needs xface_msgs
    run = subprocess.run(
        [sys.executable, "-c", "\n".join(blocks if typed else blocks[:2])],
        env=running.env(), capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr + running.node.log()
    lines = run.stdout.strip().splitlines()
    first, plan, why = lines[-4:-1] if typed else lines[-3:]
    assert first.startswith("b'\\x00' SEATED: ")
    assert plan in ("accepted", "rejected")
    assert why.split()[0] in ANSWERS
    if typed:  # the typed answer to the question the plan answered
        outcome, accepted = lines[-1].split()[:2]
        assert outcome in Outcome.__members__
        assert accepted == ("True" if plan == "accepted" else "False")
