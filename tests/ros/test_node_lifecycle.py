"""The node's parameters at startup and at run time, its signals and its recording.

Each test starts a node process of its own (separate ROS domain) through the ``launch``
fixture of tests/ros/conftest.py.
"""

from __future__ import annotations

import math
import signal
from pathlib import Path
from typing import Any

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from xface_core.codes import Outcome
from xface_core.frames import wrap_angle
from xface_core.geometry import make_face
from xface_core.predict import predict

pytestmark = pytest.mark.ros

WIDTH = 0.05
Y_START = 3.0 * WIDTH
#: A pose at which the X-Face seats and the V-Face (same H/D and r_p) fails, both with
#: the same answer 0.02 D either side (x0 = D/2 puts the V tip exactly on a notch corner,
#: a knife edge between the two: docs/crosscheck.md).
X_ONLY = (0.7, 0.0)


def stream(running: Any, x0_widths: float, theta0: float) -> DiagnosticStatus:
    c = running.client
    yaw = wrap_angle(theta0 + math.pi)
    _sent, status = c.publish_until_status(lambda: c.pose_msg(x0_widths * WIDTH, Y_START, yaw))
    return status  # type: ignore[no-any-return]


@pytest.mark.parametrize(
    ("overrides", "extra_args", "match"),
    [
        ({"width_m": 50.0}, [], "width_m"),
        ({"h_over_d": -1.0}, [], "h_over_d"),
        ({"face": "Q"}, [], "face must be one of"),
        ({"friction": 3.0}, [], "friction"),
        ({}, ["-p", "damping_ratio:=0.0"], "damping_ratio"),
    ],
    ids=["width-range", "h_over_d-range", "face-letter", "friction-range", "cli-override"],
)
def test_node_refuses_to_start_with_a_bad_parameter(
    launch: Any, overrides: dict[str, Any], extra_args: list[str], match: str
) -> None:
    running = launch(wait=False, extra_args=extra_args, **overrides)
    code = running.node.wait_exit(timeout_s=300.0)
    log = running.node.log()
    assert code == 2, log
    assert "refusing to start" in log
    assert match in log


def test_out_of_range_change_at_run_time_is_refused_and_changes_nothing(launch: Any) -> None:
    running = launch(compute_margins=False)
    c = running.client
    results = c.set_parameters(width_m=50.0)
    assert not results[0].successful
    results = c.set_parameters(friction=3.0)
    assert not results[0].successful
    results = c.set_parameters(face="Q")
    assert not results[0].successful
    results = c.set_parameters(record=True)  # read-only
    assert not results[0].successful
    assert c.get_parameter("width_m") == pytest.approx(WIDTH)
    assert c.get_parameter("face") == "X"
    status = stream(running, 0.0, 0.0)
    assert c.values(status)["face"] == "X"
    assert float(c.values(status)["width_m"]) == pytest.approx(WIDTH)


def test_valid_design_change_takes_effect_for_the_next_prediction(launch: Any) -> None:
    running = launch(compute_margins=False)
    c = running.client
    before = stream(running, *X_ONLY)
    assert c.values(before)["outcome"] == "SEATED"
    results = c.set_parameters(face="V")
    assert results[0].successful, results[0].reason
    after = stream(running, *X_ONLY)
    v = c.values(after)
    assert v["face"] == "V"
    x0 = X_ONLY[0] * WIDTH
    expected = predict(make_face("V", 0.25, 1.0, width=WIDTH), x0, 0.0, y_start=Y_START)
    assert not expected.seated
    assert v["outcome"] == expected.outcome.name
    assert float(v["final_phi_m_rad"]) == pytest.approx(expected.phi_m, abs=1e-12)
    assert after.level == DiagnosticStatus.WARN


def test_min_margin_turns_a_thin_seat_into_a_warning(launch: Any) -> None:
    running = launch(compute_margins=False)
    c = running.client
    assert stream(running, 0.3, 0.2).level == DiagnosticStatus.OK
    assert c.set_parameters(min_margin=1.0)[0].successful  # 1 m: no seat has that
    status = stream(running, 0.3, 0.2)
    v = c.values(status)
    assert v["outcome"] == "SEATED"
    assert v["accepted"] == "false"
    assert status.level == DiagnosticStatus.WARN
    assert float(v["margin_m"]) < 1.0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_stops_the_node_with_exit_code_zero(launch: Any, sig: int) -> None:
    running = launch(compute_margins=False)
    stream(running, 0.0, 0.0)  # it has done work and its worker is idle or busy
    assert running.node.stop(sig) == 0, running.node.log()


def test_recording_is_finished_on_shutdown(launch: Any, tmp_path: Path) -> None:
    pytest.importorskip("xface_core.viz.recording")
    rrd = tmp_path / "run.rrd"
    running = launch(compute_margins=False, record=True, record_path=str(rrd))
    stream(running, 0.3, 0.2)
    stream(running, 0.9, 0.8)
    assert running.node.stop(signal.SIGINT) == 0, running.node.log()
    assert rrd.stat().st_size > 0
    import rerun as rr

    store = rr.chunk.RrdReader(str(rrd)).store()  # a truncated file would fail to decode
    assert store is not None


def _series(rrd: Path, entity: str) -> list[float]:
    """The scalars of one entity of a recording, in the order of the ROS stamps."""
    import rerun as rr

    rows: list[tuple[int, float]] = []
    for chunk in rr.chunk.RrdReader(str(rrd)).store().stream():
        if chunk.entity_path != entity:
            continue
        batch = chunk.to_record_batch()
        stamps = batch.column("ros2_timestamp").cast("int64").to_pylist()
        scalars = [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
        rows.extend(zip(stamps, scalars, strict=True))
    return [v for _, v in sorted(rows)]


def test_the_recording_holds_outcome_accepted_and_margin_series(
    launch: Any, tmp_path: Path
) -> None:
    pytest.importorskip("xface_core.viz.recording")
    rrd = tmp_path / "run.rrd"
    running = launch(compute_margins=True, record=True, record_path=str(rrd))
    c = running.client
    first, second = stream(running, 0.3, 0.2), stream(running, 0.9, 0.8)
    assert running.node.stop(signal.SIGINT) == 0, running.node.log()
    # Every status the node published is in the recording, in stamp order: under load a pose
    # can be published again before its status arrives, and both copies are then answered.
    with c.status.cond:
        received = list(c.status.messages)
    values = sorted((c.values(s) for s in received), key=lambda v: int(v["input_stamp_ns"]))
    assert [v["outcome"] for v in values[:1] + values[-1:]] == [
        c.values(first)["outcome"],
        c.values(second)["outcome"],
    ]
    assert _series(rrd, "/xface/verdict/outcome_code") == [
        float(Outcome[v["outcome"]]) for v in values
    ]
    assert _series(rrd, "/xface/verdict/accepted") == [
        1.0 if v["accepted"] == "true" else 0.0 for v in values
    ]
    margins = _series(rrd, "/xface/verdict/margin/lateral_minus")
    assert margins[0] == pytest.approx(float(values[0]["margin_lateral_minus_m"]))
