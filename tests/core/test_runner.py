"""runner.outcomes_at: the outcomes of poses in units of D, the one way the question packages
ask the engine."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import xface_core as xf
from xface_core.codes import Outcome
from xface_core.runner import MAX_LOCAL_WORKERS, count_engine_calls, outcomes_at, process_count


@pytest.mark.parametrize("y_start", [None, 0.12, 0.02])
def test_outcomes_in_d_are_predict_batch_outcomes_in_lengths(y_start: float | None) -> None:
    # 0.02 m is below the base for most angles: INVALID_INPUT there in both.
    design = xf.v_face(0.5, 1.0, width=0.05)
    rng = np.random.default_rng(4)
    xs, ts = rng.uniform(-0.1, 0.1, 40), rng.uniform(-1.5, 1.5, 40)
    physics = xf.Physics()
    w = design.width
    ours = outcomes_at(
        design, xs / w, ts, physics, y_start=None if y_start is None else y_start / w
    )
    theirs = xf.predict_batch(design, xs, ts, physics=physics, y_start=y_start).outcome
    assert np.array_equal(ours, theirs)
    assert len(set(theirs.tolist())) >= 2


def test_outcomes_broadcast_like_numpy() -> None:
    codes = outcomes_at(xf.x_face(0.25, 1.0), np.zeros((3, 1)), np.array([0.0, 0.1]), xf.Physics())
    assert codes.shape == (3, 2)
    assert codes.dtype == np.int8


def test_a_pose_that_cannot_be_simulated_is_invalid_input() -> None:
    codes = outcomes_at(xf.x_face(0.25, 1.0), [np.nan, 0.1, 1e9], [0.1, np.inf, 0.1], xf.Physics())
    assert codes.tolist() == [Outcome.INVALID_INPUT] * 3


def test_outcomes_are_the_same_whatever_the_threads() -> None:
    design = xf.s_face(0.5, 1.0)
    xs, ts = np.meshgrid(np.linspace(-1, 1, 30), np.linspace(-1, 1, 30))
    one = outcomes_at(design, xs, ts, xf.Physics(), threads=1)
    two = outcomes_at(design, xs, ts, xf.Physics(), threads=2)
    assert np.array_equal(one, two)


def test_every_call_is_counted_with_its_poses() -> None:
    with count_engine_calls() as calls:
        outcomes_at(xf.x_face(0.25, 1.0), np.zeros(4), 0.1, xf.Physics())
    assert (calls.calls, calls.poses) == (1, 4)


@given(workers=st.integers(1, MAX_LOCAL_WORKERS) | st.none(), jobs=st.integers(1, 5000) | st.none())
def test_a_pool_never_has_more_processes_than_jobs(workers: int | None, jobs: int | None) -> None:
    n = process_count(workers, jobs)
    asked = process_count(workers)  # one per core for None
    assert n == (asked if jobs is None else min(asked, jobs))
    assert 1 <= n <= MAX_LOCAL_WORKERS


@pytest.mark.parametrize("workers", [0, -1, MAX_LOCAL_WORKERS + 1, 100_000, 2.0, True, "2"])
def test_a_process_count_out_of_range_or_not_an_integer_is_refused(workers: object) -> None:
    with pytest.raises(xf.XfaceValueError, match=r"workers must be in \[1, 1024\]"):
        process_count(workers, 10)


def test_a_numpy_integer_is_a_process_count() -> None:
    assert process_count(np.int64(3), 10) == 3
