"""The typed interface over real DDS: ``predict_dock`` (xface_msgs/srv/PredictDock) and
``prediction/result`` (xface_msgs/msg/DockPrediction).

A client's answer equals :func:`xface_core.predict.predict` for the X, V and S faces and a face
file; a streamed pose's DockPrediction says what its status says; a covariance in the request
gives the seat probability the covariance topic gives; a bad requirement is answered as
refused. Without the built package the node runs without them and says how to build it.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped

import xface_core as xf
from xface_core.atlas.margins import ANGLE_RESOLUTION, LATERAL_RESOLUTION
from xface_core.codes import Outcome
from xface_core.frames import PlanarPose, planar_yaw, relative_pose_to_start, wrap_angle
from xface_core.geometry import make_face
from xface_ros.conversions import typed_interface_problem

pytestmark = pytest.mark.ros

needs_xface_msgs = pytest.mark.skipif(
    typed_interface_problem() is not None, reason=str(typed_interface_problem())
)

WIDTH = 0.05  # config/xface.yaml
Y_START = 3.0 * WIDTH
#: (x0 / D, theta0): seats, seats, jams (X), out of reach, misses the base, mirror side.
POSES = [(0.0, 0.0), (0.3, 0.2), (0.9, 0.8), (2.5, 0.0), (1.5, 0.3), (-0.4, -0.3)]
#: A lopsided notch of the user's own (as tests/ros/test_node_custom_face.py), D = 4 cm.
FILE_WIDTH = 0.04
BASE = [(-0.5, -1.0), (0.5, -1.0), (0.5, 1.3), (0.1, 1.0), (-0.5, 1.3)]
MOVING = [(-0.5, -1.0), (0.5, -1.0), (0.5, 1.0), (-0.1, 1.3), (-0.5, 1.0)]


def dock_client(client: Any) -> Any:
    from xface_msgs.srv import PredictDock

    return client.node.create_client(PredictDock, "predict_dock")


def call_dock(client: Any, start: PoseStamped, **fields: Any) -> Any:
    """``predict_dock`` for ``start``; ``fields`` are the request's other fields."""
    from xface_msgs.srv import PredictDock

    dock = getattr(client, "_dock_client", None) or dock_client(client)
    client._dock_client = dock
    return client.call(dock, PredictDock.Request(start=start, **fields), resend_s=5.0)


def subscribe_results(client: Any) -> Any:
    """An inbox (tests/ros/conftest.py) of the node's ``prediction/result``."""
    from xface_msgs.msg import DockPrediction

    return client._inbox(DockPrediction, "prediction/result", 100)


def start_of(msg: PoseStamped) -> Any:
    o = msg.pose.orientation
    planar = PlanarPose(msg.pose.position.x, msg.pose.position.y, planar_yaw(o.x, o.y, o.z, o.w))
    return relative_pose_to_start(planar)


def assert_equals_core(got: Any, path: Any, expected: xf.Prediction, width: float) -> None:
    assert (got.outcome, got.outcome_name) == (int(expected.outcome), expected.outcome.name)
    assert got.seated == expected.seated
    assert got.accepted == expected.seated  # min_margin 0: every seat is accepted
    assert got.input_error == ""
    assert (got.x0, got.theta0) == (expected.x0, expected.theta0)
    assert expected.margins is not None
    # Margins are defined to the search's resolution (tests/ros/test_node.py says why).
    lateral, angle = LATERAL_RESOLUTION * width, ANGLE_RESOLUTION
    m = expected.margins
    assert got.margin_lateral_minus == pytest.approx(m.lateral_minus, abs=lateral)
    assert got.margin_lateral_plus == pytest.approx(m.lateral_plus, abs=lateral)
    assert got.margin_angle_minus == pytest.approx(m.angle_minus, abs=angle)
    assert got.margin_angle_plus == pytest.approx(m.angle_plus, abs=angle)
    assert got.margin == pytest.approx(
        min(m.lateral, m.angle * width), abs=max(lateral, angle * width)
    )
    assert math.isnan(got.seat_probability)  # no covariance
    assert math.isnan(got.suggested_dx)
    assert got.width == width
    assert got.compute_time > 0.0
    assert (len(path.poses) > 0) == expected.seated
    if expected.seated:
        assert path.poses[-1].pose.position.y == pytest.approx(expected.pivot_m[1], abs=1e-12)


@needs_xface_msgs
@pytest.mark.parametrize("face", ["X", "V", "S", "file"])
def test_predict_dock_answers_what_the_core_predicts(
    launch: Any, tmp_path: Path, face: str
) -> None:
    if face == "file":
        design = xf.custom_face([BASE], [MOVING], mated_distance=2.3, width=FILE_WIDTH)
        path = xf.save_face(design, tmp_path / "my_connector.yaml", name="lopsided notch")
        running = launch(face="custom", face_file=str(path))
        design, width, poses = xf.load_face(path), FILE_WIDTH, [(0.2, -0.3), (0.3, 0.25)]
    else:
        running = launch(face=face)
        design, width, poses = make_face(face, 0.25, 1.0, width=WIDTH), WIDTH, POSES
    c = running.client
    outcomes = set()
    for x0_widths, theta0 in poses:
        start = c.pose_msg(x0_widths * width, 3.0 * width, wrap_angle(theta0 + math.pi))
        response = call_dock(c, start)
        s = start_of(start)
        expected = xf.predict(design, s.x0, s.theta0, y_start=s.y_start, margins=True)
        got = response.prediction
        assert_equals_core(got, response.path, expected, width)
        assert c.stamp_ns(got.header.stamp) == c.stamp_ns(start.header.stamp)
        assert got.header.frame_id == "xface_base"
        assert got.face_kind == ("custom" if face == "file" else face)
        if face == "file":
            assert got.face_name == "lopsided notch"
            assert math.isnan(got.h_over_d)
        outcomes.add(expected.seated)
    assert outcomes == {True, False}  # both answers were asked for


@needs_xface_msgs
def test_a_streamed_pose_has_a_dock_prediction_matching_its_status(launch: Any) -> None:
    running = launch()
    c = running.client
    results = subscribe_results(c)
    for x0_widths, theta0 in [(0.3, 0.2), (0.9, 0.8)]:
        yaw = wrap_angle(theta0 + math.pi)
        sent, status = c.publish_until_status(
            lambda x=x0_widths, y=yaw: c.pose_msg(x * WIDTH, Y_START, y)
        )
        sent_ns = c.stamp_ns(sent.header.stamp)
        got = results.wait_for(lambda r, ns=sent_ns: c.stamp_ns(r.header.stamp) == ns)
        v = c.values(status)
        assert status.message == f"{got.outcome_name}: {got.reason}"
        assert (got.outcome, got.outcome_name) == (int(v["outcome_code"]), v["outcome"])
        assert got.accepted == (v["accepted"] == "true")
        assert (got.x0, got.theta0) == (float(v["x0_m"]), float(v["theta0_rad"]))
        assert got.margin == float(v["margin_m"])
        assert got.margin_lateral_plus == float(v["margin_lateral_plus_m"])
        assert got.margin_angle_minus == float(v["margin_angle_minus_rad"])
        assert got.required_margin == float(v["required_margin_m"])
        assert got.compute_time == pytest.approx(float(v["compute_time_ms"]) * 1e-3, rel=1e-9)
        # An empty start frame is the latest streamed pose: the same answer.
        latest = call_dock(c, PoseStamped()).prediction
        assert (latest.outcome, latest.x0, latest.theta0) == (got.outcome, got.x0, got.theta0)
    # A rejected pose: INVALID_INPUT with its input error, as on the status.
    sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, Y_START, 0.0))
    sent_ns = c.stamp_ns(sent.header.stamp)
    got = results.wait_for(lambda r: c.stamp_ns(r.header.stamp) == sent_ns)
    assert (got.outcome, got.input_error) == (Outcome.INVALID_INPUT, "not_facing")
    assert got.input_error == c.values(status)["input_error"]
    assert status.message == f"INVALID_INPUT: {got.input_error}: {got.reason}"


def wait_atlas_ready(running: Any, timeout_s: float = 120.0) -> None:
    c = running.client
    c.diagnostics.wait_for(
        lambda array: any(
            s.name.endswith(": predictor") and c.values(s).get("atlas") == "ready"
            for s in array.status
        ),
        timeout_s=timeout_s,
    )


@needs_xface_msgs
def test_a_covariance_request_gives_the_seat_probability_of_the_covariance_topic(
    launch: Any,
) -> None:
    running = launch(compute_margins=False)
    wait_atlas_ready(running)
    c = running.client
    pub = c.node.create_publisher(PoseWithCovarianceStamped, "relative_pose_with_covariance", 10)
    cov = [0.0] * 36
    cov[0], cov[35] = 0.002**2, 0.1**2  # sigma 2 mm and 0.1 rad
    deadline = time.monotonic() + 60.0
    while True:  # best effort: send until a status with a probability comes for the pose sent
        plain = c.pose_msg(0.3 * WIDTH, Y_START, wrap_angle(0.2 + math.pi))
        msg = PoseWithCovarianceStamped(header=plain.header)
        msg.pose.pose, msg.pose.covariance = plain.pose, cov
        pub.publish(msg)
        ns = str(c.stamp_ns(plain.header.stamp))
        try:
            status = c.status.wait_for(
                lambda s, ns=ns: (
                    c.values(s).get("input_stamp_ns") == ns and "seat_probability" in c.values(s)
                ),
                2.0,
            )
            break
        except TimeoutError:
            assert time.monotonic() < deadline, "no status with a seat probability"
    topic_p = float(c.values(status)["seat_probability"])
    assert 0.0 < topic_p < 1.0

    # The same pose and covariance asked of predict_dock: the same atlas and the same reading
    # of it (the covariance path of decision.py), so the same number.
    got = call_dock(c, plain, has_covariance=True, covariance=cov).prediction
    assert got.seat_probability == topic_p
    assert got.accepted  # it seats and no probability was required
    # Required above it: not accepted, with the correction that reaches it.
    level = (1.0 + topic_p) / 2.0
    strict = call_dock(
        c, plain, has_covariance=True, covariance=cov, required_probability=level
    ).prediction
    assert strict.seat_probability == topic_p
    assert strict.required_probability == level
    assert strict.seated
    assert not strict.accepted
    assert f"seat probability {topic_p:.3g} < required {level:.3g}" in strict.reason
    assert math.isfinite(strict.suggested_dx)
    # Without a covariance there is no probability.
    assert math.isnan(call_dock(c, plain).prediction.seat_probability)


@needs_xface_msgs
def test_a_bad_requirement_is_answered_as_refused_and_the_node_keeps_answering(
    launch: Any,
) -> None:
    running = launch(compute_margins=False)
    c = running.client
    start = c.pose_msg(0.0, Y_START, math.pi)
    for fields, code in [
        ({"required_margin": -0.001}, "bad_required_margin"),
        ({"required_margin": math.nan}, "bad_required_margin"),
        ({"required_margin": math.inf}, "bad_required_margin"),
        ({"required_probability": 1.5}, "bad_required_probability"),
        ({"required_probability": -0.1}, "bad_required_probability"),
    ]:
        response = call_dock(c, start, **fields)
        got = response.prediction
        assert (got.outcome, got.input_error) == (Outcome.INVALID_INPUT, code), fields
        assert not got.accepted
        assert response.path.poses == []
    assert running.node.process.poll() is None
    good = call_dock(c, start, required_margin=1e-9)
    assert good.prediction.accepted
    assert good.prediction.required_margin == 1e-9
    assert len(good.path.poses) > 0
    # Every call counted with the other services' on /diagnostics.
    c.diagnostics.wait_for(
        lambda array: any(
            s.name.endswith(": predictor") and int(c.values(s)["service_calls_total"]) >= 6
            for s in array.status
        )
    )


def test_without_xface_msgs_the_node_runs_and_says_how_to_build_it(
    launch: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A package of that name that cannot be imported hides the built one (as for a user who
    # pip-installed without `make msgs`).
    hidden = tmp_path / "hide" / "xface_msgs"
    hidden.mkdir(parents=True)
    (hidden / "__init__.py").write_text("raise ImportError('hidden by the test')\n")
    root = Path(__file__).resolve().parents[2]
    monkeypatch.setenv("PYTHONPATH", f"{hidden.parent}:{root}")
    running = launch(compute_margins=False)
    c = running.client
    _sent, status = c.publish_until_status(lambda: c.pose_msg(0.0, Y_START, math.pi))
    assert status.message.startswith("SEATED: ")
    assert len(c.call_plan(c.pose_msg(0.0, Y_START, math.pi)).poses) > 0
    log = running.node.log()
    assert log.count("scripts/build_msgs.py --prefix") == 1, log
    assert "hidden by the test" in log
    services = dict(c.node.get_service_names_and_types_by_node("xface_predictor", "/"))
    assert "/predict" in services
    assert "/predict_dock" not in services
    topics = dict(c.node.get_publisher_names_and_types_by_node("xface_predictor", "/"))
    assert "/prediction/status" in topics
    assert "/prediction/result" not in topics
