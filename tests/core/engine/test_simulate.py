"""simulate.py: the entry points over many poses and one pose, and the reach below a pivot."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core._engine.records import (
    O_INVALID,
    O_OUT_OF_REACH,
    P_END,
    R_NONFINITE,
    R_OUT_OF_REACH,
    R_OVERLAP,
    RUN_DTYPE,
    make_options,
)
from xface_core._engine.simulate import lowest_reach, simulate_many, simulate_one
from xface_core.contact import pair_table
from xface_core.physics import Physics
from xface_core.runner import engine_model, start_height, start_heights

DESIGN = xf.x_face(0.5, 1.0)
MODEL = engine_model(DESIGN)
OPTS = make_options(Physics())
COUNTERS = ("steps", "events", "contact_changes", "rejected_steps", "n_samples")


def _one(x0: float, theta0: float, y: float, n_buf: int = 64):
    runs = np.zeros(1, dtype=RUN_DTYPE)
    path = np.full((n_buf, 4), np.nan)
    pairs = np.full((n_buf, 4), -7, dtype=np.int64)
    simulate_one(MODEL, OPTS, x0, theta0, y, runs, path, pairs)
    return runs[0], path, pairs


def test_simulate_many_gives_one_row_per_pose_and_marks_invalid_ones() -> None:
    xs = np.array([0.3, -0.2, 0.1, 0.0])
    ts = np.array([0.2, 0.1, 0.0, -0.3])
    ys = start_heights(DESIGN, ts)
    valid = np.array([True, False, True, False])
    runs = simulate_many(MODEL, OPTS, xs, ts, ys, valid)
    assert runs.dtype == RUN_DTYPE
    assert runs.shape == (4,)
    assert runs["outcome"][~valid].tolist() == [O_INVALID, O_INVALID]
    assert np.all(np.isnan(runs["phi_b"][~valid]))
    assert np.all(np.isnan(runs["phi_m"][~valid]))
    assert all(o in {int(m) for m in xf.Outcome} for o in runs["outcome"][valid])
    for name in COUNTERS:
        assert np.all(runs[name] >= 0), name


def test_simulate_many_agrees_with_simulate_one() -> None:
    xs, ts = np.array([0.3, -0.6, 0.9]), np.array([0.2, -0.2, 0.5])
    ys = start_heights(DESIGN, ts)
    many = simulate_many(MODEL, OPTS, xs, ts, ys, np.ones(3, dtype=np.bool_))
    for k in range(3):
        one, _, _ = _one(xs[k], ts[k], ys[k], n_buf=1)
        assert many[k].tolist() == one.tolist()


@pytest.mark.parametrize("physics", [Physics(), Physics(friction=0.3)], ids=["mu0", "mu0.3"])
def test_the_batch_reuses_one_work_and_every_row_is_the_pose_alone(physics: Physics) -> None:
    # simulate_many puts one set of scratch arrays back between its poses (reset_work): a
    # run must not see anything of the one before it, so each row equals the pose
    # simulated alone in fresh arrays, bit for bit. On the S-Face, whose flush edges make
    # the runs most varied (seats, jams, several events each).
    design = xf.s_face(0.5, 1.0)
    model, opts = engine_model(design), make_options(physics)
    rng = np.random.default_rng(7)
    xs, ts = rng.uniform(-0.8, 0.8, 40), rng.uniform(-0.6, 0.6, 40)
    ys = start_heights(design, ts)
    many = simulate_many(model, opts, xs, ts, ys, np.ones(40, dtype=np.bool_))
    assert len(set(many["outcome"].tolist())) >= 2
    for k in range(40):
        runs = np.zeros(1, dtype=RUN_DTYPE)
        path, pairs = np.zeros((1, 4)), np.full((1, 4), -1, dtype=np.int64)
        simulate_one(model, opts, xs[k], ts[k], ys[k], runs, path, pairs)
        assert many[k].tolist() == runs[0].tolist(), k


def test_out_of_reach_ends_at_once_with_one_end_sample() -> None:
    x0 = MODEL.mated_distance + 0.1
    run, path, pairs = _one(x0, 0.0, 5.0)
    assert (run["outcome"], run["reason"]) == (O_OUT_OF_REACH, R_OUT_OF_REACH)
    assert run["n_samples"] == 1
    assert path[0].tolist() == [5.0, 0.0, 0.0, P_END]
    assert pairs[0].tolist() == [-1, -1, -1, -1]
    assert (run["steps"], run["events"]) == (0, 0)


def test_an_interpenetrating_start_is_invalid() -> None:
    # Aligned and centred, the moving pivot at half the mated distance: the parts overlap.
    run, _, _ = _one(0.0, 0.0, 0.5 * MODEL.mated_distance)
    assert (run["outcome"], run["reason"]) == (O_INVALID, R_OVERLAP)


def test_a_nonfinite_start_is_invalid() -> None:
    run, _, _ = _one(0.1, math.nan, 5.0)
    assert (run["outcome"], run["reason"]) == (O_INVALID, R_NONFINITE)


def test_the_path_ends_with_the_final_state() -> None:
    run, path, _ = _one(0.3, 0.2, float(start_heights(DESIGN, 0.2)))
    n = int(run["n_samples"])
    assert 2 < n <= len(path)
    assert path[n - 1].tolist() == [run["y_m"], run["phi_b"], run["phi_m"], P_END]
    assert np.all(np.diff(path[:n, 0]) <= 0.0)  # the pivot only descends
    for name in COUNTERS:
        assert run[name] >= 0, name


def test_a_one_row_buffer_keeps_the_final_state_and_counts_every_sample() -> None:
    full, _, _ = _one(0.3, 0.2, float(start_heights(DESIGN, 0.2)))
    run, path, _ = _one(0.3, 0.2, float(start_heights(DESIGN, 0.2)), n_buf=1)
    assert run["n_samples"] == full["n_samples"]
    assert path[0].tolist() == [run["y_m"], run["phi_b"], run["phi_m"], P_END]


@pytest.mark.parametrize("theta", [0.0, 0.4, -1.2, math.pi])
def test_lowest_reach_is_the_deepest_body_point(theta: float) -> None:
    v = pair_table(DESIGN).moving_vertices
    expected = np.max(np.sin(theta) * v[:, 0] + np.cos(theta) * v[:, 1])
    assert lowest_reach(v, theta) == pytest.approx(expected, abs=1e-15)


def test_start_heights_are_the_single_angle_start_per_angle_and_nan_when_not_finite() -> None:
    # The batch start (runner.start_heights, compiled) and the one-pose start
    # (runner.start_height) must be the same bit for bit: a prediction and a batch of the
    # same pose start at the same height.
    thetas = np.array([[0.0, 0.3, -1.2], [np.pi, -2.0 * np.pi, np.nan]])
    heights = start_heights(DESIGN, thetas)
    assert heights.shape == thetas.shape
    for th, y in zip(thetas.ravel()[:-1], heights.ravel()[:-1], strict=True):
        assert y == start_height(DESIGN, float(th))
    assert np.isnan(heights[1, 2])
    assert np.isnan(start_heights(DESIGN, np.inf))
