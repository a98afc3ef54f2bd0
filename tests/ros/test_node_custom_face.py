"""A connector of the user's own over real DDS: ``face: custom`` with a ``face_file``.

The node's predictions for a face file equal the core's for the same file; the file is read
when ``face`` or ``face_file`` is set, not on another parameter's change; and a file the
node cannot use is refused with its reason while the node keeps its design: at run time also
a hostile one (nested 10,000 deep, a 5,000-digit number, /dev/zero, a FIFO), which once ended
the node or blocked its executor; at start, one line and exit code 2.
"""

from __future__ import annotations

import math
import os
import resource
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

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
    values, expected = streamed_and_core(running, xf.load_face(face_file), (x0_widths, theta0))
    assert_same_prediction(values, expected)
    assert int(values["events"]) == expected.counters.events


def streamed_and_core(
    running: Any,
    face: xf.FaceDesign,
    pose: tuple[float, float] = POSES[0],
    physics: xf.Physics | None = None,
) -> tuple[dict[str, str], xf.Prediction]:
    """Stream ``pose`` (x0 in widths, theta0) and return its status's values and the core's
    prediction for ``face`` from the pose the node received."""
    sent, values = streamed(running, *pose)
    o = sent.pose.orientation
    start = relative_pose_to_start(
        PlanarPose(sent.pose.position.x, sent.pose.position.y, planar_yaw(o.x, o.y, o.z, o.w))
    )
    expected = xf.predict(
        face, start.x0, start.theta0, y_start=start.y_start, physics=physics, margins=False
    )
    return values, expected


def streamed(running: Any, x0_widths: float, theta0: float) -> tuple[Any, dict[str, str]]:
    """Stream a pose; the pose sent and its status's values."""
    c = running.client
    yaw = wrap_angle(theta0 + math.pi)
    sent, status = c.publish_until_status(lambda: c.pose_msg(x0_widths * WIDTH, Y_START, yaw))
    values: dict[str, str] = c.values(status)
    return sent, values


def assert_same_prediction(values: dict[str, str], expected: xf.Prediction) -> None:
    assert values["outcome"] == expected.outcome.name
    assert float(values["final_phi_m_rad"]) == pytest.approx(expected.phi_m, abs=1e-12)
    assert float(values["final_y_m"]) == pytest.approx(expected.pivot_m[1], abs=1e-12)


#: The face file's design edited: the same outline at another width, so that every
#: prediction's final height (m) differs from the file's first design's.
EDITED = xf.custom_face([BASE], [MOVING], mated_distance=2.3, width=1.25 * WIDTH)


def test_a_change_without_geometry_keeps_the_design_when_its_file_is_gone(
    launch: Any, face_file: Path
) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    face_file.unlink()
    results = running.client.set_parameters(friction=0.1)
    assert results[0].successful, results[0].reason
    values, expected = streamed_and_core(running, DESIGN, physics=xf.Physics(friction=0.1))
    assert_same_prediction(values, expected)


def test_a_change_without_geometry_does_not_read_the_edited_file(
    launch: Any, face_file: Path
) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    xf.save_face(EDITED, face_file, name="lopsided notch, wider")
    assert running.client.set_parameters(min_margin=0.001)[0].successful
    values, expected = streamed_and_core(running, DESIGN)
    assert_same_prediction(values, expected)
    edited = xf.predict(EDITED, expected.x0, expected.theta0, y_start=expected.y_start)
    assert float(values["final_y_m"]) != pytest.approx(edited.pivot_m[1], abs=1e-9)


def test_setting_face_file_again_reads_the_edited_file(launch: Any, face_file: Path) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    xf.save_face(EDITED, face_file, name="lopsided notch, wider")
    results = running.client.set_parameters(face_file=str(face_file))
    assert results[0].successful, results[0].reason
    values, expected = streamed_and_core(running, EDITED)
    assert_same_prediction(values, expected)


def test_a_face_file_that_cannot_be_read_is_refused_and_the_design_kept(
    launch: Any, face_file: Path, tmp_path: Path
) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    results = running.client.set_parameters(face_file=str(tmp_path / "missing.yaml"))
    assert not results[0].successful
    assert "cannot read the face file" in results[0].reason
    assert running.client.get_parameter("face_file") == str(face_file)


# --- hostile face files: refused with a reason, never the end of the node -------------------


def hostile_face_files(tmp_path: Path, good: Path) -> dict[str, str]:
    """Face files the node must refuse, by what is wrong with them."""
    deep = tmp_path / "deep.yaml"
    deep.write_text("[" * 10_000 + "]" * 10_000 + "\n", encoding="utf-8")
    wide = tmp_path / "wide.yaml"
    wide.write_text(
        good.read_text(encoding="utf-8").replace(f"width: {WIDTH}", "width: " + "9" * 5000),
        encoding="utf-8",
    )
    assert "9" * 5000 in wide.read_text(encoding="utf-8")
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    return {
        "nested 10,000 deep": str(deep),
        "a 5,000-digit width": str(wide),
        "/dev/zero": "/dev/zero",
        "a FIFO": str(fifo),
        "missing": str(tmp_path / "missing.yaml"),
    }


@pytest.mark.slow
def test_hostile_face_files_at_run_time_are_refused_and_the_node_runs_on_its_design(
    launch: Any, face_file: Path, tmp_path: Path
) -> None:
    running = launch(face="custom", face_file=str(face_file), compute_margins=False)
    c = running.client
    _, before = streamed(running, *POSES[0])
    for what, path in hostile_face_files(tmp_path, face_file).items():
        results = c.set_parameters(face_file=path)
        assert not results[0].successful, what
        assert results[0].reason.startswith("face_file: "), (what, results[0].reason)
        assert c.get_parameter("face_file") == str(face_file), what
        diagnostics_seen = c.diagnostics.count()
        c.diagnostics.wait_for(lambda _msg, n=diagnostics_seen: c.diagnostics.count() > n)
        _, after = streamed(running, *POSES[0])  # the old design's prediction
        assert after["outcome"] == before["outcome"], what
        assert after["final_phi_m_rad"] == before["final_phi_m_rad"], what
        assert after["final_y_m"] == before["final_y_m"], what
    assert c.set_parameters(min_margin=0.001)[0].successful  # parameters still work
    assert running.node.log().count("parameter change refused: face_file: ") == 5
    assert running.node.stop() == 0


@pytest.mark.parametrize(
    "what", ["nested 10,000 deep", "a 5,000-digit width", "/dev/zero", "a FIFO", "missing"]
)
def test_a_hostile_face_file_at_start_is_one_line_and_exit_code_2(
    what: str, face_file: Path, tmp_path: Path, ros_domain_id: int
) -> None:
    path = hostile_face_files(tmp_path, face_file)[what]
    params = tmp_path / "params.yaml"
    overrides = {"face": "custom", "face_file": path}
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": overrides}}), encoding="utf-8")
    # The suite's conftest put discovery on loopback in os.environ; the domain is this test's.
    env = {**os.environ, "ROS_DOMAIN_ID": str(ros_domain_id)}
    run = subprocess.run(
        [sys.executable, "-m", "xface_ros", "--ros-args", "--params-file", str(params)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120, check=False,
        preexec_fn=limit_memory,
    )  # fmt: skip
    assert run.returncode == 2, run.stderr
    assert len(run.stderr.splitlines()) == 1, run.stderr
    assert run.stderr.startswith("xface_predictor: refusing to start: face_file: "), run.stderr


def limit_memory() -> None:
    """In the node's process: at most 4 GiB of address space (it needs about 1.2), so a node
    that reads /dev/zero fails soon instead of filling the machine's memory."""
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def test_the_node_describes_a_face_file_by_its_name(face_file: Path) -> None:
    from xface_ros.config import SPECS, config_from_values
    from xface_ros.node import XfacePredictor

    values = {spec.name: spec.default for spec in SPECS}
    config = config_from_values({**values, "face": "custom", "face_file": str(face_file)})
    text = XfacePredictor._describe(config)
    assert text.startswith(f"custom face 'lopsided notch' ({face_file}) D=")
