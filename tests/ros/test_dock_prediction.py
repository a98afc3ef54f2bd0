"""The typed answer (``xface_msgs/DockPrediction``) of a verdict, without starting DDS: it says
what ``prediction/status`` says, field by field, with NaN where the status has no value."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from std_msgs.msg import Header

import xface_core as xf
from xface_core.codes import Outcome
from xface_core.frames import DockStart
from xface_core.predict import predict
from xface_core.result import Margins, Prediction
from xface_ros.conversions import (
    dock_prediction_msg,
    ns_to_stamp,
    prediction_status,
    typed_interface_problem,
)
from xface_ros.decision import INPUT_ERRORS, Decision, Predicted, Rejected
from xface_ros.params import SPECS, NodeConfig, config_from_values

pytestmark = pytest.mark.skipif(
    typed_interface_problem() is not None, reason=str(typed_interface_problem())
)

NOW_NS = 1_700_000_000_000_000_000
HEADER = Header(stamp=ns_to_stamp(NOW_NS), frame_id="xface_base")


@pytest.fixture(scope="module")
def config() -> NodeConfig:
    return config_from_values({spec.name: spec.default for spec in SPECS})


@pytest.fixture(scope="module")
def seated(config: NodeConfig) -> Prediction:
    prediction = predict(config.design, 0.015, 0.2, y_start=0.15, margins=True)
    assert prediction.outcome is Outcome.SEATED
    return prediction


def status_number(values: dict[str, str], key: str) -> float:
    """A status value as a number; NaN when the status does not carry it."""
    return float(values[key]) if key in values else math.nan


def same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


finite = st.floats(min_value=0.0, max_value=1.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    outcome=st.sampled_from([o for o in Outcome if o is not Outcome.INVALID_INPUT]),
    with_margins=st.booleans(),
    accepted=st.booleans(),
    required_m=finite,
    required_probability=finite,
    seat_probability=st.none() | finite,
    suggestion=st.none() | st.tuples(finite, finite),
    why=st.text(max_size=20),
)
def test_dock_prediction_says_what_the_status_says(
    seated: Prediction,
    config: NodeConfig,
    outcome: Outcome,
    with_margins: bool,
    accepted: bool,
    required_m: float,
    required_probability: float,
    seat_probability: float | None,
    suggestion: tuple[float, float] | None,
    why: str,
) -> None:
    margins = Margins(0.002, math.inf, 0.03, 0.04) if with_margins else None
    prediction = replace(seated, outcome=outcome, margins=margins)
    margin_m = None if margins is None else min(margins.lateral, margins.angle * 0.05)
    decision = Decision(
        accepted, margin_m, required_m, why, seat_probability, suggestion, required_probability
    )
    start = DockStart(prediction.x0, prediction.theta0, prediction.y_start)
    verdict = Predicted(NOW_NS, start, prediction, decision, 0.0025)

    status = prediction_status(verdict, name="n", hardware_id="xface_base")
    v = {kv.key: kv.value for kv in status.values}
    msg = dock_prediction_msg(verdict, HEADER, config)

    assert (msg.outcome, msg.outcome_name) == (int(v["outcome_code"]), v["outcome"])
    assert status.message == f"{msg.outcome_name}: {msg.reason}"
    assert msg.input_error == ""
    assert msg.accepted == (v["accepted"] == "true")
    assert msg.seated == (outcome is Outcome.SEATED)
    pairs = {
        "x0_m": msg.x0,
        "theta0_rad": msg.theta0,
        "required_margin_m": msg.required_margin,
        "margin_m": msg.margin,
        "margin_lateral_minus_m": msg.margin_lateral_minus,
        "margin_lateral_plus_m": msg.margin_lateral_plus,
        "margin_angle_minus_rad": msg.margin_angle_minus,
        "margin_angle_plus_rad": msg.margin_angle_plus,
        "seat_probability": msg.seat_probability,
        "suggest_dx_m": msg.suggested_dx,
        "suggest_dtheta_rad": msg.suggested_dtheta,
        "width_m": msg.width,
        "h_over_d": msg.h_over_d,
        "r_p": msg.r_p,
    }
    for key, got in pairs.items():
        assert same(got, status_number(v, key)), key
    assert msg.compute_time == pytest.approx(float(v["compute_time_ms"]) * 1e-3, rel=1e-12)
    assert msg.required_probability == required_probability
    assert (msg.face_kind, msg.face_name) == (v["face"], "X-Face")
    assert (msg.header.frame_id, msg.header.stamp) == (HEADER.frame_id, HEADER.stamp)


@pytest.mark.parametrize("code", sorted(INPUT_ERRORS))
def test_a_rejected_input_is_invalid_input_with_its_code_and_nothing_computed(
    config: NodeConfig, code: str
) -> None:
    msg = dock_prediction_msg(Rejected(NOW_NS, code, "why not"), HEADER, config)
    assert (msg.outcome, msg.outcome_name) == (msg.INVALID_INPUT, "INVALID_INPUT")
    assert (msg.input_error, msg.reason) == (code, "why not")
    assert not msg.accepted
    assert not msg.seated
    not_computed = (
        "x0", "theta0", "margin", "margin_lateral_minus", "margin_lateral_plus",
        "margin_angle_minus", "margin_angle_plus", "seat_probability", "suggested_dx",
        "suggested_dtheta", "compute_time",
    )  # fmt: skip
    for field in not_computed:
        assert math.isnan(getattr(msg, field)), field
    assert (msg.required_margin, msg.required_probability) == (
        config.min_margin,
        config.min_seat_probability,
    )
    asked = dock_prediction_msg(
        Rejected(NOW_NS, code, "why not"), HEADER, config,
        required_margin_m=-1.0, required_probability=0.5,
    )  # fmt: skip
    assert (asked.required_margin, asked.required_probability) == (-1.0, 0.5)


def test_a_custom_face_has_no_h_over_d_or_r_p(tmp_path: Path, config: NodeConfig) -> None:
    square = [(-0.5, -1.0), (0.5, -1.0), (0.5, 1.0), (-0.5, 1.0)]
    design = xf.custom_face([square], [square], mated_distance=2.0, width=0.04)
    prediction = predict(design, 0.0, 0.0, y_start=0.2, margins=False)
    start = DockStart(prediction.x0, prediction.theta0, prediction.y_start)
    decision = Decision(False, None, 0.0, "x")
    msg = dock_prediction_msg(Predicted(NOW_NS, start, prediction, decision, 0.1), HEADER, config)
    assert (msg.face_kind, msg.face_name, msg.width) == ("custom", "custom face", 0.04)
    assert math.isnan(msg.h_over_d)
    assert math.isnan(msg.r_p)
    assert math.isnan(msg.margin)
    assert math.isnan(msg.seat_probability)
