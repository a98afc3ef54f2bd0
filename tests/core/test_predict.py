"""predict(): outcomes, the seated pose, input validation, batch agreement."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core import Outcome, Phase


def test_aligned_start_seats_without_alignment_steps() -> None:
    p = xf.predict(xf.x_face(0.25, 2.0), 0.0, 0.0)
    assert p.outcome is Outcome.SEATED
    assert p.counters.steps == 0
    assert Phase.ALIGN not in set(p.path.phase.tolist())


@pytest.mark.parametrize("face", ["X", "V", "S"])
def test_seated_pose_is_the_mated_pose(face: str) -> None:
    design = xf.make_face(face, 0.5, 1.0)
    x0 = 0.2
    p = xf.predict(design, x0, 0.05)
    assert p.outcome is Outcome.SEATED
    phi = design.seated_angle(x0)
    assert p.phi_b == pytest.approx(phi, abs=1e-4)
    assert p.phi_m == pytest.approx(phi, abs=1e-4)
    assert p.pivot_m[1] == pytest.approx(design.mated_distance * math.cos(phi), abs=1e-4)


def test_parallel_start_slides_without_aligning() -> None:
    # theta0 = 0 with an offset: the X-Face inclines meet flush, the parts turn together.
    design = xf.x_face(0.5, 1.0)
    p = xf.predict(design, 0.4, 0.0)
    assert p.outcome is Outcome.SEATED
    assert Phase.ALIGN not in set(p.path.phase.tolist())
    assert p.phi_m == pytest.approx(math.asin(-0.4 / design.mated_distance), abs=1e-9)


def test_out_of_reach_is_decided_without_simulation() -> None:
    design = xf.x_face(0.0625, 0.0)  # L = 0.0625 D
    p = xf.predict(design, 0.5, 0.0)
    assert p.outcome is Outcome.OUT_OF_REACH
    assert p.counters.steps == 0
    assert p.counters.events == 0


def test_large_angle_passes_beside_the_base_as_bad_mate() -> None:
    p = xf.predict(xf.x_face(0.25, 2.0), 0.5, 0.5)
    assert p.outcome is Outcome.BAD_MATE
    assert "seat height" in p.reason


def test_path_descends_monotonically() -> None:
    p = xf.predict(xf.v_face(0.5, 1.0), 0.3, 0.2)
    assert np.all(np.diff(p.path.descent) >= 0.0)
    assert p.path.phase[-1] == Phase.END


@pytest.mark.parametrize(
    ("x0", "theta0"),
    [(math.nan, 0.0), (0.0, math.inf), (-math.inf, 0.1), (1e9, 0.0), (0.0, 100.0)],
)
def test_bad_pose_raises_input_error(x0: float, theta0: float) -> None:
    with pytest.raises(xf.InputError):
        xf.predict(xf.x_face(0.25, 1.0), x0, theta0)


def test_interpenetrating_start_is_invalid_input() -> None:
    design = xf.x_face(0.25, 1.0)
    p = xf.predict(design, 0.0, 0.0, y_start=design.mated_distance - 0.5)
    assert p.outcome is Outcome.INVALID_INPUT
    assert "interpenetrates" in p.reason


@pytest.mark.parametrize("ratio", [0.0, -1.0, math.nan])
def test_bad_damping_ratio_raises(ratio: float) -> None:
    with pytest.raises(xf.XfaceValueError):
        xf.predict(xf.x_face(0.25, 1.0), 0.0, 0.0, damping_ratio=ratio)


@pytest.mark.parametrize("mu", [-0.1, math.nan, math.inf, 11.0])
def test_bad_friction_raises(mu: float) -> None:
    with pytest.raises(xf.XfaceValueError, match="friction"):
        xf.predict(xf.x_face(0.25, 1.0), 0.0, 0.0, friction=mu)


def test_batch_equals_scalar_bitwise() -> None:
    design = xf.s_face(0.5, 1.0)
    rng = np.random.default_rng(7)
    x0 = rng.uniform(-1, 1, 40)
    th = rng.uniform(-1.2, 1.2, 40)
    batch = xf.predict_batch(design, x0, th)
    for k in range(40):
        p = xf.predict(design, float(x0[k]), float(th[k]), path=False)
        assert batch.outcome[k] == p.outcome
        assert batch.phi_b[k] == p.phi_b
        assert batch.phi_m[k] == p.phi_m


def test_batch_marks_bad_entries_invalid() -> None:
    r = xf.predict_batch(xf.v_face(0.5, 1.0), [0.0, math.nan, 0.1], [0.0, 0.0, math.inf])
    assert [Outcome(c) for c in r.outcome] == [
        Outcome.SEATED,
        Outcome.INVALID_INPUT,
        Outcome.INVALID_INPUT,
    ]


@pytest.mark.parametrize("threads", [0, -2, 1.5, True, "2"])
def test_batch_refuses_a_thread_count_that_is_not_a_positive_integer(threads: object) -> None:
    # A large batch (split over threads) and a small one (run on the caller's thread) alike:
    # 1.5 and "2" ended in a TypeError inside the split, 0 and -2 were taken as 1.
    design = xf.x_face(0.25, 1.0)
    for n in (2, 300):
        with pytest.raises(xf.XfaceValueError, match="threads must be an integer >= 1"):
            xf.predict_batch(design, np.zeros(n), np.zeros(n), threads=threads)  # type: ignore[arg-type]


def test_batch_takes_a_numpy_integer_thread_count() -> None:
    design = xf.x_face(0.25, 1.0)
    xs = np.linspace(-0.5, 0.5, 300)
    two = xf.predict_batch(design, xs, 0.1, threads=np.int64(2))
    one = xf.predict_batch(design, xs, 0.1, threads=1)
    assert np.array_equal(two.outcome, one.outcome)


def test_width_scales_lengths_not_outcomes() -> None:
    small = xf.predict(xf.x_face(0.5, 1.0, width=1e-3), 0.3e-3, 0.1)
    unit = xf.predict(xf.x_face(0.5, 1.0), 0.3, 0.1)
    assert small.outcome is unit.outcome
    assert small.pivot_m[1] == pytest.approx(unit.pivot_m[1] * 1e-3, rel=1e-12)


def test_a_start_below_the_seat_height_ends_where_it_started() -> None:
    # Before: the run was "stopped at the seat height" above its start, a negative descent.
    p = xf.predict(xf.v_face(0.28, 44.8), 0.75, 1.33)
    assert p.outcome is xf.Outcome.BAD_MATE
    assert p.reason == xf.Reason.BELOW_SEAT.text
    assert p.pivot_m[1] == p.y_start
    assert p.path is not None
    assert p.path.descent.min() >= 0.0


@pytest.mark.parametrize(
    ("design", "x0", "theta0"),
    [
        (xf.x_face(0.25, 2.0), 0.3, 0.2),
        (xf.v_face(0.5, 1.0), -0.2, 0.3),
        (xf.s_face(0.5, 1.0), 0.1, -0.2),
    ],
)
def test_a_start_exactly_at_first_contact_is_not_interpenetrating(
    design: xf.FaceDesign, x0: float, theta0: float
) -> None:
    # Before: rounding put a vertex 1e-16 D inside and about half such starts were INVALID.
    p = xf.predict(design, x0, theta0)
    assert p.path is not None
    at_contact = float(p.path.pivot_m[1, 1])  # the state at the first contact
    q = xf.predict(design, x0, theta0, y_start=at_contact)
    assert q.outcome is p.outcome


def test_a_start_1e_6_inside_is_interpenetrating() -> None:
    design = xf.x_face(0.25, 2.0)
    p = xf.predict(design, 0.3, 0.2)
    assert p.path is not None
    q = xf.predict(design, 0.3, 0.2, y_start=float(p.path.pivot_m[1, 1]) - 1e-6)
    assert q.outcome is xf.Outcome.INVALID_INPUT
