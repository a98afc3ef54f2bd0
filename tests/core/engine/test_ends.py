"""ends.py: the seat test, the sample writer and the two ways to end a run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xface_core._engine.ends import end_at_rest, end_run, is_seated, record
from xface_core._engine.records import (
    O_BAD_MATE,
    O_PASSED,
    O_SEATED,
    P_ALIGN,
    P_END,
    R_JAMMED,
    R_PASSED,
    R_SEATED,
    RUN_DTYPE,
    UNDECIDED,
)

L, TOL = 2.5, 1e-4


def _seat(phi: float) -> tuple[float, float]:
    """x0 and y_M of the mated pose at angle phi: P_M = L (-sin phi, cos phi)."""
    return -L * math.sin(phi), L * math.cos(phi)


@pytest.mark.parametrize("phi", [0.0, 0.3, -0.7])
def test_the_mated_pose_is_seated(phi: float) -> None:
    assert is_seated(phi, phi, *_seat(phi), L, TOL)


@pytest.mark.parametrize(
    ("d_pb", "d_pm", "d_x", "d_y", "seated"),
    [
        (0.9 * TOL, 0.0, 0.0, 0.0, True),  # angles differ by less than the tolerance
        (2.0 * TOL, 0.0, 0.0, 0.0, False),  # ... by more
        (0.0, 0.0, 0.0, 0.9 * TOL * L, True),  # pivot off by less than tol * L
        (0.0, 0.0, 0.0, 1.1 * TOL * L, False),
        (0.0, 0.0, 1.1 * TOL * L, 0.0, False),
    ],
)
def test_the_seat_tolerance(d_pb: float, d_pm: float, d_x: float, d_y: float, seated: bool) -> None:
    x0, y = _seat(0.2)
    assert is_seated(0.2 + d_pb, 0.2 + d_pm, x0 + d_x, y + d_y, L, TOL) is seated


def _run(y: float = 2.0, pb: float = 0.1, pm: float = 0.2, n_active: int = 2) -> np.ndarray:
    runs = np.zeros(1, dtype=RUN_DTYPE)
    runs[0]["outcome"] = UNDECIDED
    runs[0]["y_m"], runs[0]["phi_b"], runs[0]["phi_m"] = y, pb, pm
    runs[0]["n_active"] = n_active
    return runs


ACT = np.array([3, 4, -1, -1], dtype=np.int64)


def test_record_appends_a_sample_with_its_contacts() -> None:
    runs = _run()
    path, pairs = np.zeros((3, 4)), np.full((3, 4), -7, dtype=np.int64)
    record(runs[0], path, pairs, P_ALIGN, ACT, 1)
    assert runs[0]["n_samples"] == 1
    assert path[0].tolist() == [2.0, 0.1, 0.2, P_ALIGN]
    assert pairs[0].tolist() == [3, -1, -1, -1]
    assert pairs[1].tolist() == [-7, -7, -7, -7]


def test_record_past_the_buffer_overwrites_the_last_row_and_keeps_counting() -> None:
    runs = _run()
    path, pairs = np.zeros((2, 4)), np.full((2, 4), -1, dtype=np.int64)
    for k in range(5):
        runs[0]["y_m"] = 2.0 - k
        record(runs[0], path, pairs, P_ALIGN, ACT, 2)
    assert runs[0]["n_samples"] == 5
    assert path[:, 0].tolist() == [2.0, -2.0]


def test_end_run_sets_the_outcome_and_records_an_end_sample() -> None:
    runs = _run()
    path, pairs = np.zeros((2, 4)), np.zeros((2, 4), dtype=np.int64)
    end_run(runs[0], path, pairs, ACT, O_PASSED, R_PASSED, False)
    assert (runs[0]["outcome"], runs[0]["reason"]) == (O_PASSED, R_PASSED)
    assert path[0, 3] == P_END
    assert pairs[0].tolist() == [-1, -1, -1, -1]  # contacts not kept


def test_end_run_can_keep_the_active_contacts() -> None:
    runs = _run(n_active=2)
    path, pairs = np.zeros((2, 4)), np.zeros((2, 4), dtype=np.int64)
    end_run(runs[0], path, pairs, ACT, O_BAD_MATE, R_JAMMED, True)
    assert pairs[0].tolist() == [3, 4, -1, -1]


@pytest.mark.parametrize(
    ("phi_m", "outcome", "reason"), [(0.3, O_SEATED, R_SEATED), (0.4, O_BAD_MATE, R_JAMMED)]
)
def test_end_at_rest_is_seated_only_at_the_mated_pose(
    phi_m: float, outcome: int, reason: int
) -> None:
    x0, y = _seat(0.3)
    runs = _run(y=y, pb=0.3, pm=phi_m)
    runs[0]["x0"] = x0
    path, pairs = np.zeros((2, 4)), np.zeros((2, 4), dtype=np.int64)
    end_at_rest(runs[0], path, pairs, ACT, L, TOL, R_JAMMED, False)
    assert (runs[0]["outcome"], runs[0]["reason"]) == (outcome, reason)
