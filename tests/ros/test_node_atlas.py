"""The node's acceptance atlas over real DDS: built after the warm-up, reported on
/diagnostics, and its margins agree with the exact search."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped

from xface_core.frames import wrap_angle

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


def test_a_pose_with_covariance_is_answered_with_its_seat_probability(launch: Any) -> None:
    running = launch(compute_margins=False)
    _atlas_state(running, "ready")
    c = running.client
    pub = c.node.create_publisher(PoseWithCovarianceStamped, "relative_pose_with_covariance", 10)
    width = 0.05  # config/xface.yaml

    def make() -> PoseWithCovarianceStamped:
        # x0 = 0.3 D, theta0 = 0.2 rad, 3 D above the base; sigma 2 mm and 0.1 rad.
        plain = c.pose_msg(0.3 * width, 3.0 * width, wrap_angle(0.2 + math.pi))
        msg = PoseWithCovarianceStamped(header=plain.header)
        msg.pose.pose = plain.pose
        cov = [0.0] * 36
        cov[0], cov[35] = 0.002**2, 0.1**2
        msg.pose.covariance = cov
        return msg

    sent: list[int] = []

    def publish_once() -> Any:
        msg = make()
        sent.append(c.stamp_ns(msg.header.stamp))
        pub.publish(msg)
        return msg

    for _ in range(50):
        publish_once()
        try:
            status = c.status.wait_for(
                lambda s: (
                    "seat_probability" in c.values(s)
                    and c.values(s).get("input_stamp_ns") == str(sent[-1])
                ),
                2.0,
            )
            break
        except TimeoutError:
            continue
    else:
        raise AssertionError("no status with a seat probability")
    p = float(c.values(status)["seat_probability"])
    assert 0.0 <= p <= 1.0


def test_the_cached_atlas_holds_every_grid_line_flip(launch: Any, tmp_path: Any) -> None:
    # The node builds its atlas with every flip bisected, so a planner's first question near
    # a boundary is interpolated, and a restart reads them all from the cache.
    from xface_core.atlas.flips import boundary_segments

    cache = tmp_path / "atlases"
    running = launch(atlas_cache_dir=str(cache))
    _atlas_state(running, "ready")
    assert running.node.stop() == 0
    (path,) = cache.glob("atlas-*.npz")
    with np.load(path) as data:
        segments = boundary_segments(np.asarray(data["outcomes"]))
        assert len(segments) > 0
        assert sorted(map(tuple, data["flip_keys"].tolist())) == sorted(segments)
