"""suggest_approach: a correction that meets the requirement, and none when it already does."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import xface_core as xf
from xface_core.atlas import approach


def test_correction_reaches_the_probability(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    cov = np.diag([0.05**2, 0.05**2])
    assert xf.seat_probability(design, 0.3, 0.4, cov, atlas=coarse_v_atlas) < 0.5
    s = xf.suggest_approach(design, 0.3, 0.4, cov, level=0.9, atlas=coarse_v_atlas)
    assert s.reached
    assert s.metric == "mahalanobis"
    p = xf.seat_probability(design, 0.3 + s.dx, 0.4 + s.dtheta, cov, atlas=coarse_v_atlas)
    assert p >= 0.9
    assert s.distance == pytest.approx(math.hypot(s.dx / 0.05, s.dtheta / 0.05), rel=1e-5)


def test_correction_reaches_the_margins(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    s = xf.suggest_approach(
        design, 0.3, 0.4, min_lateral=0.05, min_angle=0.05, atlas=coarse_v_atlas
    )
    assert s.reached
    assert s.metric == "scaled"
    assert s.distance > 0
    p = xf.predict(design, 0.3 + s.dx, 0.4 + s.dtheta, path=False, margins=True)
    assert p.seated
    assert p.margins is not None
    assert p.margins.lateral >= 0.05
    assert p.margins.angle >= 0.05


def test_pose_already_meeting_the_level_needs_no_correction(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    s = xf.suggest_approach(coarse_v_atlas.design, 0.0, 0.0, np.eye(2) * 1e-4, atlas=coarse_v_atlas)
    assert (s.dx, s.dtheta, s.distance, s.reached) == (0.0, 0.0, 0.0, True)


def test_level_out_of_range_is_refused(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.XfaceValueError, match="level"):
        xf.suggest_approach(
            coarse_v_atlas.design, 0.0, 0.0, np.eye(2), level=1.0, atlas=coarse_v_atlas
        )


@pytest.mark.parametrize(
    ("cov", "centre"),
    [
        (np.diag([0.05**2, 0.04**2]), (10, 20)),
        (np.array([[0.02, 0.01], [0.01, 0.03]]), (0, 3)),
        (np.diag([1e-4, 0.0]), (60, 40)),
    ],
)
def test_windowed_smoothing_equals_the_whole_grids(
    coarse_v_atlas: xf.AcceptanceAtlas, cov: np.ndarray, centre: tuple[int, int]
) -> None:
    shape = coarse_v_atlas.outcomes.shape
    whole = approach._smoothed_seated(coarse_v_atlas, cov, slice(0, shape[0]), slice(0, shape[1]))
    rows = slice(max(centre[0] - 7, 0), min(centre[0] + 9, shape[0]))
    cols = slice(max(centre[1] - 5, 0), min(centre[1] + 4, shape[1]))
    window = approach._smoothed_seated(coarse_v_atlas, cov, rows, cols)
    np.testing.assert_allclose(window, whole[rows, cols], atol=1e-12)


def test_likely_nodes_come_nearest_first_as_over_the_whole_grid(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    at = coarse_v_atlas
    cov = np.diag([0.02**2, 0.03**2])
    reg = cov + 1e-6 * np.diag([at.lateral_step**2, at.angle_step**2])
    inv = np.linalg.inv(reg)

    def measure(delta: np.ndarray) -> np.ndarray:
        return np.sqrt(np.einsum("...i,ij,...j->...", delta, inv, delta))

    start = np.array([0.9, 0.45])
    shape = at.outcomes.shape
    whole = approach._smoothed_seated(at, cov, slice(0, shape[0]), slice(0, shape[1]))
    nodes = np.stack(np.meshgrid(at.x0, at.theta0, indexing="ij"), axis=-1)[whole >= 0.9]
    expected = np.sort(measure(nodes - start))[:40]
    got = list(itertools.islice(approach._likely_nodes(at, start, cov, reg, 0.9, measure), 40))
    assert len(got) == 40
    np.testing.assert_allclose(measure(np.array(got) - start), expected, rtol=1e-12)


def test_secant_pull_back_meets_the_level_in_fewer_evaluations_than_bisection() -> None:
    calls: list[float] = []

    def logistic(pose: np.ndarray) -> float:
        calls.append(float(pose[0]))
        return float(1.0 / (1.0 + math.exp(-12.0 * (pose[0] - 0.37))))

    start, target = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    level = 0.9
    p0, p1 = logistic(start), logistic(target)
    calls.clear()
    pose, p = approach._secant_back(start, target, p0, p1, logistic, level)
    crossing = 0.37 + math.log(9.0) / 12.0
    assert p >= level
    assert crossing <= pose[0] <= crossing + 0.5**approach.LINE_STEPS
    assert len(calls) < approach.LINE_STEPS


def test_known_probability_gives_the_same_suggestion(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    cov = np.diag([0.05**2, 0.05**2])
    p = float(xf.seat_probability(design, 0.3, 0.4, cov, atlas=coarse_v_atlas))
    plain = xf.suggest_approach(design, 0.3, 0.4, cov, level=0.9, atlas=coarse_v_atlas)
    known = xf.suggest_approach(
        design, 0.3, 0.4, cov, level=0.9, atlas=coarse_v_atlas, probability=p
    )
    assert known == plain


@pytest.mark.parametrize("probability", [-0.1, 1.5, math.nan])
def test_known_probability_out_of_range_is_refused(
    coarse_v_atlas: xf.AcceptanceAtlas, probability: float
) -> None:
    with pytest.raises(xf.XfaceValueError, match="probability"):
        xf.suggest_approach(
            coarse_v_atlas.design, 0.3, 0.4, np.eye(2) * 1e-3, atlas=coarse_v_atlas,
            probability=probability,
        )  # fmt: skip


def test_an_unreachable_level_smooths_the_whole_grid_once_per_covariance(
    coarse_v_atlas: xf.AcceptanceAtlas, monkeypatch: pytest.MonkeyPatch
) -> None:
    whole = coarse_v_atlas.outcomes.shape
    calls: list[tuple[int, int]] = []
    inner = approach._smoothed_seated

    def counting(atlas, cov_d, rows, cols):  # type: ignore[no-untyped-def]
        calls.append((rows.stop - rows.start, cols.stop - cols.start))
        return inner(atlas, cov_d, rows, cols)

    monkeypatch.setattr(approach, "_smoothed_seated", counting)
    # Half a radian of angle noise: no pose of this V-Face seats with probability 0.99.
    cov = np.diag([0.05**2, 0.5**2])
    for _ in range(2):
        s = xf.suggest_approach(
            coarse_v_atlas.design, 0.0, 0.0, cov, level=0.99, atlas=coarse_v_atlas
        )
        assert not s.reached
    assert calls.count(whole) == 1


@pytest.mark.parametrize("k", [1, 3, 6, 40])
def test_nearest_are_the_first_of_a_stable_sort(k: int) -> None:
    rng = np.random.default_rng(k)
    for _ in range(50):
        # Few distinct values: ties everywhere, which a stable sort orders by index.
        dist = rng.integers(0, 5, size=int(rng.integers(1, 30))).astype(np.float64)
        expected = np.argsort(dist, kind="stable")[:k]
        assert np.array_equal(approach._nearest(dist, k), expected)


def test_safe_nodes_are_found_once_per_requirement(
    coarse_v_atlas: xf.AcceptanceAtlas, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[tuple[int, int]] = []
    inner = approach._safe_nodes

    def counting(atlas, need_x, need_t):  # type: ignore[no-untyped-def]
        calls.append((need_x, need_t))
        return inner(atlas, need_x, need_t)

    monkeypatch.setattr(approach, "_safe_nodes", counting)
    monkeypatch.setattr(approach, "_SAFE", approach._KeptPerAtlas(approach.SAFE_KEPT))
    design = coarse_v_atlas.design
    for _ in range(2):
        for min_angle in (0.05, 0.08):
            s = xf.suggest_approach(
                design, 0.3, 0.4, min_lateral=0.05, min_angle=min_angle, atlas=coarse_v_atlas
            )
            assert s.reached
    assert len(calls) == 2
    first = approach._safe_coordinates(coarse_v_atlas, 0.05 / design.width, 0.05)
    assert first is approach._safe_coordinates(coarse_v_atlas, 0.05 / design.width, 0.05)
    runs = approach._required_runs(coarse_v_atlas, 0.05 / design.width, 0.05)
    good = approach._safe_nodes(coarse_v_atlas, *runs)
    assert first.shape == (int(good.sum()), 2)
