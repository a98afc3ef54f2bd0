"""The node started under another namespace and name: the shipped params file still applies.

``config/xface.yaml`` is keyed ``/**``, so it reaches the node however it is remapped; a file
keyed for another node name reaches nothing, and the node says so at startup.
"""

from __future__ import annotations

from typing import Any

import pytest

from xface_ros.config import SPEC_BY_NAME

pytestmark = pytest.mark.ros

REMAP = ["-r", "__ns:=/left", "-r", "__node:=dock_left"]
FQN = "/left/dock_left"
#: Differs from the built-in default, so only the file can have set it.
WIDTH_FROM_FILE = 0.08


def test_remapped_node_takes_the_files_values(launch: Any) -> None:
    running = launch(extra_args=REMAP, node_fqn=FQN, width_m=WIDTH_FROM_FILE, compute_margins=False)
    assert running.client.get_parameter("width_m") == pytest.approx(WIDTH_FROM_FILE)


def test_remapped_node_names_itself_on_diagnostics(launch: Any) -> None:
    running = launch(extra_args=REMAP, node_fqn=FQN, width_m=WIDTH_FROM_FILE, compute_margins=False)
    c = running.client
    array = c.diagnostics.wait_for(
        lambda a: any(s.name == f"{FQN}: predictor" for s in a.status), timeout_s=30.0
    )
    status = next(s for s in array.status if s.name == f"{FQN}: predictor")
    assert float(c.values(status)["width_m"]) == pytest.approx(WIDTH_FROM_FILE)


def test_params_file_for_another_node_name_is_reported(launch: Any) -> None:
    running = launch(
        extra_args=REMAP, node_fqn=FQN, params_key="xface_predictor", compute_margins=False
    )
    assert running.client.get_parameter("width_m") == SPEC_BY_NAME["width_m"].default
    assert "sets none of this node's parameters" in running.node.log()
