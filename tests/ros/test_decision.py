"""The node's decisions without ROS: input checks, which start, acceptance, verdicts, stats.

Nothing here imports rclpy or a message package; the last test runs this whole module (and
tests/ros/test_worker.py) again in a fresh interpreter in which no ROS module can be
imported, which proves it. (No custom
markers here: that run has no conftest to register them.)
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
import textwrap
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from xface_core.codes import Outcome
from xface_core.frames import (
    DockStart,
    PlanarPose,
    mated_pose,
    planar_yaw,
    relative_pose_to_start,
    yaw_to_quaternion,
)
from xface_core.predict import predict
from xface_core.result import Counters, Margins, Prediction
from xface_ros.config import SPECS, NodeConfig, config_from_values
from xface_ros.decision import (
    ANSWERS,
    INPUT_ERRORS,
    InputRejected,
    PoseInput,
    Predicted,
    Rejected,
    answer,
    check_pose,
    combined_margin,
    decide,
    evaluate,
    evaluate_dock_query,
    evaluate_query,
    evaluate_streamed,
    required_margin_m,
)
from xface_ros.stats import PredictorStats, StatsCounts, StatsWindow

NOW_NS = 1_700_000_000_000_000_000
WIDTH = 0.05  # the default width_m


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    return config_from_values({spec.name: spec.default for spec in SPECS})


def pose(
    x: float = 0.01,
    y: float = 0.15,
    yaw: float = math.pi - 0.2,
    *,
    frame: str = "xface_base",
    stamp_ns: int = NOW_NS,
    quaternion: tuple[float, float, float, float] | None = None,
) -> PoseInput:
    q = yaw_to_quaternion(yaw) if quaternion is None else quaternion
    return PoseInput(frame_id=frame, stamp_ns=stamp_ns, position=(x, y, 0.0), orientation=q)


def at_start(x0_widths: float, theta0: float, *, stamp_ns: int = NOW_NS) -> PoseInput:
    """The pose of a simulator start (x0 in widths, theta0 in rad) 3 widths up."""
    return pose(x0_widths * WIDTH, 3.0 * WIDTH, theta0 + math.pi, stamp_ns=stamp_ns)


# --- input checks ---------------------------------------------------------------------------


def test_good_pose_converts_like_the_frames_module(config: NodeConfig) -> None:
    p = pose()
    start = check_pose(p, config, now_ns=NOW_NS + 1000)
    expected = relative_pose_to_start(PlanarPose(0.01, 0.15, planar_yaw(*p.orientation)))
    assert start == expected
    assert start.theta0 == pytest.approx(-0.2)


def bad_inputs() -> list[tuple[str, dict[str, Any]]]:
    s = math.sin(0.2)
    return [
        ("wrong_frame", {"frame": "map"}),
        ("wrong_frame", {"frame": ""}),
        ("non_finite", {"x": math.nan}),
        ("non_finite", {"y": math.inf}),
        ("non_finite", {"quaternion": (0.0, 0.0, math.nan, 1.0)}),
        ("stale_stamp", {"stamp_ns": NOW_NS - 2_000_000_000}),
        ("stale_stamp", {"stamp_ns": 0}),
        ("future_stamp", {"stamp_ns": NOW_NS + 2_000_000_000}),
        ("unnormalised_quaternion", {"quaternion": (0.0, 0.0, 0.0, 0.0)}),
        ("unnormalised_quaternion", {"quaternion": (0.0, 0.0, 1.0, 1.0)}),
        ("non_planar", {"quaternion": (s, 0.0, 0.0, math.cos(0.2))}),  # roll 0.4 rad
        ("absurd_distance", {"x": 60.0}),  # 1200 widths of 5 cm
        ("absurd_distance", {"y": -51.0}),
        ("not_facing", {"quaternion": (0.0, 0.0, 0.0, 1.0)}),  # identity: back to back
        ("not_facing", {"yaw": math.pi / 2 - 0.01}),  # theta0 just past -pi/2
    ]


@pytest.mark.parametrize(("code", "kwargs"), bad_inputs())
def test_each_bad_input_is_rejected_with_its_code(
    config: NodeConfig, code: str, kwargs: dict[str, Any]
) -> None:
    assert code in INPUT_ERRORS
    with pytest.raises(InputRejected) as info:
        check_pose(pose(**kwargs), config, now_ns=NOW_NS)
    assert info.value.code == code
    verdict = evaluate_streamed(pose(**kwargs), config, receive_ns=NOW_NS, path=False)
    assert isinstance(verdict, Rejected)
    assert verdict.code == code
    assert not verdict.accepted


def test_a_leading_slash_names_the_same_frame(config: NodeConfig) -> None:
    assert check_pose(pose(frame="/xface_base"), config, now_ns=NOW_NS).x0 == 0.01


def test_a_zero_stamp_is_called_a_zero_stamp(config: NodeConfig) -> None:
    with pytest.raises(InputRejected, match="stale_stamp: zero stamp"):
        check_pose(pose(stamp_ns=0), config, now_ns=NOW_NS)


def test_an_old_stamp_suggests_clock_skew(config: NodeConfig) -> None:
    with pytest.raises(InputRejected, match=r"stale_stamp: pose is 2\.000 s old.*clock skew"):
        check_pose(pose(stamp_ns=NOW_NS - 2_000_000_000), config, now_ns=NOW_NS)


def test_a_future_stamp_is_called_clock_skew(config: NodeConfig) -> None:
    with pytest.raises(InputRejected, match=r"future_stamp: clock skew: the stamp is 2\.000 s"):
        check_pose(pose(stamp_ns=NOW_NS + 2_000_000_000), config, now_ns=NOW_NS)


def test_checks_run_in_the_documented_order(config: NodeConfig) -> None:
    # Wrong frame before non-finite before stale before the quaternion.
    everything_wrong = pose(math.nan, frame="map", stamp_ns=0, quaternion=(0.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputRejected, match="wrong_frame"):
        check_pose(everything_wrong, config, now_ns=NOW_NS)
    with pytest.raises(InputRejected, match="non_finite"):
        check_pose(replace(everything_wrong, frame_id="xface_base"), config, now_ns=NOW_NS)


def test_faces_at_a_right_angle_still_face_each_other(config: NodeConfig) -> None:
    assert check_pose(pose(yaw=math.pi / 2 + 0.01), config, now_ns=NOW_NS).theta0 < 0.0


def test_no_clock_skips_the_stamp_check(config: NodeConfig) -> None:
    assert check_pose(pose(stamp_ns=0), config, now_ns=None).x0 == 0.01


def test_zero_timeout_disables_the_stamp_check(config: NodeConfig) -> None:
    no_timeout = replace(config, input_timeout_s=0.0)
    assert check_pose(pose(stamp_ns=0), no_timeout, now_ns=NOW_NS).x0 == 0.01


# --- acceptance -----------------------------------------------------------------------------


def hand_prediction(outcome: Outcome, margins: Margins | None, config: NodeConfig) -> Prediction:
    """A Prediction built by hand: only the fields the decision reads matter here."""
    return Prediction(
        design=config.design, x0=0.0, theta0=0.0, y_start=0.2, outcome=outcome, reason="r",
        phi_b=0.0, phi_m=0.0, pivot_m=(0.0, 0.1), counters=Counters(1, 1, 1), margins=margins,
    )  # fmt: skip


def test_combined_margin_is_the_smaller_of_lateral_and_width_times_angle() -> None:
    margins = Margins(lateral_minus=0.02, lateral_plus=0.03, angle_minus=0.5, angle_plus=0.1)
    assert combined_margin(margins, 0.05) == pytest.approx(0.005)  # 0.1 rad x 5 cm
    assert combined_margin(margins, 1.0) == pytest.approx(0.02)


def test_decision_accepts_a_seat_with_enough_margin(config: NodeConfig) -> None:
    seated = hand_prediction(Outcome.SEATED, Margins(0.02, 0.03, 0.5, 0.1), config)
    assert decide(seated, required_margin_m=0.0).accepted
    assert decide(seated, required_margin_m=0.004).accepted
    short = decide(seated, required_margin_m=0.006)
    assert not short.accepted
    assert "margin" in short.why


def test_decision_rejects_every_other_outcome_whatever_the_margin(config: NodeConfig) -> None:
    for outcome in Outcome:
        if outcome is not Outcome.SEATED:
            p = hand_prediction(outcome, Margins(1.0, 1.0, 1.0, 1.0), config)
            assert not decide(p, required_margin_m=0.0).accepted


def test_decision_without_margins_cannot_meet_a_required_margin(config: NodeConfig) -> None:
    seated = hand_prediction(Outcome.SEATED, None, config)
    assert decide(seated, required_margin_m=0.0).accepted
    assert not decide(seated, required_margin_m=0.001).accepted


def test_query_tolerance_replaces_min_margin_only_when_positive(config: NodeConfig) -> None:
    strict = replace(config, min_margin=0.003)
    assert required_margin_m(0.002, strict) == 0.002
    assert required_margin_m(0.0, strict) == 0.003


@pytest.mark.parametrize("tolerance_m", [-0.001, math.nan, math.inf])
def test_query_with_a_bad_tolerance_is_rejected(config: NodeConfig, tolerance_m: float) -> None:
    start = at_start(0.0, 0.0)
    verdict = evaluate_query(start, None, config, tolerance_m=tolerance_m, now_ns=NOW_NS)
    assert isinstance(verdict, Rejected)
    assert verdict.code == "bad_tolerance"
    assert repr(tolerance_m) in verdict.detail


@pytest.mark.parametrize(
    ("margin", "probability", "code"),
    [
        (-0.001, 0.0, "bad_required_margin"),
        (math.nan, 0.0, "bad_required_margin"),
        (math.inf, 0.0, "bad_required_margin"),
        (0.0, -0.1, "bad_required_probability"),
        (0.0, 1.5, "bad_required_probability"),
        (0.0, math.nan, "bad_required_probability"),
    ],
)
def test_dock_query_with_a_bad_requirement_is_rejected(
    config: NodeConfig, margin: float, probability: float, code: str
) -> None:
    verdict = evaluate_dock_query(
        at_start(0.0, 0.0), None, config, required_margin=margin,
        required_probability=probability, now_ns=NOW_NS,
    )  # fmt: skip
    assert isinstance(verdict, Rejected)
    assert verdict.code == code
    assert code in INPUT_ERRORS


def test_dock_query_requirements_replace_the_node_minimums_only_when_positive(
    config: NodeConfig,
) -> None:
    strict = replace(config, min_margin=0.003, min_seat_probability=0.7)
    for asked, margin, probability in [((0.0, 0.0), 0.003, 0.7), ((0.002, 0.9), 0.002, 0.9)]:
        verdict = evaluate_dock_query(
            at_start(0.0, 0.0), None, strict, required_margin=asked[0],
            required_probability=asked[1], now_ns=NOW_NS,
        )  # fmt: skip
        assert isinstance(verdict, Predicted)
        assert verdict.decision.required_m == margin
        assert verdict.decision.required_probability == probability


def test_dock_query_covariance_applies_to_the_latest_pose(config: NodeConfig) -> None:
    # Without an atlas the probability is not computed, so a required one is not met: the
    # request's covariance reached the latest pose (which had none) if it is refused.
    latest = at_start(0.0, 0.0)
    requested = replace(pose(frame=""), covariance=(1e-6, 0.0, 0.0, 1e-4))
    kwargs: dict[str, Any] = {"required_margin": 0.0, "now_ns": NOW_NS}
    exact = evaluate_dock_query(pose(frame=""), latest, config, required_probability=0.9, **kwargs)
    assert exact.accepted
    uncertain = evaluate_dock_query(requested, latest, config, required_probability=0.9, **kwargs)
    assert isinstance(uncertain, Predicted)
    assert uncertain.prediction.seated
    assert not uncertain.accepted
    assert "seat probability not available" in uncertain.decision.why


# --- verdicts -------------------------------------------------------------------------------


def test_streamed_verdict_equals_the_core_and_carries_the_seat(config: NodeConfig) -> None:
    verdict = evaluate_streamed(at_start(0.3, 0.2), config, receive_ns=NOW_NS, path=True)
    assert isinstance(verdict, Predicted)
    start = verdict.start
    expected = predict(config.design, start.x0, start.theta0, y_start=start.y_start, margins=True)
    assert verdict.prediction.outcome is expected.outcome is Outcome.SEATED
    assert verdict.prediction.phi_m == expected.phi_m
    assert verdict.prediction.margins == expected.margins
    assert verdict.accepted
    assert verdict.stamp_ns == NOW_NS
    assert verdict.compute_s > 0.0
    assert verdict.seated_pose is not None
    seat = mated_pose(config.design, 0.3 * WIDTH)
    assert verdict.seated_pose.x == pytest.approx(seat.x, abs=1e-9)
    assert verdict.seated_pose.y == pytest.approx(seat.y, abs=1e-6)


def test_streamed_verdict_follows_the_config(config: NodeConfig) -> None:
    no_margins = replace(config, compute_margins=False)
    verdict = evaluate_streamed(at_start(0.3, 0.2), no_margins, receive_ns=NOW_NS, path=False)
    assert isinstance(verdict, Predicted)
    assert verdict.prediction.margins is None
    assert verdict.prediction.path is None
    required = replace(no_margins, min_margin=1.0)  # 1 m: no seat has that
    verdict = evaluate_streamed(at_start(0.3, 0.2), required, receive_ns=NOW_NS, path=False)
    assert isinstance(verdict, Predicted)
    assert verdict.prediction.seated
    assert not verdict.accepted
    assert verdict.seated_pose is not None  # it still seats: the seat is published


def test_a_pose_that_does_not_seat_has_no_seated_pose(config: NodeConfig) -> None:
    verdict = evaluate_streamed(at_start(0.9, 0.8), config, receive_ns=NOW_NS, path=False)
    assert isinstance(verdict, Predicted)
    assert not verdict.prediction.seated
    assert not verdict.accepted
    assert verdict.seated_pose is None


def test_interpenetrating_start_is_rejected_as_invalid_input(config: NodeConfig) -> None:
    verdict = evaluate_streamed(pose(0.0, 0.0, math.pi), config, receive_ns=NOW_NS, path=False)
    assert isinstance(verdict, Rejected)
    assert verdict.code == "invalid_input"


def test_a_failing_simulator_gives_an_internal_error(
    config: NodeConfig, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(*args: Any, **kwargs: Any) -> Prediction:
        raise RuntimeError("boom")

    monkeypatch.setattr("xface_ros.decision.predict", broken)
    verdict = evaluate(
        at_start(0.0, 0.0), config, now_ns=None, required_margin_m=0.0, path=False, margins=False
    )
    assert isinstance(verdict, Rejected)
    assert verdict.code == "internal_error"
    assert "boom" in verdict.detail


def test_query_with_an_empty_frame_predicts_the_latest_pose_and_checks_its_age(
    config: NodeConfig,
) -> None:
    empty = pose(frame="", stamp_ns=0)
    verdict = evaluate_query(empty, None, config, tolerance_m=0.0, now_ns=NOW_NS)
    assert isinstance(verdict, Rejected)
    assert verdict.code == "no_pose"
    latest = at_start(-0.4, -0.3)
    verdict = evaluate_query(empty, latest, config, tolerance_m=0.0, now_ns=NOW_NS)
    assert isinstance(verdict, Predicted)
    assert verdict.stamp_ns == latest.stamp_ns
    assert verdict.start == DockStart(-0.4 * WIDTH, pytest.approx(-0.3), 3.0 * WIDTH)
    late = evaluate_query(empty, latest, config, tolerance_m=0.0, now_ns=NOW_NS + 10**10)
    assert isinstance(late, Rejected)
    assert late.code == "stale_stamp"


def test_query_with_an_explicit_start_ignores_its_stamp_and_always_has_a_path(
    config: NodeConfig,
) -> None:
    old = at_start(0.3, 0.2, stamp_ns=0)
    no_margins = replace(config, compute_margins=False)
    verdict = evaluate_query(old, None, no_margins, tolerance_m=0.0, now_ns=NOW_NS)
    assert isinstance(verdict, Predicted)
    assert verdict.accepted
    assert verdict.prediction.path is not None
    assert verdict.prediction.margins is None  # no margin required, none configured
    assert verdict.decision.margin_m is None


def test_query_tolerance_is_the_required_combined_margin(config: NodeConfig) -> None:
    start = at_start(0.3, 0.2, stamp_ns=0)
    verdict = evaluate_query(start, None, config, tolerance_m=0.0, now_ns=NOW_NS)
    assert isinstance(verdict, Predicted)
    margin = verdict.decision.margin_m
    assert margin is not None
    assert 0.0 < margin < math.inf
    half = evaluate_query(start, None, config, tolerance_m=0.5 * margin, now_ns=NOW_NS)
    double = evaluate_query(start, None, config, tolerance_m=2.0 * margin, now_ns=NOW_NS)
    assert half.accepted
    assert not double.accepted


def query_answer(config: NodeConfig, latest: PoseInput | None, *, required_m: float) -> str:
    """The answer to "the latest pose, with this margin required"."""
    empty = pose(frame="")
    return answer(evaluate_query(empty, latest, config, tolerance_m=required_m, now_ns=NOW_NS))


@pytest.mark.parametrize(
    ("expected", "latest", "required_m"),
    [
        ("no_pose", None, 0.0),
        ("stale", at_start(0.0, 0.0, stamp_ns=NOW_NS - 2_000_000_000), 0.0),
        ("invalid", pose(quaternion=(0.0, 0.0, 0.0, 1.0)), 0.0),
        ("will_not_seat", at_start(0.9, 0.8), 0.0),
        ("seats_without_margin", at_start(0.0, 0.0), 1.0),  # no seat has 1 m of margin
        ("seats", at_start(0.0, 0.0), 0.0),
    ],
)
def test_each_answer_of_a_query(
    config: NodeConfig, expected: str, latest: PoseInput | None, required_m: float
) -> None:
    assert expected in ANSWERS
    assert query_answer(config, latest, required_m=required_m) == expected


# --- stats ----------------------------------------------------------------------------------


def test_stats_count_predictions_errors_and_windows(config: NodeConfig) -> None:
    stats = PredictorStats(start_ns=0)
    assert stats.warming_up
    stats.set_warming_up(False)
    stats.count_received(stamp_ns=NOW_NS)
    stats.count_received(stamp_ns=NOW_NS + 1)
    seated = evaluate_streamed(at_start(0.0, 0.0), config, receive_ns=NOW_NS, path=False)
    assert isinstance(seated, Predicted)
    stats.count_verdict(seated, latency_ms=2.0)
    stats.count_verdict(Rejected(NOW_NS + 1, "non_planar", "tilted"), latency_ms=1.0)
    stats.count_service_call()
    stats.count_recording_error()
    stats.set_dds_lost_reported_total(3)
    snap = stats.take_snapshot(2_000_000_000, received_total=2, dropped_total=0)
    assert snap.window == StatsWindow(
        received=2, predicted=1, latency_ms=[2.0], compute_ms=[seated.compute_s * 1e3]
    )
    assert snap.window_s == pytest.approx(2.0)
    assert snap.pose_age_s == pytest.approx((2_000_000_000 - NOW_NS - 1) * 1e-9)
    # The last verdict was the rejection: it sets the last outcome and error; the latency
    # is that of the last prediction.
    assert snap.counts == StatsCounts(
        warming_up=False, predicted_total=1, input_errors_total=1, dds_lost_reported_total=3,
        service_calls_total=1, recording_errors_total=1, last_outcome="INVALID_INPUT",
        last_accepted=None, last_input_error="non_planar", last_latency_ms=2.0,
        last_stamp_ns=NOW_NS + 1,
    )  # fmt: skip
    # A new window starts empty; the totals stay.
    later = stats.take_snapshot(3_000_000_000, received_total=2, dropped_total=0)
    assert later.window.received == 0
    assert later.counts.predicted_total == 1
    assert later.window_s == pytest.approx(1.0)


def test_stats_time_the_warm_up_while_it_runs_and_keep_its_length_after() -> None:
    clock = [100.0]
    stats = PredictorStats(start_ns=0, monotonic_s=lambda: clock[0])
    stats.start_warm_up("compiles")
    stats.set_warm_up_progress(3, 7)
    clock[0] = 141.5

    def counts() -> StatsCounts:
        return stats.take_snapshot(10, received_total=0, dropped_total=0).counts

    running = counts()
    assert (running.engine, running.warm_up_done, running.warm_up_total) == ("compiles", 3, 7)
    assert running.warm_up_s == 41.5
    stats.set_warm_up_progress(7, 7)
    clock[0] = 150.0
    stats.set_warming_up(False)
    clock[0] = 500.0  # the warm-up is over: its length stays
    assert counts().warm_up_s == 50.0


def test_stats_before_any_pose() -> None:
    snap = PredictorStats(start_ns=0).take_snapshot(10, received_total=0, dropped_total=0)
    assert math.isnan(snap.pose_age_s)
    assert snap.counts.last_outcome == "none"
    assert snap.counts.warming_up


# --- the proof that none of this needs ROS --------------------------------------------------

#: Refuses every ROS 2 module (the client library, its C layers, generators, message
#: packages) in the interpreter it runs in, then runs pytest with the given arguments.
_RUN_PYTEST_WITHOUT_ROS = textwrap.dedent(
    """
    import sys

    ALREADY_LOADED = set(sys.modules)  # by .pth files at startup (the ROS wheels' bootstrapper)

    def is_ros(name):
        top = name.partition(".")[0]
        return top in ("rclpy", "rpyutils", "ament_index_python") or top.startswith(
            ("rcl", "rmw", "rosidl", "ros_")
        ) or top.endswith(("_msgs", "_srvs", "_interfaces"))

    class RosBlocker:
        def find_spec(self, name, path=None, target=None):
            if is_ros(name):
                raise ModuleNotFoundError(f"No module named {name!r} (ROS blocked)", name=name)
            return None

    sys.meta_path.insert(0, RosBlocker())
    try:
        import rclpy
    except ModuleNotFoundError:
        pass
    else:
        sys.exit("the blocker let rclpy through")
    import pytest

    code = pytest.main(sys.argv[1:])
    leaked = sorted(m for m in set(sys.modules) - ALREADY_LOADED if is_ros(m))
    sys.exit(f"ROS modules imported: {leaked}" if leaked else int(code))
    """
)


def test_every_test_here_and_of_the_worker_runs_without_ros() -> None:
    here = Path(__file__).resolve()
    args = [
        here.name,
        "test_worker.py",
        "--noconftest",
        "-p",
        "no:cacheprovider",
        "-q",
        "-k",
        "not without_ros",
    ]
    run = subprocess.run(
        [sys.executable, "-c", _RUN_PYTEST_WITHOUT_ROS, *args],
        cwd=here.parent, capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    out = run.stdout + run.stderr
    assert run.returncode == 0, out
    passed = re.search(r"(\d+) passed", out)
    assert passed is not None, out
    assert int(passed[1]) >= 40, out
    assert "failed" not in out, out


def test_streamed_margins_run_on_the_configured_threads(
    config: NodeConfig, monkeypatch: pytest.MonkeyPatch
) -> None:
    from xface_core.atlas import lookup as atlas_margins
    from xface_core.atlas.build import build_atlas

    asked: list[int] = []
    real = atlas_margins._outcomes_split

    def spy(atlas: Any, xs: Any, ts: Any, sims: Any) -> Any:
        asked.append(sims.threads)
        return real(atlas, xs, ts, sims)

    monkeypatch.setattr(atlas_margins, "_outcomes_split", spy)
    atlas = build_atlas(config.design, lateral_step=1 / 32, angle_step=math.pi / 128)
    values = {**config.values(), "margin_threads": 3}
    three = config_from_values(values)
    # The second query near the first reads the grid-line flips the first found and confirms
    # them in one batch (a one-off query searches its own line instead).
    for x0 in (0.05, 0.051):
        verdict = evaluate_streamed(
            at_start(x0, 0.1), three, receive_ns=NOW_NS, path=False, atlas=atlas
        )
    assert isinstance(verdict, Predicted)
    assert verdict.prediction.margins is not None
    assert set(asked) == {3}  # and not empty: the margins were confirmed from the atlas
