"""The integer codes are one source, and their values are a stored contract."""

from __future__ import annotations

import pytest

import xface_core as xf
from xface_core import codes
from xface_core._engine import records
from xface_core.predict import REASONS

#: The documented values: stored int8 maps, JSON and ROS messages carry these numbers.
DOCUMENTED_OUTCOMES = {
    "INVALID_INPUT": 0,
    "OUT_OF_REACH": 1,
    "NO_CONTACT": 2,
    "SEATED": 3,
    "BAD_MATE": 4,
    "PASSED": 5,
    "UNRESOLVED": 6,
}
DOCUMENTED_PHASES = {"APPROACH": 0, "ALIGN": 1, "SLIDE": 2, "END": 3}


def test_outcome_values_are_the_documented_ones() -> None:
    assert {o.name: o.value for o in codes.Outcome} == DOCUMENTED_OUTCOMES


def test_phase_values_are_the_documented_ones() -> None:
    assert {p.name: p.value for p in codes.Phase} == DOCUMENTED_PHASES


def test_outcome_codes_fit_the_int8_of_stored_maps() -> None:
    amap = xf.acceptance_map(xf.v_face(0.5, 1.0), grid=5)
    assert amap.outcomes.dtype.name == "int8"
    assert all(-128 <= o.value <= 127 for o in codes.Outcome)


def test_public_enums_are_the_codes_module_enums() -> None:
    assert xf.Outcome is codes.Outcome
    assert xf.Phase is codes.Phase
    assert xf.Reason is codes.Reason


@pytest.mark.parametrize("reason", list(codes.Reason))
def test_every_reason_has_a_text(reason: codes.Reason) -> None:
    assert reason.text == codes.REASON_TEXT[reason]
    assert REASONS[int(reason)] == reason.text


@pytest.mark.parametrize(
    ("enum", "prefix"),
    [
        (codes.Outcome, "O_"),
        (codes.Reason, "R_"),
        (codes.Phase, "P_"),
        (codes.EventKind, "E_"),
    ],
)
def test_engine_constants_are_read_from_the_codes(enum: type, prefix: str) -> None:
    names = {
        "INVALID_INPUT": "INVALID",
        "NONFINITE": "NONFINITE",
    }
    for member in enum:  # type: ignore[attr-defined]
        name = prefix + names.get(member.name, member.name)
        assert getattr(records, name) == member.value, name


def test_slip_states_are_read_from_the_codes() -> None:
    assert records.FREE == codes.SlipState.FREE
    assert records.STICK == codes.SlipState.STICK
    assert records.SLIDE_POSITIVE == codes.SlipState.SLIDE_POSITIVE
    assert records.SLIDE_NEGATIVE == codes.SlipState.SLIDE_NEGATIVE


def test_a_prediction_reports_its_reason_text() -> None:
    p = xf.predict(xf.x_face(0.25, 0.0), 0.9, 0.0)
    assert p.outcome is xf.Outcome.OUT_OF_REACH
    assert p.reason == codes.Reason.OUT_OF_REACH.text
