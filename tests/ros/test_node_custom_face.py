"""A connector of the user's own over real DDS: ``face: custom`` with a ``face_file``.

The node's predictions for a face file equal the core's for the same file, and a file the
node cannot use is refused with its reason while the node keeps its design.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import xface_core as xf
from xface_core.frames import PlanarPose, planar_yaw, relative_pose_to_start, wrap_angle

pytestmark = pytest.mark.ros

WIDTH = 0.04  # the file's width: differs from the node's width_m default (0.05)
# A lopsided notch of the user's own: the base a block with a V notch, the moving part a
# block with a tip that fits it (units of D, body frames, profile facing +y).
BASE = [(-0.5, -1.0), (0.5, -1.0), (0.5, 1.3), (0.1, 1.0), (-0.5, 1.3)]
MOVING = [(-0.5, -1.0), (0.5, -1.0), (0.5, 1.0), (-0.1, 1.3), (-0.5, 1.0)]
DESIGN = xf.custom_face([BASE], [MOVING], mated_distance=2.3, width=WIDTH)
Y_START = 3.0 * WIDTH
#: seats after three events; jams (below the seat height) after two.
POSES = [(0.2, -0.3), (0.3, 0.25)]


@pytest.fixture
def face_file(tmp_path: Path) -> Path:
    return xf.save_face(DESIGN, tmp_path / "my_connector.yaml", name="lopsided notch")


@pytest.mark.parametrize(("x0_widths", "theta0"), POSES)
def test_streamed_predictions_for_a_face_file_equal_the_core(
    launch: Any, face_file: Path, x0_widths: float, theta0: float
) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    c = running.client
    yaw = wrap_angle(theta0 + math.pi)
    sent, status = c.publish_until_status(lambda: c.pose_msg(x0_widths * WIDTH, Y_START, yaw))
    o = sent.pose.orientation
    start = relative_pose_to_start(
        PlanarPose(sent.pose.position.x, sent.pose.position.y, planar_yaw(o.x, o.y, o.z, o.w))
    )
    expected = xf.predict(
        xf.load_face(face_file), start.x0, start.theta0, y_start=start.y_start, margins=False
    )
    v = c.values(status)
    assert v["outcome"] == expected.outcome.name
    assert float(v["final_phi_m_rad"]) == pytest.approx(expected.phi_m, abs=1e-12)
    assert float(v["final_y_m"]) == pytest.approx(expected.pivot_m[1], abs=1e-12)
    assert int(v["events"]) == expected.counters.events


def test_a_face_file_that_cannot_be_read_is_refused_and_the_design_kept(
    launch: Any, face_file: Path, tmp_path: Path
) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    results = running.client.set_parameters(face_file=str(tmp_path / "missing.yaml"))
    assert not results[0].successful
    assert "cannot read the face file" in results[0].reason
    assert running.client.get_parameter("face_file") == str(face_file)
