"""The node's acceptance atlas over real DDS: built after the warm-up, reported on
/diagnostics, and its margins agree with the exact search."""

from __future__ import annotations

from typing import Any

import pytest

from xface_ros.diagnostics import WARMING_UP_MESSAGE

pytestmark = pytest.mark.ros


def _atlas_state(running: Any, state: str, timeout_s: float = 120.0) -> Any:
    c = running.client

    def says(array: Any) -> bool:
        return any(
            s.name.endswith(": predictor") and c.values(s).get("atlas") == state
            for s in array.status
        )

    return c.diagnostics.wait_for(says, timeout_s=timeout_s)


def test_the_atlas_becomes_ready_on_diagnostics(launch: Any) -> None:
    running = launch()  # margins on: the default
    _atlas_state(running, "ready")


def test_without_margins_no_atlas_is_built(launch: Any) -> None:
    running = launch(compute_margins=False)  # returns once the warm-up is over
    c = running.client
    array = c.diagnostics.wait_for(
        lambda a: any(
            s.name.endswith(": predictor") and s.message != WARMING_UP_MESSAGE for s in a.status
        ),
        timeout_s=60.0,
    )
    status = next(s for s in array.status if s.name.endswith(": predictor"))
    assert c.values(status)["atlas"] == "off"
