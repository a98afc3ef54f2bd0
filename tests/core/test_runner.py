"""runner.outcomes_at: the outcomes of poses in units of D, the one way the question packages
ask the engine."""

from __future__ import annotations

import numpy as np
import pytest

import xface_core as xf
from xface_core.codes import Outcome
from xface_core.runner import count_engine_calls, outcomes_at


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
