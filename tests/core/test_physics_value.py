"""Physics and SolverSettings: one validated value for every entry point."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core.errors import XfaceValueError
from xface_core.physics import MAX_FRICTION, Physics, SolverSettings


def test_defaults_are_the_papers_model() -> None:
    p = Physics()
    assert (p.damping_ratio, p.friction, p.settings) == (1.0, 0.0, xf.DEFAULT_SETTINGS)


@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, True, "1", 1e-300, 1e-9, 1e9, -math.inf])
def test_bad_damping_ratio_is_rejected_with_its_name(value: object) -> None:
    with pytest.raises(XfaceValueError, match="damping_ratio"):
        Physics(damping_ratio=value)  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [-0.1, MAX_FRICTION * 1.01, math.nan, math.inf, None])
def test_bad_friction_is_rejected_with_its_name(value: object) -> None:
    with pytest.raises(XfaceValueError, match="friction"):
        Physics(friction=value)  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [1e-4, 1.0, 1e4, math.inf])
def test_supported_damping_ratios_are_accepted(value: float) -> None:
    assert Physics(damping_ratio=value).damping_ratio == value


def test_the_extreme_damping_ratio_that_gave_nan_angles_is_refused_by_predict() -> None:
    # Before: NaN final angles reported as BAD_MATE.
    with pytest.raises(XfaceValueError, match="damping_ratio must be in"):
        xf.predict(
            xf.s_face(0.0017347218674217794, 0.0), 0.0010450531173217942, -1.503134859460741,
            damping_ratio=1e-300, friction=0.103,
        )  # fmt: skip


def test_infinite_damping_ratio_holds_the_base() -> None:
    assert Physics(damping_ratio=math.inf).base_fixed
    assert not Physics().base_fixed


def test_numpy_and_int_values_are_normalised_to_equal_floats() -> None:
    a = Physics(damping_ratio=np.float64(2.0), friction=np.int64(0))  # type: ignore[arg-type]
    assert a == Physics(damping_ratio=2.0, friction=0.0)
    assert hash(a) == hash(Physics(damping_ratio=2.0, friction=0.0))
    assert type(a.damping_ratio) is float


@pytest.mark.parametrize(
    "changes",
    [{"rtol": 0.0}, {"atol": 1.0}, {"event_tol": math.nan}, {"max_step": -1.0},
     {"first_step": math.inf}, {"max_steps": 0}, {"max_events": 2.5}, {"jam_speed": 0.0}],
)  # fmt: skip
def test_bad_settings_are_rejected_with_their_name(changes: dict[str, object]) -> None:
    (name,) = changes
    with pytest.raises(XfaceValueError, match=f"settings.{name}"):
        SolverSettings(**changes)  # type: ignore[arg-type]


def test_tightened_settings_stay_valid() -> None:
    s = xf.DEFAULT_SETTINGS.tightened(1e-6)
    assert s.rtol == pytest.approx(1e-14)
    assert s.event_tol >= 1e-15


def test_resolve_builds_from_loose_keywords() -> None:
    assert Physics.resolve(friction=0.3) == Physics(friction=0.3)
    assert Physics.resolve() == Physics()


def test_resolve_refuses_physics_and_loose_keywords_together() -> None:
    with pytest.raises(XfaceValueError, match="either physics or friction"):
        Physics.resolve(Physics(), friction=0.1)


def test_resolve_refuses_a_non_physics_value() -> None:
    with pytest.raises(XfaceValueError, match="physics must be a Physics"):
        Physics.resolve({"friction": 0.1})  # type: ignore[arg-type]


def test_predict_with_physics_equals_predict_with_loose_keywords() -> None:
    design = xf.v_face(0.5, 1.0)
    a = xf.predict(design, 0.2, 0.3, physics=Physics(damping_ratio=2.0, friction=0.1))
    b = xf.predict(design, 0.2, 0.3, damping_ratio=2.0, friction=0.1)
    assert (a.outcome, a.phi_b, a.phi_m, a.counters) == (b.outcome, b.phi_b, b.phi_m, b.counters)


def test_map_with_physics_equals_map_with_loose_keywords() -> None:
    design = xf.x_face(0.25, 2.0)
    a = xf.acceptance_map(design, grid=9, physics=Physics(friction=0.2))
    b = xf.acceptance_map(design, grid=9, friction=0.2)
    np.testing.assert_array_equal(a.outcomes, b.outcomes)


def test_entry_points_reject_invalid_physics_before_simulating() -> None:
    design = xf.x_face(0.25, 2.0)
    with pytest.raises(XfaceValueError, match="friction"):
        xf.predict_batch(design, [0.0], [0.0], friction=-1.0)
    with pytest.raises(XfaceValueError, match="damping_ratio"):
        xf.outcome_margins(design, 0.0, 0.0, xf.Outcome.SEATED, damping_ratio=0.0)
