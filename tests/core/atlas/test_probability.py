"""Seat probability under a Gaussian pose uncertainty, against plain Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest

import xface_core as xf
from xface_core.atlas.probability import DEFAULT_RAY_TOL, FIRST_RAYS, _adaptive_in_angle
from xface_core.runner import count_engine_calls


def _cov(sx: float, st: float, rho: float) -> np.ndarray:
    return np.array([[sx * sx, rho * sx * st], [rho * sx * st, st * st]])


@pytest.mark.parametrize(
    ("x0", "theta0", "cov"),
    [
        (-0.72, 0.14, _cov(0.13, 0.05, -0.56)),  # across the seated region's lateral edge
        (0.9, -0.3, _cov(0.1, 0.05, 0.5)),
        (-0.3, 0.5, _cov(0.03, 0.2, -0.6)),  # across the angular edge
    ],
)
def test_probability_agrees_with_monte_carlo(
    coarse_v_atlas: xf.AcceptanceAtlas, x0: float, theta0: float, cov: np.ndarray
) -> None:
    design = coarse_v_atlas.design
    p = xf.seat_probability(design, x0, theta0, cov, atlas=coarse_v_atlas)
    n = 2000
    rng = np.random.default_rng(11)
    samples = rng.multivariate_normal([x0, theta0], cov, size=n)
    mc = float(np.mean(xf.predict_batch(design, samples[:, 0], samples[:, 1]).outcome == 3))
    assert 0.05 < mc < 0.95  # the case is on a boundary, not a trivial 0 or 1
    # 4 binomial standard errors of the Monte Carlo estimate (<= 0.045 at n = 2000), plus
    # the 0.01 the quadrature is asked for.
    assert abs(p - mc) <= 4 * math.sqrt(mc * (1 - mc) / n) + 0.01


@pytest.mark.parametrize(("x0", "seated"), [(0.0, 1.0), (0.9, 0.0)])
def test_zero_covariance_is_the_exact_outcome(
    coarse_v_atlas: xf.AcceptanceAtlas, x0: float, seated: float
) -> None:
    design = coarse_v_atlas.design
    assert xf.predict(design, x0, 0.0, path=False).seated == bool(seated)
    assert xf.seat_probability(design, x0, 0.0, np.zeros((2, 2)), atlas=coarse_v_atlas) == seated


def test_vectorised_equals_one_by_one(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    xs, ts = np.array([0.4, -0.2]), np.array([0.1, -0.4])
    cov = _cov(0.05, 0.05, 0.0)
    many = xf.seat_probability(design, xs, ts, cov, atlas=coarse_v_atlas)
    ones = [
        xf.seat_probability(design, x, t, cov, atlas=coarse_v_atlas)
        for x, t in zip(xs, ts, strict=True)
    ]
    assert isinstance(many, np.ndarray)
    assert many.shape == (2,)
    assert many.tolist() == ones


def test_singular_covariance_is_a_line_integral(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    # All uncertainty in x0: the probability is the 1-D Gaussian mass over the seated
    # stretch of the row, whose ends the exact margins give.
    design = coarse_v_atlas.design
    sx = 0.3
    p = xf.seat_probability(design, 0.0, 0.0, _cov(sx, 0.0, 0.0), atlas=coarse_v_atlas)
    m = xf.predict(design, 0.0, 0.0, path=False, margins=True).margins
    assert m is not None

    def phi(z: float) -> float:
        return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))

    expected = phi(m.lateral_plus / sx) - phi(-m.lateral_minus / sx)
    assert p == pytest.approx(expected, abs=2e-3)


def test_adaptive_rays_keep_a_constant_at_the_first_level() -> None:
    calls: list[int] = []

    def masses(phi: np.ndarray) -> np.ndarray:
        calls.append(phi.size)
        return np.full(phi.size, 0.25)

    mean, rays = _adaptive_in_angle(masses, DEFAULT_RAY_TOL)
    assert mean == pytest.approx(0.25, abs=1e-15)
    assert rays == 2 * FIRST_RAYS  # the first rays and one middle each: nothing to split
    assert calls == [FIRST_RAYS, FIRST_RAYS]


def test_adaptive_rays_gather_at_kinks() -> None:
    # |cos(phi + 0.3)| has kinks (as where a ray grazes a boundary) between the first rays;
    # its mean is 2 / pi.
    seen: list[np.ndarray] = []

    def masses(phi: np.ndarray) -> np.ndarray:
        seen.append(phi)
        return np.abs(np.cos(phi + 0.3))

    mean, rays = _adaptive_in_angle(masses, DEFAULT_RAY_TOL)
    phi = (np.concatenate(seen) + 0.3) % math.pi
    near_kink = np.abs(phi - math.pi / 2) < 0.2
    near_crest = np.minimum(phi, math.pi - phi) < 0.2
    assert near_kink.sum() > near_crest.sum()
    even = np.abs(np.cos(2.0 * math.pi * (np.arange(rays) + 0.5) / rays + 0.3)).mean()
    assert abs(mean - 2.0 / math.pi) < abs(even - 2.0 / math.pi) / 4.0  # as many even rays


def test_adaptive_rays_agree_with_many_even_ones(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    cov = _cov(0.13, 0.05, -0.56)  # across the seated region's lateral edge
    adaptive = xf.seat_probability(design, -0.72, 0.14, cov, atlas=coarse_v_atlas)
    even = xf.seat_probability(design, -0.72, 0.14, cov, atlas=coarse_v_atlas, rays=1024)
    assert 0.05 < even < 0.95
    assert adaptive == pytest.approx(even, abs=2e-3)


@pytest.mark.parametrize(
    ("keyword", "value"),
    [("rays", 3), ("rays", True), ("rays", 4097), ("ray_tol", 0.0), ("ray_tol", math.nan),
     ("ray_tol", 1.5), ("ray_tol", "0.1")],
)  # fmt: skip
def test_quadrature_settings_are_checked(
    coarse_v_atlas: xf.AcceptanceAtlas, keyword: str, value: object
) -> None:
    with pytest.raises(xf.XfaceValueError, match=f"{keyword} must be"):
        xf.seat_probability(
            coarse_v_atlas.design, 0.0, 0.0, np.eye(2) * 1e-4, atlas=coarse_v_atlas,
            **{keyword: value},  # type: ignore[arg-type]
        )  # fmt: skip


def test_crossing_steps_narrow_the_boundaries(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    # The line integral of the test above: with no bisection a crossing is the middle of its
    # two samples (off by up to half their spacing); 8 steps bring it to the exact margins.
    design = coarse_v_atlas.design
    sx = 0.3
    m = xf.predict(design, 0.0, 0.0, path=False, margins=True).margins
    assert m is not None

    def phi(z: float) -> float:
        return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))

    expected = phi(m.lateral_plus / sx) - phi(-m.lateral_minus / sx)
    cov = _cov(sx, 0.0, 0.0)
    err = {
        steps: abs(
            float(
                xf.seat_probability(
                    design, 0.0, 0.0, cov, atlas=coarse_v_atlas, rays=1024, crossing_steps=steps
                )
            )
            - expected
        )
        for steps in (0, 8)
    }
    assert err[8] < err[0] / 4.0
    assert err[8] <= 2e-4


@pytest.mark.parametrize("steps", [-1, 31, True, 2.0])
def test_crossing_steps_must_be_an_integer_in_range(
    coarse_v_atlas: xf.AcceptanceAtlas, steps: object
) -> None:
    with pytest.raises(xf.XfaceValueError, match="crossing_steps must be an integer"):
        xf.seat_probability(
            coarse_v_atlas.design, 0.0, 0.0, np.eye(2) * 1e-4, atlas=coarse_v_atlas,
            crossing_steps=steps,  # type: ignore[arg-type]
        )  # fmt: skip


@pytest.mark.parametrize(
    "cov",
    [
        [[1.0, 0.5], [0.0, 1.0]],  # not symmetric
        [[1.0, 2.0], [2.0, 1.0]],  # indefinite
        [[math.nan, 0.0], [0.0, 1.0]],
        [1.0, 2.0],  # wrong shape
    ],
)
def test_bad_covariance_is_refused(coarse_v_atlas: xf.AcceptanceAtlas, cov: object) -> None:
    with pytest.raises(xf.XfaceValueError, match="cov must"):
        xf.seat_probability(coarse_v_atlas.design, 0.0, 0.0, cov, atlas=coarse_v_atlas)


def test_non_finite_mean_is_refused(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.InputError):
        xf.seat_probability(
            coarse_v_atlas.design, math.inf, 0.0, np.eye(2) * 1e-4, atlas=coarse_v_atlas
        )


def test_probability_does_not_depend_on_the_length_unit(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    # Same connector in metres (D = 3 cm), atlas built in widths: poses and covariance scale.
    w = 0.03
    metric = xf.v_face(0.5, 1.0, width=w)
    cov = _cov(0.1, 0.05, 0.5)
    in_d = xf.seat_probability(coarse_v_atlas.design, 0.9, -0.3, cov, atlas=coarse_v_atlas)
    scaled = cov * np.outer([w, 1.0], [w, 1.0])
    in_m = xf.seat_probability(metric, 0.9 * w, -0.3, scaled, atlas=coarse_v_atlas)
    assert in_m == pytest.approx(in_d, abs=1e-12)


def test_one_pose_many_covariances(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    design = coarse_v_atlas.design
    covs = np.stack([_cov(0.05, 0.05, 0.0), _cov(0.1, 0.05, 0.5)])
    many = xf.seat_probability(design, 0.9, -0.3, covs, atlas=coarse_v_atlas)
    ones = [xf.seat_probability(design, 0.9, -0.3, c, atlas=coarse_v_atlas) for c in covs]
    assert np.asarray(many).tolist() == ones


@pytest.fixture(scope="module")
def flipped_v_atlas() -> xf.AcceptanceAtlas:
    """The V-Face atlas on the default grid with every grid-line flip bisected, as the ROS
    node builds its own (under a second), its chords checked as the node's keeper does."""
    atlas = xf.build_atlas(xf.v_face(0.5, 1.0), every_flip=True)
    atlas.checked_chords()
    return atlas


@pytest.mark.parametrize(
    ("x0", "theta0", "cov"),
    [
        (-0.72, 0.14, _cov(0.13, 0.05, -0.56)),
        (0.9, -0.3, _cov(0.1, 0.05, 0.5)),
        (-0.3, 0.5, _cov(0.03, 0.2, -0.6)),
        # Narrow, on the tip of a wedge of the SEATED region that a straight line per cell
        # cuts short: the largest error met (0.068 against 0.077; docs/atlas.md).
        (0.95, -0.3, _cov(0.02, 0.01, 0.0)),
    ],
)
def test_atlas_boundary_agrees_with_the_exact_one_without_simulating(
    flipped_v_atlas: xf.AcceptanceAtlas, x0: float, theta0: float, cov: np.ndarray
) -> None:
    design = flipped_v_atlas.design
    with count_engine_calls() as exact_calls:
        exact = xf.seat_probability(design, x0, theta0, cov, atlas=flipped_v_atlas)
    with count_engine_calls() as atlas_calls:
        drawn = xf.seat_probability(
            design, x0, theta0, cov, atlas=flipped_v_atlas, boundary="atlas"
        )
    assert 0.001 < exact < 0.999  # on a boundary
    assert abs(drawn - exact) < 0.01
    assert atlas_calls.poses < exact_calls.poses / 10


def test_unknown_boundary_mode_is_refused(coarse_v_atlas: xf.AcceptanceAtlas) -> None:
    with pytest.raises(xf.XfaceValueError, match="boundary must be one of"):
        xf.seat_probability(
            coarse_v_atlas.design, 0.0, 0.0, _cov(0.1, 0.1, 0.0), atlas=coarse_v_atlas,
            boundary="drawn",
        )  # fmt: skip


def test_poses_beyond_the_mated_distance_are_not_simulated(
    coarse_v_atlas: xf.AcceptanceAtlas,
) -> None:
    # L = 2.5 D: a Gaussian beyond it is OUT_OF_REACH by the engine's first rule, outside
    # the atlas, and known without a simulation but the mean's own.
    design = coarse_v_atlas.design
    with count_engine_calls() as calls:
        p = xf.seat_probability(design, 3.0, 0.0, _cov(0.1, 0.1, 0.0), atlas=coarse_v_atlas)
    assert p == 0.0
    assert calls.poses == 1
